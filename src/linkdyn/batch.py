"""The design axis of batch results: design k's single-design results out of a batch.

A batch of D designs (``linkdyn.analyze([m0, m1, ...], t)``) gives every per-sample array a
design axis: component-first arrays ``(..., D, T)`` (the solvers' per-body lists) and
components-last ones ``(D, T, ...)`` (``lam``, ``tau``, ``Q``). The functions here take design
k out of each result, as the result of that one mechanism: ``(..., T)`` and ``(T, ...)``. They
slice (views, no copy); internals computed on first read are taken when read.
"""

from __future__ import annotations

from dataclasses import replace
from functools import partial

import numpy as np

from .loads import has_potential


def take(x, k: int):
    """Design k of a component-first array ``(..., D, T)``: ``(..., T)``. An array broadcast
    along the designs (length 1 there, as a revolute joint's constant ``p_i`` (3, 1, 1)) gives
    its only row; ``None`` stays ``None``."""
    if x is None:
        return None
    return x[..., k if x.shape[-2] > 1 else 0, :]


def take_each(xs, k: int) -> list:
    """:func:`take` of every entry of a per-body (or per-joint) list."""
    return [take(x, k) for x in xs]


def kinematics(kin, k: int):
    """Design k of a batch :class:`~linkdyn.kinematics.KinematicSolution`."""
    pose = kin.pose
    arrays = (None if kin.arrays is None else   # the kernel's arrays keep a design axis of 1
              {key: x[..., k:k + 1, :] for key, x in kin.arrays.items()})
    return replace(
        kin, layout=kin.layout.design(k),
        joint_motion=tuple(take_each(x, k) for x in kin.joint_motion),
        pose=type(pose)(*(take_each(x, k) for x in (pose.phi, pose.c, pose.s, pose.r, pose.e))),
        motion=take_each(kin.motion, k), twists=take_each(kin.twists, k),
        rates=take_each(kin.rates, k), jacobian=take(kin.jacobian, k), pivot=kin.pivot[k],
        residual=kin.residual[k], valid=kin.valid[k], arrays=arrays)


def loads(ld, k: int, layout):
    """Design k of a batch :class:`~linkdyn.loads.Loads`; ``layout``: that design's
    (whether it has a potential energy is its own)."""
    return replace(ld, wrenches=take_each(ld.wrenches, k),
                   potential_energy=ld.potential_energy[k], power=ld.power[k],
                   on_ground=take(ld.on_ground, k), has_potential=has_potential(layout),
                   values=tuple(take_each(ld.values, k)), powers=tuple(take_each(ld.powers, k)))


def _dynamics_internals(internals, k: int) -> tuple:
    w_star, w_tilde, Q = internals() if callable(internals) else internals
    return take_each(w_star, k), take_each(w_tilde, k), Q[k]


def dynamics(dyn, k: int):
    """Design k of a batch :class:`~linkdyn.dynamics.denoc.DynamicSolution` (internals computed
    on first read stay so, taken from the batch's when read)."""
    internals = (partial(_dynamics_internals, dyn.internals, k) if callable(dyn.internals)
                 else _dynamics_internals(dyn.internals, k))
    return replace(dyn, lam=dyn.lam[k], tau=dyn.tau[k], kinetic_energy=dyn.kinetic_energy[k],
                   pivot=dyn.pivot[k], internals=internals)


def _tree(internals, k: int) -> list:
    return take_each(internals() if callable(internals) else internals, k)


def reactions(react, k: int):
    """Design k of a batch :class:`~linkdyn.reactions.Reactions`."""
    internals = (partial(_tree, react.internals, k) if callable(react.internals)
                 else _tree(react.internals, k))
    return replace(react, on_second=take_each(react.on_second, k), internals=internals)


def check_index(k, n: int) -> int:
    """``k`` as an index into ``n`` designs (negative counts from the end)."""
    if isinstance(k, (bool, np.bool_)) or not isinstance(k, (int, np.integer)):
        raise TypeError(f"a design index must be an integer, not {type(k).__name__}")
    if not -n <= k < n:
        raise IndexError(f"design {k} out of range: the batch has {n} design(s)")
    return int(k) % n
