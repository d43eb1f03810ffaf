"""The recursions along the tree and the loop-closure terms (seed paper, eqs. 1-7).

Along the tree,

- positions:      phi_i = phi_p + s q_i,   O_i = joint point (+ s q_i e for a slider),
- twists (eq. 2): t_i = A(r_i - r_p) t_p + p_i qd_i,
- twist rates:    td_i = A(r_i - r_p) td_p + [0, w_p perp(v_i - v_p)] + p_i qdd_i + pd_i qd_i.

At every cut joint the relative twist of its two bodies, taken at the cut point and reduced by
the cut-row selection S, must vanish: ``J qd = 0``; its rate gives the closure bias. Arrays are
component-first, one per body (see :mod:`linkdyn.planar`); the loops run over bodies.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import joints as jk
from ..planar import perp, rotate_cs, shift_twist, solve_small, twist
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


def forward_positions(lay: Layout, q: np.ndarray) -> Pose:
    """Poses of all bodies from the tree joint coordinates ``q`` (n, ...) (``q[0]`` unused)."""
    topo, shape = lay.topo, q.shape[1:]
    phi, c, s = [np.zeros(shape)], [np.ones(shape)], [np.zeros(shape)]
    r, e = [np.zeros((2,) + shape)], [None]
    for i in range(1, topo.n):
        k = topo.parent[i]
        # joint point on the parent, then the child placed by the joint kind
        r_joint = r[k] + rotate_cs(c[k], s[k], lay.joint_point[i])
        phi_i, c_i, s_i, r_i, e_i = jk.get(lay.kind[i]).place_child(
            topo.sign[i], q[i], lay.angle[i], lay.axis[i], phi[k], c[k], s[k], r_joint)
        phi.append(phi_i), c.append(c_i), s.append(s_i), r.append(r_i), e.append(e_i)
    return Pose(phi, c, s, r, e)


def _cut_frames(lay: Layout, pose: Pose, c: Cut):
    """Cut point positions on both bodies and the cut's axis, global, (2, ...) each."""
    return pose.point(c.a, c.pa), pose.point(c.b, c.pb), pose.rotate(c.a, c.axis)


def closure_residual(lay: Layout, pose: Pose) -> np.ndarray:
    """Loop-closure residual of all cuts (n_rows, ...): m for positions, rad for angles; each
    cut contributes its kind's rows (``topo.rows``)."""
    out = []
    for c in lay.cuts:
        r_pa, r_pb, e_a = _cut_frames(lay, pose, c)
        out.append(jk.get(c.kind).cut_residual(c.angle, pose.phi[c.a], pose.phi[c.b], e_a, r_pa,
                                               r_pb))
    return np.concatenate(out) if out else np.zeros((0,) + pose.phi[0].shape)


def motion_vectors(lay: Layout, pose: Pose) -> list:
    """Joint-motion propagation vectors ``p_i`` (3, ...) of all tree joints (eq. 3)."""
    topo, ndim = lay.topo, pose.phi[0].ndim
    return [None] + [jk.get(lay.kind[i]).motion_vector(topo.sign[i], pose.e[i], ndim)
                     for i in range(1, topo.n)]


def closure_jacobian(lay: Layout, pose: Pose, p: list) -> np.ndarray:
    """Loop-closure Jacobian ``J`` (n_rows, n - 1, ...): tree joint rates to the cut rows.

    Column k of cut c is ``S_c A(r_Pb - r_k) p_k``, with sign +1 if joint k is on the path to
    the cut's second body, -1 if on the path to its first, 0 if on both or neither (eqs. 20-24).
    """
    topo, shape = lay.topo, pose.phi[0].shape
    rows = []
    for c in lay.cuts:
        r_pa, r_pb, e_a = _cut_frames(lay, pose, c)
        kind = jk.get(c.kind)
        side = topo.ancestors[c.b].astype(int) - topo.ancestors[c.a].astype(int)
        cols = []
        for k in range(1, topo.n):
            if side[k] == 0:
                cols.append(np.zeros((kind.rows,) + shape))
                continue
            x = side[k] * shift_twist(np.broadcast_to(p[k], (3,) + shape), r_pb - pose.r[k])
            cols.append(kind.cut_rows(e_a, x))
        rows.append(np.stack(cols, axis=1))
    return np.concatenate(rows) if rows else np.zeros((0, topo.n - 1) + shape)


def forward_twists(lay: Layout, pose: Pose, p: list, qd: np.ndarray) -> list:
    """Twists ``t_i`` (3, ...) of all bodies at their O_i from tree joint rates ``qd`` (n, ...)."""
    topo = lay.topo
    tw = [np.zeros((3,) + qd.shape[1:])]
    for i in range(1, topo.n):
        k = topo.parent[i]
        # t_i = A(r_i - r_p) t_p + p_i qd_i      (eq. 2)
        tw.append(jk.get(lay.kind[i]).add_motion(topo.sign[i], pose.e[i],
                                                 shift_twist(tw[k], pose.r[i] - pose.r[k]), qd[i]))
    return tw


def forward_twist_rates(lay: Layout, pose: Pose, p: list, tw: list, qd: np.ndarray,
                        qdd: np.ndarray) -> list:
    """Twist rates ``td_i`` (3, ...): angular acceleration and acceleration of O_i."""
    topo = lay.topo
    td = [np.zeros_like(tw[0])]
    for i in range(1, topo.n):
        k = topo.parent[i]
        # td_i = A td_p + [0, w_p perp(v_i - v_p)] + p_i qdd_i + pd_i qd_i
        kind, sign, e = jk.get(lay.kind[i]), topo.sign[i], pose.e[i]
        td_i = kind.add_motion(sign, e, shift_twist(td[k], pose.r[i] - pose.r[k]), qdd[i])
        w_k = tw[k][0]
        td_i[1] -= w_k * (tw[i][2] - tw[k][2])
        td_i[2] += w_k * (tw[i][1] - tw[k][1])
        kind.add_motion_rate(sign, e, tw[k if sign > 0 else i][0], td_i, qd[i])
        td.append(td_i)
    return td


def _at_point(t_x, td_x, r_x, r_pt, v_pt):
    """Twist and twist rate of body x taken at a point moving with velocity v_pt (2, ...)."""
    a = r_pt - r_x
    t_at = shift_twist(t_x, a)
    # d/dt [w, v + w perp(a)] with the point moving at v_pt
    acc = td_x[1:] + td_x[0] * perp(a) + t_x[0] * perp(v_pt - t_x[1:])
    return t_at, twist(td_x[0], acc)


def closure_bias(lay: Layout, pose: Pose, tw: list, td: list) -> np.ndarray:
    """Rate of the cut rows ``d/dt (S x)`` (n_rows, ...) for the given twist rates, ``x`` being
    the relative twist of the cut's second body to its first at the cut point."""
    out = []
    for c in lay.cuts:
        r_pa, r_pb, e_a = _cut_frames(lay, pose, c)
        v_pb = shift_twist(tw[c.b], r_pb - pose.r[c.b])[1:]
        tb, ab = _at_point(tw[c.b], td[c.b], pose.r[c.b], r_pb, v_pb)
        ta, aa = _at_point(tw[c.a], td[c.a], pose.r[c.a], r_pb, v_pb)
        kind = jk.get(c.kind)
        out.append(kind.cut_rows(e_a, ab - aa) + kind.cut_rows_rate(e_a, tw[c.a][0], tb - ta))
    return np.concatenate(out) if out else np.zeros((0,) + tw[0].shape[1:])


def dependent_rates(lay: Layout, J: np.ndarray, q_rates_drv: np.ndarray):
    """Dependent joint rates from the driven ones: ``J_dep x = -J_drv qd_drv`` (eqs. 4-5)."""
    topo = lay.topo
    dep, drv = np.array(topo.dependent, int), np.array(topo.driven, int)
    rhs = -np.einsum("ij...,j...->i...", J[:, drv - 1], q_rates_drv)
    return solve_small(J[:, dep - 1], rhs)


def point_acceleration(tw, twd, a):
    """Acceleration (2, ...) of the body point at offset ``a`` from O: ``a_O + al perp(a) - w^2 a``."""
    return twd[1:] + twd[0] * perp(a) - tw[0] ** 2 * a
