"""Applied loads as wrenches on the bodies: gravity, point forces, torques, springs, dampers.

Every wrench is ``[n, fx, fy]`` about the body's reference point O_i (its tree joint), global
components, N m and N: one component-first array ``(3, T)`` per body, tree order. A body without
loads gets a read-only zero broadcast over the samples (stride 0 along them, no memory per
sample).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .brief import brief_repr

from .kinematics import KinematicSolution
from .kinematics.layout import load_rows
from .kinematics.recursion import relative
from .model import Model
from .planar import _stack, about, at, dot, stack_last, turned, twist
from .steps import select, step


@dataclass(frozen=True)
class Loads:
    """Applied wrenches and their energy terms.

    Attributes
    ----------
    wrenches : list of ndarray (3, T)
        Sum of applied wrenches on each body about O_i (tree order), N m / N; a broadcast
        (read-only, stride 0 along T) zero for a body without loads.
    potential_energy : ndarray (..., T)
        Gravity and spring potential, J (zero at the global origin / free length).
    power : ndarray (..., T)
        Power of the non-conservative loads (forces, torques, dampers), W.
    has_potential : bool
        Whether gravity or springs are present.
    on_ground : ndarray (3, T)
        Wrench of the springs and dampers anchored on the ground on it, about the global origin
        (it enters no balance of the moving bodies; the shaking load includes it); a broadcast
        zero as in ``wrenches`` when there are none.
    values : tuple of ndarray
        Each load's value (``model.loads`` order), SI: a ``force`` its global components
        ``(2, T)`` N; a ``torque`` or ``joint_torque`` ``(T,)`` N m; a ``joint_force`` ``(T,)``
        N; a ``spring`` or ``damper`` its tension ``(T,)`` N (positive pulling its two points
        together: a stretched spring, a lengthening damper). Empty when not asked for.
    powers : tuple of ndarray (T,)
        Each load's power on the mechanism, W (``model.loads`` order): ``f . v`` of a force at
        its point, ``n omega`` of a torque, the effort times the joint's rate inside a joint,
        ``f . (v_1 - v_2)`` of a spring or damper on its two points (a spring's is minus the rate
        of its potential energy, which ``power`` leaves out; a damper's is never positive).
    """

    __repr__ = brief_repr   # shapes, not every number (linkdyn.brief)

    wrenches: list
    potential_energy: np.ndarray
    power: np.ndarray
    has_potential: bool
    on_ground: np.ndarray
    values: tuple = ()
    powers: tuple = ()

    @property
    def w_ext(self) -> np.ndarray:
        """Applied wrenches stacked components last, (T, n, 3), tree order."""
        return stack_last(self.wrenches)


#: the columns of each load kind's value (``results.csv``: ``<column>_<label>``): a force's
#: global components, else one number (a torque, an effort inside a joint, a tension); not
#: ``Fx_``, ``tau_``, ``force_``, which name the reactions and the drivers' efforts
VALUE_COLUMNS = {"force": ("value_x", "value_y"), "torque": ("value",),
                 "joint_torque": ("value",), "joint_force": ("value",), "spring": ("value",),
                 "damper": ("value",)}
VALUE_UNITS = {"force": "N", "torque": "N m", "joint_torque": "N m", "joint_force": "N",
               "spring": "N", "damper": "N"}


def labels(model: Model) -> tuple[str, ...]:
    """Each load's label (``model.loads`` order), as error messages name it: ``loads.<name>``
    for a load whose name no other load shares, else ``loads[<k>]`` (k its position in the
    file's ``[[loads]]``, from 0). The result columns and the summary use it."""
    names = [ld.name for ld in model.loads]
    return tuple(f"loads.{n}" if n and names.count(n) == 1 else f"loads[{k}]"
                 for k, n in enumerate(names))


def has_potential(lay) -> bool:
    """Whether the loads of layout ``lay`` (any of its designs) have a potential energy:
    gravity or springs."""
    return bool(np.any(lay.gravity != 0)) or any(r.kind == "spring" for r in lay.loads)


# --- the steps: one load, on component tuples (arrays, or floats in a compiled kernel) -------

@step
def body_point(c, s, r, t, p):
    """Global position and velocity ``(x, y)`` of the point ``p`` of a body (its frame, from O),
    the body's cosine ``c``, sine ``s``, reference point ``r`` and twist ``t`` at O."""
    # r + R p, and the velocity of A(R p) t
    a = turned(c, s, p)
    v = at(t, a)
    return (r[0] + a[0], r[1] + a[1]), (v[1], v[2])


@step
def force_at(f, r_o, r):
    """The wrench ``(n, fx, fy)`` about ``r_o`` of the force ``f`` applied at ``r``:
    ``[(r - r_o) x f, f]``."""
    return about((0.0, f[0], f[1]), relative(r_o, r))


@step
def weight(mass, g, r_c):
    """A body's weight ``m g`` (at its mass centre ``r_c``) and its potential ``-m g . r_c``."""
    return (mass * g[0], mass * g[1]), -mass * (g[0] * r_c[0] + g[1] * r_c[1])


@step
def spring_force(stiffness, free_length, r1, r2):
    """Force ``(x, y)`` of a spring on its first point ``r1`` (minus it on ``r2``), its
    potential energy, J, and its tension ``k (l - l0)``, N (positive when stretched)."""
    # tension k (l - l0) pulls the two points together; zero free length: the force k d,
    # defined also where the two points meet
    d = relative(r1, r2)
    length = np.sqrt(dot(d, d))
    tension = stiffness * (length - free_length)
    zero = free_length == 0
    f = (select(zero, stiffness * d[0], tension * (d[0] / length)),
         select(zero, stiffness * d[1], tension * (d[1] / length)))
    return f, 0.5 * stiffness * (length - free_length) ** 2, tension


@step
def damper_force(damping, r1, v1, r2, v2):
    """Force ``(x, y)`` of a damper on its first point (minus it on the second), its power
    (negative), W, and its tension ``c dl/dt``, N (positive while it lengthens)."""
    # tension c dl/dt along the line of the two points
    d = relative(r1, r2)
    length = np.sqrt(dot(d, d))
    u = (d[0] / length, d[1] / length)
    rate = dot(u, relative(v1, v2))
    tension = damping * rate
    return (tension * u[0], tension * u[1]), -damping * rate ** 2, tension


# --- the numpy path: the steps on whole arrays, a loop over the loads -------------------------

def _point(kin: KinematicSolution, i: int, name: str):
    """Global position and velocity (2, T) of body i's named point."""
    pose = kin.pose
    r, v = body_point(pose.c[i], pose.s[i], pose.r[i], kin.twists[i], kin.layout.points[i][name])
    return _stack(r), _stack(v)


def _add_force(w, kin, i, r, f):
    """Accumulate force ``f`` (2, T) applied at ``r`` on body i: ``[(r - r_i) x f, f]``."""
    w[i] = w[i] + _stack(force_at(f, kin.pose.r[i], r))


#: Load kinds whose value depends on the joint reactions: ``wrenches`` leaves them out and the
#: inverse dynamics applies them with the reactions (:mod:`linkdyn.friction`).
REACTION_KINDS = ("friction",)


def joint_effort_units(kin: KinematicSolution, body: int, body2: int, point: str, axis):
    """The wrenches (3, ...) about ``O_body`` and ``O_body2`` of a unit effort inside a joint
    whose second body is ``body`` (joint point ``point``) and first ``body2`` (tree indices): a
    unit torque on the second body and minus it on the first for ``axis`` None (the same at
    every sample: shape (3, 1, ...)), else a unit force along ``axis`` (2,) (or (2, D, 1)),
    fixed in the first body's frame, at the second body's point, and minus it on the first
    body at the same place."""
    if axis is None:
        unit = np.zeros((3,) + (1,) * len(kin.shape))
        unit[0] = 1.0
        return unit, -unit
    r_b, _ = _point(kin, body, point)
    e = kin.pose.rotate(body2, axis)
    return (_stack(force_at(e, kin.pose.r[body], r_b)),
            _stack(force_at(-e, kin.pose.r[body2], r_b)))


def add_joint_effort(w, kin: KinematicSolution, body: int, body2: int, point: str, axis,
                     x) -> None:
    """Accumulate into ``w`` (per-body wrenches, tree order) the effort ``x`` (batch shape)
    inside a joint (:func:`joint_effort_units`, arguments as there): a torque x (N m) for
    ``axis`` None, else a force x (N) along ``axis``."""
    # x times the unit effort's wrenches on the second and the first body
    on_b, on_a = joint_effort_units(kin, body, body2, point, axis)
    w[body] = w[body] + on_b * x
    w[body2] = w[body2] + on_a * x


def values(lay, load, kin: KinematicSolution) -> np.ndarray:
    """A load's value at the samples of ``kin``, components first: ``value(t)``, or for a formula
    in joint coordinates and rates (its ``state_variables``, e.g. ``qd_J1``)
    ``value(t, motion)`` with ``motion = kin.joint_motion`` (SI, model joint order)."""
    f = load.values[0]
    if not getattr(f, "state_variables", ()):
        return lay.load_values(load, kin.t)
    if lay.designs:   # one function per design, each with its design's motion
        q, qd, _ = kin.joint_motion
        v = np.stack([load.values[min(d, len(load.values) - 1)](
            kin.t, ([x[d] for x in q], [x[d] for x in qd])) for d in range(lay.designs)])
    else:
        v = f(kin.t, kin.joint_motion[:2])
    return np.moveaxis(v, -1, 0) if load.kind == "force" else v


def wrenches(model: Model | None, kin: KinematicSolution) -> Loads:
    """Applied wrenches of the loads and gravity over the kinematic solution ``kin``.

    Parameters
    ----------
    model : Model or None
        One mechanism whose gravity and loads act (``kin`` of that mechanism, no design axis);
        None (or the sequence of a batch's models) takes each design's gravity, load values,
        spring and damper constants from ``kin.layout``, where the kinematics put them.
    kin : KinematicSolution
    """
    lay = kin.layout
    if isinstance(model, Model):
        if lay.designs:
            raise ValueError("a batch of designs takes its loads from kin.layout: pass None")
        lay = replace(lay, gravity=np.asarray(model.gravity, float).reshape(2),
                      loads=load_rows(model, lay.topo))
    topo = lay.topo
    shape = kin.shape
    # no load: one zero wrench shared by every body, broadcast over the samples
    zero = np.broadcast_to(np.zeros((3,) + (1,) * len(shape)), (3,) + shape)
    w = [zero] * topo.n
    pe = np.zeros(shape)
    power = np.zeros(shape)
    g = lay.gravity   # (2,), or (2, D, 1) per design
    has_pe = has_potential(lay)
    # gravity: m g at the mass centre; potential -m g . r_C
    if np.any(g != 0):
        for i in range(1, topo.n):
            r_c = kin.pose.point(i, lay.com[i])
            f, pe_i = weight(lay.mass[i], g, r_c)
            _add_force(w, kin, i, r_c, np.stack([np.broadcast_to(x, r_c.shape[1:]) for x in f]))
            pe += pe_i
    values_, powers = [], []   # each load's value and power, model.loads order
    for load in lay.loads:
        i = load.body
        if load.kind == "force":
            r, v = _point(kin, i, load.point)
            # components first, then the samples' axes: a value of the times alone (2, T)
            # gains the batch axes between (simulate's 1 + nf acceleration cases)
            f = values(lay, load, kin)
            f = f.reshape(f.shape[:1] + (1,) * (len(shape) + 1 - f.ndim) + f.shape[1:])
            f = np.broadcast_to(f, (2,) + shape)
            _add_force(w, kin, i, r, f)
            # its power f . v at the point
            value, p = f, dot(f, v)
        elif load.kind == "torque":
            tq = np.broadcast_to(values(lay, load, kin), shape)
            w[i] = w[i] + twist(tq, np.zeros((2,) + shape))
            # its power n omega
            value, p = tq, tq * kin.twists[i][0]
        elif load.kind in ("joint_torque", "joint_force"):
            x = np.broadcast_to(values(lay, load, kin), shape)
            add_joint_effort(w, kin, i, load.body2, load.point,
                             None if load.kind == "joint_torque" else load.axis, x)
            # its power: the effort times the joint's rate
            value, p = x, x * kin.joint_motion[1][load.joint]
        elif load.kind in REACTION_KINDS:
            # applied with the reactions it depends on: linkdyn.friction.solve adds its wrench
            # and fills its value and power in
            value, p = np.zeros(shape), np.zeros(shape)
        else:  # spring or damper between two points, force along the line joining them
            j = load.body2
            r1, v1 = _point(kin, i, load.point)
            r2, v2 = _point(kin, j, load.point2)
            if load.kind == "spring":
                f, pe_k, value = spring_force(load.stiffness, load.free_length, r1, r2)
                pe += pe_k
                # its power f . v1 - f . v2 on its two points: -d(pe_k)/dt
                p = dot(_stack(f), v1 - v2)
            else:
                f, p, value = damper_force(load.damping, r1, v1, r2, v2)
            f = _stack(f)
            _add_force(w, kin, i, r1, f)
            _add_force(w, kin, j, r2, -f)
        values_.append(np.broadcast_to(value, (2,) + shape if load.kind == "force" else shape))
        powers.append(np.broadcast_to(p, shape))
        if load.kind != "spring":   # a spring's work is in the potential energy
            power = power + powers[-1]
    # the ground's O_0 is the global origin: w[0] is the load on the ground about it, which does
    # no work and is not part of the moving bodies' balance
    on_ground, w[0] = w[0], zero
    return Loads(w, pe, power, has_pe, on_ground, tuple(values_), tuple(powers))
