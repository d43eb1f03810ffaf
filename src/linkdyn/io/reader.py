"""The validation context of a model file: type checks whose messages name the field and the fix.

:class:`_Reader` carries the file, its directory and its declared units; every check raises
:class:`~linkdyn.errors.ModelError` with the dotted field path, and an unknown name gets the
closest valid spelling (:func:`_did_you_mean`).
"""

from __future__ import annotations

import difflib
import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from .. import expr as _expr
from ..errors import ModelError

_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_\-]*\Z")
MAX_NAME = 100              # characters of a body, point, joint or load name
MAX_MAGNITUDE = 1e12        # largest magnitude of a number in a model file, in the file's units
MIN_MAGNITUDE = 1e-30       # smallest non-zero magnitude
MAX_SAMPLES = 10_000_000    # [analysis] samples


def _quote(value: Any, n: int = 40) -> str:
    """A value from the file for a message: quoted, escaped and shortened (never echoed whole)."""
    if isinstance(value, str):
        if len(value) <= n:
            return repr(value)
        return repr(value[:n]) + f"... ({len(value):,} characters)"
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**n:
        digits = int(abs(value).bit_length() * 0.30103) + 1
        return f"an integer of about {digits:,} digits"
    return _shorten(repr(value), n)


def _shorten(text: str, n: int = 40) -> str:
    return text if len(text) <= n else text[:n - 3] + "..."


def _did_you_mean(word: Any, choices, what: str) -> str:
    """'Did you mean ...? Valid <what>: ...' for an unknown name."""
    choices = list(choices)
    if not choices:
        return f"There are no {what} to choose from"
    text = ""
    if isinstance(word, str) and len(word) <= MAX_NAME:
        lower = {c.lower(): c for c in choices}
        close = ([lower[word.lower()]] if word.lower() in lower
                 else difflib.get_close_matches(word, choices, n=1, cutoff=0.5))
        text = f"Did you mean '{close[0]}'? " if close else ""
    if len(choices) <= 16:
        text += f"Valid {what}: {', '.join(choices)}"
    return text.strip()


def _type_name(value: Any) -> str:
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, str):
        return f"the string {_quote(value)}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return f"a list of {_count(len(value))}"
    return _quote(value)


@dataclass
class _Reader:
    """Validation context: the file read, the directory it is in and its declared units."""

    file: str
    base_dir: Path
    length: float = 1.0
    angle: float = 1.0
    length_name: str = "m"
    angle_name: str = "rad"
    allow_outside: bool = False      # motion tables may lie outside base_dir
    dim: int = 2                     # components of a vector: 2 planar, 3 spatial
    kinds: Any = None                # the joint kinds' registry (None: linkdyn.joints)

    def kind(self, name: str):
        """The joint kind ``name`` of this file's space (planar or spatial)."""
        if self.kinds is None:
            from .. import joints
            return joints.get(name)
        return self.kinds.get(name)

    def fail(self, field: str, message: str, fix: str) -> NoReturn:
        raise ModelError(message, file=self.file, field=field, fix=fix)

    def table(self, value: Any, field: str, keys, required=(), *, noun="key", what="keys",
              note="") -> dict:
        """Check that ``value`` is a table with known keys only and the ``required`` ones."""
        if not isinstance(value, dict):
            self.fail(field, f"expected a table, got {_type_name(value)}",
                      f"Write it as [{field}] or {{ key = value, ... }}")
        for key in value:
            if key not in keys:
                self.fail(field, f"unknown {noun} {_quote(key)}", _did_you_mean(key, keys, what) + (
                    f". {note}" if note else ""))
        for key in required:
            if key not in value:
                self.fail(f"{field}.{key}" if field else key, f"missing required key '{key}'",
                          f"Add {key} = ...")
        return value

    def entries(self, value: Any, field: str) -> list[dict]:
        """An array of tables such as [[bodies]]."""
        fix = f"Write each entry under its own [[{field}]] header"
        if not isinstance(value, list):
            self.fail(field, f"expected an array of tables, got {_type_name(value)}", fix)
        for i, entry in enumerate(value):
            if not isinstance(entry, dict):
                self.fail(f"{field}[{i}]", f"expected a table, got {_type_name(entry)}", fix)
        return value

    def number(self, value: Any, field: str, unit: str = "", *, positive=False,
               nonnegative=False, fix: str = "") -> float:
        u = f" {unit}" if unit else ""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            hint = " without quotes" if isinstance(value, str) and _is_float(value) else ""
            self.fail(field, f"expected a number{' in' + u if u else ''}, got {_type_name(value)}",
                      f"Write a plain number{hint}, e.g. {_key(field)} = 1.5")
        try:
            x = float(value)
        except OverflowError:                                    # an integer beyond 1.8e308
            x = math.inf if value > 0 else -math.inf
        if not math.isfinite(x):
            self.fail(field, f"must be a finite number, got {_quote(value)}",
                      fix or f"Give a finite value of magnitude at most {MAX_MAGNITUDE:g}{u}")
        if abs(x) > MAX_MAGNITUDE or 0 < abs(x) < MIN_MAGNITUDE:
            self.fail(field, f"magnitude of {x:g}{u} is out of range",
                      f"Give 0 or a magnitude from {MIN_MAGNITUDE:g} to {MAX_MAGNITUDE:g}{u} "
                      f"(linkdyn's limits for a number in a model file)")
        if positive and x <= 0:
            self.fail(field, f"must be positive, got {x:g}{u}", fix or f"Give a value > 0{u}")
        if nonnegative and x < 0:
            self.fail(field, f"must not be negative, got {x:g}{u}", fix or f"Give a value >= 0{u}")
        return x

    def vector(self, value: Any, field: str, unit: str = "", n: int | None = None) -> np.ndarray:
        """A vector of ``n`` numbers (default the file's :attr:`dim`)."""
        n = n or self.dim
        if not isinstance(value, list) or len(value) != n:
            got = _count(len(value)) if isinstance(value, list) else _type_name(value)
            u = f" in {unit}" if unit else ""
            self.fail(field, f"expected a vector [{', '.join('xyz'[:n])}] of {n} numbers{u}, "
                      f"got {got}", f"Write e.g. {_key(field)} = "
                      f"[{', '.join(['1.0'] + ['0.0'] * (n - 1))}]")
        return np.array([self.number(c, f"{field}[{i}]", unit) for i, c in enumerate(value)])

    def string(self, value: Any, field: str, *, empty=False) -> str:
        if not isinstance(value, str) or (not value and not empty):
            self.fail(field, f"expected a non-empty string, got {_type_name(value)}",
                      f'Write it in double quotes, e.g. {_key(field)} = "..."')
        return value

    def name(self, value: Any, field: str) -> str:
        self.string(value, field)
        if len(value) > MAX_NAME:
            self.fail(field, f"name {_quote(value)} is longer than {MAX_NAME} characters",
                      "Give a shorter name")
        if not _NAME.match(value):
            self.fail(field, f"invalid name {_quote(value)}",
                      "Use letters, digits, '_' and '-' only (no dots or spaces)")
        return value

    def choice(self, value: Any, field: str, choices, what: str, plural: str = "") -> str:
        if not isinstance(value, str) or value not in choices:
            self.fail(field, f"unknown {what} {_quote(value)}" if isinstance(value, str)
                      else f"expected the name of a {what}, got {_type_name(value)}",
                      _did_you_mean(value, choices, plural or f"{what}s"))
        return value

    def point(self, body: str, points: dict, value: Any, field: str) -> str:
        if not isinstance(value, str) or value not in points:
            self.fail(field, f"body '{body}' has no point {_quote(value)}",
                      _did_you_mean(value, points, f"points of '{body}'"))
        return value

    def expression(self, text: str, field: str, unit: str):
        try:
            return _expr.parse(text, variables=("t",))
        except _expr.ExpressionError as e:
            self.fail(field, str(e).rstrip("."), _expr_fix(unit))


def _expr_fix(unit: str) -> str:
    return f"Write a formula of time t (s) giving {unit}; see docs/model-format.md"


def _count(n: int) -> str:
    return f"{n} value" if n == 1 else f"{n} values"


def _key(field: str) -> str:
    """The last key of a dotted field path, for examples: ``bodies.crank.com`` -> ``com``."""
    return re.sub(r"\[\d+\]$", "", field.rsplit(".", 1)[-1])


def _is_float(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False


def _entry_field(section: str, i: int, entry: Any) -> str:
    """``bodies.crank`` for an entry with a valid name, else ``bodies[1]`` (0-based)."""
    name = entry.get("name") if isinstance(entry, dict) else None
    return (f"{section}.{name}" if isinstance(name, str) and len(name) <= MAX_NAME
            and _NAME.match(name) else f"{section}[{i}]")
