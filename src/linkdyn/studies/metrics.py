"""Design metrics: one number per design, from a solved run of one design or of a batch.

Each metric is computed by the same functions the summary of ``linkdyn analyze`` uses
(:mod:`linkdyn.design`), over the last (time) axis, so a metric of a sweep equals the one of
``analyze`` for that design. All values SI:

``peak_<effort column>``, ``rms_<effort column>``
    Largest |effort| and its root mean square over the run for each driver, e.g. ``peak_tau_J1``
    (N m) or ``rms_force_J4`` (N) (:func:`linkdyn.design.overview.peak`, ``rms``).
``peak_F_<joint>``
    Largest joint force magnitude ``|(Fx, Fy)|`` of each joint, N.
``min_transmission_angle``
    Over the run and every four-bar loop, the smallest ``min(mu, pi - mu)`` of the transmission
    angle mu, rad (90 deg ideal, 0 a toggle) (:func:`linkdyn.design.fourbar.transmission_worst`).
``path_deviation``
    Largest perpendicular distance of the path point from its total-least-squares line over the
    path range (the model's ``[analysis] path_point`` and ``path_range``, or given), m
    (:func:`linkdyn.design.path.line_fit`).
``min_contact_<joint>``
    Least contact force of each joint that can only push (a cam's), signed: negative where the
    follower would leave the cam at the run's speed, N, better larger
    (:func:`linkdyn.design.overview.contact_forces`, the summary's ``contact.*.min_force_N``).
``peak_shaking_force``
    Largest magnitude of the shaking force on the ground, N (:func:`linkdyn.design.shaking_force`).
``flywheel_inertia``
    Flywheel that keeps the first constant-speed revolute driver within a coefficient of speed
    fluctuation C_s (default 0.02) over its first cycle, kg m^2
    (:func:`linkdyn.design.energy.energy_fluctuation`, ``flywheel_inertia``).
``friction_loss``, ``efficiency``
    With friction loads: the energy all of them dissipate over the run, J, and the mechanical
    efficiency over the run, ``1 - friction_loss / drivers' net work`` (NaN when the drivers do
    no positive net work), better larger (:func:`linkdyn.friction.energies`, ``efficiency``).
``output_efficiency``
    With ``[analysis] output``: the work done on the output loads over the drivers' net work
    over the run (NaN when the drivers do no positive net work), better larger
    (:func:`linkdyn.friction.output_efficiency`, the summary's ``output.efficiency``).
``stroke_<joint>``
    Travel (largest minus smallest coordinate) of each undriven guide on the ground, the slider
    of a slider-crank, m (:func:`linkdyn.design.path.travel`, as the summary's
    ``joint_travel``).

A spatial model (``Model.space == "spatial"``) has the effort metrics, ``peak_F_<joint>``
(``|(Fx, Fy, Fz)|``) and ``peak_shaking_force`` (:func:`linkdyn.spatial.shaking.shaking_force`);
the others are for planar models only (:data:`PLANAR_ONLY`, refused by name).

Senses: every metric is better smaller (:func:`sense` ``'min'``) except
``min_transmission_angle``, ``stroke_<joint>``, ``efficiency``, ``output_efficiency`` and
``min_contact_<joint>``, better larger (``'max'``). Whatever ranks
designs (the sweep's best designs and Pareto fronts, ``compare --sweep --by``, ``optimize``)
ranks by :func:`cost`, the metric signed so that smaller is better.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..design import four_bars, shaking_force, transmission_angle
from ..design.energy import driver_power, energy_fluctuation, first_cycle, flywheel_inertia
from ..design.fourbar import transmission_worst
from ..design.overview import contact_forces, peak, rms
from ..design.reduce import root_mean
from ..design.path import (_in_range, _parse_point, default_path_point, line_fit, max_deviation,
                           travel)
from ..errors import ModelError
from .. import joints as jk
from ..model import GROUND, Model
from ..motion import ConstantSpeed
from ..topology import registry

__all__ = ["names", "evaluate", "path_spec", "reads_reactions", "sense", "cost", "ranked",
           "unit", "quantity"]

# metrics a designer wants large; every other metric is better small
_LARGER_IS_BETTER = ("min_transmission_angle", "stroke_", "efficiency", "output_efficiency",
                     "min_contact_")


def sense(name: str) -> str:
    """``'max'`` for a metric that is better larger (``min_transmission_angle``,
    ``stroke_<joint>``), ``'min'`` for every other (efforts, forces, deviation, flywheel)."""
    return "max" if name.startswith(_LARGER_IS_BETTER) else "min"


def cost(name: str, x):
    """The metric ``x`` signed so that smaller is better: ``x``, or ``-x`` where
    :func:`sense` is ``'max'``. Ranking, Pareto fronts and the optimizer use it."""
    x = np.asarray(x, float)
    return -x if sense(name) == "max" else x


def ranked(df, name: str) -> np.ndarray:
    """Row positions of the valid designs of a sweep table ``df`` with a finite ``name``, best
    first by :func:`cost` (ties: the lower design number first)."""
    col = df[name].to_numpy(float)
    ok = np.flatnonzero(df["valid"].to_numpy(bool) & np.isfinite(col))
    return ok[np.lexsort((df["design"].to_numpy()[ok], cost(name, col[ok])))]


def unit(name: str) -> str:
    """The SI unit of a metric's values: ``'N m'`` or ``'N'`` for an effort (by its column's
    ``tau_``/``force_`` prefix), ``'N'`` for joint and shaking forces, ``'rad'``, ``'m'``,
    ``'kg m^2'``."""
    if name.startswith(("peak_tau_", "rms_tau_")):
        return "N m"
    if name.startswith(("peak_", "rms_", "min_contact_")):
        return "N"
    return {"min_transmission_angle": "rad", "path_deviation": "m",
            "flywheel_inertia": "kg m^2", "friction_loss": "J"}.get(name, "m" if name.startswith("stroke_") else "")


def quantity(name: str) -> str | None:
    """What a metric measures, a quantity of :mod:`linkdyn.units` (``'torque'``, ``'force'``,
    ``'angle'``, ``'length'``, ``'inertia'``, ``'energy'``, ``'number'``), for its display in the
    file's units and a constraint's bound; None for an unknown name."""
    if name.startswith(("peak_tau_", "rms_tau_")):
        return "torque"
    if (name.startswith(("peak_force_", "rms_force_", "peak_F_", "min_contact_"))
            or name == "peak_shaking_force"):
        return "force"
    if name.startswith("stroke_"):
        return "length"
    return {"min_transmission_angle": "angle", "path_deviation": "length",
            "flywheel_inertia": "inertia", "friction_loss": "energy",
            "efficiency": "number"}.get(name)


def _effort(model: Model, joint: str) -> str:
    return f"{registry(model.space).get(model.joint(joint).kind).effort}_{joint}"


#: Metrics of planar models only (a spatial model has the efforts' and the joint forces').
PLANAR_ONLY = ("min_transmission_angle", "path_deviation", "flywheel_inertia", "stroke_",
               "friction_loss", "efficiency", "output_efficiency", "min_contact_")


def _guides(model: Model) -> list[str]:
    """Undriven guides on the ground (a slider-crank's slider): the joints with a stroke."""
    driven = {d.joint for d in model.drivers}
    return [j.name for j in model.joints if j.body_a == GROUND and j.name not in driven
            and not jk.get(j.kind).angular and "axis" in jk.get(j.kind).keys]


def _flywheel_driver(model: Model) -> int | None:
    return next((k for k, d in enumerate(model.drivers)
                 if isinstance(d.motion, ConstantSpeed) and d.motion.speed
                 and jk.get(model.joint(d.joint).kind).angular), None)


def path_spec(model: Model, path_point=None, path_range=None):
    """The path point (``'BODY.POINT'`` or None) and range (rad or m, or None) of
    ``path_deviation``: the ones given, else the model's ``[analysis]`` ones, else the only free
    coupler point over the whole run."""
    point = path_point or model.path_point or default_path_point(model)
    q_range = path_range if path_range is not None else (model.path_range if point else None)
    if point:
        _parse_point(model, point)
    return point, q_range


def names(model: Model, *, path_point=None) -> list[str]:
    """Every metric this model has, in table order (a spatial model: the efforts' and the
    joint forces' only)."""
    out = []
    for d in model.drivers:
        out += [f"peak_{_effort(model, d.joint)}", f"rms_{_effort(model, d.joint)}"]
    out += [f"peak_F_{j.name}" for j in model.joints]
    if model.space == "spatial":
        return out + ["peak_shaking_force"]
    out += [f"min_contact_{j.name}" for j in model.joints if jk.get(j.kind).one_sided]
    if four_bars(model):
        out.append("min_transmission_angle")
    if path_spec(model, path_point)[0]:
        out.append("path_deviation")
    out.append("peak_shaking_force")
    if _flywheel_driver(model) is not None:
        out.append("flywheel_inertia")
    out += [f"stroke_{j}" for j in _guides(model)]
    if any(ld.kind == "friction" for ld in model.loads):
        out += ["friction_loss", "efficiency"]
    if model.output:
        out.append("output_efficiency")
    return out


def check_names(model: Model, wanted, *, path_point=None) -> list[str]:
    """``wanted`` (None: all) checked against :func:`names`, with the closest spelling."""
    from ..io.reader import _did_you_mean

    have = names(model, path_point=path_point)
    if wanted is None:
        return have
    for w in wanted:
        if w not in have and model.space == "spatial" and w.startswith(PLANAR_ONLY):
            raise ModelError(f"the metric '{w}' is for planar models only, and this model is "
                             "spatial", field="--metric",
                             fix="Use a metric of spatial models: " + ", ".join(have))
        if w not in have:
            raise ModelError(f"no metric '{w}' for this model", field="--metric",
                             fix=_did_you_mean(w, have, "metrics"))
    return list(wanted)


def reads_reactions(wanted) -> bool:
    """Whether any of the metrics ``wanted`` reads the joint reactions (``peak_F_<joint>``,
    ``min_contact_<joint>``, and
    ``peak_shaking_force``, the ground joints' reactions summed): a sweep solves them only then.
    """
    return any(w.startswith(("peak_F_", "min_contact_")) or w == "peak_shaking_force"
               for w in wanted)


def evaluate(sol, wanted=None, *, models=None, path_point=None, path_range=None,
             fluctuation: float = 0.02) -> dict[str, np.ndarray]:
    """Metrics of a solved run.

    Parameters
    ----------
    sol : Solution
        Of one design (arrays (T, ...)) or of D designs (arrays (D, T, ...)).
    wanted : sequence of str, optional
        Metric names (default: all of :func:`names`).
    models : sequence of Model, optional
        Unused (each design's driver speed is read from the solution's layout); kept for
        callers that pass it.
    path_point, path_range : optional
        For ``path_deviation`` (see :func:`path_spec`).
    fluctuation : float
        Coefficient of speed fluctuation C_s of ``flywheel_inertia``.

    Returns
    -------
    dict
        Name -> ndarray of the batch shape (``()`` for one design, ``(D,)`` for D), SI. Samples
        that are not valid (NaN) are left out; a design without a valid sample gets NaN.
    """
    m = sol.model
    wanted = check_names(m, wanted, path_point=path_point)
    if m.space == "spatial":
        return _spatial(sol, wanted)
    out: dict[str, np.ndarray] = {}
    want = set(wanted)
    for k, d in enumerate(m.drivers):
        col = _effort(m, d.joint)
        tau = sol.dyn.tau[..., k]
        if f"peak_{col}" in want:
            out[f"peak_{col}"] = peak(tau)
        if f"rms_{col}" in want:
            out[f"rms_{col}"] = rms(tau)
    for k, j in enumerate(m.joints):
        if f"peak_F_{j.name}" in want:
            out[f"peak_F_{j.name}"] = peak(np.linalg.norm(sol.reactions.force[..., k, :], axis=-1))
    if any(w.startswith("min_contact_") for w in want):
        for name, f in contact_forces(sol, sol.dyn, sol.reactions).items():
            out[f"min_contact_{name}"] = lowest(f)
    if "min_transmission_angle" in want:
        worst = [lowest(transmission_worst(transmission_angle(sol, fb))) for fb in four_bars(m)]
        out["min_transmission_angle"] = np.min(worst, axis=0)
    if "path_deviation" in want:
        out["path_deviation"] = _path_deviation(sol, path_point, path_range)
    if "peak_shaking_force" in want:
        out["peak_shaking_force"] = peak(np.linalg.norm(shaking_force(sol), axis=-1))
    if "flywheel_inertia" in want:
        out["flywheel_inertia"] = _flywheel(sol, models, fluctuation)
    names_j = [j.name for j in m.joints]
    for j in _guides(m):
        if f"stroke_{j}" in want:
            k = names_j.index(j)
            lo, hi = travel(sol.t, sol.kin.q[..., k], sol.kin.qd[..., k], sol.kin.qdd[..., k])
            out[f"stroke_{j}"] = hi - lo
    if want & {"friction_loss", "efficiency"}:
        from .. import friction
        lost, work = friction.energies(sol)
        out["friction_loss"] = np.sum(lost, axis=0)
        out["efficiency"] = friction.efficiency(out["friction_loss"], work)
    if "output_efficiency" in want:
        from .. import friction
        out["output_efficiency"] = friction.output_efficiency(sol)[2]
    return {w: out[w] for w in wanted}


@dataclass(frozen=True)
class Reduced:
    """How a sweep's kernel gives the metrics ``wanted`` while it walks each design's samples
    (:func:`reduced`; :func:`linkdyn.dynamics.compiled.sweep` with ``metrics``): each effort
    metric ``(name, driver index, 'peak' or 'rms')`` reduced by the steps of its definition
    (:func:`~linkdyn.design.reduce.larger_magnitude`, :func:`~linkdyn.design.reduce.plus_square`),
    and the path point ``(body, point)`` of ``path_deviation`` (or None), whose per-sample
    path the kernel keeps for :func:`~linkdyn.design.path.line_fit`, over ``q_range``."""

    efforts: tuple
    point: tuple | None = None
    q_range: tuple | None = None

    def values(self, model: Model, reduced, path, q_drv, samples: int) -> dict:
        """The metrics (each (D,), SI) from the kernel's ``reduced`` (n_efforts, D), ``path``
        (2, D, T), the drivers' coordinates ``q_drv`` (n_drivers, D, T) and the number of
        samples: the numbers :func:`evaluate` gives of the designs' solution."""
        out = {}
        for a, (name, _, how) in enumerate(self.efforts):
            out[name] = reduced[a] if how == "peak" else root_mean(reduced[a], samples)
        if self.point is not None:
            out["path_deviation"] = _deviation(model, np.moveaxis(path, 0, -1),
                                               q_drv[0] if len(q_drv) else None, self.q_range)
        return out


def reduced(model: Model, wanted, *, path_point=None, path_range=None) -> Reduced | None:
    """The :class:`Reduced` of the metrics ``wanted`` of a planar ``model``, or None when one
    of them is not a driver's ``peak_``/``rms_`` effort or ``path_deviation`` (the sweep then
    keeps the solution and :func:`evaluate` reads it)."""
    if model.space == "spatial":
        return None
    cols = {_effort(model, d.joint): k for k, d in enumerate(model.drivers)}
    efforts, point, q_range = [], None, None
    for w in wanted:
        how, _, col = w.partition("_")
        if how in ("peak", "rms") and col in cols:
            efforts.append((w, cols[col], how))
        elif w == "path_deviation":
            name, q_range = path_spec(model, path_point, path_range)
            point = tuple(name.split("."))
        else:
            return None
    return Reduced(tuple(efforts), point, q_range)


def _spatial(sol, wanted) -> dict[str, float]:
    """Metrics of one spatial run (:class:`linkdyn.spatial.SpatialSolution`): each driver's
    peak and RMS effort, each joint's peak force magnitude ``|(Fx, Fy, Fz)|`` and the peak
    shaking force (:func:`linkdyn.spatial.shaking.shaking_force`); of a batch of D designs
    (``sol.batch``) each (D,)."""
    from ..spatial.shaking import shaking_force

    m, out = sol.model, {}
    shape = sol.batch or (len(sol.t),)

    def per(x):                          # (N,) rows -> (D, T), or (T,)
        return np.reshape(x, shape)
    for d in m.drivers:
        col = _effort(m, d.joint)
        tau = per(sol.effort(d.joint))
        out[f"peak_{col}"], out[f"rms_{col}"] = peak(tau), rms(tau)
    for j in m.joints:
        out[f"peak_F_{j.name}"] = peak(per(np.linalg.norm(sol.reaction(j.name)[:, :3], axis=-1)))
    if "peak_shaking_force" in wanted:
        out["peak_shaking_force"] = peak(per(np.linalg.norm(shaking_force(sol), axis=-1)))
    return {w: out[w] for w in wanted}


def lowest(x):
    """Smallest x over the last (time) axis, finite samples only; NaN where none is finite."""
    ok = np.isfinite(x)
    return np.where(np.any(ok, axis=-1), np.min(np.where(ok, x, np.inf), axis=-1), np.nan)


def _path_deviation(sol, path_point, path_range):
    m = sol.model
    point, q_range = path_spec(m, path_point, path_range)
    body, name = point.split(".")
    q = None
    if q_range is not None and m.drivers:
        q = sol.kin.q[..., [j.name for j in m.joints].index(m.drivers[0].joint)]
    return _deviation(m, sol.point(body, name), q, q_range)


def _deviation(m: Model, xy, q, q_range):
    """``path_deviation`` of the path ``xy`` (..., T, 2) over the samples where the first
    driver's coordinate ``q`` (..., T) lies in ``q_range`` (None: every sample)."""
    sel = np.ones(xy.shape[:-1], bool)
    if q_range is not None and m.drivers:
        sel = _in_range(m, q, q_range)
    c, u, dev = line_fit(xy, sel)
    dev = np.where(np.sum(np.isfinite(dev), axis=-1)[..., None] >= 3, dev, np.nan)
    return max_deviation(dev)


def _flywheel(sol, models, fluctuation):
    m, t = sol.model, sol.t
    k = _flywheel_driver(m)
    power = driver_power(sol)[..., k]
    # each design's own speed: from its layout's motions (one per design in a batch)
    lay = sol.kin.layout
    speeds = np.broadcast_to(np.array(
        [mo.speed for mo in lay.motions[k]] if lay.designs else m.drivers[k].motion.speed,
        float), power.shape[:-1])
    out = np.full(power.shape[:-1], np.nan)
    # one cycle per distinct driver speed (all designs share it unless the speed is varied)
    for w in np.unique(speeds):
        group = speeds == w
        cyc, _ = first_cycle(t, 2 * np.pi / abs(w))
        p = power[group][..., cyc] if power.ndim > 1 else power[cyc]
        ok = np.all(np.isfinite(p), axis=-1)
        de = energy_fluctuation(t[cyc], np.where(ok[..., None], p, 0.0))
        out[group] = np.where(ok, flywheel_inertia(de, w, fluctuation), np.nan)
    return out
