"""What ``linkdyn check`` proves about a model before a run: that it assembles, where it locks,
what its dyads are.

Over the run (:func:`over_run`)
    The model is solved over the run ``analyze`` would make (its ``[analysis]`` samples and
    duration). Where a loop stops closing, the driver value where it locks is bracketed by
    bisection in time between the last sample that closes and the first that does not (each
    round solves the run up to the bracket again with 32 samples across it, so continuation
    follows the same branch), and the error names the loop (its cut joint and links).

Slider-crank dyads (:func:`slider_cranks`)
    A guide on the ground whose slider is pinned to a rod driven by a crank turning about a
    ground pivot: crank r, rod l (pin to pin), offset e (distance of the crank pivot from the
    slide line). The crank turns fully when ``r + e < l``; the stroke and the transmission
    angle (rod against the guide's normal) over the run come from the solved run.

Free coordinates (:func:`free_coordinates`)
    A model with fewer drivers than its mobility is meant for ``simulate``: the partition that
    ``simulate`` makes names the free coordinates, and the model is assembled at t = 0 with
    them at their ``[initial]`` values.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import joints as jk
from ..errors import AssemblyError
from ..model import GROUND, Model
from ..planar import cross
from ..units import Units, coordinate

__all__ = ["over_run", "loops", "SliderCrank", "slider_cranks", "free_coordinates", "shown",
           "span", "length", "guide_normal", "guide_transmission_angle", "slider_crank_runs"]

REFINE = 3          # bisection rounds of where a loop locks (32 samples each)


def shown(model: Model, joint: str, value: float) -> str:
    """A joint coordinate (rad or m) in the model file's unit, with the unit: ``'142.3 deg'``
    (:meth:`linkdyn.units.Units.show`)."""
    return Units.of(model).show(value, coordinate(model, joint))


def span(model: Model, joint: str, lo: float, hi: float) -> str:
    """A range of a joint coordinate in the file's unit: ``'0 .. 360 deg'``."""
    return Units.of(model).span(lo, hi, coordinate(model, joint))


def length(model: Model, value: float) -> str:
    """A length (m) in the model file's unit, with the unit."""
    return Units.of(model).show(value, "length", 4)


def loops(model: Model, topo) -> list[tuple[str, list[str]]]:
    """Each loop as ``(cut joint, its links in tree order)``: the bodies on the tree paths
    from the cut joint's two bodies up to their nearest common ancestor."""
    index = {b: i for i, b in enumerate(topo.bodies)}

    def up(i):
        path = [i]
        while topo.parent[path[-1]] >= 0:
            path.append(topo.parent[path[-1]])
        return path

    out = []
    for j in topo.cut:
        jt = model.joints[j]
        a, b = up(index[jt.body_a]), up(index[jt.body_b])
        common = next(i for i in a if i in b)
        body = sorted(set(a[:a.index(common) + 1]) | set(b[:b.index(common) + 1]))
        out.append((jt.name, [topo.bodies[i] for i in body]))
    return out


def _drivers(model: Model, t: float) -> dict[str, float]:
    from ..kinematics import driver_values
    v = driver_values(model, np.array([float(t)]))[0][:, 0]
    return {d.joint: float(x) for d, x in zip(model.drivers, v)}


def _bracket(model: Model, t: np.ndarray, k: int) -> tuple[float, float]:
    """Times ``(last that closes, first that does not)`` around the first invalid sample ``k``
    of the run ``t``, narrowed by :data:`REFINE` rounds of 32 samples."""
    from ..analysis import analyze

    lo, hi = float(t[k - 1]), float(t[k])
    head = t[:k - 1]
    for _ in range(REFINE):
        fine = np.linspace(lo, hi, 33)
        sol = analyze(model, np.r_[head, fine], allow_singular=True, backend="numpy")
        bad = np.flatnonzero(~sol.valid[len(head):])
        if not len(bad) or bad[0] == 0:
            break
        lo, hi = float(fine[bad[0] - 1]), float(fine[bad[0]])
        head = np.r_[head, fine[:bad[0] - 1]]
    return lo, hi


def over_run(model: Model, t: np.ndarray, topo):
    """Solve ``model`` over the run ``t``; on failure an :class:`AssemblyError` naming the loop
    and, when the loops stop closing after t = 0, the driver values between which it locks.

    Returns
    -------
    Solution
    """
    from ..analysis import analyze

    try:
        return analyze(model, t, backend="numpy")
    except AssemblyError as err:
        if err.time is None:
            raise
        where = "; ".join(f"the loop cut at {cut} ({', '.join(links)})"
                          for cut, links in loops(model, topo))
        k = int(np.searchsorted(t, err.time))
        closes = "singular" in err.message
        if k == 0 or closes or not where:
            err.message += f" ({where or 'no loop'})"
            raise
        lo, hi = _bracket(model, t, k)
        last = ", ".join(f"q_{j} = {shown(model, j, v)}" for j, v in _drivers(model, lo).items())
        drv = ", ".join(f"q_{j} = {shown(model, j, v)}" for j, v in _drivers(
            model, err.time).items())
        raise AssemblyError(
            f"at t = {err.time:.6g} s ({drv}): {where} stops closing: it closes up to {last} "
            f"(t = {lo:.6g} s, within {hi - lo:.2g} s) and not beyond, where the mechanism "
            "locks", file=model.source,
            fix="Limit the driver's range ([analysis] duration) or change the link lengths "
                "so the loop closes over the whole range") from None


@dataclass(frozen=True)
class SliderCrank:
    """An RRP dyad on a crank: ``guide`` (joint on the ground), ``crank``, ``rod``, ``slider``
    bodies; ``r`` crank, ``l`` rod (pin to pin), ``e`` offset of the crank pivot from the slide
    line, m."""

    guide: str
    crank: str
    rod: str
    slider: str
    r: float
    l: float
    e: float

    @property
    def turns(self) -> bool:
        """Whether the crank can turn fully: ``r + e < l``."""
        return self.r + self.e < self.l


def _point(model: Model, body: str, joint) -> np.ndarray:
    return np.asarray(model.body(body).points[joint.point_a if joint.body_a == body
                                              else joint.point_b], float)


def slider_cranks(model: Model) -> list[SliderCrank]:
    """Every slider-crank dyad: a guide on the ground (:func:`linkdyn.report.keys.slider_rods`)
    whose rod's other joint is on a crank pinned to the ground by a revolute joint."""

    out = []
    for g, rod, pin, other in slider_rods(model):
        rj = next(j for j in model.joints if rod in (j.body_a, j.body_b)
                  and (j.point_a if j.body_a == rod else j.point_b) == other)
        crank = rj.body_b if rj.body_a == rod else rj.body_a
        pivot = [j for j in model.joints if crank in (j.body_a, j.body_b) and j is not rj
                 and GROUND in (j.body_a, j.body_b) and jk.get(j.kind).angular]
        if crank == GROUND or not pivot:
            continue
        p = pivot[0]
        r = float(np.linalg.norm(_point(model, crank, rj) - _point(model, crank, p)))
        l = float(np.linalg.norm(np.asarray(model.body(rod).points[other], float)
                                 - np.asarray(model.body(rod).points[pin], float)))
        axis = np.asarray(g.axis, float) / np.linalg.norm(g.axis)
        e = abs(float(cross(axis, _point(model, GROUND, p) - _point(model, GROUND, g))))
        out.append(SliderCrank(g.name, crank, rod, g.body_b, r, l, e))
    return out


def guide_normal(sol, j) -> np.ndarray:
    """Unit normal (T, 2) of a guide's axis, global, to the axis's left."""
    phi = 0.0 if j.body_a == GROUND else sol.phi(j.body_a)
    a = np.arctan2(float(j.axis[1]), float(j.axis[0])) + np.asarray(phi) + np.zeros(np.shape(sol.t))
    return np.stack([-np.sin(a), np.cos(a)], axis=-1)


def guide_transmission_angle(sol, g, rod: str, pin: str, other: str) -> np.ndarray:
    """(T,) rad: the angle between the rod (its pin on the slider to its other joint) and the
    guide's normal, in [0, pi/2] (pi/2: the rod pushes along the guide)."""
    d = np.asarray(sol.point(rod, other)) - np.asarray(sol.point(rod, pin))
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    c = np.abs(np.sum(d * guide_normal(sol, g), axis=-1))  # cos of the angle to the normal
    return np.arccos(np.clip(c, 0.0, 1.0))


def slider_crank_runs(sol) -> list[dict]:
    """What a run does with each slider-crank dyad (:func:`slider_cranks`), SI: ``rod``,
    ``slider``, ``guide``, ``stroke_m`` (the slider's travel along its guide, max - min of
    ``q_guide`` over the valid samples), ``travel_m`` ([min, max]) and
    ``transmission_angle_rad`` (``min``, ``max``, ``min_time_s``: the rod against the guide's
    normal, :func:`guide_transmission_angle`)."""
    from .path import joint_travel

    m, t = sol.model, np.asarray(sol.t, float)
    guides = {sc.guide for sc in slider_cranks(m)}
    out = []
    for g, rod, pin, other in slider_rods(m):
        if g.name not in guides:
            continue
        lo, hi = joint_travel(sol, g.name)
        mu = np.asarray(guide_transmission_angle(sol, g, rod, pin, other), float)
        k = int(np.nanargmin(mu)) if np.any(np.isfinite(mu)) else None
        out.append({"rod": rod, "slider": g.body_b, "guide": g.name, "stroke_m": hi - lo,
                    "travel_m": [lo, hi], "transmission_angle_rad": {
                        "min": None if k is None else float(mu[k]),
                        "max": None if k is None else float(np.nanmax(mu)),
                        "min_time_s": None if k is None else float(t[k])}})
    return out


def free_coordinates(model: Model):
    """The partition ``simulate`` makes of a model with free degrees of freedom and its start:
    ``(partition, q0)``, ``partition.free`` the joints it integrates, q0 (n,) the tree
    coordinates assembled at t = 0 (:func:`linkdyn.forward.start_state`). Raises what ``simulate``
    would: a wrong ``[initial]`` (ModelError), a start that cannot be assembled
    (AssemblyError)."""
    from .. import forward

    part = forward.partition(model)
    return part, forward.start_state(part)


def slider_rods(m) -> list:
    """``(guide joint, rod, rod's pin point on the slider, rod's other joint point)`` for each
    guide fixed on the ground (a joint with an axis, not angular) whose slider is pinned to a
    rod with a second joint: the slider-crank's RRP dyads. (A guide on a moving link, as in an
    inverted slider-crank, has another transmission angle and is left out.)"""
    out = []
    for g in m.joints:
        kind = jk.get(g.kind)
        if kind.angular or "axis" not in kind.keys or g.body_a != GROUND:
            continue
        slider = g.body_b
        for r in m.joints:
            if r is g or not jk.get(r.kind).angular or slider not in (r.body_a, r.body_b):
                continue
            rod, pin = (r.body_a, r.point_a) if r.body_b == slider else (r.body_b, r.point_b)
            if rod in (GROUND, g.body_a):
                continue
            others = [(j.point_a if j.body_a == rod else j.point_b) for j in m.joints
                      if j is not r and rod in (j.body_a, j.body_b)]
            others = [p for p in others if p != pin]
            if others:
                out.append((g, rod, pin, others[0]))
    return out
