"""Driver motions: a joint coordinate prescribed as a function of time, with exact derivatives.

Each motion is a frozen dataclass with ``evaluate(t) -> (q, qd, qdd)``: the joint coordinate
(rad for a revolute joint, m for a prismatic one), its rate (per s) and its second derivative
(per s^2), each of the shape of ``t`` (any shape, s), float64. Units are SI: a ``scale`` converts
the numbers of a model file (deg -> rad, mm -> m).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:                            # imported when a table is built (scipy takes ~1 s)
    from scipy.interpolate import CubicSpline

from .errors import InvalidValue, ModelError
from .expr import Expr, parse

__all__ = ["ConstantSpeed", "ExpressionMotion", "Segment", "SegmentMotion", "TableMotion",
           "PeriodicFormula"]


def _time(t) -> np.ndarray:
    return np.asarray(t, dtype=np.float64)


def _finite(name: str, value: float) -> float:
    value = float(value)
    if not math.isfinite(value):
        raise InvalidValue(f"{name} must be a finite number, got {value}", field=name,
                           fix="Give a finite value")
    return value


@dataclass(frozen=True)
class ConstantSpeed:
    """q = start + speed t.

    Attributes
    ----------
    speed : float
        rad/s (revolute) or m/s (prismatic).
    start : float
        q at t = 0, rad or m.
    rpm : bool
        The model file gave the speed in revolutions per minute (``rpm = 45``): the summary
        and :func:`linkdyn.save` say it in rpm again.
    """

    speed: float
    start: float = 0.0
    rpm: bool = field(default=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "speed", _finite("speed", self.speed))
        object.__setattr__(self, "start", _finite("start", self.start))

    @property
    def period(self) -> float | None:
        """Time of one turn, 2 pi / |speed| (s), for a revolute driver; None if speed == 0."""
        return 2 * math.pi / abs(self.speed) if self.speed else None

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q, qd, qdd)`` at times ``t`` (s, any shape); each of the shape of ``t``."""
        t = _time(t)
        return self.start + self.speed * t, np.full_like(t, self.speed), np.zeros_like(t)

    def describe(self, unit: str = "rad", scale: float = 1.0) -> str:
        """E.g. ``'constant speed 4.712 rad/s from 0'``, ``'constant speed 45 rpm from 0'``, in
        ``unit`` of ``scale`` SI ('deg', pi/180; 'mm', 1e-3)."""
        if self.rpm:
            return f"constant speed {self.speed * 30 / math.pi:.4g} rpm from {self.start / scale:.4g}"
        return f"constant speed {self.speed / scale:.4g} {unit}/s from {self.start / scale:.4g}"


@dataclass(frozen=True)
class ExpressionMotion:
    """q = scale * f(t) for an expression f of ``t`` (see :func:`linkdyn.expr.parse`).

    The text is parsed at construction (an invalid text raises
    :class:`~linkdyn.expr.ExpressionError` at once); qd and qdd come from the exact symbolic
    derivatives f' and f''.

    Attributes
    ----------
    text : str
        E.g. ``"0.3 + 6.0*t + 0.4*sin(5*t)"``, in the model file's units, t in s.
    scale : float
        Factor to SI, e.g. pi/180 for degrees, 1e-3 for mm.
    expr, d1, d2 : Expr
        f, f' and f'' (derived; not constructor arguments).
    """

    text: str
    scale: float = 1.0
    expr: Expr = field(init=False, repr=False, compare=False)
    d1: Expr = field(init=False, repr=False, compare=False)
    d2: Expr = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "scale", _finite("scale", self.scale))
        f = parse(self.text, ("t",))
        object.__setattr__(self, "expr", f)
        object.__setattr__(self, "d1", f.diff("t"))
        object.__setattr__(self, "d2", self.d1.diff("t"))

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q, qd, qdd)`` = scale * (f, f', f'') at times ``t`` (s, any shape); shape of ``t``.

        Outside the domain of a function (e.g. log of a negative number) the values are NaN.
        """
        t = _time(t)
        return tuple(self.scale * g(t) for g in (self.expr, self.d1, self.d2))

    def describe(self, unit: str = "rad", scale: float = 1.0) -> str:
        """E.g. ``'q(t) = 0.3 + 6.0*t + 0.4*sin(5*t) rad'``, ``'q(t) = 30*t deg'`` (``unit`` of
        ``scale`` SI, the file's), or ``'q(t) = 0.0174533*(30*t) rad'`` in another unit."""
        text = self.text.strip()
        factor = self.scale / scale
        return f"q(t) = {text if factor == 1 else f'{factor:.6g}*({text})'} {unit}"


@dataclass(frozen=True)
class Segment:
    """One segment of a :class:`SegmentMotion`: from the previous segment's end to ``to`` in
    ``time`` by a motion law (:data:`linkdyn.laws.LAWS`; ``'dwell'`` holds its start).

    Attributes
    ----------
    law : str
    to : float
        The coordinate at its end, rad or m (a dwell's is its start).
    time : float
        Its duration, s (> 0).
    """

    law: str
    to: float
    time: float


@dataclass(frozen=True, eq=False)
class SegmentMotion:
    """A joint swung between values by motion laws, segment after segment, with dwells: e.g.
    a rise by a cycloidal law, a dwell, a return by a 3-4-5 polynomial, a dwell. Each law
    starts and ends at rest (:mod:`linkdyn.laws`), so the rate is continuous at every join.

    Attributes
    ----------
    start : float
        The coordinate at t = 0, rad or m.
    segments : tuple[Segment, ...]
    repeat : bool
        Repeat the segments for ever (the last must end at ``start``): the motion is periodic,
        ``period`` = the sum of the durations. Else the joint holds its last value after them
        (and its start before t = 0).
    """

    start: float
    segments: tuple
    repeat: bool = True

    def __post_init__(self):
        from . import laws
        object.__setattr__(self, "start", _finite("start", self.start))
        segs = tuple(self.segments)
        if not segs:
            raise InvalidValue("a segment motion needs at least one segment", field="segments",
                               fix='Give segments = [{ law = "cycloidal", to = ..., time = ... }]')
        for k, x in enumerate(segs):
            if x.law not in laws.LAWS:
                raise InvalidValue(f"unknown motion law {x.law!r}", field=f"segments[{k}].law",
                                   fix=f"Use one of {', '.join(laws.LAWS)}")
            if not (math.isfinite(x.time) and x.time > 0):
                raise InvalidValue(f"a segment's time must be positive and finite, got {x.time}",
                                   field=f"segments[{k}].time", fix="Give its duration in s")
            _finite(f"segments[{k}].to", x.to)
        object.__setattr__(self, "segments", segs)
        ends = np.array([self.start] + [x.to for x in segs], float)
        # a dwell holds the value it starts at
        for k, x in enumerate(segs):
            if x.law == "dwell":
                ends[k + 1] = ends[k]
        object.__setattr__(self, "_ends", ends)
        object.__setattr__(self, "_times", np.concatenate(([0.0], np.cumsum([x.time for x in segs]))))
        if self.repeat and not math.isclose(ends[-1], ends[0], rel_tol=1e-12, abs_tol=1e-15):
            raise InvalidValue(
                f"the segments end at {ends[-1]:.6g}, not at the start {ends[0]:.6g}: repeated, "
                "the joint would jump at each repeat", field="segments",
                fix="End the last segment at the start, or set repeat = false")

    @property
    def period(self) -> float | None:
        """Time of one cycle (s), the sum of the durations, when the motion repeats."""
        return float(self._times[-1]) if self.repeat else None

    def _at(self, t):
        """Segment index, normalized time ``u`` in it, and time in the cycle at ``t``."""
        t = _time(t)
        total = self._times[-1]
        tc = np.mod(t, total) if self.repeat else np.clip(t, 0.0, total)
        k = np.clip(np.searchsorted(self._times, tc, side="right") - 1, 0, len(self.segments) - 1)
        u = (tc - self._times[k]) / np.diff(self._times)[k]
        return k, u

    def _piece(self, j: int, u) -> list:
        """``[q, qd, qdd, qddd]`` of segment ``j`` at its normalized times ``u`` (any shape)."""
        from . import laws
        h, T = self._ends[j + 1] - self._ends[j], self.segments[j].time
        parts = laws.rise(self.segments[j].law, u)
        # q = q_k + h s(u), and h s^(n)(u) / T^n                    (SVAJ)
        out = [h * parts[n] / T ** n for n in range(4)]
        out[0] = out[0] + self._ends[j]
        return out

    def svaj(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(q, qd, qdd, qddd)``: coordinate, rate, acceleration and jerk at times ``t``."""
        k, u = self._at(t)
        out = [np.zeros_like(u) for _ in range(4)]
        for j in range(len(self.segments)):
            on = k == j
            if np.any(on):
                for n, x in enumerate(self._piece(j, u[on])):
                    out[n][on] = x
        if not self.repeat:      # at rest before t = 0 and after the last segment
            t = _time(t)
            still = (t < 0) | (t > self._times[-1])
            for n in range(1, 4):
                out[n] = np.where(still, 0.0, out[n])
        return tuple(out)

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q, qd, qdd)`` at times ``t`` (s, any shape); each of the shape of ``t``."""
        return self.svaj(t)[:3]

    def jumps(self) -> tuple[np.ndarray, np.ndarray]:
        """The joins between consecutive segments (and, repeating, the one that closes the
        cycle, at t = 0): their times (J,) s and the jumps (4, J) of q, qd, qdd and qddd
        across each, the next segment's start minus the previous one's end (0 where the
        motion is that smooth; a law's end at rest keeps q and qd continuous, a harmonic
        law's acceleration and a cycloidal law's jerk jump at a dwell)."""
        n = len(self.segments)
        pairs = [(k, k + 1) for k in range(n - 1)] + ([(n - 1, 0)] if self.repeat else [])
        jump = [np.subtract(self._piece(b, 0.0), self._piece(a, 1.0)) for a, b in pairs]
        times = np.array([self._times[b] for _, b in pairs], float)
        return times, np.array(jump, float).reshape(len(pairs), 4).T

    def describe(self, unit: str = "rad", scale: float = 1.0) -> str:
        """E.g. ``'from 0 rad: cycloidal to 1.047 rad in 0.5 s, dwell 0.25 s, ... (repeats
        every 1.5 s)'``, in ``unit`` of ``scale`` SI (the file's: ``'cycloidal to 60 deg'``)."""
        parts = [f"dwell {x.time:.4g} s" if x.law == "dwell" else
                 f"{x.law} to {x.to / scale:.4g} {unit} in {x.time:.4g} s" for x in self.segments]
        tail = f" (repeats every {self.period:.4g} s)" if self.repeat else " (then holds)"
        return f"from {self.start / scale:.4g} {unit}: " + ", ".join(parts) + tail


@dataclass(frozen=True, eq=False)
class PeriodicTable:
    """A periodic motion through a table of points: the periodic cubic spline (C2: the value,
    rate and acceleration continuous everywhere, the first point's too after a period) through
    ``(t_k, q_k)``, repeated every ``period``.

    Attributes
    ----------
    t : ndarray (n,)
        Times (or cam angles), strictly increasing, within one period of ``t[0]``; n >= 3.
    q : ndarray (n,)
    period : float
    """

    t: np.ndarray
    q: np.ndarray
    period: float

    def __post_init__(self):
        from scipy.interpolate import CubicSpline
        t, q = np.asarray(self.t, float), np.asarray(self.q, float)
        # the first point again one period later closes the curve
        spline = CubicSpline(np.append(t, t[0] + self.period), np.append(q, q[0]),
                             bc_type="periodic")
        object.__setattr__(self, "_spline", spline)

    def svaj(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(q, qd, qdd, qddd)`` at ``t`` (any shape); qddd is the spline's piecewise
        constant third derivative (the right one at a point of the table)."""
        x = self.t[0] + np.mod(_time(t) - self.t[0], self.period)
        return tuple(self._spline(x, n) for n in range(4))

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.svaj(t)[:3]

    def jumps(self) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`SegmentMotion.jumps`: the table's points (n,) and the jumps (4, n) across
        them, only the third derivative's not zero (``6 (c_k - c_(k-1))``, ``c`` the cubic
        coefficients of the intervals on either side)."""
        c3 = 6 * self._spline.c[0]
        jump = np.zeros((4, len(self.t)))
        jump[3] = c3 - np.roll(c3, 1)
        return np.array(self.t, float), jump


@dataclass(frozen=True, eq=False)
class PeriodicFormula:
    """A periodic motion by a formula: ``q(x) = scale f(x / unit)``, ``f`` an expression of
    ``variable`` (:func:`linkdyn.expr.parse`, never executed) evaluated at ``x`` taken within
    one ``period`` from 0, with its exact symbolic derivatives (:meth:`linkdyn.expr.Expr.diff`),
    e.g. a cam's lift in mm as a formula of the cam angle in deg.

    Attributes
    ----------
    text : str
        E.g. ``"10*(1 - cos(theta))"``.
    scale : float
        ``q`` per unit of ``f``, to SI (1e-3 for mm).
    unit : float
        ``x`` per unit of the variable (pi/180 for deg): ``f``'s n-th derivative is divided by
        ``unit**n``.
    period : float
        ``x`` of one cycle (2 pi for a cam angle in rad).
    variable : str
    """

    text: str
    scale: float = 1.0
    unit: float = 1.0
    period: float = 2 * math.pi
    variable: str = "theta"

    def __post_init__(self):
        f = parse(self.text, (self.variable,))
        # f and its first three derivatives, exact, in the variable
        d = [f]
        for _ in range(3):
            d.append(d[-1].diff(self.variable))
        object.__setattr__(self, "_d", tuple(d))

    def _at(self, x: np.ndarray) -> tuple:
        # q^(n)(x) = scale f^(n)(x / unit) / unit^n
        u = x / self.unit
        return tuple(self.scale / self.unit ** n * g.evaluate(**{self.variable: u})
                     for n, g in enumerate(self._d))

    def svaj(self, x) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(q, q', q'', q''')`` at ``x`` (any shape; per unit of ``x``: rad or s), NaN outside
        a function's domain."""
        return self._at(np.mod(_time(x), self.period))

    def evaluate(self, x) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.svaj(x)[:3]

    def jumps(self) -> tuple[np.ndarray, np.ndarray]:
        """As :meth:`SegmentMotion.jumps`, where the cycle closes: x = 0 (1,) and the jumps
        (4, 1) of q and its first three derivatives from the end of a cycle to the start of the
        next (only there: the joins of a ``where`` inside the formula are not looked for)."""
        start, end = self._at(np.zeros(1)), self._at(np.full(1, float(self.period)))
        return np.zeros(1), np.subtract(start, end)


class Free:
    """The motion placeholder of a free coordinate in forward dynamics (planar or spatial):
    its driver slot holds no motion, the integrator supplies the coordinate's values."""

    def evaluate(self, t):
        z = np.zeros(np.shape(t))
        return z, z, z


@dataclass(frozen=True, eq=False)
class TableMotion:
    """q(t) interpolated through a table by a cubic spline (not-a-knot ends).

    qd and qdd are the exact first and second derivatives of that spline (continuous: the spline
    is C2). It is not extrapolated: evaluating at a time outside ``[t[0], t[-1]]`` (beyond a
    rounding tolerance) raises :class:`~linkdyn.errors.ModelError` naming the table, its time
    range and the times asked for.

    Attributes
    ----------
    t : ndarray (n,)
        Times, s, strictly increasing, n >= 4.
    q : ndarray (n,)
        Joint coordinates in the table's units.
    scale : float
        Factor to SI (rad or m), e.g. pi/180 for degrees.
    origin, model, model_field : str
        For messages: the table's file as the model names it, the model file and the field
        that names the table (e.g. ``drivers[0].motion.file``); '' when built in Python.

    Raises
    ------
    ValueError
        For a table that is too short, not 1-D of equal lengths, not finite, or whose times do not
        strictly increase (the message names the first offending row, counted from 1).
    """

    t: np.ndarray
    q: np.ndarray
    scale: float = 1.0
    origin: str = field(default="", compare=False)
    model: str = field(default="", compare=False)
    model_field: str = field(default="", compare=False)
    spline: CubicSpline = field(init=False, repr=False)

    def __post_init__(self):
        t, q = _time(self.t).copy(), _time(self.q).copy()
        if t.ndim != 1 or q.shape != t.shape:
            raise InvalidValue(f"a motion table needs two columns of equal length (t, q), "
                               f"got shapes {t.shape} and {q.shape}", field="t, q")
        if len(t) < 4:
            raise InvalidValue(f"a motion table needs at least 4 rows for a cubic spline, "
                               f"got {len(t)}", field="t, q")
        bad = np.flatnonzero(~(np.isfinite(t) & np.isfinite(q)))
        if bad.size:
            i = bad[0]
            raise InvalidValue(f"row {i + 1} of the motion table is not finite "
                               f"(t = {t[i]}, q = {q[i]})", field="t, q")
        bad = np.flatnonzero(np.diff(t) <= 0)
        if bad.size:
            i = bad[0] + 1
            raise InvalidValue(f"times of a motion table must strictly increase: row {i + 1} has "
                               f"t = {t[i]:.6g} after t = {t[i - 1]:.6g}", field="t")
        t.flags.writeable = q.flags.writeable = False
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "q", q)
        object.__setattr__(self, "scale", _finite("scale", self.scale))
        from scipy.interpolate import CubicSpline

        object.__setattr__(self, "spline", CubicSpline(t, q, bc_type="not-a-knot", extrapolate=False))

    @classmethod
    def from_csv(cls, path: str | Path, scale: float = 1.0, *, origin: str | None = None,
                 model: str = "", field: str = "") -> TableMotion:
        """Read a two-column CSV file ``t,q`` (s, table units) with an optional header line.

        Blank lines and lines starting with ``#`` are skipped. Only a regular file of at most
        10 MB is read (see :func:`linkdyn.io.files.read_text`). Messages quote at most a short,
        escaped excerpt of a line. ``origin`` (default: ``path``), ``model`` and ``field`` are
        kept for messages.

        Raises
        ------
        FileNotFoundError
            If ``path`` does not exist (the message contains the path).
        ValueError
            For a file that is not a regular UTF-8 file of at most 10 MB, a line that is not two
            numbers (the message names the file and line), or a table rejected by the constructor
            (the message names the file).
        """
        from .io.files import read_text      # here: linkdyn.io imports this module

        path = Path(path)
        if not path.exists():
            raise FileNotFoundError(f"motion table file not found: {_excerpt(str(path), 200)}")
        try:
            lines = read_text(path).splitlines()
        except UnicodeDecodeError:
            raise InvalidValue("not a UTF-8 text file", file=str(path)) from None
        except ValueError as e:                               # not a regular file, too large
            raise InvalidValue(f"the file {e}", file=str(path)) from None
        rows, header_allowed = [], True
        for n, line in enumerate(lines, start=1):
            text = line.strip()
            if not text or text.startswith("#"):
                continue
            fields = [f.strip() for f in text.split(",")]
            try:
                ti, qi = map(float, fields)
            except ValueError:
                if header_allowed and not _is_number(fields[0]):
                    header_allowed = False
                    continue
                raise InvalidValue(f"expected two numbers 't,q', got {_excerpt(text)}",
                                   file=str(path), field=f"line {n}") from None
            if not (math.isfinite(ti) and math.isfinite(qi)):
                raise InvalidValue(f"t and q must be finite, got {_excerpt(text)}", file=str(path),
                                   field=f"line {n}")
            if rows and ti <= rows[-1][0]:
                raise InvalidValue(f"t = {ti:.6g} does not increase "
                                   f"(previous t = {rows[-1][0]:.6g})", file=str(path),
                                   field=f"line {n}")
            rows.append((ti, qi))
            header_allowed = False
        t, q = np.array(rows, dtype=np.float64).reshape(-1, 2).T
        try:
            return cls(t, q, scale, origin=str(path) if origin is None else origin, model=model,
                       model_field=field)
        except InvalidValue as exc:
            raise InvalidValue(exc.message, file=str(path), fix=exc.fix) from None

    def evaluate(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(q, qd, qdd)`` at times ``t`` (s, any shape); shape of ``t``.

        Raises
        ------
        ModelError
            If a time lies outside the table's range (beyond rounding), naming the table, its
            range and the run's times.
        """
        t = _time(t)
        t0, t1 = float(self.t[0]), float(self.t[-1])
        if t.size:
            lo, hi = float(np.min(t)), float(np.max(t))     # NaN times stay NaN below
            tol = 1e-9 * max(t1 - t0, abs(t0), abs(t1))        # rounding of the run's times
            if lo < t0 - tol or hi > t1 + tol:
                name = f"motion table {_excerpt(self.origin, 80)}" if self.origin else "the motion table"
                raise ModelError(
                    f"{name} covers t = {t0:.6g} to {t1:.6g} s, but the run needs t = {lo:.6g} "
                    f"to {hi:.6g} s", file=self.model, field=self.model_field,
                    fix="Extend the table to cover the run, or run within its time range "
                        "(a shorter duration, or fewer cycles)")
            t = np.clip(t, t0, t1)
        return tuple(self.scale * self.spline(t, nu) for nu in (0, 1, 2))

    def describe(self, unit: str = "rad", scale: float = 1.0) -> str:
        """E.g. ``'table of 37 rows, t from 0 to 2 s, q in deg'`` (``unit`` of ``scale`` SI)."""
        factor = (f", q in {unit}" if self.scale == scale and scale != 1 else "" if self.scale == scale
                  else f", q x {self.scale / scale:.6g} to {unit}")
        return f"table of {len(self.t)} rows, t from {self.t[0]:.4g} to {self.t[-1]:.4g} s{factor}"


def _excerpt(text: str, n: int = 40) -> str:
    """A quoted, escaped excerpt of at most ``n`` characters of text from a file."""
    return repr(text) if len(text) <= n else repr(text[:n]) + f"... ({len(text):,} characters)"


def _is_number(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False
