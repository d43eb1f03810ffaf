"""Safe expressions with exact derivatives.

A driver's motion or a load may be given as text, e.g. ``"0.3 + 6.0*t + 0.4*sin(5*t)"``.
:func:`parse` reads it with a small tokenizer and a precedence-climbing parser that knows only
numbers, the declared variables, ``pi``, ``e``, ``+ - * / **`` and calls of a fixed list of
functions; the text is never executed. :meth:`Expr.diff` differentiates symbolically, so driver
velocities and accelerations are exact rather than finite differences.

Expressions are directed acyclic graphs: equal subexpressions are one shared object (hash
consing), so a derivative reuses the parts of the expression it repeats, evaluation computes each
distinct subexpression once, and no operation recurses over the depth of the tree. Limits, each
named in its error message: :data:`MAX_LENGTH` characters of text, :data:`MAX_DEPTH` nesting
levels, :data:`MAX_NODES` distinct subexpressions in an expression or a derivative.

Examples
--------
>>> q = parse("0.3 + 6.0*t + 0.4*sin(5*t)")
>>> str(q.diff())
'6 + 2*cos(5*t)'
>>> str(q.diff().diff())
'-10*sin(5*t)'
>>> float(q(0.0))
0.3
>>> float(parse("where(t < 1, t, 1)")(2.0))
1.0
"""

from __future__ import annotations

import difflib
import keyword
import math
import re
import weakref

import numpy as np

from .errors import InvalidValue

__all__ = ["Expr", "ExpressionError", "parse", "flatten", "CONSTANTS", "FUNCTIONS", "OPCODES",
           "MAX_LENGTH", "MAX_DEPTH", "MAX_NODES"]

MAX_LENGTH = 10_000     # characters of a formula
MAX_DEPTH = 100         # nesting levels: parentheses, call arguments, unary signs, powers
MAX_NODES = 10_000      # distinct subexpressions of an expression or of its derivative


def _real(x):
    """The real part of a complex array (complex inputs serve complex-step checks), else x."""
    return np.real(x) if np.iscomplexobj(x) else x


def _abs(x):
    # |x| as x or -x, so that a complex step through it stays analytic
    return np.where(np.real(x) < 0, -x, x) if np.iscomplexobj(x) else np.abs(x)


def _minimum(a, b):
    if np.iscomplexobj(a) or np.iscomplexobj(b):
        return np.where(np.real(a) <= np.real(b), a, b)
    return np.minimum(a, b)


def _maximum(a, b):
    if np.iscomplexobj(a) or np.iscomplexobj(b):
        return np.where(np.real(a) >= np.real(b), a, b)
    return np.maximum(a, b)


CONSTANTS = {"pi": math.pi, "e": math.e}
FUNCTIONS = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log,
             "sqrt": np.sqrt, "sinh": np.sinh, "cosh": np.cosh, "tanh": np.tanh,
             "asin": np.arcsin, "acos": np.arccos, "atan": np.arctan,
             "abs": _abs, "sign": lambda x: np.sign(_real(x)),
             "min": _minimum, "max": _maximum,
             "clip": lambda x, lo, hi: _minimum(_maximum(x, lo), hi),
             "where": lambda c, a, b: np.where(c, a, b)}
ARITY = {"min": 2, "max": 2, "clip": 3, "where": 3}                 # others take one argument
ALIASES = {"arcsin": "asin", "arccos": "acos", "arctan": "atan"}   # NumPy spellings
COMPARISONS = {"<": lambda a, b: _real(a) < _real(b), "<=": lambda a, b: _real(a) <= _real(b),
               ">": lambda a, b: _real(a) > _real(b), ">=": lambda a, b: _real(a) >= _real(b)}

_OPS = {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide, "**": np.power,
        "neg": np.negative, **FUNCTIONS, **COMPARISONS}
_PRECEDENCE = {"+": 1, "-": 1, "*": 2, "/": 2, "neg": 3, "**": 4,   # others (atoms, calls): 5
               **dict.fromkeys(COMPARISONS, 0)}


class ExpressionError(InvalidValue):
    """Text that is not an allowed expression (one-line message naming the offending token).

    A :class:`~linkdyn.errors.ModelError` (so a ``LinkdynError``) and a ``ValueError``.
    """


# ------------------------------------------------------------------------------ the tree

class Expr:
    """An immutable expression node; equal expressions are the same object.

    Parameters
    ----------
    op : str
        ``'num'`` (``args = (value,)``, a finite float), ``'var'`` (``args = (name,)``),
        ``'+' '-' '*' '/' '**'`` (two operands), ``'neg'`` (one operand), a function name of
        :data:`FUNCTIONS` (as many operands as it takes) or a comparison ``'<' '<=' '>' '>='``
        (two operands; only as the condition of ``where``).
    args : tuple
        The operands (``Expr``), or the value or name of a leaf.

    Attributes
    ----------
    op, args
        As given.
    variables : frozenset of str
        Names of the variables the expression depends on.
    """

    __slots__ = ("op", "args", "variables", "_negative", "_program", "_hash", "__weakref__")
    _table: weakref.WeakValueDictionary = weakref.WeakValueDictionary()

    def __new__(cls, op: str, args: tuple = ()):
        args = tuple(args)
        if op == "num":
            args = (float(args[0]),)
        key = (op, args)
        self = cls._table.get(key)
        if self is not None:                                     # hash consing: one object each
            return self
        self = object.__new__(cls)
        put = object.__setattr__
        put(self, "op", op)
        put(self, "args", args)
        put(self, "variables", frozenset(args) if op == "var" else frozenset().union(
            *(a.variables for a in args if isinstance(a, Expr))))
        # reads better subtracted: -x, a negative number, (-c)*x, (-c)/x, (-c)*x/y (two
        # levels at most, so that negating it never walks down a long chain of factors)
        put(self, "_negative", _signed(self) or op in ("*", "/") and (
            _signed(args[0]) or args[0].op in ("*", "/") and _signed(args[0].args[0])))
        put(self, "_program", None)
        put(self, "_hash", hash(key))                            # children's hashes are cached
        cls._table[key] = self
        return self

    def __init__(self, op: str, args: tuple = ()):
        pass

    def __eq__(self, other) -> bool:
        # equal expressions are normally one object; the structural test covers two built at
        # once by two threads (its recursion stops at the first shared child)
        return self is other or (isinstance(other, Expr) and self._hash == other._hash
                                 and self.op == other.op and self.args == other.args)

    def __hash__(self) -> int:
        return self._hash

    def __setattr__(self, name, value):
        raise AttributeError(f"an Expr is immutable (cannot set {name!r})")

    def __delattr__(self, name):
        raise AttributeError(f"an Expr is immutable (cannot delete {name!r})")

    def __reduce__(self):
        # a flat list of nodes, children first: no recursion over the depth of the tree
        nodes, children, _ = _program(self)
        flat = tuple((n.op, n.args if n.op in ("num", "var") else tuple(c))
                     for n, c in zip(nodes, children))
        return _rebuild, (flat,)

    def __repr__(self) -> str:
        return f"Expr({_label(self, 60)})"

    def evaluate(self, **values) -> np.ndarray:
        """Evaluate with NumPy, broadcasting the variables' arrays.

        Parameters
        ----------
        **values : array_like
            One array (any shape) per variable, e.g. ``t=...`` in s.

        Returns
        -------
        ndarray
            Of the broadcast shape of the inputs; float64 (complex128 if an input is complex,
            which allows complex-step derivative checks). Outside a function's domain the
            result is NaN (NumPy rules), never an exception or a warning; an overflow gives inf.
        """
        arrays = {k: _as_array(v) for k, v in values.items()}
        missing = sorted(self.variables - arrays.keys())
        if missing:
            raise ValueError(f"no value given for variable(s) {', '.join(missing)} of "
                             f"{_label(self, 60)}")
        shape = np.broadcast_shapes(*(a.shape for a in arrays.values()))
        with np.errstate(all="ignore"):          # inf and NaN are results, checked by the caller
            return _evaluate(self, arrays) + np.zeros(shape)

    def __call__(self, t) -> np.ndarray:
        """Evaluate at ``t`` (array_like, any shape): shorthand for ``evaluate(t=t)``."""
        return self.evaluate(t=t)

    def diff(self, var: str = "t") -> Expr:
        """Exact derivative with respect to ``var``, lightly simplified (0*x -> 0, constants folded).

        Raises
        ------
        ExpressionError
            If the derivative has more than :data:`MAX_NODES` distinct subexpressions.
        """
        return _diff(self, var)

    @property
    def size(self) -> int:
        """Number of distinct subexpressions (nodes of the shared graph)."""
        return len(_program(self)[0])

    def __str__(self) -> str:
        return _format(self)


def _label(e: Expr, n: int = 40) -> str:
    """``'text...'`` of ``e`` for a message, without printing a huge shared graph in full."""
    nodes, children, _ = _program(e)
    if len(nodes) > 2000:
        return f"an expression of {len(nodes):,} distinct terms"
    size = []                                            # terms of each node written out
    for kids in children:
        size.append(min(1 + sum(size[i] for i in kids), 10**6))
    if size[-1] > 2000:
        return f"an expression of {len(nodes):,} distinct terms"
    return repr(_shorten(str(e), n))


def _signed(e: Expr) -> bool:
    return e.op == "neg" or e.op == "num" and e.args[0] < 0


def _rebuild(flat) -> Expr:
    nodes: list[Expr] = []
    for op, args in flat:
        nodes.append(Expr(op, args if op in ("num", "var") else tuple(nodes[i] for i in args)))
    return nodes[-1]


def _program(root: Expr):
    """The distinct nodes under ``root``, children before parents (root last), each node's
    child positions, and per position the children whose last use it is (cached on ``root``)."""
    if root._program is not None:
        return root._program
    position: dict[int, int] = {}
    nodes: list[Expr] = []
    stack = [(root, False)]
    while stack:                                                 # iterative post-order walk
        node, ready = stack.pop()
        if id(node) in position:
            continue
        if ready or node.op in ("num", "var"):
            position[id(node)] = len(nodes)
            nodes.append(node)
            continue
        stack.append((node, True))
        stack.extend((a, False) for a in reversed(node.args) if id(a) not in position)
    children = [[position[id(a)] for a in n.args] if n.op not in ("num", "var") else []
                for n in nodes]
    last = {}
    for k, c in enumerate(children):
        for i in c:
            last[i] = k
    frees: list[list[int]] = [[] for _ in nodes]
    for i, k in last.items():
        frees[k].append(i)
    object.__setattr__(root, "_program", (nodes, children, frees))
    return root._program


# ------------------------------------------------------------------------------ op codes

#: the op code of each node kind in a flattened program (:func:`flatten`): ``num`` a constant,
#: ``var`` a variable's slot, the operators, :data:`FUNCTIONS` and :data:`COMPARISONS`
OPCODES = {op: k for k, op in enumerate(
    ("num", "var", "+", "-", "*", "/", "**", "neg", *FUNCTIONS, *COMPARISONS))}


def flatten(formulas, slots: dict[str, tuple[int, float]]):
    """Formulas as one flat program of op codes, for an evaluator that runs without Python (the
    compiled right-hand side of :mod:`linkdyn.forward`): the distinct nodes of all formulas,
    children first (:func:`_program`), each a row ``[op, child 1, child 2, child 3]``.

    Parameters
    ----------
    formulas : sequence of Expr or float
        A float is a constant (one ``num`` node).
    slots : dict
        Each variable's ``(slot, scale)``: a ``var`` node reads ``x[slot] / scale`` of the
        evaluator's variables ``x``.

    Returns
    -------
    code : ndarray (N, 4) int64
        ``[OPCODES[op], children...]`` (unused children -1; a ``var``'s first is its slot).
    value : ndarray (N,)
        A ``num``'s constant, a ``var``'s scale, else 0.
    roots : ndarray (len(formulas),) int64
        The row of each formula's value.
    """
    code, value, roots, seen = [], [], [], {}
    alive = [f if isinstance(f, Expr) else Expr("num", (float(f),)) for f in formulas]
    for f in alive:     # (all alive while ``seen`` holds their nodes' ids)
        nodes, children, _ = _program(f)
        for node, kids in zip(nodes, children):
            if id(node) in seen:
                continue
            seen[id(node)] = len(code)
            row = [OPCODES[node.op], -1, -1, -1]
            if node.op == "num":
                value.append(float(node.args[0]))
            elif node.op == "var":
                row[1], scale = slots[node.args[0]]
                value.append(float(scale))
            else:
                row[1:1 + len(kids)] = [seen[id(nodes[i])] for i in kids]
                value.append(0.0)
            code.append(row)
        roots.append(seen[id(nodes[-1])])
    return (np.array(code, np.int64).reshape(-1, 4), np.array(value, float),
            np.array(roots, np.int64))


# ------------------------------------------------------------------------------ parsing

def parse(text: str, variables: tuple[str, ...] = ("t",)) -> Expr:
    """Parse text into an :class:`Expr`, accepting only whitelisted syntax (no eval/exec).

    Parameters
    ----------
    text : str
        E.g. ``"0.3 + 6.0*t + 0.4*sin(5*t)"``. Allowed: numbers, the names in ``variables``,
        ``pi``, ``e``, unary ``+ -``, binary ``+ - * / **`` (``**`` binds tighter than a unary
        sign and groups from the right, as in Python), calls with one argument of sin, cos,
        tan, exp, log, sqrt, sinh, cosh, tanh, asin, acos, atan (also arcsin, arccos, arctan),
        abs, sign, and ``min(a, b)``, ``max(a, b)``, ``clip(x, lo, hi)``,
        ``where(cond, a, b)`` whose condition is one comparison ``< <= > >=``.
        At most :data:`MAX_LENGTH` characters and :data:`MAX_DEPTH` nesting levels.
    variables : tuple of str
        Names of the free variables, e.g. ``("t", "q_J1", "qd_J1")``.

    Raises
    ------
    ExpressionError
        With a one-line message naming the offending token (shortened), suggesting the closest
        allowed name for a misspelt one, and listing what is allowed.
    """
    variables = (variables,) if isinstance(variables, str) else tuple(variables)
    for v in variables:
        if (not isinstance(v, str) or not v.isidentifier() or keyword.iskeyword(v)
                or v in CONSTANTS or v in FUNCTIONS or v in ALIASES):
            raise ValueError(f"invalid variable name {_shorten(repr(v), 40)}")
    if not isinstance(text, str):
        raise ExpressionError(f"expected an expression as text, got {type(text).__name__} "
                              f"{_shorten(repr(text), 40)}")
    if len(text) > MAX_LENGTH:
        raise ExpressionError(f"expression of {len(text):,} characters is longer than the limit "
                              f"of {MAX_LENGTH:,} characters")
    src = text.strip()
    if not src:
        raise ExpressionError(f"empty expression; {_allowed(variables)}")
    return _Parser(src, variables).parse()


_NUMBER = re.compile(r"(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?\Z")
_TOKEN = re.compile(r"""\s*(?:
    (?P<num>(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?[\w.]*)
  | (?P<name>[^\W\d]\w*)
  | (?P<str>'[^'\n]*'?|"[^"\n]*"?)
  | (?P<op>\*\*|//|<=|>=|==|!=|<<|>>|[-+*/()\[\]{},.<>=^%~@&|!:;])
  | (?P<bad>\S))""", re.VERBOSE)
_OPENING = {"(": ")", "[": "]", "{": "}"}
_CLOSING = {v: k for k, v in _OPENING.items()}
_KIND = {"[": "list", "{": "set or dict"}
_KEYWORD_KIND = {"lambda": "lambda", "if": "conditional expression", "for": "comprehension",
                 "not": "boolean operator", "and": "boolean operator", "or": "boolean operator",
                 "is": "comparison", "in": "comparison"}


class _Token:
    __slots__ = ("kind", "text", "start", "end", "match")

    def __init__(self, kind, text, start, end):
        self.kind, self.text, self.start, self.end, self.match = kind, text, start, end, -1


def _tokenize(src: str) -> list[_Token]:
    """Tokens of ``src`` (one regular-expression step each, linear), brackets matched."""
    tokens, pos, opened = [], 0, []
    while True:
        m = _TOKEN.match(src, pos)
        if m is None or m.lastgroup is None:                     # only white space left
            break
        kind = m.lastgroup
        tokens.append(_Token(kind, m.group(kind), m.start(kind), m.end()))
        pos = m.end()
        text = tokens[-1].text
        if kind == "op" and text in _OPENING:
            opened.append(len(tokens) - 1)
        elif kind == "op" and text in _CLOSING and opened and tokens[opened[-1]].text == _CLOSING[text]:
            i = opened.pop()
            tokens[i].match, tokens[-1].match = len(tokens) - 1, i
    tokens.append(_Token("end", "", len(src), len(src)))
    return tokens


class _Parser:
    """Recursive descent by precedence: sums, then products, unary signs, powers, atoms.

    Runs of ``+ -`` and ``* /`` are read by loops (any length); only what nests (parentheses,
    call arguments, signs, powers) recurses, and that is bounded by :data:`MAX_DEPTH`.
    """

    def __init__(self, src: str, variables: tuple[str, ...]):
        self.src, self.variables = src, variables
        self.tokens = _tokenize(src)
        self.i = 0

    # -- messages
    def fail(self, what: str, hint: str = ""):
        raise ExpressionError(f"{what} in {_shorten(self.src, 40)!r}; {hint}"
                              f"{_allowed(self.variables)}")

    def syntax(self, tok: _Token, why: str):
        raise ExpressionError(f"invalid syntax in {_shorten(self.src, 40)!r} at column "
                              f"{tok.start + 1} ({why}). {_allowed(self.variables)}")

    def segment(self, first: int, last: int) -> str:
        """Source text of tokens ``first..last``, shortened and quoted."""
        return repr(_shorten(self.src[self.tokens[first].start:self.tokens[last].end], 40))

    def unexpected(self, tok: _Token):
        """A token that cannot continue the expression: say what it is."""
        k = self.tokens.index(tok, self.i)
        t = tok.text
        if tok.kind == "op" and t in COMPARISONS:
            self.fail(f"comparison '{t}' outside a condition",
                      "a comparison is allowed only as the condition of where(cond, a, b). ")
        if t in ("==", "!="):
            self.fail(f"comparison '{t}' is not allowed", "compare with < <= > >= in where(). ")
        if t == "^":
            self.fail("operator '^' is not a power", "use '**' for powers, e.g. 't**2'. ")
        if t == "[":
            end = tok.match if tok.match >= 0 else len(self.tokens) - 2
            self.fail(f"subscript {self.segment(k - 1, end)}")
        if t == ".":
            self.attribute(k - 1)
        if t == "(":
            self.fail(f"{self.segment(k - 1, k - 1)} is not a function",
                      f"use '*' to multiply, e.g. '{_shorten(self.tokens[k - 1].text, 20)}*(...)'. ")
        if tok.kind == "name" and t in _KEYWORD_KIND:
            self.fail(f"unsupported syntax {self.segment(k, len(self.tokens) - 2)} "
                      f"({_KEYWORD_KIND[t]})")
        if tok.kind == "op" and t in "%//@<<>>|&~!=:;":
            self.fail(f"operator '{t}' is not allowed")
        if t == ")" and tok.match < 0:
            self.syntax(tok, "unmatched ')'")
        if tok.kind == "end":
            self.syntax(tok, "the expression ends early")
        self.syntax(tok, f"unexpected {_shorten(repr(t), 20)}; an operator is missing")

    def attribute(self, k: int):
        """``a.b`` or ``a.b(...)`` starting at token ``k``."""
        j = k
        while self.tokens[j + 1].text == "." and self.tokens[j + 2].kind == "name":
            j += 2
        attr = self.tokens[j].text
        if self.tokens[j + 1].text == "(":
            self.fail(f"call of {self.segment(k, j)}", _suggest(attr, FUNCTIONS))
        self.fail(f"attribute access {self.segment(k, j)}", _suggest(attr, FUNCTIONS))

    def deeper(self, depth: int) -> int:
        if depth >= MAX_DEPTH:
            self.fail(f"nesting deeper than {MAX_DEPTH} levels (the limit)",
                      "split the formula or remove redundant parentheses or signs. ")
        return depth + 1

    # -- grammar
    def parse(self) -> Expr:
        e = self.sum(0)
        tok = self.tokens[self.i]
        if tok.kind != "end":
            self.unexpected(tok)
        if e.size > MAX_NODES:
            self.fail(f"expression of {e.size:,} distinct terms is larger than the limit of "
                      f"{MAX_NODES:,}")
        return e

    def sum(self, depth: int) -> Expr:
        left = self.product(depth)
        while self.tokens[self.i].text in ("+", "-") and self.tokens[self.i].kind == "op":
            op = self.tokens[self.i].text
            self.i += 1
            left = Expr(op, (left, self.product(depth)))
        return left

    def product(self, depth: int) -> Expr:
        left = self.unary(depth)
        while self.tokens[self.i].text in ("*", "/") and self.tokens[self.i].kind == "op":
            op = self.tokens[self.i].text
            self.i += 1
            left = Expr(op, (left, self.unary(depth)))
        return left

    def unary(self, depth: int) -> Expr:
        signs = []
        while self.tokens[self.i].text in ("+", "-") and self.tokens[self.i].kind == "op":
            signs.append(self.tokens[self.i].text)
            depth = self.deeper(depth)
            self.i += 1
        e = self.power(depth)
        for s in reversed(signs):
            if s == "-":
                e = Expr("neg", (e,))
        return e

    def power(self, depth: int) -> Expr:
        base = self.atom(depth)
        if self.tokens[self.i].text == "**":
            self.i += 1
            return Expr("**", (base, self.unary(self.deeper(depth))))
        return base

    def atom(self, depth: int) -> Expr:
        k = self.i
        tok = self.tokens[k]
        nxt = self.tokens[k + 1] if tok.kind != "end" else tok
        if tok.kind == "num":
            if not _NUMBER.match(tok.text):
                self.fail(f"unsupported constant {self.segment(k, k)}",
                          "use a real number such as 2, 0.5 or 1.5e3. ")
            value = float(tok.text)
            if not math.isfinite(value):
                self.fail(f"number {self.segment(k, k)} is too large")
            if nxt.text == "(":
                self.i = k + 1
                self.unexpected(nxt)
            self.i = k + 1
            return Expr("num", (value,))
        if tok.kind == "name":
            return self.name(k, depth)
        if tok.kind == "op" and tok.text == "(":
            if nxt.text == ")":
                self.syntax(nxt, "empty parentheses")
            self.i = k + 1
            e = self.sum(self.deeper(depth))
            self.close(k)
            return e
        if tok.kind == "str":
            self.fail(f"unsupported constant {self.segment(k, k)}", "use a real number. ")
        if tok.text in _KIND:
            end = tok.match if tok.match >= 0 else len(self.tokens) - 2
            self.fail(f"unsupported syntax {self.segment(k, end)} ({_KIND[tok.text]})")
        if tok.kind == "end":
            self.syntax(tok, "the expression ends early")
        if tok.text in ("~", "!"):
            self.fail(f"operator '{tok.text}' is not allowed")
        self.syntax(tok, f"expected a number, a name or '(' but got {_shorten(repr(tok.text), 20)}")

    def close(self, k: int):
        """Expect the ')' that closes the '(' at token ``k``."""
        tok = self.tokens[self.i]
        if tok.text == ")" and tok.kind == "op":
            self.i += 1
            return
        if tok.kind == "end":
            self.syntax(self.tokens[k], "'(' was never closed")
        self.unexpected(tok)

    def name(self, k: int, depth: int) -> Expr:
        tok, nxt = self.tokens[k], self.tokens[k + 1]
        name = tok.text
        if nxt.text == "." and nxt.kind == "op":
            self.attribute(k)
        if name in ("True", "False", "None"):
            self.fail(f"unsupported constant {self.segment(k, k)}", "use a real number. ")
        if name in _KEYWORD_KIND or keyword.iskeyword(name):
            self.fail(f"unsupported syntax {self.segment(k, len(self.tokens) - 2)} "
                      f"({_KEYWORD_KIND.get(name, 'keyword ' + repr(name))})")
        if nxt.text == "(" and nxt.kind == "op":
            return self.call(k, depth)
        self.i = k + 1
        if name in self.variables:
            return Expr("var", (name,))
        if name in CONSTANTS:
            return Expr("num", (CONSTANTS[name],))
        if name in FUNCTIONS or name in ALIASES:
            self.fail(f"function '{name}' used without an argument",
                      f"write e.g. '{name}({', '.join(['t'] * ARITY.get(name, 1))})'. ")
        self.fail(f"unknown name {_shorten(repr(name), 40)}",
                  _suggest(name, (*self.variables, *CONSTANTS, *FUNCTIONS)))

    def call(self, k: int, depth: int) -> Expr:
        name, opening = self.tokens[k].text, self.tokens[k + 1]
        closing = opening.match
        if closing >= 0 and self.tokens[closing + 1].text == ".":    # f(...).attr
            j = closing + 1
            while self.tokens[j].text == "." and self.tokens[j + 1].kind == "name":
                j += 2
            self.fail(f"call of {self.segment(k, j - 1)}",
                      _suggest(self.tokens[j - 1].text, FUNCTIONS))
        if name in self.variables or name in CONSTANTS:
            self.i = k + 1
            self.unexpected(opening)
        func = ALIASES.get(name, name)
        if func not in FUNCTIONS:
            self.fail(f"unknown function {_shorten(repr(name), 40)}", _suggest(name, FUNCTIONS))
        depth = self.deeper(depth)
        self.i = k + 2
        args = []
        while True:
            tok, nxt = self.tokens[self.i], self.tokens[self.i + 1] if self.i + 1 < len(
                self.tokens) else self.tokens[-1]
            if tok.kind == "name" and nxt.text == "=":
                self.fail(f"keyword argument '{_shorten(tok.text, 20)}=' in the call of '{name}'",
                          "give the arguments by position. ")
            if tok.text == ")" and not args:
                break
            args.append(self.condition(depth) if func == "where" and not args
                        else self.sum(depth))
            if self.tokens[self.i].text != ",":
                break
            self.i += 1
        self.close(k + 1)
        n = ARITY.get(func, 1)
        if len(args) != n:
            count = {1: "exactly one argument", 2: "exactly two arguments",
                     3: "exactly three arguments"}[n]
            self.fail(f"function '{name}' takes {count}, got {self.segment(k, self.i - 1)}")
        return Expr(func, tuple(args))

    def condition(self, depth: int) -> Expr:
        """``a < b`` (or <=, >, >=): the first argument of where."""
        left = self.sum(depth)
        tok = self.tokens[self.i]
        if tok.kind != "op" or tok.text not in COMPARISONS:
            if tok.text in ("==", "!="):
                self.fail(f"comparison '{tok.text}' is not allowed",
                          "compare with < <= > >= in where(). ")
            self.fail("the condition of where(cond, a, b) must be a comparison",
                      "write e.g. 'where(t < 1, t, 1)'. ")
        self.i += 1
        right = self.sum(depth)
        after = self.tokens[self.i]
        if after.kind == "op" and after.text in COMPARISONS:
            self.fail("chained comparison in the condition of where",
                      "nest where() for two conditions, e.g. 'where(t < 1, a, where(t < 2, b, c))'. ")
        return Expr(tok.text, (left, right))


def _allowed(variables) -> str:
    names = list(variables)
    shown = ", ".join(names[:6]) + (f" (and {len(names) - 6} more)" if len(names) > 6 else "")
    return (f"Allowed: numbers, {shown}, pi, e; + - * / **; "
            f"{', '.join(f for f in FUNCTIONS if f not in ARITY)}, min(a, b), max(a, b), "
            f"clip(x, lo, hi), where(cond, a, b) with < <= > >= in cond.")


def _shorten(text: str, n: int = 60) -> str:
    return text if len(text) <= n else text[:n - 3] + "..."


def _suggest(name: str, candidates) -> str:
    """``"did you mean 'x'? "`` for the closest candidate, or ``""``."""
    if len(name) > 40:
        return ""
    lower = {c.lower(): c for c in candidates}
    match = ([lower[name.lower()]] if name.lower() in lower
             else ["log"] if name == "ln" and "log" in candidates
             else difflib.get_close_matches(name, list(candidates), n=1))
    return f"did you mean '{match[0]}'? " if match else ""


# ------------------------------------------------------------------- evaluation, printing

def _as_array(v) -> np.ndarray:
    a = np.asarray(v)
    return a.astype(np.complex128 if np.iscomplexobj(a) else np.float64)


def _evaluate(e: Expr, values: dict[str, np.ndarray]):
    """Each distinct node once, children first; a value is dropped after its last use."""
    nodes, children, frees = _program(e)
    out: list = [None] * len(nodes)
    for k, node in enumerate(nodes):
        if node.op == "num":
            out[k] = node.args[0]
        elif node.op == "var":
            out[k] = values[node.args[0]]
        else:
            out[k] = _OPS[node.op](*(out[i] for i in children[k]))
            for i in frees[k]:
                out[i] = None
    return out[-1]


def _format(e: Expr) -> str:
    """Text of ``e`` (parsable again, to the same values)."""
    nodes, children, _ = _program(e)
    text: list[tuple[str, int]] = []                             # (text, precedence) per node
    for node, kids in zip(nodes, children):
        if node.op == "num":
            v = node.args[0]
            t = "pi" if v == math.pi else "e" if v == math.e else repr(v).removesuffix(".0")
            text.append((t, 3 if v < 0 else 5))
            continue
        if node.op == "var":
            text.append((node.args[0], 5))
            continue
        if node.op in FUNCTIONS:
            text.append((f"{node.op}({', '.join(text[i][0] for i in kids)})", 5))
            continue
        p = _PRECEDENCE[node.op]
        if node.op == "neg":
            t, q = text[kids[0]]
            text.append(("-" + (f"({t})" if q < p else t), p))
            continue
        (lt, lp), (rt, rp) = text[kids[0]], text[kids[1]]
        left = f"({lt})" if lp < p or (node.op == "**" and lp == p) else lt
        right = f"({rt})" if rp < p or (node.op in "-/" and rp == p) else rt
        sep = f" {node.op} " if p <= 1 else node.op
        text.append((left + sep + right, p))
    return text[-1][0]


# ------------------------------------------------------ simplifying constructors, derivative

ZERO, ONE, TWO = Expr("num", (0.0,)), Expr("num", (1.0,)), Expr("num", (2.0,))


def _num(e: Expr, value: float) -> bool:
    return e.op == "num" and e.args[0] == value


def _node(op: str, *args: Expr) -> Expr:
    """``Expr(op, args)``, folded to a number when every operand is constant and the result finite."""
    if op not in COMPARISONS and not any(a.variables for a in args):
        with np.errstate(all="ignore"):
            v = float(_OPS[op](*(_evaluate(a, {}) for a in args)))
        if math.isfinite(v):
            return Expr("num", (v,))
    return Expr(op, args)


def neg(a: Expr) -> Expr:
    if a.op == "neg":
        return a.args[0]
    if a.op == "-":                                              # -(x - y) -> y - x
        return sub(a.args[1], a.args[0])
    if a.op in ("*", "/") and (a.args[0]._negative or a.args[0].op == "num"):
        return _node(a.op, neg(a.args[0]), a.args[1])           # -(c*x) -> (-c)*x
    return _node("neg", a)


def add(a: Expr, b: Expr) -> Expr:
    if _num(a, 0):
        return b
    if _num(b, 0):
        return a
    if b._negative:
        return sub(a, neg(b))
    return sub(b, neg(a)) if a._negative else _node("+", a, b)


def sub(a: Expr, b: Expr) -> Expr:
    if _num(b, 0):
        return a
    if _num(a, 0):
        return neg(b)
    if a is b:
        return ZERO
    return add(a, neg(b)) if b._negative else _node("-", a, b)


def mul(a: Expr, b: Expr) -> Expr:
    if _num(a, 0) or _num(b, 0):
        return ZERO
    if not b.variables and a.variables:                          # constant factor first
        a, b = b, a
    if _num(a, 1):
        return b
    if _num(a, -1):
        return neg(b)
    if a.op == "neg" or b.op == "neg":                           # pull signs out
        return neg(mul(a.args[0] if a.op == "neg" else a, b.args[0] if b.op == "neg" else b))
    if b.op == "/":                                              # a*(u/v) -> (a*u)/v
        return div(mul(a, b.args[0]), b.args[1])
    if a.op == "/":                                              # (u/v)*b -> (u*b)/v
        return div(mul(a.args[0], b), a.args[1])
    if a.op == "*" and a.variables and not a.args[0].variables:  # (c*x)*y -> c*(x*y)
        return mul(a.args[0], mul(a.args[1], b))
    if b.op == "*" and not b.args[0].variables:                  # a*(c*x) -> (a*c)*x or c*(a*x)
        c, x = b.args
        return mul(_node("*", a, c), x) if not a.variables else mul(c, mul(a, x))
    return power(a, TWO) if a is b else _node("*", a, b)


def div(a: Expr, b: Expr) -> Expr:
    if _num(a, 0):
        return ZERO
    if a.op == "neg":
        return neg(div(a.args[0], b))
    if a is b:
        return ONE
    return a if _num(b, 1) else _node("/", a, b)


def power(a: Expr, b: Expr) -> Expr:
    if _num(b, 0):
        return ONE
    if a.op == "**" and b.op == "num" and b.args[0].is_integer() and not a.args[1].variables:
        return power(a.args[0], mul(a.args[1], b))               # (u^c)^n = u^(c n)
    return a if _num(b, 1) else _node("**", a, b)


def call(name: str, *u: Expr) -> Expr:
    return _node(name, *u)


def where(cond: Expr, a: Expr, b: Expr) -> Expr:
    """``where(cond, a, b)``, or ``a`` when both branches are the same."""
    return a if a is b else Expr("where", (cond, a, b))


# f'(u) for each function f of one argument, as an expression of u
_DERIVATIVES = {
    "sin": lambda u: call("cos", u),
    "cos": lambda u: neg(call("sin", u)),
    "tan": lambda u: div(ONE, power(call("cos", u), TWO)),
    "exp": lambda u: call("exp", u),
    "log": lambda u: div(ONE, u),
    "sqrt": lambda u: div(Expr("num", (0.5,)), call("sqrt", u)),
    "sinh": lambda u: call("cosh", u),
    "cosh": lambda u: call("sinh", u),
    "tanh": lambda u: sub(ONE, power(call("tanh", u), TWO)),
    "asin": lambda u: div(ONE, call("sqrt", sub(ONE, power(u, TWO)))),
    "acos": lambda u: neg(div(ONE, call("sqrt", sub(ONE, power(u, TWO))))),
    "atan": lambda u: div(ONE, add(ONE, power(u, TWO))),
    "abs": lambda u: call("sign", u),                            # |u|' = sign(u) u'
    "sign": lambda u: ZERO,                                      # piecewise constant
}


def _diff(e: Expr, x: str) -> Expr:
    """d e / d x over the shared graph: each distinct node differentiated once, children first."""
    nodes, children, _ = _program(e)
    d: list = [None] * len(nodes)
    try:
        for k, node in enumerate(nodes):
            d[k] = _diff_node(node, [d[i] for i in children[k]], x)
    except RecursionError:
        raise ExpressionError(f"the derivative of {_label(e)} nests too deeply "
                              f"to simplify") from None
    result = d[-1]
    if result.size > MAX_NODES:
        raise ExpressionError(f"the derivative of {_label(e)} with respect to {x} "
                              f"has {result.size:,} distinct terms, more than the limit of "
                              f"{MAX_NODES:,}; simplify the formula (e.g. write a product of "
                              f"equal factors as a power)")
    return result


def _diff_node(e: Expr, d: list, x: str) -> Expr | None:
    """Derivative of one node ``e`` given its operands' derivatives ``d``."""
    if e.op in COMPARISONS:
        return None                                              # only used as a condition
    if x not in e.variables:
        return ZERO
    if e.op == "var":
        return ONE
    if e.op == "neg":
        return neg(d[0])
    if e.op == "+":
        return add(*d)
    if e.op == "-":
        return sub(*d)
    if e.op in _DERIVATIVES:                                     # chain rule: u' f'(u)
        return mul(d[0], _DERIVATIVES[e.op](e.args[0]))
    if e.op == "min":                                            # the branch that is taken
        return where(Expr("<=", e.args), d[0], d[1])
    if e.op == "max":
        return where(Expr(">=", e.args), d[0], d[1])
    if e.op == "clip":                                           # lo below lo, hi above hi
        u, lo, hi = e.args
        return where(Expr("<", (u, lo)), d[1], where(Expr(">", (u, hi)), d[2], d[0]))
    if e.op == "where":
        return where(e.args[0], d[1], d[2])
    (u, v), (du, dv) = e.args, d
    if e.op == "*":                                              # u' v + u v'
        return add(mul(du, v), mul(u, dv))
    if e.op == "/":                                              # u'/v - u v'/v^2
        return sub(div(du, v), div(mul(u, dv), power(v, TWO)))
    if x not in v.variables:                                     # (u^c)' = c u^(c-1) u'
        return mul(mul(v, power(u, sub(v, ONE))), du)
    if x not in u.variables:                                     # (c^v)' = c^v log(c) v'
        return mul(mul(e, call("log", u)), dv)
    return mul(e, add(mul(dv, call("log", u)), div(mul(v, du), u)))   # u^v (v' log u + v u'/u)
