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

from .brief import brief_repr

from . import joints as jk
from .dynamics.denoc import DynamicSolution, _array, composite
from .kinematics import KinematicSolution
from .joints.base import frame
from .kinematics.recursion import _axis, cut_frame, relative
from .model import Model
from .planar import about, first, stack_last, turned
from .steps import step


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
        per-sample copy of it unless asked: its kernel then runs again, keeping it).
    tree : list of ndarray (3, T)
        ``R_i``: total wrench by the parent on body i about O_i through its tree joint, driver
        effort included (tree order).
    """

    __repr__ = brief_repr   # shapes, not every number (linkdyn.brief)

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


# --- the steps: each equation once, for both backends (linkdyn.steps) ------------------------

@step
def plus(x, y):
    """``x + y`` of two wrenches ``(n, fx, fy)``."""
    return (x[0] + y[0], x[1] + y[1], x[2] + y[2])


@step
def minus(x, y):
    """``x - y`` of two wrenches ``(n, fx, fy)``."""
    return (x[0] - y[0], x[1] - y[1], x[2] - y[2])


@step
def cut_wrench(code, nums, e_a, lam, r_pa, r_pb, r_a, r_b):
    """The constraint wrench of a cut joint of kind ``code`` on its two bodies.

    Parameters
    ----------
    nums : tuple
        The cut's numbers (:meth:`~linkdyn.joints.JointKind.own`).
    e_a : (x, y)
        The joint's axis, fixed in its first body a, global components.
    lam : (l0, l1, l2)
        Its multipliers, padded with zeros to three.
    r_pa, r_pb, r_a, r_b : (x, y)
        The cut points on the first body a and the second body b, O_a and O_b, m.

    Returns
    -------
    on_b : (n, fx, fy)
        The kind's ``wrench`` (``S^T lam``, and for a gear the radial force that does no
        work), by a on b about the cut point: the joint's reaction.
    w_b, w_a : (n, fx, fy)
        On b about O_b, ``A(r_Pb - r_b)^T S^T lam``, and its opposite on a about O_a.
    """
    # the kind's wrench acts at the cut point on the second body, its opposite on the first
    on_b = jk.wrench(code, nums, frame(r_pa, r_pb, e_a), lam)
    w_a = about(on_b, relative(r_a, r_pb))
    return on_b, about(on_b, relative(r_b, r_pb)), (-w_a[0], -w_a[1], -w_a[2])


@step
def without_effort(code, s, e, w, tau):
    """``w - tau p_i``: the wrench through tree joint i of kind ``code`` (sign ``s``, global axis
    ``e``) less its driver's effort ``tau`` (N m or N), leaving the reaction."""
    p = jk.motion(code, s, e)
    return (w[0] - tau * p[0], w[1] - tau * p[1], w[2] - tau * p[2])


@step
def flipped(w, r_i, c_p, s_p, r_p, joint_p):
    """``A(r_i - r_P)^T (-w)``: the opposite of a wrench ``w`` about O_i (on the child), about
    the parent's joint point ``r_P = r_p + R_p joint_p`` (the reaction on the parent when it is
    the joint's second body); ``c_p``, ``s_p``, ``r_p`` the parent's cosine, sine and O_p."""
    j = turned(c_p, s_p, joint_p)
    return about((-w[0], -w[1], -w[2]),
                 relative((r_p[0] + j[0], r_p[1] + j[1]), r_i))


# --- the numpy path: the steps on whole arrays, loops over cuts and bodies --------------------

def _multipliers(lam: np.ndarray, rows: slice) -> tuple:
    """A cut's multipliers (rows of ``lam`` (n_rows, ...)) padded with zeros to three."""
    own = tuple(lam[rows])
    return own + (0.0,) * (3 - len(own))


def _cuts(kin: KinematicSolution, lam: np.ndarray) -> list:
    """Per cut joint: the cut, its reaction ``S^T lam`` on b and its wrenches on b and a about
    O_b and O_a, each a tuple of components, by :func:`cut_wrench`."""
    lay, pose = kin.layout, kin.pose
    out = []
    for k, c in enumerate(lay.cuts):
        r_pa, r_pb, e_a = cut_frame(jk.CODES[c.kind], c.own, pose.c[c.a], pose.s[c.a],
                                    pose.r[c.a], pose.c[c.b], pose.s[c.b], pose.r[c.b], c.pa,
                                    c.pb, c.axis, np.nan)
        out.append((c,) + cut_wrench(jk.CODES[c.kind], c.own, e_a,
                                     _multipliers(lam, lay.topo.row_slice(k)), r_pa, r_pb,
                                     pose.r[c.a], pose.r[c.b]))
    return out


def _on_bodies(n: int, cuts: list) -> list:
    """The cut wrenches of ``cuts`` (:func:`_cuts`) summed on each of the n bodies about its O:
    a tuple of components, or None for a body no cut joint acts on."""
    w = [None] * n
    for c, _, w_b, w_a in cuts:
        w[c.b] = w_b if w[c.b] is None else plus(w[c.b], w_b)
        w[c.a] = w_a if w[c.a] is None else plus(w[c.a], w_a)
    return w


def cut_wrenches(kin: KinematicSolution, lam: np.ndarray) -> list:
    """Wrenches (3, T) of the cut-joint multipliers ``lam`` (n_rows, T) on every body about O_i."""
    return [np.zeros((3,) + kin.shape) if w is None else _array(w, np.zeros(kin.shape))
            for w in _on_bodies(kin.layout.topo.n, _cuts(kin, lam))]


def tree_wrenches(kin: KinematicSolution, dyn: DynamicSolution, cuts: list | None = None
                  ) -> list:
    """``R_i`` (3, T) per body: the wrench by the parent on body i about O_i through its tree
    joint, driver effort included (``cuts``: :func:`_cuts` of ``dyn.lam`` if known)."""
    cuts = _cuts(kin, first(dyn.lam)) if cuts is None else cuts
    w_cut = _on_bodies(kin.layout.topo.n, cuts)
    # R_i = w_star_i - w_cut_i + sum_c A^T R_c  (the composite of w_star - w_cut)
    return composite(kin, [ws if wc is None else minus(ws, wc)
                           for ws, wc in zip(dyn.wstar, w_cut)])


def solve(model: Model, kin: KinematicSolution, dyn: DynamicSolution) -> Reactions:
    """Reactions at all joints from the dynamic solution."""
    lay, pose = kin.layout, kin.pose
    topo = lay.topo
    cuts = _cuts(kin, first(dyn.lam))
    R = tree_wrenches(kin, dyn, cuts)
    on_b = [None] * len(model.joints)
    driver_of = {i: k for k, i in enumerate(topo.driven)}
    for i in range(1, topo.n):
        j, k = topo.tree_joint[i], topo.parent[i]
        on_child = R[i]
        if i in driver_of:  # remove the driver's effort tau p_i
            on_child = without_effort(jk.CODES[lay.kind[i]], topo.sign[i], _axis(pose.e[i]),
                                      on_child, dyn.tau[..., driver_of[i]])
        if topo.sign[i] > 0:  # the child is the second body: its wrench about O_i as is
            on_b[j] = _array(on_child, R[i][0]) if isinstance(on_child, tuple) else on_child
        else:  # the child is the first body: the second (the parent) receives the opposite
            on_b[j] = _array(flipped(on_child, pose.r[i], pose.c[k], pose.s[k], pose.r[k],
                                     lay.joint_point[i]), R[i][0])
    for c, on_cut, _, _ in cuts:
        on_b[c.joint] = _array(on_cut, R[0][0])
    return Reactions(on_b, R)
