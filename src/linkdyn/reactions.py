"""Joint reactions, body by body from the ends of the tree back to the ground.

With the cut-joint multipliers known, the wrench the parent exerts on body i through its tree
joint (reaction plus driver effort) follows from body i's wrench balance:

    R_i = w_star_i - w_cut_i + sum_{children c} A(r_c - r_i)^T R_c,

where ``w_cut_i`` is the wrench of the cut joints on body i about O_i. Removing the driver's
share ``tau p_i`` leaves the joint's reaction.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable

import numpy as np

from . import joints as jk
from .dynamics.denoc import DynamicSolution, composite
from .kinematics import KinematicSolution
from .kinematics.recursion import _cut_frames
from .model import Model
from .planar import first, shift_wrench, stack_last


@dataclass(frozen=True)
class Reactions:
    """Reaction at every joint, in the model's joint order.

    Attributes
    ----------
    on_second : list of ndarray (3, T)
        Per joint, the wrench ``[M, Fx, Fy]`` by its first body on its second about the second
        body's joint point, component-first; ``force`` and ``moment`` stack it.
    force : ndarray (..., T, n_joints, 2)
        Force exerted by the joint's first body on its second, global components, N.
    moment : ndarray (..., T, n_joints)
        Moment exerted by the first body on the second about the second body's joint point,
        N m (zero to rounding for revolute joints, which cannot transmit one).
    internals : list or callable
        ``tree``, or a function returning it when first read (the compiled backend keeps no
        per-sample copy of it unless asked: it is then computed by :func:`tree_wrenches`).
    tree : list of ndarray (3, T)
        ``R_i``: total wrench by the parent on body i about O_i through its tree joint, driver
        effort included (tree order).
    """

    on_second: list
    internals: list | Callable = field(repr=False, compare=False)

    @cached_property
    def tree(self) -> list:
        return self.internals() if callable(self.internals) else self.internals

    @cached_property
    def force(self) -> np.ndarray:
        """(T, n_joints, 2) force by each joint's first body on its second, N."""
        return stack_last([w[1:] for w in self.on_second])

    @cached_property
    def moment(self) -> np.ndarray:
        """(T, n_joints) moment by the first body on the second about the second's point, N m."""
        return np.stack([w[0] for w in self.on_second], axis=-1)


def cut_wrenches(kin: KinematicSolution, lam: np.ndarray) -> list:
    """Wrenches (3, T) of the cut-joint multipliers ``lam`` (n_rows, T) on every body about O_i."""
    lay = kin.layout
    w = [np.zeros((3,) + kin.shape) for _ in range(lay.topo.n)]
    for k, c in enumerate(lay.cuts):
        r_pa, r_pb, e_a = _cut_frames(lay, kin.pose, c)
        # S^T lam acts at the cut point on the second body, its opposite on the first
        on_b = jk.get(c.kind).cut_wrench(e_a, lam[lay.topo.row_slice(k)])
        w[c.b] = w[c.b] + shift_wrench(on_b, r_pb - kin.pose.r[c.b])
        w[c.a] = w[c.a] - shift_wrench(on_b, r_pb - kin.pose.r[c.a])
    return w


def tree_wrenches(kin: KinematicSolution, dyn: DynamicSolution) -> list:
    """``R_i`` (3, T) per body: the wrench by the parent on body i about O_i through its tree
    joint, driver effort included."""
    w_cut = cut_wrenches(kin, first(dyn.lam))
    # R_i = w_star_i - w_cut_i + sum_c A^T R_c  (the composite of w_star - w_cut)
    return composite(kin, [ws - wc for ws, wc in zip(dyn.wstar, w_cut)])


def solve(model: Model, kin: KinematicSolution, dyn: DynamicSolution) -> Reactions:
    """Reactions at all joints from the dynamic solution."""
    lay = kin.layout
    topo = lay.topo
    lam = first(dyn.lam)
    R = tree_wrenches(kin, dyn)
    on_b = [None] * len(model.joints)
    driver_of = {i: k for k, i in enumerate(topo.driven)}
    for i in range(1, topo.n):
        j, k = topo.tree_joint[i], topo.parent[i]
        on_child = R[i]
        if i in driver_of:  # remove the driver's effort tau p_i
            on_child = on_child - dyn.tau[..., driver_of[i]] * kin.motion[i]
        if topo.sign[i] > 0:  # the child is the second body: its wrench about O_i as is
            on_b[j] = on_child
        else:  # the child is the first body: the second (the parent) receives the opposite
            r_pb = kin.pose.point(k, lay.joint_point[i])
            on_b[j] = shift_wrench(-on_child, kin.pose.r[i] - r_pb)
    for k, c in enumerate(lay.cuts):
        _, _, e_a = _cut_frames(lay, kin.pose, c)
        on_b[c.joint] = jk.get(c.kind).cut_wrench(e_a, lam[topo.row_slice(k)])
    return Reactions(on_b, R)
