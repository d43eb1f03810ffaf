"""Optimization over design parameters: minimize (or maximize) a metric subject to metric
constraints.

The global search is scipy's differential evolution with the population evaluated as one batch
of designs per generation (``vectorized=True``: one ``analyze`` over a design axis, never a loop
over designs). The local polish that follows is a compass search, also batched: each step solves
the 2 P designs one step along each parameter axis at once, keeps the best and halves the step
when none improves. Constraints are met by ranking (Deb's rule): a feasible design beats any
infeasible one, infeasible ones compare by their total violation, a design that cannot be
solved comes last. A maximized metric is minimized as its negative. When no design meets every
constraint the result says so (``feasible`` False) and names, by :meth:`Result.nearest`, the
constraint its design misses by the least; the command line then exits with status 3 and
writes nothing.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass, field

import numpy as np

from ..brief import brief_repr
from ..errors import LinkdynError, ModelError
from . import checks
from .metrics import check_names, quantity, unit
from ..units import Units
from .params import Space, check_ranges, space, with_values
from .runner import Task, check_size, evaluate

_CONSTRAINT = re.compile(r"\s*([A-Za-z_][\w.]*)\s*(<=|>=|<|>)\s*([-+0-9.eE]+)\s*"
                         r"([A-Za-z][A-Za-z ^0-9]*)?\s*\Z")
BIG = 1e30  # score of an infeasible design, plus its violation


class Infeasible(LinkdynError):
    """No design in the ranges meets every constraint (exit status 3): the message names the
    constraint nearest to holding and by how much it is missed."""

    exit_code = 3


@dataclass(frozen=True)
class Constraint:
    """``metric <= value`` (or ``>=``), value in SI; ``unit`` the one it was written in (the
    model file's unit of the metric's quantity when it was a bare number; '' for SI) and
    ``scale`` the SI size of that unit, for messages."""

    metric: str
    upper: bool
    value: float
    unit: str = ""
    scale: float = 1.0

    def violation(self, x: np.ndarray) -> np.ndarray:
        """How far (SI, >= 0) each metric value is outside the bound; NaN where not solved."""
        return np.maximum(x - self.value, 0.0) if self.upper else np.maximum(self.value - x, 0.0)

    def shown(self, x: float) -> str:
        """An SI value of the metric in the constraint's unit, with the unit."""
        u = self.unit or unit(self.metric)
        return f"{x / self.scale:.4g} {u}".rstrip()

    def __str__(self) -> str:
        """``'path_deviation <= 0.1 mm'``: the bound in the unit it was given in."""
        return f"{self.metric} {'<=' if self.upper else '>='} {self.shown(self.value)}"


def parse_constraint(text: str, units: Units | None = None) -> Constraint:
    """``'path_deviation<=0.1mm'`` -> Constraint: ``<=`` or ``>=``, a finite value in a unit of
    the metric's quantity (m, mm, cm, in; rad, deg; N; N m; kg m^2, kg mm^2, ...) or, a bare
    number, in ``units`` (the model file's units, :class:`linkdyn.units.Units`; None: SI)."""
    m = _CONSTRAINT.match(text) if isinstance(text, str) else None

    def fail(message, fix):
        return ModelError(message, field="--constraint", fix=fix)

    if m is None:
        raise fail(f"cannot read the constraint {text!r}",
                   'Write METRIC<=VALUE or METRIC>=VALUE with an optional unit, e.g. '
                   '"path_deviation<=0.1mm" (SI when no unit is given)')
    metric, op, unit = m.group(1), m.group(2), " ".join((m.group(4) or "").split())
    if op in ("<", ">"):
        raise fail(f"{text!r} is a strict bound ({op})", f"Write {op}= (a bound the best "
                   "design may reach, as a continuous metric's optimum does)")
    units = units or Units()
    kind = quantity(metric) or "number"   # an unknown metric is named by the caller's check
    accepted = units.accepted(kind)
    size = units.size(unit, kind) if kind != "number" else 1.0  # an unknown metric: refused later
    if unit and size is None:
        what = (f"{metric} is in {units.unit(kind)[0]}" if kind != "number"
                else "the unit is not known")
        raise fail(f"{text!r}: {what}, so '{unit}' does not fit it",
                   f"Give the value in {' or '.join(accepted)}, or without a unit (the "
                   f"model file's, {units.unit(kind)[0]})" if kind != "number"
                   else "Use m, mm, cm, in, rad, deg, N, N m or kg m^2")
    shown, scale = (unit, size) if unit else units.unit(kind)
    try:
        value = float(m.group(3)) * scale
    except ValueError:
        raise fail(f"cannot read the number in {text!r}", "Write a plain number, e.g. 1e-4") \
            from None
    if not np.isfinite(value):
        raise fail(f"the bound of {text!r} is not finite", "Write a finite number")
    return Constraint(metric, op == "<=", value, shown, scale)


def _names(model, wanted, option: str, path_point) -> list[str]:
    """:func:`.metrics.check_names`, naming ``option`` for an unknown metric."""
    try:
        return check_names(model, wanted, path_point=path_point)
    except ModelError as e:
        raise ModelError(e.message, field=option, fix=e.fix) from None


@dataclass
class Result:
    """What :func:`optimize` found.

    Attributes
    ----------
    values : dict[str, float]
        The best design's parameters, in the file's units.
    metrics : dict[str, float]
        Its objective and constraint metrics, SI.
    feasible : bool
        It meets every constraint (and is valid). When not, it is the design that misses them
        by the least (total violation relative to each bound).
    data : dict
        The model file's structure with the best values (write it with
        :func:`linkdyn.io.writer.dumps_toml`).
    model : Model
    evaluations, generations : int
        Designs solved, and generations of the global search.
    seconds : float
    history : list of float
        Best score after each generation and polish step (the objective, negated when
        maximized, for a feasible design).
    objective, sense : str
        The metric optimized and ``'min'`` or ``'max'``.
    constraints : list of Constraint
    """

    __repr__ = brief_repr   # not the whole model and its data (linkdyn.brief)

    values: dict
    metrics: dict
    feasible: bool
    data: dict
    model: object
    evaluations: int = 0
    generations: int = 0
    seconds: float = 0.0
    history: list = field(default_factory=list)
    objective: str = ""
    sense: str = "min"
    constraints: list = field(default_factory=list)

    def misses(self) -> list:
        """``(constraint, violation SI)`` of each constraint the design does not meet, the one
        nearest to holding (smallest violation relative to its bound) first."""
        out = [(c, float(c.violation(self.metrics[c.metric]))) for c in self.constraints]
        out = [(c, v) for c, v in out if not v <= 0.0]   # NaN (not solved) misses too
        return sorted(out, key=lambda cv: cv[1] / max(abs(cv[0].value), 1e-300))

    def nearest(self) -> str:
        """The constraint nearest to holding in words, in its unit: ``'path_deviation <= 0.1
        mm, missed by 0.012 mm (path_deviation = 0.112 mm)'``; '' when feasible."""
        miss = self.misses()
        if self.feasible or not miss:
            return ""
        c, v = miss[0]
        bound = f"{c.metric} {'<=' if c.upper else '>='} {c.shown(c.value)}"
        return (f"{bound}, missed by {c.shown(v)} ({c.metric} = {c.shown(self.metrics[c.metric])})"
                + (f"; {len(miss) - 1} other constraint(s) missed too" if len(miss) > 1 else ""))


#: a constraint is active (binding) when its slack is within this fraction of its bound
ACTIVE = 0.01


def standing(res: Result, sp: Space, bounds: dict, units: Units) -> dict:
    """What an optimize found, for its report: the objective, each constraint with its value
    and whether it is active, and each parameter's change.

    Parameters
    ----------
    res : Result
    sp : Space
        The design space (each parameter's base value and unit, the file's).
    bounds : dict
        ``{path: (lo, hi)}`` of ``--vary``, in the file's units.
    units : Units
        The model file's units, to show the metrics in.

    Returns
    -------
    dict
        ``objective``: ``{metric, sense, value, shown}`` (``value`` SI, ``shown`` in the file's
        unit); ``constraints``: ``{text, metric, value, shown, slack, active}`` each (``slack``
        SI, >= 0 where it holds; ``active`` when the slack is within :data:`ACTIVE` of the
        bound's magnitude: the constraint limits the design); ``parameters``: ``{path, unit,
        base, best, change, pct, at_bound}`` each, in the file's units (``at_bound``: 'low',
        'high' or '' when within 1 % of the range's width of a bound).
    """
    def show(metric, x):
        return units.show(x, quantity(metric) or "number")

    obj = res.metrics.get(res.objective)
    cons = []
    for c in res.constraints:
        x = res.metrics.get(c.metric)
        slack = (c.value - x if c.upper else x - c.value) if x is not None else None
        active = slack is not None and np.isfinite(slack) and \
            abs(slack) <= ACTIVE * max(abs(c.value), 1e-300)
        cons.append({"text": str(c), "metric": c.metric, "value": x, "shown": c.shown(x)
                     if x is not None else "n/a", "slack": slack, "active": bool(active)})
    params = []
    for prm in sp.params:
        best = float(res.values[prm.path])
        lo, hi = bounds.get(prm.path, (None, None))
        edge = ""
        if lo is not None:
            tol = 0.01 * abs(hi - lo)
            edge = "low" if abs(best - lo) <= tol else "high" if abs(best - hi) <= tol else ""
        params.append({"path": prm.path, "unit": prm.unit, "base": float(prm.base),
                       "best": best, "change": best - float(prm.base),
                       "pct": 100.0 * (best - prm.base) / abs(prm.base) if prm.base else None,
                       "at_bound": edge, "range": [lo, hi]})
    return {"objective": {"metric": res.objective, "sense": res.sense, "value": obj,
                          "shown": show(res.objective, obj)},
            "constraints": cons, "parameters": params}


class _Objective:
    """Scores of a batch of designs: the objective's cost (negated when maximized) where
    feasible, else BIG + violation."""

    def __init__(self, task: Task, objective: str, sign: float, constraints):
        self.task, self.objective, self.sign = task, objective, sign
        self.constraints = list(constraints)
        self.evaluations = 0
        self.best = (np.inf, None, None)  # score, values, metrics

    def scores(self, x: np.ndarray) -> np.ndarray:
        x = np.atleast_2d(x)
        cols = evaluate(self.task, x)
        self.evaluations += len(x)
        f = self.sign * cols[self.objective]
        viol = sum((c.violation(cols[c.metric]) / max(abs(c.value), 1e-300)
                    for c in self.constraints), np.zeros(len(x)))
        score = np.where(viol > 0, BIG * (1.0 + viol), f)
        score = np.where(cols["valid"] & np.isfinite(score), score, np.inf)
        k = int(np.argmin(score))
        if score[k] < self.best[0]:
            self.best = (float(score[k]), x[k].copy(),
                         {n: float(cols[n][k]) for n in dict.fromkeys(
                             [self.objective] + [c.metric for c in self.constraints])})
        return score


def optimize(model, bounds: dict, t, minimize: str | None = None, constraints=(), *,
             maximize: str | None = None, seed: int | None = 0,
             popsize: int = 15, maxiter: int = 60, tol: float = 1e-6, polish: bool = True,
             backend: str | None = None, path_point=None, path_range=None,
             fluctuation: float = 0.02) -> Result:
    """Minimize (or maximize) a metric over design parameters, subject to metric constraints.

    Parameters
    ----------
    model : str, os.PathLike, dict or Model
        As for :func:`linkdyn.sweep`.
    bounds : dict
        ``{path: (lo, hi)}`` in the file's units.
    t : array_like (T,)
        Sample times, s.
    minimize, maximize : str
        The metric to minimize, or (one or the other) to maximize, e.g.
        ``maximize="min_transmission_angle"`` (see :mod:`linkdyn.studies.metrics`).
    constraints : sequence of str or Constraint
        E.g. ``"path_deviation<=0.1mm"``.
    seed : int or None
        Seeds the differential evolution: the same seed gives the same result.
    popsize, maxiter, tol
        Of :func:`scipy.optimize.differential_evolution` (population ``popsize * P``).
    polish : bool
        Refine the best design by a batched compass search.

    Returns
    -------
    Result
        ``feasible`` False when no design met every constraint (``Result.nearest()`` names the
        constraint missed by the least).
    """
    from scipy.optimize import differential_evolution

    if (minimize is None) == (maximize is None):
        raise ModelError("give one metric to minimize or to maximize", field="--minimize",
                         fix="Give --minimize METRIC or --maximize METRIC (one of them)")
    objective = minimize if maximize is None else maximize
    sign = 1.0 if maximize is None else -1.0
    start = time.perf_counter()
    lohi = _bounds(bounds)
    seed = checks.seed(seed)
    popsize = checks.count(popsize, "--popsize", "population per parameter")
    maxiter = checks.count(maxiter, "--maxiter", "generations")
    sp: Space = space(model, list(bounds))
    check_ranges(sp, lohi)
    base = sp.model()
    # a bare bound is in the model file's unit of the metric's quantity
    cons = [c if isinstance(c, Constraint) else parse_constraint(c, Units.of(base))
            for c in constraints]
    names = tuple(dict.fromkeys(_names(base, [objective], "--minimize" if maximize is None else "--maximize",
                                       path_point)
                                + _names(base, [c.metric for c in cons], "--constraint",
                                         path_point)))
    task = Task(sp, t, names, backend, path_point, path_range, fluctuation)
    # the designs of every generation and of the polish, bounded as a sweep's
    check_size(task, popsize * len(lohi) * (maxiter + 1) + 80 * len(lohi), option="--popsize")
    task = task.with_builder([a for a, _ in lohi], [b for _, b in lohi])
    obj = _Objective(task, objective, sign, cons)
    history: list[float] = []

    def batch(xT):  # scipy passes the population as (P, S)
        return obj.scores(np.asarray(xT).T)

    res = differential_evolution(batch, lohi, seed=seed, popsize=popsize, maxiter=maxiter,
                                 tol=tol, polish=False, vectorized=True, updating="deferred",
                                 init="sobol", callback=lambda *a, **k: history.append(
                                     obj.best[0]))
    if polish and obj.best[1] is not None:
        _compass(obj, np.array(lohi), history)
    score, x, mets = obj.best
    if x is None:
        raise ModelError("no design in the ranges could be solved", field="--vary",
                         fix="Widen or move the ranges, or check the model at their centre")
    data = with_values(sp.data, sp.params, x)
    return Result(values={p.path: float(v) for p, v in zip(sp.params, x)}, metrics=mets,
                  feasible=bool(score < BIG), data=data, model=sp.model(x),
                  evaluations=obj.evaluations, generations=int(res.nit),
                  seconds=time.perf_counter() - start, history=history, objective=objective,
                  sense="min" if maximize is None else "max", constraints=cons)


def _bounds(bounds) -> list[tuple[float, float]]:
    """``{path: (lo, hi)}`` -> the (lo, hi) pairs: at least one parameter, two finite numbers
    each."""
    if not isinstance(bounds, dict) or not bounds:
        raise ModelError(f"bounds must name at least one parameter, got {bounds!r:.80}",
                         field="bounds", fix="Pass {path: (lo, hi)}, e.g. "
                                             "{'bodies.ground.points.O4[0]': (85, 95)}")
    return [checks.pair(v, f"bounds[{p!r}]", "its range LO, HI in the file's units")
            for p, v in bounds.items()]


def _compass(obj: _Objective, lohi: np.ndarray, history: list, steps: int = 40) -> None:
    """Batched compass search from the best design: 2 P trial designs per step, one solve."""
    lo, hi = lohi[:, 0], lohi[:, 1]
    step = 0.02 * (hi - lo)
    for _ in range(steps):
        x0 = obj.best[1]
        trials = np.clip(x0 + np.concatenate([np.diag(step), -np.diag(step)]), lo, hi)
        before = obj.best[0]
        obj.scores(trials)
        history.append(obj.best[0])
        if not obj.best[0] < before:
            step = step / 2
            if np.all(step < 1e-6 * (hi - lo)):
                break
