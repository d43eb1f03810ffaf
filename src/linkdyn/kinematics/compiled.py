"""Compiled kinematics: the recursions of :mod:`.recursion` and the dyads of :mod:`.dyads`,
fused by a numba kernel (see :mod:`linkdyn.compiled`). The per-body and per-cut equations are the
steps of :mod:`.recursion` (``child_pose``, ``cut_frame``, ``jacobian_column``, ``child_twist``,
``child_twist_rate``, ``cut_bias``, ``cut_coordinate``) and the joint kinds' steps, called by
their codes; the loops here only gather each sample's scalars, call them and write back.

For every sample the kernel closes the loops (in closed form, dyad by dyad, from the nearest
continuation node; or takes the coordinates Newton's method closed), places the bodies, forms
the loop-closure Jacobian, solves ``J_dep qd_dep = -J_drv qd_drv`` (eqs. 4-5), propagates the
twists (eq. 2), solves ``J_dep qdd_dep = -bias`` (eqs. 6-7) and propagates the twist rates.

The samples are taken a block at a time (:data:`BLOCK`): every step walks the bodies (or cuts,
or dyads) and, for each, the samples of the block. Each sample sees the operations of the
one-sample recursion in the same order, while the independent samples keep the processor busy
and every array is read and written in contiguous runs. The equations are the steps of
:mod:`.dyads` and :mod:`.recursion` (:mod:`linkdyn.steps`), called on one sample's scalars
inside these loops; the kernel itself only moves data between the arrays and the steps. The
sample loops call nothing from the C library where they can help it (angles by
:func:`linkdyn.steps.atan2`, one loop per dyad shape), so the compiler turns them into vector
instructions.

All per-sample arrays are component-first with the batch ``(D, T)`` last, indexed
``[..., d, t]``. The kernel reads the numeric layout (:class:`.layout.Layout`) through its view
(:attr:`.Layout.view`, a :data:`.layout.View`): named arrays, read by name (``L.parent[i]``,
``L.cut_rows[c]``, ``L.joint_point[i, 0, d]``, a joint kind's numbers such as ``L.axis``,
``L.cut_angle``), the topology's integer arrays and every number with the design axis last,
built once per layout; kinds by their codes (:data:`linkdyn.joints.CODES`). The per-call
inputs (times, nodes, drivers' values) come as :data:`Inputs`.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from .. import joints as jk
from ..compiled import (PRI, factor, inline, inner, njit, screw_views, substitute,
                        vector_views)
from ..planar import turned
from . import dyads as dy
from .layout import DYAD_SHAPES, Layout, fixed
from .positions import nearest_node, scaled_error
from .state import MAXITER, STEP_TOL
from .recursion import (child_pose, child_twist, child_twist_rate, cut_bias, cut_coordinate,
                        cut_frame, jacobian_column)

SPLIT, CHAIN, SLIDE = (DYAD_SHAPES[k] for k in ("split", "chain", "slide"))
BLOCK = 1024         # samples per block of the kernel
PIVOT_TOL = 1e-13    # relative pivot below which a small system counts as singular (solve_small)


# --- scalar helpers, compiled into their callers -----------------------------------------------

@inline
def bracket(nodes, tc, j):
    """The node j with ``nodes[j] <= tc < nodes[j + 1]``, clamped to ``0 .. K - 2``
    (``searchsorted(nodes, tc, side="right") - 1``): ``j`` itself or the next when one of them
    brackets ``tc`` (the previous sample's, for times in order), else by bisection."""
    K = len(nodes)
    if j + 1 < K and nodes[j] <= tc and tc < nodes[j + 1]:
        return j
    if j + 2 < K and nodes[j + 1] <= tc and tc < nodes[j + 2]:
        return j + 1
    lo, hi = 0, K
    while lo < hi:   # searchsorted(nodes, tc, side="right")
        mid = (lo + hi) // 2
        if nodes[mid] <= tc:
            lo = mid + 1
        else:
            hi = mid
    return min(max(lo - 1, 0), K - 2)


@inline
def nearest(nodes, tc, j):
    """Index of the continuation node nearest to the time ``tc`` (positions.nearest_node),
    and the node j bracketing it (:func:`bracket`, from the guess ``j``)."""
    j = bracket(nodes, tc, j)
    return nearest_node(j, nodes[j], nodes[j + 1], tc), j


# --- the steps of one block of samples -----------------------------------------------------------

@inline
def _pose(phi, c, s, r, e, i, d, ks):
    """Body i's pose over the samples ``ks`` of design d, as views to read and write:
    ``phi``, ``c``, ``s``, the origin's ``x``, ``y`` and the slider axis's ``x``, ``y``."""
    rx_i, ry_i = vector_views(r, i, d, ks)
    ex_i, ey_i = vector_views(e, i, d, ks)
    return phi[i, d, ks], c[i, d, ks], s[i, d, ks], rx_i, ry_i, ex_i, ey_i


@inner
def _place(L, d, w, kw, nb, q, cq, sq, phi, c, s, r, e):
    """Poses of all bodies (:func:`.recursion.child_pose`) of design d of the layout's view
    ``L`` into the work arrays at ``w``, ``kw``; ``cq``, ``sq`` (n, block): cosine and sine of
    ``s q_i`` for the angular joints."""
    ks = slice(kw, kw + nb)   # the block's samples in the work arrays
    c[0, w, ks] = 1.0   # the ground's other rows stay zero
    for i in range(1, len(L.parent)):
        p, code, sign = L.parent[i], L.kind[i], float(L.sign[i])
        joint = (L.joint_point[i, 0, d], L.joint_point[i, 1, d])
        axis, angle = (L.axis[i, 0, d], L.axis[i, 1, d]), L.angle[i, d]
        phi_p, c_p, s_p, rx_p, ry_p, _, _ = _pose(phi, c, s, r, e, p, w, ks)
        phi_i, c_i, s_i, rx_i, ry_i, ex_i, ey_i = _pose(phi, c, s, r, e, i, w, ks)
        q_i, cq_i, sq_i = q[i, w, ks], cq[i], sq[i]
        for k in range(nb):
            ph, co, si, o, ax = child_pose(code, sign, q_i[k], (cq_i[k], sq_i[k]), angle, axis,
                                           joint, phi_p[k], c_p[k], s_p[k], (rx_p[k], ry_p[k]))
            phi_i[k], c_i[k], s_i[k] = ph, co, si
            rx_i[k], ry_i[k], ex_i[k], ey_i[k] = o[0], o[1], ax[0], ax[1]


@inner
def _rotate(L, root, rot, d, k0, nb, phi, c, s, r, e):
    """Turn body ``root`` and every body beyond it, sample k by the turn ``rot[:, k]`` =
    ``[angle, cos, sin, centre x, centre y]`` (dyads.turned_pose)."""
    ks = slice(k0, k0 + nb)
    for j in range(1, len(L.parent)):
        if not L.ancestors[j, root]:
            continue
        prismatic = L.kind[j] == PRI
        phi_j, c_j, s_j, rx_j, ry_j, ex_j, ey_j = _pose(phi, c, s, r, e, j, d, ks)
        for k in range(nb):
            rot_k = (rot[0, k], rot[1, k], rot[2, k], rot[3, k], rot[4, k])
            phi_k, c_k, s_k, r_k = dy.turned_pose(rot_k, phi_j[k], c_j[k], s_j[k],
                                                  (rx_j[k], ry_j[k]))
            phi_j[k], c_j[k], s_j[k], rx_j[k], ry_j[k] = phi_k, c_k, s_k, r_k[0], r_k[1]
            if prismatic:
                ex_j[k], ey_j[k] = turned(rot_k[1], rot_k[2], (ex_j[k], ey_j[k]))


@inline
def _body(c, s, r, i, d, ks):
    """Body i's cosine, sine and origin x, y over the samples ``ks`` of design d, as views."""
    rx_i, ry_i = vector_views(r, i, d, ks)
    return c[i, d, ks], s[i, d, ks], rx_i, ry_i


@inline
def _at(body, k):
    """Sample k of a body's views (:func:`_body`): its pose tuple (cos, sin, x, y)."""
    return body[0][k], body[1][k], body[2][k], body[3][k]


@inline
def _point(body, k, px, py):
    """Body point (px, py) in global coordinates, sample k, from the body's views (_body)."""
    return dy.point(_at(body, k), (px, py))


@inline
def _turns(out, k, rot):
    """A turn of sample k into ``out`` (5, block): angle, cosine, sine, centre x, y."""
    out[0, k], out[1, k], out[2, k], out[3, k] = rot[0], rot[1], rot[2], rot[3]
    out[4, k] = rot[4]


@inner
def cut_numbers(L, ci, d):
    """Cut ci's numbers as its kind's cut steps take them (``nums``, ``L.cut_own``), design d:
    a tuple of :data:`linkdyn.joints.WIDTH` floats."""
    x = L.cut_own
    return (x[ci, 0, d], x[ci, 1, d], x[ci, 2, d], x[ci, 3, d], x[ci, 4, d], x[ci, 5, d],
            x[ci, 6, d], x[ci, 7, d], x[ci, 8, d])


assert jk.WIDTH == 9, "cut_numbers gathers WIDTH numbers"


@inner
def _cut_points(L, ci, d):
    """Cut ci's points on its bodies a and b (relative to O_a, O_b), design d."""
    return ((L.cut_pa[ci, 0, d], L.cut_pa[ci, 1, d]), (L.cut_pb[ci, 0, d], L.cut_pb[ci, 1, d]))


@inner
def _close(L, modes, d, wd, kw, nb, q, phi, c, s, r, e, up, low):
    """Close every loop dyad by dyad (dyads.solve): each dyad's shape step (dyads.split,
    chain, slide, swing) gives the two turns of the samples, one sample loop per shape
    (a chain's lower turn, dyads.chain_lower, once the upper turn has moved its body); the
    subtrees beyond its two unknown joints turn. Design d's numbers (of the view ``L``, and
    ``modes``), the work arrays at ``wd``, ``kw``; ``up``, ``low`` (5, block) scratch for the
    two turns."""
    ks = slice(kw, kw + nb)
    for m in range(L.dyad_shape.shape[0]):
        shape, cut, ju, jl = L.dyad_shape[m], L.dyad_cut[m], L.dyad_upper[m], L.dyad_lower[m]
        on_b = L.dyad_on_b[m]
        side = modes[m, d]
        A = _body(c, s, r, L.cut_a[cut], wd, ks)
        B = _body(c, s, r, L.cut_b[cut], wd, ks)
        pa, pb = _cut_points(L, cut, d)
        axis, angle = (L.cut_axis[cut, 0, d], L.cut_axis[cut, 1, d]), L.cut_angle[cut, d]
        # the cut's body on the side of both unknown joints (chain, slide), and the other
        M, F, pm, pf = (B, A, pb, pa) if on_b else (A, B, pa, pb)
        sgn = 1.0 if on_b else -1.0
        x1x, x1y = vector_views(r, ju, wd, ks)   # the upper and lower unknown joints
        x2x, x2y = vector_views(r, jl, wd, ks)
        if shape == SPLIT:
            for k in range(nb):
                u, w = dy.split(_at(A, k), _at(B, k), pa, pb, (x1x[k], x1y[k]),
                                (x2x[k], x2y[k]), side)
                _turns(up, k, u)
                _turns(low, k, w)
        elif shape == CHAIN:   # the lower turn's centre, its turn after the upper turn
            for k in range(nb):
                u, w = dy.chain(_at(M, k), _at(F, k), pm, pf, (x1x[k], x1y[k]),
                                (x2x[k], x2y[k]), side)
                _turns(up, k, u)
                low[3, k], low[4, k] = w
        elif shape == SLIDE:
            for k in range(nb):
                u, w = dy.slide(_at(A, k), _at(M, k), _at(F, k), pm, pf, axis, angle, sgn,
                                (x1x[k], x1y[k]), (x2x[k], x2y[k]), side)
                _turns(up, k, u)
                _turns(low, k, w)
        else:
            for k in range(nb):
                u, w = dy.swing(_at(A, k), _at(B, k), pa, pb, axis, angle, (x1x[k], x1y[k]),
                                (x2x[k], x2y[k]), side)
                _turns(up, k, u)
                _turns(low, k, w)
        _rotate(L, ju, up, wd, kw, nb, phi, c, s, r, e)
        if shape == CHAIN:
            for k in range(nb):
                m_k = (low[3, k], low[4, k])
                _turns(low, k, dy.chain_lower(_at(M, k), _at(F, k), pm, pf, m_k))
        _rotate(L, jl, low, wd, kw, nb, phi, c, s, r, e)
        # q_i = s (phi_i - phi_parent): the turns are the changes of the two joint angles
        q_u, q_l, s_u, s_l = q[ju, wd, ks], q[jl, wd, ks], L.sign[ju], L.sign[jl]
        for k in range(nb):
            q_u[k] += s_u * up[0, k]
            q_l[k] += s_l * low[0, k]


@inner
def _cut_frames(L, d, w, kw, nb, c, s, r, P, again):
    """Every cut's points on its bodies a and b, its axis (fixed in a), global, and its
    contact, once the loops are closed (:func:`.recursion.cut_frame`), for the steps that
    follow: ``P`` (n_cut, 9, block) rows ``[r_Pa (2), r_Pb (2), e_a (2), e_b (2), t]``
    (design d's numbers, the poses at ``w``, ``kw``). The contact's search starts from the
    sample's own contact in ``P`` when ``again`` (the same samples' frames at a nearby pose:
    Newton's method's last step), else from the previous sample's."""
    ks = slice(kw, kw + nb)
    for ci in range(len(L.cut_a)):
        c_a, s_a, rx_a, ry_a = _body(c, s, r, L.cut_a[ci], w, ks)
        c_b, s_b, rx_b, ry_b = _body(c, s, r, L.cut_b[ci], w, ks)
        pa, pb = _cut_points(L, ci, d)
        axis = (L.cut_axis[ci, 0, d], L.cut_axis[ci, 1, d])
        P_c, code, nums = P[ci], L.cut_kind[ci], cut_numbers(L, ci, d)
        t0 = P_c[8, 0]   # the contact's search starts from the last sample's (or a stale one)
        for k in range(nb):
            if again:
                t0 = P_c[8, k]
            r_pa, r_pb, e_a = cut_frame(code, nums, c_a[k], s_a[k], (rx_a[k], ry_a[k]), c_b[k],
                                        s_b[k], (rx_b[k], ry_b[k]), pa, pb, axis, t0)
            t0 = e_a[4]
            P_c[0, k], P_c[1, k], P_c[2, k] = r_pa[0], r_pa[1], r_pb[0]
            P_c[3, k], P_c[4, k], P_c[5, k] = r_pb[1], e_a[0], e_a[1]
            P_c[6, k], P_c[7, k], P_c[8, k] = e_a[2], e_a[3], e_a[4]


@inline
def _frame(P_c, k):
    """A cut's points and axis, sample k of the block, from its rows ``P_c`` = ``P[ci]``
    (:func:`_cut_frames`): ``r_Pa``, ``r_Pb``, each ``(x, y)``, and the axes and contact
    ``(e_a, e_b, t)``."""
    return ((P_c[0, k], P_c[1, k]), (P_c[2, k], P_c[3, k]),
            (P_c[4, k], P_c[5, k], P_c[6, k], P_c[7, k], P_c[8, k]))


@inner
def _residual(L, d, k0, w, kw, nb, phi, P, err, g):
    """Loop-closure residual (the kinds' ``residual`` steps) into ``g`` (n_rows, block), and
    its rows in metres relative to the layout's size, max over the cut rows
    (:func:`.positions.scaled_error`), into ``err`` at ``w``, samples from ``kw`` (as the angles
    ``phi``); design d's numbers."""
    err_d = err[w, kw:kw + nb]
    err_d[:] = 0.0
    size = L.size
    last = g.shape[0] - 1
    for ci in range(len(L.cut_a)):
        P_c = P[ci]
        a, b, code, nums = L.cut_a[ci], L.cut_b[ci], L.cut_kind[ci], cut_numbers(L, ci, d)
        row, rows = L.cut_row[ci], L.cut_rows[ci]
        m0, m1, m2 = L.cut_metres[ci, 0], L.cut_metres[ci, 1], L.cut_metres[ci, 2]
        phi_a, phi_b = phi[a, w, kw:kw + nb], phi[b, w, kw:kw + nb]
        # cut ci's rows (a view of a row past the cut's is never written)
        G0, G1, G2 = g[row], g[min(row + 1, last)], g[min(row + 2, last)]
        for k in range(nb):   # the padded rows are zero
            r_pa, r_pb, e_a = _frame(P_c, k)
            x = jk.residual(code, nums, jk.frame(r_pa, r_pb, e_a), phi_a[k], phi_b[k])
            e = scaled_error(err_d[k], x[0], m0, size[d])
            e = scaled_error(e, x[1], m1, size[d])
            err_d[k] = scaled_error(e, x[2], m2, size[d])
            G0[k] = x[0]
            if rows > 1:
                G1[k] = x[1]
            if rows > 2:
                G2[k] = x[2]


@inner
def _jacobian(L, d, w, kw, nb, r, e, P, J):
    """Loop-closure Jacobian J (n_rows, n - 1): each cut's rows of each tree joint's rate
    (:func:`.recursion.jacobian_column`, eqs. 20-24); the columns of joints that move both
    bodies of a cut alike, or neither, stay zero. Design d's cut numbers, the arrays at design
    ``w``, samples from ``kw``."""
    ks = slice(kw, kw + nb)   # the block's samples in the arrays
    last = J.shape[0] - 1
    for ci in range(len(L.cut_a)):
        P_c = P[ci]
        cut, row, rows = L.cut_kind[ci], L.cut_row[ci], L.cut_rows[ci]
        nums = cut_numbers(L, ci, d)
        for j in range(1, len(L.parent)):
            f = L.side[ci, j]
            if f == 0:
                continue
            code, sign = L.kind[j], float(L.sign[j])
            rx_j, ry_j = vector_views(r, j, w, ks)
            ex_j, ey_j = vector_views(e, j, w, ks)
            # cut ci's rows (a view of a row past the cut's is never written)
            J0 = J[row, j - 1, w, ks]
            J1 = J[min(row + 1, last), j - 1, w, ks]
            J2 = J[min(row + 2, last), j - 1, w, ks]
            for k in range(nb):
                r_pa, r_pb, e_a = _frame(P_c, k)
                x = jacobian_column(cut, nums, code, sign, f, (ex_j[k], ey_j[k]),
                                    (rx_j[k], ry_j[k]), r_pa, r_pb, e_a)
                J0[k] = x[0]
                if rows > 1:
                    J1[k] = x[1]
                if rows > 2:
                    J2[k] = x[2]


@inner
def _twists(L, d, k0, nb, r, e, rate, tw):
    """Twists of every body (:func:`.recursion.child_twist`, eq. 2); ``rate`` (n, D, T)."""
    ks = slice(k0, k0 + nb)
    for i in range(1, len(L.parent)):   # the ground's row stays zero
        p, code, sign = L.parent[i], L.kind[i], float(L.sign[i])
        w_i, vx_i, vy_i = screw_views(tw, i, d, ks)
        w_p, vx_p, vy_p = screw_views(tw, p, d, ks)
        rx_i, ry_i = vector_views(r, i, d, ks)
        rx_p, ry_p = vector_views(r, p, d, ks)
        ex_i, ey_i = vector_views(e, i, d, ks)
        rate_i = rate[i, d, ks]
        for k in range(nb):
            w_i[k], vx_i[k], vy_i[k] = child_twist(
                code, sign, (ex_i[k], ey_i[k]), (w_p[k], vx_p[k], vy_p[k]), (rx_p[k], ry_p[k]),
                (rx_i[k], ry_i[k]), rate_i[k])


@inline
def _motion(tw, td, r, i, d, ks):
    """Body i's twist, twist rate and origin over the samples ``ks`` of design d, as views:
    ``w, vx, vy, al, ax, ay, x, y``."""
    w_i, vx_i, vy_i = screw_views(tw, i, d, ks)
    al_i, ax_i, ay_i = screw_views(td, i, d, ks)
    rx_i, ry_i = vector_views(r, i, d, ks)
    return w_i, vx_i, vy_i, al_i, ax_i, ay_i, rx_i, ry_i


@inner
def _twist_rates(L, d, k0, nb, r, e, tw, qd, qdd, td):
    """Twist rates of every body (:func:`.recursion.child_twist_rate`)."""
    ks = slice(k0, k0 + nb)
    for i in range(1, len(L.parent)):   # the ground's row stays zero
        p, code, sign = L.parent[i], L.kind[i], float(L.sign[i])
        w_i, vx_i, vy_i, al_i, ax_i, ay_i, rx_i, ry_i = _motion(tw, td, r, i, d, ks)
        w_p, vx_p, vy_p, al_p, ax_p, ay_p, rx_p, ry_p = _motion(tw, td, r, p, d, ks)
        ex_i, ey_i = vector_views(e, i, d, ks)
        qd_i, qdd_i = qd[i, d, ks], qdd[i, d, ks]
        for k in range(nb):
            al_i[k], ax_i[k], ay_i[k] = child_twist_rate(
                code, sign, (ex_i[k], ey_i[k]), (w_p[k], vx_p[k], vy_p[k]),
                (al_p[k], ax_p[k], ay_p[k]), (w_i[k], vx_i[k], vy_i[k]), (rx_p[k], ry_p[k]),
                (rx_i[k], ry_i[k]), qd_i[k], qdd_i[k])


@inner
def _bias(L, d, w, kw, nb, r, tw, td, P, bias):
    """Rate of the cut rows ``d/dt (S x)`` for the twist rates ``td``
    (:func:`.recursion.cut_bias`); ``bias`` (n_rows, block). Design d's cut numbers, the
    arrays at design ``w``, samples from ``kw``."""
    ks = slice(kw, kw + nb)   # the block's samples in the arrays
    last = bias.shape[0] - 1
    for ci in range(len(L.cut_a)):
        P_c = P[ci]
        a, b, cut = L.cut_a[ci], L.cut_b[ci], L.cut_kind[ci]
        row, rows = L.cut_row[ci], L.cut_rows[ci]
        w_a, vx_a, vy_a, al_a, ax_a, ay_a, rx_a, ry_a = _motion(tw, td, r, a, w, ks)
        w_b, vx_b, vy_b, al_b, ax_b, ay_b, rx_b, ry_b = _motion(tw, td, r, b, w, ks)
        B0, B1, B2 = bias[row], bias[min(row + 1, last)], bias[min(row + 2, last)]
        nums = cut_numbers(L, ci, d)
        for k in range(nb):
            r_pa, r_pb, e_a = _frame(P_c, k)
            x = cut_bias(cut, nums, e_a, (w_a[k], vx_a[k], vy_a[k]),
                         (al_a[k], ax_a[k], ay_a[k]), (rx_a[k], ry_a[k]),
                         (w_b[k], vx_b[k], vy_b[k]), (al_b[k], ax_b[k], ay_b[k]),
                         (rx_b[k], ry_b[k]), r_pa, r_pb)
            B0[k] = x[0]
            if rows > 1:
                B1[k] = x[1]
            if rows > 2:
                B2[k] = x[2]


@inner
def _factor_dep(dep, J, d, k0, nb, A, perm, col):
    """LU-factor ``J_dep`` for the samples of a block into ``A`` (n_dep, n_dep, block) and
    ``perm``; the relative pivots into ``col`` (block,)."""
    nd = len(dep)
    for i in range(nd):
        for m in range(nd):
            A_im, J_im = A[i, m], J[i, dep[m] - 1, d, k0:k0 + nb]
            for k in range(nb):
                A_im[k] = J_im[k]
    factor(A, nd, nb, perm, col)


@inner
def _solve_dep(dep, A, perm, col, d, k0, nb, rhs, x, sol):
    """``J_dep x_dep = rhs`` (``rhs`` (2 n_cut, block)) from :func:`_factor_dep`, into
    ``x[dep]``; ``sol`` scratch."""
    substitute(A, perm, col, len(dep), nb, rhs, sol, PIVOT_TOL)
    for m in range(len(dep)):
        x_m, sol_m = x[dep[m], d, k0:k0 + nb], sol[m]
        for k in range(nb):
            x_m[k] = sol_m[k]


@inner
def _cut_motion(L, d, w, kw, nb, phi, r, tw, td, P, out):
    """Coordinate, rate and acceleration of every cut joint (:func:`.recursion.cut_coordinate`);
    ``out`` (n_cut, 3, D, T). Design d's cut numbers, the arrays at design
    ``w``, samples from ``kw``."""
    ks = slice(kw, kw + nb)   # the block's samples in the arrays
    for ci in range(len(L.cut_a)):
        P_c = P[ci]
        a, b, cut = L.cut_a[ci], L.cut_b[ci], L.cut_kind[ci]
        w_a, vx_a, vy_a, al_a, ax_a, ay_a, rx_a, ry_a = _motion(tw, td, r, a, w, ks)
        w_b, vx_b, vy_b, al_b, ax_b, ay_b, rx_b, ry_b = _motion(tw, td, r, b, w, ks)
        phi_a, phi_b = phi[a, w, ks], phi[b, w, ks]
        q_c, qd_c, qdd_c = out[ci, 0, w, ks], out[ci, 1, w, ks], out[ci, 2, w, ks]
        nums = cut_numbers(L, ci, d)
        for k in range(nb):
            r_pa, r_pb, e_a = _frame(P_c, k)
            q_c[k], qd_c[k], qdd_c[k] = cut_coordinate(
                cut, nums, e_a, phi_a[k], (w_a[k], vx_a[k], vy_a[k]), (al_a[k], ax_a[k], ay_a[k]),
                (rx_a[k], ry_a[k]), phi_b[k], (w_b[k], vx_b[k], vy_b[k]),
                (al_b[k], ax_b[k], ay_b[k]), (rx_b[k], ry_b[k]), r_pa, r_pb)


@inner
def _finite(d, k0, w, kw, nb, qd, qdd, fin):
    """``fin`` at ``w``, samples from ``kw`` (as ``qd``, ``qdd``): whether every rate and
    acceleration of the sample is finite."""
    fin_d = fin[w, kw:kw + nb]
    fin_d[:] = True
    for i in range(len(qd)):
        qd_i, qdd_i = qd[i, w, kw:kw + nb], qdd[i, w, kw:kw + nb]
        for k in range(nb):
            fin_d[k] = fin_d[k] & math.isfinite(qd_i[k]) & math.isfinite(qdd_i[k])


@inner
def _coordinates(L, i, q_from, q_i, cq_i, sq_i, nb):
    """Joint i's coordinates over a block copied from ``q_from``, and the cosine and sine of
    ``s q_i`` for an angular joint (the ``turn`` of :func:`.recursion.child_pose`)."""
    sign = L.sign[i]
    for k in range(nb):
        q_i[k] = q_from[k]
    if L.angular[i]:   # decided once per joint, not per sample
        for k in range(nb):
            x = sign * q_i[k]
            cq_i[k], sq_i[k] = math.cos(x), math.sin(x)


@inner
def newton(L, d, k0, nb, q, cq, sq, phi, c, s, r, e, J, P, g, err, A, perm, col, dx,
           limit=1.0):
    """:func:`newton_at` with the arrays at design d, samples from ``k0`` (the outputs
    themselves)."""
    newton_at(L, d, k0, d, k0, nb, q, cq, sq, phi, c, s, r, e, J, P, g, err, A, perm, col, dx,
              limit)


@inner
def newton_at(L, d, k0, w, kw, nb, q, cq, sq, phi, c, s, r, e, J, P, g, err, A, perm, col, dx,
              limit=1.0):
    """Close the loops of the samples ``k0`` .. ``k0 + nb`` of design d by Newton's method on
    the dependent coordinates from the guess in ``q`` (n, D, T) at design ``w``, samples from
    ``kw`` (its independent rows already the state's, ``cq``, ``sq`` (n, block) the cosines and
    sines of ``s q`` of its angular joints), as :func:`.state.close`'s Newton stage: until no
    sample's step is above ``STEP_TOL`` (radians, or metres over the size), at most ``MAXITER``
    steps; a step of ``limit`` radians or times the size (default 1) is not taken (no
    correction of a nearby guess; :func:`.positions.newton`, the continuation's, has no
    limit: ``inf``). On
    return the poses (``phi`` ... ``e``, at ``w``, ``kw``), the cut frames ``P`` and the
    residual ``g`` (n_rows, block) are those of ``q``, the scaled residual in ``err`` (D, T) at
    d, ``k0``; ``J`` the Jacobian of the last step. ``A``, ``perm``, ``col``: the LU of
    ``J_dep`` (:func:`scratch`); ``dx`` (n_dep, block). After the first pose each contact's
    search starts from the sample's own contact at the pose before (:func:`_cut_frames`)."""
    dep, angular, size = L.dependent, L.angular, L.size[d]
    m, kws = len(dep), slice(kw, kw + nb)
    _place(L, d, w, kw, nb, q, cq, sq, phi, c, s, r, e)
    _cut_frames(L, d, w, kw, nb, c, s, r, P, False)
    _residual(L, d, k0, w, kw, nb, phi, P, err, g)
    for _ in range(MAXITER if m else 0):
        # J_dep dx = -g                                                          (F1-F2)
        _jacobian(L, d, w, kw, nb, r, e, P, J)
        _factor_dep(dep, J, w, kw, nb, A, perm, col)
        for a in range(m):
            for k in range(nb):
                g[a, k] = -g[a, k]
        substitute(A, perm, col, m, nb, g, dx, 0.0)
        more = False
        for k in range(nb):
            # the step, in rad or in m relative to the size (NaN: singular)
            step = 0.0
            for a in range(m):
                u = abs(dx[a, k]) * (1.0 if angular[dep[a]] else 1.0 / size)
                step = math.nan if u != u or step != step else max(step, u)
            more = more or step > STEP_TOL   # NaN (singular) stops too
            for a in range(m):
                if math.isfinite(dx[a, k]) and step < limit:
                    q[dep[a], w, kw + k] += dx[a, k]
        for a in range(m):
            i = dep[a]
            _coordinates(L, i, q[i, w, kws], q[i, w, kws], cq[i], sq[i], nb)
        _place(L, d, w, kw, nb, q, cq, sq, phi, c, s, r, e)
        _cut_frames(L, d, w, kw, nb, c, s, r, P, True)
        _residual(L, d, k0, w, kw, nb, phi, P, err, g)
        if not more:
            break


# --- the kernel ----------------------------------------------------------------------------------

@njit
def scratch(n, nc, nd, n_rows, block):
    """The kernel's scratch for one block of samples: the cosines and sines of the angular
    joints' coordinates, the two turns of a dyad, the right-hand sides, the cut frames, the LU
    factors of ``J_dep``, the solution, the pivots and the nearest nodes (:func:`block`)."""
    B = block
    return (np.ones((n, B)), np.zeros((n, B)), np.zeros((5, B)), np.zeros((5, B)),
            np.zeros((n_rows, B)), np.zeros((nc, 9, B)), np.zeros((nd, nd, B)),
            np.zeros((max(nd, 1), B)), np.zeros(B), np.zeros((nd, B), np.int64),
            np.zeros(B, np.int64))


@inner
def _driven_rhs(drv, nd, J, w, kws, qd_drv, d, ks, nb, rhs):
    """The right-hand side of the dependent rates, ``rhs[:nd, :nb] = -J_drv qd_drv`` (eqs. 4-5):
    ``J`` (n_rows, n - 1, ., .) at design ``w``, samples ``kws`` (a slice), the drivers' rates
    ``qd_drv`` (n_drivers, D, T) at design ``d``, samples ``ks`` (a slice of the same length)."""
    for row in range(nd):
        acc = rhs[row]   # the sum over the drivers, negated once summed
        acc[:nb] = 0.0
        for j in range(len(drv)):
            J_rj, qd_j = J[row, drv[j] - 1, w, kws], qd_drv[j, d, ks]
            for k in range(nb):
                acc[k] += J_rj[k] * qd_j[k]
        for k in range(nb):
            acc[k] = -acc[k]


#: The per-call inputs of :func:`kernel` and :func:`block` beside the layout's view: the times
#: ``t_s`` (T,); the continuation ``nodes`` (K,) s with their coordinates ``Qn`` (n, D, K) and
#: the cosines and sines ``cQ``, ``sQ`` of ``s Qn``, each design's times clamped to ``lo``,
#: ``hi`` (D,); the dyads' assembly ``modes`` (n_dyads, D); ``q_in`` (n, D, T) the coordinates
#: closing the loops where there are no nodes (K = 0), or, with ``newton`` (1,) = 1, the
#: guess from which the kernel's Newton's method closes them (:func:`newton_at`); the drivers'
#: coordinates, rates and accelerations ``q_drv``, ``qd_drv``, ``qdd_drv`` (n_drivers, D, T).
Inputs = namedtuple("Inputs", ("t_s", "nodes", "lo", "hi", "Qn", "cQ", "sQ", "modes", "q_in",
                               "newton", "q_drv", "qd_drv", "qdd_drv"), module=__name__)


@inner
def block(L, X, d, k0, nb, work, w, kw, err, pivot, fin, tmp):
    """Positions, rates and accelerations of the samples ``k0`` .. ``k0 + nb`` of design d
    (the layout's view ``L``, the inputs ``X``, as in :func:`kernel`): the per-sample arrays
    ``work`` = ``(q, phi, c, s, r, e, J, qd, qdd, tw, td)`` written at design ``w``, samples
    from ``kw`` (the outputs themselves, ``w, kw = d, k0``, or one block's scratch, ``0,
    0``); ``err``, ``pivot``, ``fin`` ((D, T), or (1, block)) at the same place; ``tmp`` the
    block's scratch (:func:`scratch`)."""
    q, phi, c, s, r, e, J, qd, qdd, tw, td = work
    cq, sq, up, low, rhs, P, A, sol, col, perm, node = tmp
    dep, drv, nodes = L.dependent, L.driven, X.nodes
    n, nd, nv = len(L.parent), len(dep), len(drv)
    ks, kws = slice(k0, k0 + nb), slice(kw, kw + nb)   # the samples, in the work arrays
    # coordinates: the nearest node's (or the closed ones) and the drivers'
    if nodes.shape[0] > 0:
        jb = 0   # the bracketing node of the previous sample
        for k in range(nb):
            node[k], jb = nearest(nodes, min(max(X.t_s[k0 + k], X.lo[d]), X.hi[d]), jb)
        for i in range(1, n):
            q_i, cq_i, sq_i = q[i, w, kws], cq[i], sq[i]
            Qn_i, cQ_i, sQ_i = X.Qn[i, d], X.cQ[i, d], X.sQ[i, d]
            for k in range(nb):
                jn = node[k]
                q_i[k], cq_i[k], sq_i[k] = Qn_i[jn], cQ_i[jn], sQ_i[jn]
    else:
        for i in range(1, n):
            _coordinates(L, i, X.q_in[i, d, ks], q[i, w, kws], cq[i], sq[i], nb)
    for j in range(nv):
        i = drv[j]
        _coordinates(L, i, X.q_drv[j, d, ks], q[i, w, kws], cq[i], sq[i], nb)
    if nodes.shape[0] == 0 and X.newton[0]:
        # positions, the loops closed by Newton's method from the guess: its last pose, cut
        # frames and residual are the sample's
        newton_at(L, d, k0, w, kw, nb, q, cq, sq, phi, c, s, r, e, J, P, rhs, err, A, perm,
                  col, sol)
    else:
        # positions, the loops closed in closed form from the nodes (or closed already)
        _place(L, d, w, kw, nb, q, cq, sq, phi, c, s, r, e)
        if nodes.shape[0] > 0:
            _close(L, X.modes, d, w, kw, nb, q, phi, c, s, r, e, up, low)
        _cut_frames(L, d, w, kw, nb, c, s, r, P, False)
        _residual(L, d, k0, w, kw, nb, phi, P, err, rhs)
    _jacobian(L, d, w, kw, nb, r, e, P, J)
    # rates: J_dep qd_dep = -J_drv qd_drv                       (eqs. 4-5)
    for m in range(nd):   # the first pass of the twist rates takes qdd_dep = 0
        qdd[dep[m], w, kws] = 0.0
    for j in range(nv):
        qd[drv[j], w, kws], qdd[drv[j], w, kws] = X.qd_drv[j, d, ks], X.qdd_drv[j, d, ks]
    _driven_rhs(drv, nd, J, w, kws, X.qd_drv, d, ks, nb, rhs)
    if nd:   # J_dep, factored once for the rates and the accelerations
        _factor_dep(dep, J, w, kw, nb, A, perm, col)
        _solve_dep(dep, A, perm, col, w, kw, nb, rhs, qd, sol)
    for k in range(nb):
        pivot[w, kw + k] = col[k] if nd else 1.0
    _twists(L, w, kw, nb, r, e, qd, tw)
    # accelerations: J_dep qdd_dep = -bias(qdd_dep = 0)          (eqs. 6-7)
    _twist_rates(L, w, kw, nb, r, e, tw, qd, qdd, td)
    if nd:
        _bias(L, d, w, kw, nb, r, tw, td, P, rhs)
        for row in range(nd):
            for k in range(nb):
                rhs[row, k] = -rhs[row, k]
        _solve_dep(dep, A, perm, col, w, kw, nb, rhs, qdd, sol)
        _twist_rates(L, w, kw, nb, r, e, tw, qd, qdd, td)
    _finite(d, k0, w, kw, nb, qd, qdd, fin)


@njit
def kernel(L, X, q, phi, c, s, r, e, J, qd, qdd, tw, td, cut, pivot, err, fin, block_size):
    """Positions, rates and accelerations at the times ``X.t_s`` (T,) of the layout whose view
    is ``L`` (:attr:`.Layout.view`), written into the outputs ``q`` ... ``err`` (see
    :func:`run`), which come zeroed: the rows that stay zero (the ground's, a revolute joint's
    slider axis) are never written.

    With continuation nodes (``X.nodes``, :data:`Inputs`), the loops are closed dyad by dyad
    from the node nearest to each time clamped to ``[lo, hi]``, in the assembly ``modes``;
    without (K = 0), ``X.q_in`` already closes them, or (``X.newton``) Newton's method closes
    them from it. Each block of samples is :func:`block`,
    written in place, then the cut joints' motion.
    """
    D, T = L.size.shape[0], X.t_s.shape[0]
    tmp = scratch(len(L.parent), len(L.cut_a), len(L.dependent), J.shape[0], block_size)
    work = (q, phi, c, s, r, e, J, qd, qdd, tw, td)
    for d in range(D):
        for k0 in range(0, T, block_size):
            nb = min(block_size, T - k0)
            block(L, X, d, k0, nb, work, d, k0, err, pivot, fin, tmp)
            _cut_motion(L, d, d, k0, nb, phi, r, tw, td, tmp[5], cut)


def inputs(lay: Layout, t: np.ndarray, q_drv, qd_drv, qdd_drv, *, q=None, nodes=None, Q=None,
           lo=None, hi=None, modes=(), newton=False) -> Inputs:
    """The per-call :data:`Inputs` of :func:`kernel` (and of :func:`block`) for the arguments
    of :func:`run`: each array C-contiguous and read-only (:func:`fixed`)."""
    topo, L = lay.topo, lay.view
    n = topo.n
    D, T = max(lay.designs, 1), len(t)
    t = np.ascontiguousarray(t, dtype=float)
    if nodes is None:
        nodes, Qn, lo, hi = np.zeros(0), np.zeros((n, D, 0)), np.zeros(D), np.zeros(D)
        q_in = np.ascontiguousarray(np.broadcast_to(q.reshape(n, -1, T), (n, D, T)))
    else:
        Qn = np.ascontiguousarray(np.broadcast_to(
            np.nan_to_num(Q).reshape(n, -1, len(nodes)), (n, D, len(nodes))))
        q_in = np.zeros((n, D, 0))
        lo, hi = (np.ascontiguousarray(np.broadcast_to(np.reshape(x, -1), (D,)), dtype=float)
                  for x in (lo, hi))
    # cos and sin of s q at the nodes, for the angular joints the nodes give (the kernel takes
    # the drivers' per sample; ``turn`` is unused for the other kinds)
    cQ, sQ = np.ones_like(Qn), np.zeros_like(Qn)
    rows = [i for i in range(1, n) if L.angular[i] and i not in topo.driven]
    if Qn.shape[-1] and rows:
        x = np.asarray(topo.sign, float)[rows, None, None] * Qn[rows]
        cQ[rows], sQ[rows] = np.cos(x), np.sin(x)
    md = np.zeros((len(modes), D))
    for k, m in enumerate(modes):
        md[k] = np.reshape(m, -1)
    nv = len(L.driven)
    drivers = [np.ascontiguousarray(np.broadcast_to(
        np.reshape(x, (nv, -1, T)), (nv, D, T)), dtype=float)
        for x in (q_drv, qd_drv, qdd_drv)]
    return Inputs(*fixed((t, np.asarray(nodes, float), lo, hi, Qn, cQ, sQ, md, q_in,
                          np.array([1 if newton else 0], np.int64), *drivers)))


def run(lay: Layout, t: np.ndarray, q_drv, qd_drv, qdd_drv, *, q=None, nodes=None, Q=None,
        lo=None, hi=None, modes=(), newton=False) -> dict:
    """Run :func:`kernel` on the layout ``lay`` at the times ``t`` (T,) with the driver values
    (n_drivers, T), or (n_drivers, D, T) per design.

    Either ``q`` (n, ...) closes the loops at every sample (batch shape (T,) or (D, T)), or,
    with ``newton``, is the guess from which Newton's method closes them in the kernel's
    blocks (:func:`newton_at`; ``err`` above :data:`.positions.ACCEPT` where it does not), or
    the loops are closed from the continuation ``nodes`` (K,) with coordinates ``Q``
    (n, ..., K), each design's times clamped to ``[lo, hi]`` (D,), in the dyads' assembly
    ``modes`` (each (1,) or (D, 1)).

    Returns the outputs, batch flattened to (D, T): ``q``, ``phi``, ``c``, ``s``, ``qd``,
    ``qdd`` (n, D, T); ``r``, ``e`` (n, 2, D, T; ``e`` is zero for revolute joints); ``tw``,
    ``twd`` (n, 3, D, T); ``J`` (n_rows, n - 1, D, T); ``cut`` (n_cut, 3, D, T) the cut
    joints' coordinate, rate and acceleration; ``pivot``, ``err`` (D, T); ``finite`` (D, T)
    bool, whether every rate and acceleration of the sample is finite.
    """
    topo = lay.topo
    n, nc = topo.n, topo.n_loops
    D, T = max(lay.designs, 1), len(t)
    args = inputs(lay, t, q_drv, qd_drv, qdd_drv, q=q, nodes=nodes, Q=Q, lo=lo, hi=hi,
                  modes=modes, newton=newton)
    out = {"q": (n,), "phi": (n,), "c": (n,), "s": (n,), "r": (n, 2), "e": (n, 2),
           "J": (topo.n_rows, n - 1), "qd": (n,), "qdd": (n,), "tw": (n, 3),
           "twd": (n, 3), "cut": (nc, 3), "pivot": (), "err": ()}
    # zeroed (lazily, by the system) so the rows that stay zero are never written: the
    # ground's, and the slider axis e of a revolute joint
    out = {k: np.zeros(shape + (D, T)) for k, shape in out.items()}
    out["finite"] = np.zeros((D, T), np.bool_)
    kernel(lay.view, args, *out.values(), min(BLOCK, T))
    return out
