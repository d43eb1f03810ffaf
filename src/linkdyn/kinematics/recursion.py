"""The recursions along the tree and the loop-closure terms (seed paper, eqs. 1-7).

Along the tree,

- positions:      phi_i = phi_p + s q_i,   O_i = joint point (+ s q_i e for a slider),
- twists (eq. 2): t_i = A(r_i - r_p) t_p + p_i qd_i,
- twist rates:    td_i = A(r_i - r_p) td_p + [0, w_p perp(v_i - v_p)] + p_i qdd_i + pd_i qd_i.

At every cut joint the relative twist of its two bodies, taken at the cut point and reduced by
the cut-row selection S, must vanish: ``J qd = 0``; its rate gives the closure bias. Arrays are
component-first, one per body (see :mod:`linkdyn.planar`); the loops run over bodies.

Each equation is one step (:mod:`linkdyn.steps`) on component tuples, per body or per cut:
:func:`child_pose`, :func:`child_twist`, :func:`child_twist_rate`, :func:`cut_frame`,
:func:`jacobian_column`, :func:`cut_bias`, :func:`cut_coordinate`, :func:`point_accel`. The
functions below call them on whole arrays, one body or cut at a time; the compiled kernel
(:mod:`.compiled`) calls the same steps on the scalars of each sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .. import joints as jk
from ..joints.base import frame
from ..planar import _stack, at, rotate_cs, solve_small, turned
from ..steps import select, step
from .layout import Cut, Layout


@dataclass(frozen=True)
class Pose:
    """Poses of all bodies, one entry per body in tree order (index 0 = ground).

    ``phi[i]`` (...) absolute angle, ``c[i]``, ``s[i]`` its cosine and sine, ``r[i]`` (2, ...)
    reference point O_i, ``e[i]`` (2, ...) global axis of a prismatic tree joint (else None).
    """

    phi: list
    c: list
    s: list
    r: list
    e: list

    def rotate(self, i: int, local: np.ndarray) -> np.ndarray:
        """Body i's local vector (2,) in the global frame, (2, ...)."""
        return rotate_cs(self.c[i], self.s[i], local)

    def point(self, i: int, local: np.ndarray) -> np.ndarray:
        """Global position (2, ...) of a point of body i given relative to O_i in its frame."""
        return self.r[i] + self.rotate(i, local)


# --- the steps: one body or cut, on component tuples (arrays or floats) ------------------------

@step
def relative(a, b):
    """The vector ``b - a`` of two vectors ``(x, y)``."""
    return (b[0] - a[0], b[1] - a[1])


@step
def child_pose(code, s, q, turn, angle, axis_p, joint_p, phi_p, c_p, s_p, r_p):
    """Pose of body i from its parent's, through its tree joint of kind ``code``.

    Parameters
    ----------
    code : int
        The tree joint's kind (:data:`linkdyn.joints.CODES`).
    s : float
        +1 if body i is the joint's second body, -1 if its first.
    q : float or ndarray (...)
        Joint coordinate, rad or m.
    turn : (c, s)
        Cosine and sine of ``s q`` for an angular kind (unused by the others).
    angle : float
        Fixed angle of the joint's second body to its first, rad (prismatic).
    axis_p, joint_p : (x, y)
        The joint's axis and point in the parent's frame (the point relative to O_p), m.
    phi_p, c_p, s_p : float or ndarray (...)
        The parent's angle (rad), its cosine and sine.
    r_p : (x, y)
        The parent's reference point O_p, global, m.

    Returns
    -------
    phi, c, s, r, e
        Body i's angle, its cosine and sine, its reference point O_i (its joint point) and the
        joint's global axis ((0, 0) for a kind without one).
    """
    # the joint point r_p + R_p j on the parent; the child placed from it by the joint's kind
    j = turned(c_p, s_p, joint_p)
    return jk.place(code, s, q, turn, angle, axis_p, phi_p, c_p, s_p,
                    (r_p[0] + j[0], r_p[1] + j[1]))


@step
def child_twist(code, s, e, t_p, r_p, r_i, rate):
    """Twist ``(w, vx, vy)`` of body i at O_i from its parent's twist ``t_p`` at O_p (eq. 2).

    ``code``, ``s``: the tree joint's kind and sign (:func:`child_pose`); ``e`` its global axis;
    ``r_p``, ``r_i`` the two reference points (m); ``rate`` the joint rate (rad/s or m/s).
    """
    # t_i = A(r_i - r_p) t_p + p_i rate
    return jk.plus_motion(code, s, e, at(t_p, relative(r_p, r_i)), rate)


@step
def child_twist_rate(code, s, e, t_p, td_p, t_i, r_p, r_i, rate, accel):
    """Twist rate ``(al, ax, ay)`` of body i at O_i (the derivative of :func:`child_twist`).

    ``t_p``, ``td_p``: the parent's twist and twist rate at O_p; ``t_i`` body i's twist at O_i;
    ``rate``, ``accel``: the joint's rate and acceleration; the rest as :func:`child_twist`.
    """
    # td_i = A(r_i - r_p) td_p + [0, w_p perp(v_i - v_p)] + p_i qdd_i + pd_i qd_i, with pd_i
    # turning at the angular velocity of the body carrying the axis (the joint's first body)
    x = at(td_p, relative(r_p, r_i))
    w = t_p[0]
    x = (x[0], x[1] - w * (t_i[2] - t_p[2]), x[2] + w * (t_i[1] - t_p[1]))
    x = jk.plus_motion(code, s, e, x, accel)
    return jk.plus_motion_rate(code, s, e, select(s > 0, t_p[0], t_i[0]), x, rate)


@step
def cut_frame(cut, nums, c_a, s_a, r_a, c_b, s_b, r_b, pa, pb, axis, t0):
    """A cut's points on its bodies a and b, its axes, global, and its contact.

    ``cut``, ``nums``: the cut's kind and numbers (:meth:`~linkdyn.joints.JointKind.own`);
    ``c_*``, ``s_*``, ``r_*``: the bodies' cosines, sines and reference points; ``pa``, ``pb``
    the cut points relative to O_a, O_b and ``axis`` in a, in the bodies' frames (m);
    ``t0``: a start for the contact's search (one sample's float: a nearby sample's contact;
    NaN: none). Returns ``r_Pa``, ``r_Pb`` (m), each ``(x, y)``, and ``(e_ax, e_ay, e_bx, e_by, t)``: the
    axis ``e_a`` fixed in a, b's x axis ``e_b`` and the contact's parameter ``t`` of a higher
    pair, found here once by the kind's ``locate`` for every step that reads the frame
    (:func:`linkdyn.joints.frame`).
    """
    # r_Pa = r_a + R_a pa,  r_Pb = r_b + R_b pb,  e_a = R_a axis,  e_b = R_b (1, 0)
    ua, ub = turned(c_a, s_a, pa), turned(c_b, s_b, pb)
    e_a = turned(c_a, s_a, axis)
    r_pa, r_pb = (r_a[0] + ua[0], r_a[1] + ua[1]), (r_b[0] + ub[0], r_b[1] + ub[1])
    t = jk.locate(cut, nums, frame(r_pa, r_pb, (e_a[0], e_a[1], c_b, s_b, t0)))
    return r_pa, r_pb, (e_a[0], e_a[1], c_b, s_b, t)


@step
def jacobian_column(cut, nums, code, s, side, e, r_k, r_pa, r_pb, e_a):
    """Column k of a cut's loop-closure Jacobian: its rows (padded to 3) of tree joint k's rate.

    ``cut``, ``nums``: the cut's kind and numbers (:meth:`~linkdyn.joints.JointKind.own`);
    ``code``, ``s``, ``e``: tree joint k's kind, sign and global axis; ``side``: +1 if joint k
    is on the path to the cut's second body, -1 to its first, 0 both or neither; ``r_k``:
    O_k; ``r_Pa``, ``r_Pb``, ``e_a``: the cut's points and axis (:func:`cut_frame`).
    """
    # side S_c A(r_Pb - r_k) p_k            (eqs. 20-24)
    x = at(jk.motion(code, s, e), relative(r_k, r_pb))
    return jk.selected(cut, nums, frame(r_pa, r_pb, e_a), (side * x[0], side * x[1], side * x[2]))


@step
def moving_point(t, td, r, r_pt, v_pt):
    """Twist and twist rate of a body (``t``, ``td`` at O = ``r``) taken at a point ``r_pt``
    moving with velocity ``v_pt`` (not a point of the body)."""
    a = relative(r, r_pt)
    # d/dt [w, v + w perp(a)] = [al, a_O + al perp(a) + w perp(v_pt - v_O)]
    return at(t, a), (td[0], td[1] - td[0] * a[1] - t[0] * (v_pt[1] - t[2]),
                      td[2] + td[0] * a[0] + t[0] * (v_pt[0] - t[1]))


@step
def cut_bias(cut, nums, e_a, t_a, td_a, r_a, t_b, td_b, r_b, r_pa, r_pb):
    """Rate of a cut's rows ``d/dt (S x)`` (padded to 3), ``x`` the relative twist of its
    second body b to its first a at the cut point P (which moves with b).

    ``cut``, ``nums``: the cut's kind and numbers; ``t_*``, ``td_*``, ``r_*``: the bodies'
    twists, twist rates and reference points; ``r_Pa``, ``r_Pb``, ``e_a`` from
    :func:`cut_frame`.
    """
    # both bodies' motion at P; d/dt (S x) = S x' + (dS/dt) x, the frame's axes turning at w_a
    # and w_b, with d' = v_Pb - v_Pa
    v_pb = at(t_b, relative(r_b, r_pb))
    v_pa = at(t_a, relative(r_a, r_pa))
    tb, ab = moving_point(t_b, td_b, r_b, r_pb, (v_pb[1], v_pb[2]))
    ta, aa = moving_point(t_a, td_a, r_a, r_pb, (v_pb[1], v_pb[2]))
    f = frame(r_pa, r_pb, e_a)
    x = jk.selected(cut, nums, f, (ab[0] - aa[0], ab[1] - aa[1], ab[2] - aa[2]))
    y = jk.selected_rate(cut, nums, f, (t_a[0], (v_pb[1] - v_pa[1], v_pb[2] - v_pa[2]), t_b[0]),
                         (tb[0] - ta[0], tb[1] - ta[1], tb[2] - ta[2]))
    return (x[0] + y[0], x[1] + y[1], x[2] + y[2])


@step
def point_accel(t, td, a):
    """Acceleration ``(x, y)`` of the body point at offset ``a`` from O, the body's twist and
    twist rate ``t``, ``td`` taken at O."""
    # a_O + al perp(a) - w^2 a
    return (td[1] - td[0] * a[1] - t[0] ** 2 * a[0], td[2] + td[0] * a[0] - t[0] ** 2 * a[1])


@step
def cut_coordinate(cut, nums, e_a, phi_a, t_a, td_a, r_a, phi_b, t_b, td_b, r_b, r_pa, r_pb):
    """Coordinate, rate and acceleration of a cut joint (an output, not an unknown).

    ``cut``, ``nums``: the cut's kind and numbers; ``phi_*``, ``t_*``, ``td_*``, ``r_*``: the bodies' angles, twists, twist rates and
    reference points; ``r_Pa``, ``r_Pb``, ``e_a`` from :func:`cut_frame`.
    """
    # the second body's cut point seen from the first's: d, d', d''; the kind's coordinate
    oa, ob = relative(r_a, r_pa), relative(r_b, r_pb)
    va, vb = at(t_a, oa), at(t_b, ob)
    aa, ab = point_accel(t_a, td_a, oa), point_accel(t_b, td_b, ob)
    return jk.coordinate(cut, nums, frame(r_pa, r_pb, e_a), (phi_a, t_a[0], td_a[0]),
                         (phi_b, t_b[0], td_b[0]), (vb[1] - va[1], vb[2] - va[2]),
                         relative(aa, ab))


# --- the recursions on arrays: a loop over bodies (or cuts), each step on whole arrays -------

def _axis(e):
    """A tree joint's global axis as the steps take it ((0, 0) for a kind without one)."""
    return (0.0, 0.0) if e is None else e


def forward_positions(lay: Layout, q: np.ndarray) -> Pose:
    """Poses of all bodies from the tree joint coordinates ``q`` (n, ...) (``q[0]`` unused)."""
    topo, shape = lay.topo, q.shape[1:]
    phi, c, s = [np.zeros(shape)], [np.ones(shape)], [np.zeros(shape)]
    r, e = [np.zeros((2,) + shape)], [None]
    for i in range(1, topo.n):
        k, kind, sign = topo.parent[i], jk.get(lay.kind[i]), topo.sign[i]
        turn = (np.cos(sign * q[i]), np.sin(sign * q[i])) if kind.angular else (1.0, 0.0)
        phi_i, c_i, s_i, r_i, e_i = child_pose(jk.CODES[lay.kind[i]], sign, q[i], turn,
                                               lay.angle[i], lay.axis[i], lay.joint_point[i],
                                               phi[k], c[k], s[k], r[k])
        phi.append(phi_i), c.append(c_i), s.append(s_i), r.append(_stack(r_i))
        e.append(_stack(e_i) if "axis" in kind.keys else None)
    return Pose(phi, c, s, r, e)


def _cut_frames(lay: Layout, pose: Pose, c: Cut):
    """Cut point positions on both bodies and the cut's axis, global, (2, ...) each."""
    return tuple(_stack(x) for x in cut_frame(jk.CODES[c.kind], c.own, pose.c[c.a],
                                               pose.s[c.a], pose.r[c.a], pose.c[c.b],
                                               pose.s[c.b], pose.r[c.b], c.pa, c.pb, c.axis,
                                               math.nan))


def _rows(parts, n: int, shape) -> np.ndarray:
    """The first ``n`` of a step's padded cut rows, as an array (n, ...) of batch ``shape``."""
    out = np.empty((n,) + shape)
    for k in range(n):
        out[k] = parts[k]
    return out


def closure_residual(lay: Layout, pose: Pose) -> np.ndarray:
    """Loop-closure residual of all cuts (n_rows, ...): m for positions, rad for angles; each
    cut contributes its kind's rows (``topo.rows``)."""
    shape, out = pose.phi[0].shape, []
    for c in lay.cuts:
        r_pa, r_pb, e_a = _cut_frames(lay, pose, c)
        out.append(_rows(jk.residual(jk.CODES[c.kind], c.own, frame(r_pa, r_pb, e_a),
                                     pose.phi[c.a], pose.phi[c.b]), jk.get(c.kind).rows, shape))
    return np.concatenate(out) if out else np.zeros((0,) + shape)


def motion_vectors(lay: Layout, pose: Pose) -> list:
    """Joint-motion propagation vectors ``p_i`` (3, ...) of all tree joints (eq. 3)."""
    topo, ndim = lay.topo, pose.phi[0].ndim
    return [None] + [jk.get(lay.kind[i]).motion_vector(topo.sign[i], pose.e[i], ndim)
                     for i in range(1, topo.n)]


def closure_jacobian(lay: Layout, pose: Pose, p: list | None = None) -> np.ndarray:
    """Loop-closure Jacobian ``J`` (n_rows, n - 1, ...): tree joint rates to the cut rows
    (:func:`jacobian_column`; ``p`` is not needed and kept for the callers' signature)."""
    topo, shape = lay.topo, pose.phi[0].shape
    J = np.zeros((topo.n_rows, topo.n - 1) + shape)
    for ci, c in enumerate(lay.cuts):
        r_pa, r_pb, e_a = _cut_frames(lay, pose, c)
        rows, n = topo.row_slice(ci), jk.get(c.kind).rows
        side = topo.ancestors[c.b].astype(int) - topo.ancestors[c.a].astype(int)
        for k in range(1, topo.n):
            if side[k]:   # else the joint moves both bodies alike, or neither
                J[rows, k - 1] = _rows(jacobian_column(
                    jk.CODES[c.kind], c.own, jk.CODES[lay.kind[k]], topo.sign[k], side[k],
                    _axis(pose.e[k]), pose.r[k], r_pa, r_pb, e_a), n, shape)
    return J


def forward_twists(lay: Layout, pose: Pose, p: list, qd: np.ndarray) -> list:
    """Twists ``t_i`` (3, ...) of all bodies at their O_i from tree joint rates ``qd`` (n, ...)."""
    topo = lay.topo
    tw = [np.zeros((3,) + qd.shape[1:])]
    for i in range(1, topo.n):
        k = topo.parent[i]
        tw.append(_stack(child_twist(jk.CODES[lay.kind[i]], topo.sign[i], _axis(pose.e[i]),
                                     tw[k], pose.r[k], pose.r[i], qd[i])))
    return tw


def forward_twist_rates(lay: Layout, pose: Pose, p: list, tw: list, qd: np.ndarray,
                        qdd: np.ndarray) -> list:
    """Twist rates ``td_i`` (3, ...): angular acceleration and acceleration of O_i."""
    topo = lay.topo
    td = [np.zeros_like(tw[0])]
    for i in range(1, topo.n):
        k = topo.parent[i]
        td.append(_stack(child_twist_rate(jk.CODES[lay.kind[i]], topo.sign[i], _axis(pose.e[i]),
                                          tw[k], td[k], tw[i], pose.r[k], pose.r[i], qd[i],
                                          qdd[i])))
    return td


def closure_bias(lay: Layout, pose: Pose, tw: list, td: list) -> np.ndarray:
    """Rate of the cut rows ``d/dt (S x)`` (n_rows, ...) for the given twist rates, ``x`` being
    the relative twist of the cut's second body to its first at the cut point."""
    shape, out = tw[0].shape[1:], []
    for c in lay.cuts:
        r_pa, r_pb, e_a = _cut_frames(lay, pose, c)
        out.append(_rows(cut_bias(jk.CODES[c.kind], c.own, e_a, tw[c.a], td[c.a], pose.r[c.a],
                                  tw[c.b], td[c.b], pose.r[c.b], r_pa, r_pb),
                         jk.get(c.kind).rows, shape))
    return np.concatenate(out) if out else np.zeros((0,) + shape)


def dependent_rates(lay: Layout, J: np.ndarray, q_rates_drv: np.ndarray):
    """Dependent joint rates from the driven ones: ``J_dep x = -J_drv qd_drv`` (eqs. 4-5)."""
    topo = lay.topo
    dep, drv = np.array(topo.dependent, int), np.array(topo.driven, int)
    rhs = -np.einsum("ij...,j...->i...", J[:, drv - 1], q_rates_drv)
    return solve_small(J[:, dep - 1], rhs)


def point_acceleration(tw, twd, a):
    """Acceleration (2, ...) of the body point at offset ``a`` (2, ...) from O
    (:func:`point_accel`): ``a_O + al perp(a) - w^2 a``."""
    return _stack(point_accel(tw, twd, a))
