"""Safe expressions of time with exact derivatives.

A driver's motion may be given as text, e.g. ``"0.3 + 6.0*t + 0.4*sin(5*t)"``. :func:`parse` reads it
with Python's :mod:`ast` parser and accepts only a whitelist of node types (numbers, the declared
variables, ``pi``, ``e``, ``+ - * / **`` and calls of smooth elementary functions); the text is
never executed. :meth:`Expr.diff` differentiates the tree symbolically, so driver velocities and
accelerations are exact rather than finite differences.

Examples
--------
>>> q = parse("0.3 + 6.0*t + 0.4*sin(5*t)")
>>> str(q.diff())
'6 + 2*cos(5*t)'
>>> str(q.diff().diff())
'-10*sin(5*t)'
>>> float(q(0.0))
0.3
"""

from __future__ import annotations

import ast
import difflib
import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

__all__ = ["Expr", "ExpressionError", "parse", "CONSTANTS", "FUNCTIONS"]

CONSTANTS = {"pi": math.pi, "e": math.e}
FUNCTIONS = {"sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log,
             "sqrt": np.sqrt, "sinh": np.sinh, "cosh": np.cosh, "tanh": np.tanh,
             "asin": np.arcsin, "acos": np.arccos, "atan": np.arctan}
ALIASES = {"arcsin": "asin", "arccos": "acos", "arctan": "atan"}   # NumPy spellings
MAX_DEPTH = 100                                                     # nesting levels accepted

_OPS = {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide, "**": np.power,
        "neg": np.negative, **FUNCTIONS}
_PRECEDENCE = {"+": 1, "-": 1, "*": 2, "/": 2, "neg": 3, "**": 4}   # others (atoms, calls): 5


class ExpressionError(ValueError):
    """Text that is not an allowed expression (one-line message naming the offending token)."""


@dataclass(frozen=True)
class Expr:
    """An immutable expression tree.

    Attributes
    ----------
    op : str
        ``'num'`` (``args = (value,)``, a finite float), ``'var'`` (``args = (name,)``),
        ``'+' '-' '*' '/' '**'`` (two operands), ``'neg'`` (one operand) or a function name of
        :data:`FUNCTIONS` (one operand).
    args : tuple
        The operands (``Expr``), or the value or name of a leaf.
    """

    op: str
    args: tuple = ()

    @cached_property
    def variables(self) -> frozenset[str]:
        """Names of the variables the expression depends on."""
        if self.op == "var":
            return frozenset(self.args)
        return frozenset().union(*(a.variables for a in self.args if isinstance(a, Expr)))

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
            result is NaN (NumPy rules), never an exception.
        """
        arrays = {k: _as_array(v) for k, v in values.items()}
        missing = sorted(self.variables - arrays.keys())
        if missing:
            raise ValueError(f"no value given for variable(s) {', '.join(missing)} of '{self}'")
        shape = np.broadcast_shapes(*(a.shape for a in arrays.values()))
        return _evaluate(self, arrays) + np.zeros(shape)

    def __call__(self, t) -> np.ndarray:
        """Evaluate at ``t`` (array_like, any shape): shorthand for ``evaluate(t=t)``."""
        return self.evaluate(t=t)

    def diff(self, var: str = "t") -> Expr:
        """Exact derivative with respect to ``var``, lightly simplified (0*x -> 0, constants folded)."""
        return _diff(self, var)

    def __str__(self) -> str:
        return _format(self)[0]


def parse(text: str, variables: tuple[str, ...] = ("t",)) -> Expr:
    """Parse text into an :class:`Expr`, accepting only whitelisted syntax (no eval/exec).

    Parameters
    ----------
    text : str
        E.g. ``"0.3 + 6.0*t + 0.4*sin(5*t)"``. Allowed: numbers, the names in ``variables``,
        ``pi``, ``e``, unary ``+ -``, binary ``+ - * / **`` and calls with one argument of
        sin, cos, tan, exp, log, sqrt, sinh, cosh, tanh, asin, acos, atan (also arcsin, arccos,
        arctan).
    variables : tuple of str
        Names of the free variables.

    Raises
    ------
    ExpressionError
        With a one-line message naming the offending token, suggesting the closest allowed
        name for a misspelt one, and listing what is allowed.
    """
    variables = (variables,) if isinstance(variables, str) else tuple(variables)
    for v in variables:
        if not v.isidentifier() or v in CONSTANTS or v in FUNCTIONS or v in ALIASES:
            raise ValueError(f"invalid variable name {v!r}")
    if not isinstance(text, str):
        raise ExpressionError(f"expected an expression as text, got {type(text).__name__} {text!r}")
    src = text.strip()
    if not src:
        raise ExpressionError(f"empty expression; {_allowed(variables)}")
    try:
        return _build(ast.parse(src, mode="eval").body, src, variables, 0)
    except SyntaxError as exc:
        where = f" at column {exc.offset}" if exc.offset else ""
        raise ExpressionError(f"invalid syntax in {_shorten(src)!r}{where} ({exc.msg}). "
                              f"{_allowed(variables)}") from None
    except RecursionError:
        raise ExpressionError(f"expression {_shorten(src)!r} is nested too deeply") from None


# ---------------------------------------------------------------------------------- parsing

_BINARY = {ast.Add: "+", ast.Sub: "-", ast.Mult: "*", ast.Div: "/", ast.Pow: "**"}
_SYMBOLS = {ast.Mod: "%", ast.FloorDiv: "//", ast.MatMult: "@", ast.LShift: "<<",
            ast.RShift: ">>", ast.BitOr: "|", ast.BitAnd: "&", ast.Not: "not", ast.Invert: "~"}
_KINDS = {ast.Subscript: "subscript", ast.Compare: "comparison", ast.Lambda: "lambda",
          ast.BoolOp: "boolean operator", ast.IfExp: "conditional expression",
          ast.Tuple: "tuple", ast.List: "list", ast.Dict: "dict", ast.Set: "set",
          ast.JoinedStr: "f-string", ast.NamedExpr: "assignment", ast.Starred: "starred argument"}


def _allowed(variables) -> str:
    return (f"Allowed: numbers, {', '.join(variables)}, pi, e; + - * / **; "
            f"{', '.join(FUNCTIONS)}.")


def _shorten(text: str, n: int = 60) -> str:
    return text if len(text) <= n else text[:n - 3] + "..."


def _suggest(name: str, candidates) -> str:
    """``"did you mean 'x'? "`` for the closest candidate, or ``""``."""
    lower = {c.lower(): c for c in candidates}
    match = ([lower[name.lower()]] if name.lower() in lower
             else ["log"] if name == "ln" and "log" in candidates
             else difflib.get_close_matches(name, list(candidates), n=1))
    return f"did you mean '{match[0]}'? " if match else ""


def _build(node: ast.AST, src: str, variables: tuple[str, ...], depth: int) -> Expr:
    """Translate one whitelisted ``ast`` node (recursively) into an :class:`Expr`."""
    def fail(what: str, hint: str = ""):
        raise ExpressionError(f"{what} in {_shorten(src)!r}; {hint}{_allowed(variables)}")

    def child(n):
        return _build(n, src, variables, depth + 1)

    if depth > MAX_DEPTH:
        fail(f"nesting deeper than {MAX_DEPTH} levels")
    seg = ast.get_source_segment(src, node) or ast.unparse(node)
    if isinstance(node, ast.Constant):
        v = node.value
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            fail(f"unsupported constant {seg!r}", "use a real number. ")
        if isinstance(v, int) and abs(v) > 1e300 or not math.isfinite(v):
            fail(f"number {seg!r} is too large")
        return Expr("num", (float(v),))
    if isinstance(node, ast.Name):
        name = node.id
        if name in variables:
            return Expr("var", (name,))
        if name in CONSTANTS:
            return Expr("num", (CONSTANTS[name],))
        if name in FUNCTIONS or name in ALIASES:
            fail(f"function '{name}' used without an argument", f"write e.g. '{name}(t)'. ")
        fail(f"unknown name '{name}'", _suggest(name, (*variables, *CONSTANTS, *FUNCTIONS)))
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.UAdd, ast.USub)):
        operand = child(node.operand)
        return operand if isinstance(node.op, ast.UAdd) else Expr("neg", (operand,))
    if isinstance(node, ast.BinOp) and type(node.op) in _BINARY:
        return Expr(_BINARY[type(node.op)], (child(node.left), child(node.right)))
    if isinstance(node, ast.BinOp) and isinstance(node.op, ast.BitXor):
        fail("operator '^' is not a power", "use '**' for powers, e.g. 't**2'. ")
    if isinstance(node, (ast.BinOp, ast.UnaryOp)):
        fail(f"operator '{_SYMBOLS.get(type(node.op), type(node.op).__name__)}' is not allowed")
    if isinstance(node, ast.Call):
        func = ast.get_source_segment(src, node.func) or ast.unparse(node.func)
        if isinstance(node.func, ast.Attribute):
            fail(f"call of {func!r}", _suggest(node.func.attr, FUNCTIONS))
        name = getattr(node.func, "id", "")
        if name not in FUNCTIONS and name not in ALIASES and (
                name in variables or name in CONSTANTS or not isinstance(node.func, ast.Name)):
            fail(f"{func!r} is not a function", f"use '*' to multiply, e.g. '{func}*(...)'. ")
        if name == "abs":
            fail("function 'abs' is not allowed (it is not smooth, so its derivative "
                 "is undefined at 0)", "use sqrt(x**2 + eps**2) for a smooth version. ")
        if name not in FUNCTIONS and name not in ALIASES:
            fail(f"unknown function '{name}'", _suggest(name, FUNCTIONS))
        if node.keywords:
            fail(f"keyword argument '{node.keywords[0].arg}=' in the call of '{name}'")
        if len(node.args) != 1 or isinstance(node.args[0], ast.Starred):
            fail(f"function '{name}' takes exactly one argument, got {seg!r}")
        return Expr(ALIASES.get(name, name), (child(node.args[0]),))
    if isinstance(node, ast.Attribute):
        fail(f"attribute access {seg!r}", _suggest(node.attr, FUNCTIONS))
    fail(f"unsupported syntax {seg!r} ({_KINDS.get(type(node), type(node).__name__)})")


# ------------------------------------------------------------------- evaluation, printing

def _as_array(v) -> np.ndarray:
    a = np.asarray(v)
    return a.astype(np.complex128 if np.iscomplexobj(a) else np.float64)


def _evaluate(e: Expr, values: dict[str, np.ndarray]):
    if e.op == "num":
        return e.args[0]
    if e.op == "var":
        return values[e.args[0]]
    return _OPS[e.op](*(_evaluate(a, values) for a in e.args))


def _format(e: Expr) -> tuple[str, int]:
    """Text of ``e`` (parsable again, to the same values) and its precedence."""
    if e.op == "num":
        v = e.args[0]
        text = "pi" if v == math.pi else "e" if v == math.e else repr(v).removesuffix(".0")
        return text, 3 if v < 0 else 5
    if e.op == "var":
        return e.args[0], 5
    if e.op in FUNCTIONS:
        return f"{e.op}({_format(e.args[0])[0]})", 5
    p = _PRECEDENCE[e.op]
    if e.op == "neg":
        t, q = _format(e.args[0])
        return "-" + (f"({t})" if q < p else t), p
    (lt, lp), (rt, rp) = map(_format, e.args)
    left = f"({lt})" if lp < p or (e.op == "**" and lp == p) else lt
    right = f"({rt})" if rp < p or (e.op in "-/" and rp == p) else rt
    sep = f" {e.op} " if p == 1 else e.op
    return left + sep + right, p


# ------------------------------------------------------ simplifying constructors, derivative

ZERO, ONE, TWO = Expr("num", (0.0,)), Expr("num", (1.0,)), Expr("num", (2.0,))


def _num(e: Expr, value: float) -> bool:
    return e.op == "num" and e.args[0] == value


def _node(op: str, *args: Expr) -> Expr:
    """``Expr(op, args)``, folded to a number when every operand is constant and the result finite."""
    if not any(a.variables for a in args):
        with np.errstate(all="ignore"):
            v = float(_OPS[op](*(_evaluate(a, {}) for a in args)))
        if math.isfinite(v):
            return Expr("num", (v,))
    return Expr(op, args)


def _negative(e: Expr) -> bool:
    """True for -x, a negative number, and (-c)*x or (-c)/x: these read better subtracted."""
    return (e.op == "neg" or e.op == "num" and e.args[0] < 0
            or e.op in ("*", "/") and _negative(e.args[0]))


def neg(a: Expr) -> Expr:
    if a.op == "neg":
        return a.args[0]
    if a.op == "-":                                              # -(x - y) -> y - x
        return sub(a.args[1], a.args[0])
    if a.op in ("*", "/") and (_negative(a.args[0]) or a.args[0].op == "num"):
        return _node(a.op, neg(a.args[0]), a.args[1])           # -(c*x) -> (-c)*x
    return _node("neg", a)


def add(a: Expr, b: Expr) -> Expr:
    if _num(a, 0):
        return b
    if _num(b, 0):
        return a
    if _negative(b):
        return sub(a, neg(b))
    return sub(b, neg(a)) if _negative(a) else _node("+", a, b)


def sub(a: Expr, b: Expr) -> Expr:
    if _num(b, 0):
        return a
    if _num(a, 0):
        return neg(b)
    if a == b:
        return ZERO
    return add(a, neg(b)) if _negative(b) else _node("-", a, b)


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
    return power(a, TWO) if a == b else _node("*", a, b)


def div(a: Expr, b: Expr) -> Expr:
    if _num(a, 0):
        return ZERO
    if a.op == "neg":
        return neg(div(a.args[0], b))
    if a == b:
        return ONE
    return a if _num(b, 1) else _node("/", a, b)


def power(a: Expr, b: Expr) -> Expr:
    if _num(b, 0):
        return ONE
    if a.op == "**" and b.op == "num" and b.args[0].is_integer() and not a.args[1].variables:
        return power(a.args[0], mul(a.args[1], b))               # (u^c)^n = u^(c n)
    return a if _num(b, 1) else _node("**", a, b)


def call(name: str, u: Expr) -> Expr:
    return _node(name, u)


# f'(u) for each function f, as an expression of u
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
}


def _diff(e: Expr, x: str) -> Expr:
    if x not in e.variables:
        return ZERO
    if e.op == "var":
        return ONE
    d = [_diff(a, x) for a in e.args]
    if e.op == "neg":
        return neg(d[0])
    if e.op == "+":
        return add(*d)
    if e.op == "-":
        return sub(*d)
    if e.op in FUNCTIONS:                                        # chain rule: u' f'(u)
        return mul(d[0], _DERIVATIVES[e.op](e.args[0]))
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
