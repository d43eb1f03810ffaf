"""Compiled DeNOC inverse dynamics and joint reactions: one pass over the samples.

The same equations as :mod:`linkdyn.dynamics.denoc` and :mod:`linkdyn.reactions`, in the same
order, fused by a numba kernel (:mod:`linkdyn.compiled`): for every sample the Newton–Euler
wrenches ``w_star``, the backward recursion ``w_tilde``, the generalized forces ``Q``, the
multipliers from ``J_dep^T lam = Q_dep`` by Gaussian elimination with partial pivoting (the
pivot rule of :func:`linkdyn.planar.solve_small`), ``tau`` and the reactions at every joint.

The kernel takes the samples a block at a time (:data:`BLOCK`): every step walks the bodies and,
for each body, the samples of the block. A sample sees exactly the scalar operations of the
one-sample recursion, but the independent samples keep the processor busy and every array is
read and written in contiguous runs (one sample at a time through all bodies, the component-
first arrays were ~2.5x slower). Each step takes a body's rows over the block as 1-D views
(:func:`~linkdyn.compiled.vector_views`, :func:`~linkdyn.compiled.screw_views`) before its
sample loop: numba then indexes them without the multi-dimensional address and wrap-around
arithmetic of every access. The numpy solvers stay the reference; the tests hold the two to
agree to rounding, NaN at the same samples.
"""

from __future__ import annotations

from functools import partial

import numpy as np

from .. import reactions
from ..compiled import PRI, REV, Packed, eliminate, njit, screw_views, vector_views
from ..kinematics import KinematicSolution
from ..loads import Loads
from ..planar import last
from ..reactions import Reactions
from . import denoc
from .denoc import DynamicSolution

#: a relative pivot at or below this marks ``J_dep^T`` singular (as in ``solve_small``)
SINGULAR_PIVOT = 1e-13
#: samples per block of the kernel: each step runs over a block, whose samples are independent
BLOCK = 1024


@njit
def _composite(parent, r, d, k0, nb, di, ki, w):
    """The backward recursion ``w_p += A(r_i - r_p)^T w_i``, leaves first, in place on the
    wrenches ``w`` (n, 3, ., .) of a block (denoc.composite), taken at design ``di`` from
    sample ``ki``: the moment gains ``a_x f_y - a_y f_x``."""
    ks, kw = slice(k0, k0 + nb), slice(ki, ki + nb)   # the block's samples, in r and in w
    for i in range(len(parent) - 1, 0, -1):
        p = parent[i]
        r_i, r_p = vector_views(r, i, d, ks), vector_views(r, p, d, ks)
        w_i, w_p = screw_views(w, i, di, kw), screw_views(w, p, di, kw)
        for k in range(nb):
            ax = r_i[0][k] - r_p[0][k]
            ay = r_i[1][k] - r_p[1][k]
            n0, f0, f1 = w_i[0][k], w_i[1][k], w_i[2][k]
            w_p[0][k] = w_p[0][k] + ((ax * f1 - ay * f0) + n0)
            w_p[1][k] = w_p[1][k] + f0
            w_p[2][k] = w_p[2][k] + f1


@njit
def _newton_euler(com, mass, inertia, d, dp, k0, nb, di, ki, c, s, tw, twd, w_ext, w_const, ke,
                  o_wstar, o_wtilde, o_ke):
    """Uncoupled Newton–Euler wrenches ``w_star`` of a block (denoc.newton_euler), copied into
    ``w_tilde`` to start its recursion, and the kinetic energy. The ground's rows stay as
    allocated (zero). ``w_const`` (n, 3, 1, block): ``w_ext`` repeated over a block when it is
    constant in time (one sample, ``w_ext`` (n, 3, D, 1))."""
    n = len(mass[dp])
    ks = slice(k0, k0 + nb)   # the block's samples
    ke[:nb] = 0.0
    # Newton–Euler about O_i, d = R(phi) com:  n = I_O al + m d x a,
    # f = m (a + al perp(d) - w^2 d), minus w_ext;  KE = 1/2 m |v + w perp(d)|^2 + 1/2 I w^2
    for i in range(1, n):
        mi, ii = mass[dp, i], inertia[dp, i]
        cx, cy = com[dp, i, 0], com[dp, i, 1]
        c_i, s_i = c[i, d, ks], s[i, d, ks]
        tw_i, twd_i = screw_views(tw, i, d, ks), screw_views(twd, i, d, ks)
        if w_ext.shape[3] == 1:   # constant in time
            w_ext_i = screw_views(w_const, i, 0, slice(0, nb))
        else:
            w_ext_i = screw_views(w_ext, i, d, ks)
        kw = slice(ki, ki + nb)   # the block's samples in the internals (see _kernel)
        wstar_i, wtilde_i = screw_views(o_wstar, i, di, kw), screw_views(o_wtilde, i, di, kw)
        for k in range(nb):
            ci, si = c_i[k], s_i[k]
            dx = ci * cx - si * cy
            dy = si * cx + ci * cy
            w, vx, vy = tw_i[0][k], tw_i[1][k], tw_i[2][k]
            al, ax, ay = twd_i[0][k], twd_i[1][k], twd_i[2][k]
            i_o = ii + mi * (dx * dx + dy * dy)
            w2 = w * w
            n0 = (i_o * al + mi * (dx * ay - dy * ax)) - w_ext_i[0][k]
            f0 = mi * (ax + al * (-dy) - w2 * dx) - w_ext_i[1][k]
            f1 = mi * (ay + al * dx - w2 * dy) - w_ext_i[2][k]
            wstar_i[0][k], wstar_i[1][k], wstar_i[2][k] = n0, f0, f1
            wtilde_i[0][k], wtilde_i[1][k], wtilde_i[2][k] = n0, f0, f1
            vcx = vx + w * (-dy)
            vcy = vy + w * dx
            ke[k] += 0.5 * mi * (vcx * vcx + vcy * vcy) + 0.5 * ii * w2
    o_ke[d, ks] = ke[:nb]


@njit
def _generalized(kind, sign, d, k0, nb, di, ki, e, o_wtilde, o_Q):
    """``Q_i = p_i . w_tilde_i`` (denoc.solve) into ``o_Q`` (the ground's row stays as
    allocated, zero). The zero entries of ``p_i`` are multiplied too, so a NaN spreads as in
    numpy's dot product."""
    ks = slice(k0, k0 + nb)   # the block's samples
    # Q_i = p_i . w_tilde_i: revolute p = [s, 0, 0], prismatic p = [0, s e]
    for i in range(1, len(kind)):
        si = sign[i]
        wtilde_i = screw_views(o_wtilde, i, di, slice(ki, ki + nb))
        e_i = vector_views(e, i, d, ks)
        o_Q_i = o_Q[i, di, ki:ki + nb]
        if kind[i] == REV:
            for k in range(nb):
                o_Q_i[k] = si * wtilde_i[0][k] + 0.0 * wtilde_i[1][k] + 0.0 * wtilde_i[2][k]
        else:
            for k in range(nb):
                o_Q_i[k] = (0.0 * wtilde_i[0][k] + (si * e_i[0][k]) * wtilde_i[1][k]
                            + (si * e_i[1][k]) * wtilde_i[2][k])


@njit
def _multipliers(dep, drv, d, k0, nb, J, Q, A, lam, tau, piv, o_lam, o_tau, o_pivot):
    """``J_dep^T lam = Q_dep``, then ``tau = Q_drv - J_drv^T lam`` (eq. 27), a block at a time;
    ``Q`` (n, block) the block's generalized forces (a view of ``o_Q``)."""
    m, n_rows, n_drv = dep.shape[0], J.shape[0], drv.shape[0]
    ks = slice(k0, k0 + nb)   # the block's samples
    # J_dep^T lam = Q_dep by Gaussian elimination with partial pivoting; NaN where the
    # smallest pivot / largest |entry| (a NaN entry: NaN) is not above SINGULAR_PIVOT
    if m > 0:
        for a in range(m):
            col = dep[a] - 1
            for b in range(m):
                A[a, b, :nb] = J[b, col, d, ks]
            A[a, m, :nb] = Q[dep[a], :nb]
        eliminate(A, m, nb, lam, piv, SINGULAR_PIVOT)
        o_pivot[d, ks] = piv[:nb]
        for a in range(m):
            o_lam[a, d, ks] = lam[a, :nb]
    else:
        o_pivot[d, ks] = 1.0
    # tau = Q_drv - J_drv^T lam
    for jd in range(n_drv):
        i = drv[jd]
        J_i, Q_i = J[:, i - 1, d, ks], Q[i, :nb]
        tau_j, o_tau_j = tau[jd, :nb], o_tau[jd, d, ks]
        for k in range(nb):
            acc = 0.0
            for a in range(n_rows):
                acc += J_i[a, k] * lam[a, k]
            tau_j[k] = Q_i[k] - acc
            o_tau_j[k] = tau_j[k]


@njit
def _cut_wrenches(cut_a, cut_b, cut_kind, cut_joint, cut_pb, cut_axis, d, dp, k0, nb, c, s, r,
                  lam, wc, o_on):
    """Cut-joint wrenches ``S^T lam`` on both bodies about their O (reactions.cut_wrenches) into
    ``wc`` (n, 3, block), and the cut joints' reactions (a revolute cut's moment, zero, stays as
    allocated)."""
    n_cut = cut_a.shape[0]
    ks = slice(k0, k0 + nb)   # the block's samples
    wc[:, :, :nb] = 0.0
    # cut wrenches S^T lam at the cut point: + on body b, - on body a, about O_b, O_a;
    # revolute [0, lam], prismatic [lam_0, lam_1 perp(e_a)]
    for cc in range(n_cut):
        a, b, jc = cut_a[cc], cut_b[cc], cut_joint[cc]
        px, py = cut_pb[dp, cc, 0], cut_pb[dp, cc, 1]
        ux, uy = cut_axis[dp, cc, 0], cut_axis[dp, cc, 1]
        prismatic = cut_kind[cc] == PRI
        c_a, s_a, r_a = c[a, d, ks], s[a, d, ks], vector_views(r, a, d, ks)
        c_b, s_b, r_b = c[b, d, ks], s[b, d, ks], vector_views(r, b, d, ks)
        wc_a = wc[a, 0, :nb], wc[a, 1, :nb], wc[a, 2, :nb]
        wc_b = wc[b, 0, :nb], wc[b, 1, :nb], wc[b, 2, :nb]
        lam_c = lam[2 * cc, :nb], lam[2 * cc + 1, :nb]
        on_c = screw_views(o_on, jc, d, ks)
        for k in range(nb):
            cb, sb = c_b[k], s_b[k]
            rpx = r_b[0][k] + (cb * px - sb * py)
            rpy = r_b[1][k] + (sb * px + cb * py)
            l0, l1 = lam_c[0][k], lam_c[1][k]
            if prismatic:
                ca, sa = c_a[k], s_a[k]
                ex = ca * ux - sa * uy
                ey = sa * ux + ca * uy
                o0, o1, o2 = l0, l1 * (-ey), l1 * ex
                on_c[0][k] = o0
            else:
                o0, o1, o2 = 0.0, l0, l1
            ax = rpx - r_b[0][k]
            ay = rpy - r_b[1][k]
            wc_b[0][k] = wc_b[0][k] + ((ax * o2 - ay * o1) + o0)
            wc_b[1][k] = wc_b[1][k] + o1
            wc_b[2][k] = wc_b[2][k] + o2
            ax = rpx - r_a[0][k]
            ay = rpy - r_a[1][k]
            wc_a[0][k] = wc_a[0][k] - ((ax * o2 - ay * o1) + o0)
            wc_a[1][k] = wc_a[1][k] - o1
            wc_a[2][k] = wc_a[2][k] - o2
            on_c[1][k], on_c[2][k] = o1, o2


@njit
def _tree_reactions(parent, kind, sign, driver_of, tree_joint, joint_point, d, dp, k0, nb, di,
                    ki, keep, c, s, r, e, tau, wc, o_wstar, o_tree, o_on):
    """``R_i`` by the backward recursion of ``w_star - w_cut`` and the reaction of every tree
    joint from it (reactions.solve). With the internals ``keep``, a joint whose reaction is
    ``R_i`` itself (the child is its second body, not driven) is not written: :func:`solve`
    gives it ``R_i``'s rows."""
    n = parent.shape[0]
    ks, kw = slice(k0, k0 + nb), slice(ki, ki + nb)   # the block's samples, in the internals
    # R_p += A(r_i - r_p)^T R_i, from R_i = w_star_i - w_cut_i; the ground's w_star_0 = 0
    R_0, wc_0 = screw_views(o_tree, 0, di, kw), (wc[0, 0, :nb], wc[0, 1, :nb], wc[0, 2, :nb])
    for k in range(nb):
        R_0[0][k] = 0.0 - wc_0[0][k]
        R_0[1][k] = 0.0 - wc_0[1][k]
        R_0[2][k] = 0.0 - wc_0[2][k]
    for i in range(1, n):
        R_i, wstar_i = screw_views(o_tree, i, di, kw), screw_views(o_wstar, i, di, kw)
        wc_i = wc[i, 0, :nb], wc[i, 1, :nb], wc[i, 2, :nb]
        for k in range(nb):
            R_i[0][k] = wstar_i[0][k] - wc_i[0][k]
            R_i[1][k] = wstar_i[1][k] - wc_i[1][k]
            R_i[2][k] = wstar_i[2][k] - wc_i[2][k]
    _composite(parent, r, d, k0, nb, di, ki, o_tree)
    # tree joints: R_i - tau p_i on the child; sign > 0 as is, sign < 0 the opposite
    # about the parent's joint point: A(r_i - r_Pb)^T (-w)
    for i in range(1, n):
        si, dr, jt, p = sign[i], driver_of[i], tree_joint[i], parent[i]
        if keep and si > 0 and dr < 0:   # R_i as is
            continue
        revolute = kind[i] == REV
        px, py = joint_point[dp, i, 0], joint_point[dp, i, 1]
        R_i, on_i = screw_views(o_tree, i, di, kw), screw_views(o_on, jt, d, ks)
        e_i, r_i = vector_views(e, i, d, ks), vector_views(r, i, d, ks)
        r_p = vector_views(r, p, d, ks)
        c_p, s_p = c[p, d, ks], s[p, d, ks]
        for k in range(nb):
            o0, o1, o2 = R_i[0][k], R_i[1][k], R_i[2][k]
            if dr >= 0:   # body i's driver
                tq = tau[dr, k]
                if revolute:
                    o0, o1, o2 = o0 - tq * si, o1 - tq * 0.0, o2 - tq * 0.0
                else:
                    o0 = o0 - tq * 0.0
                    o1 = o1 - tq * (si * e_i[0][k])
                    o2 = o2 - tq * (si * e_i[1][k])
            if si > 0:
                on_i[0][k], on_i[1][k], on_i[2][k] = o0, o1, o2
            else:
                cp, sp = c_p[k], s_p[k]
                ax = r_i[0][k] - (r_p[0][k] + (cp * px - sp * py))
                ay = r_i[1][k] - (r_p[1][k] + (sp * px + cp * py))
                on_i[0][k] = (ax * (-o2) - ay * (-o1)) + (-o0)
                on_i[1][k] = -o1
                on_i[2][k] = -o2


@njit
def _kernel(parent, kind, sign, dep, drv, driver_of, tree_joint, cut_a, cut_b, cut_kind,
            cut_joint, joint_point, com, mass, inertia, cut_pb, cut_axis,
            c, s, r, e, tw, twd, J, w_ext,
            o_wstar, o_wtilde, o_Q, o_lam, o_tau, o_ke, o_pivot, o_on, o_tree, block, keep):
    """Dynamics and reactions of every sample; arguments as in :func:`solve`, outputs written in
    place (component-first, batch ``(D, T)`` last) into zeroed arrays: the rows that are zero by
    construction (the ground's ``w_star`` and ``Q``, a revolute cut's moment) are not written,
    nor those of a joint whose reaction is ``R_i`` itself (:func:`_tree_reactions`).

    The internals ``o_wstar``, ``o_wtilde``, ``o_Q``, ``o_tree`` are outputs like the others
    when ``keep``; else one block's scratch, (n, 3, 1, block) and (n, 1, block).

    The samples are taken ``block`` at a time: each step below runs over the bodies, and for
    each body over the samples of the block, which are independent (every sample sees exactly
    the operations of the one-sample recursion, in the same order).
    """
    n = parent.shape[0]
    m = dep.shape[0]           # = 2 n_cut rows of J_dep^T lam = Q_dep
    n_drv = drv.shape[0]
    D, T = c.shape[1], c.shape[2]
    n_designs = mass.shape[0]
    B = block
    # scratch for one block of samples, allocated once per call
    # (w_star, w_tilde and R are built in place in their outputs)
    w_const = np.zeros((n, 3, 1, B))   # w_ext constant in time, repeated over a block
    wc = np.zeros((n, 3, B))      # cut-joint wrenches on the bodies
    A = np.zeros((m, m + 1, B))   # [J_dep^T | Q_dep]
    lam = np.zeros((max(m, 1), B))
    tau = np.zeros((max(n_drv, 1), B))
    ke = np.zeros(B)
    piv = np.zeros(B)
    for d in range(D):
        dp = d if n_designs > 1 else 0
        if w_ext.shape[3] == 1:   # w_ext constant in time: design d's, repeated over a block
            for i in range(n):
                for j in range(3):
                    w_const[i, j, 0, :] = w_ext[i, j, d, 0]
        for k0 in range(0, T, B):
            nb = min(B, T - k0)
            # the internals' design and first sample: the block's, or the scratch's
            di, ki = (d, k0) if keep else (0, 0)
            if not keep:   # the ground's w_tilde only accumulates
                o_wtilde[0, :, 0, :nb] = 0.0
            _newton_euler(com, mass, inertia, d, dp, k0, nb, di, ki, c, s, tw, twd, w_ext, w_const,
                          ke, o_wstar, o_wtilde, o_ke)
            # w_tilde_p += A(r_i - r_p)^T w_tilde_i, leaves first
            _composite(parent, r, d, k0, nb, di, ki, o_wtilde)
            _generalized(kind, sign, d, k0, nb, di, ki, e, o_wtilde, o_Q)
            _multipliers(dep, drv, d, k0, nb, J, o_Q[:, di, ki:ki + nb], A, lam, tau, piv, o_lam,
                         o_tau, o_pivot)
            _cut_wrenches(cut_a, cut_b, cut_kind, cut_joint, cut_pb, cut_axis, d, dp, k0, nb, c, s,
                          r, lam, wc, o_on)
            _tree_reactions(parent, kind, sign, driver_of, tree_joint, joint_point, d, dp, k0, nb,
                            di, ki, keep, c, s, r, e, tau, wc, o_wstar, o_tree, o_on)


def _plain(x) -> np.ndarray:
    """``x`` as a C-contiguous, writable float array (copied only if it is not): one array type
    for every input, so the kernel compiles once."""
    return np.require(x, float, ["C", "W"])


def _flat(x, shape, lead=()) -> np.ndarray:
    """``x`` broadcast to ``lead + shape``, batch flattened to (D, T), as :func:`_plain`."""
    x = np.asarray(x, float)
    full = tuple(lead) + tuple(shape)
    if x.shape != full:
        x = np.broadcast_to(x, full)
    d = shape[0] if len(shape) == 2 else 1
    return _plain(x.reshape(tuple(lead) + (d, shape[-1])))


def _inputs(kin: KinematicSolution) -> dict:
    """The kernel's per-sample inputs ``c``, ``s`` (n, D, T), ``r``, ``e`` (n, 2, D, T), ``tw``,
    ``twd`` (n, 3, D, T), ``J`` (2 n_cut, n - 1, D, T): the compiled kinematics' arrays as they
    are, else stacked from the per-body lists of the numpy kinematics."""
    if kin.arrays is not None:
        keys = ("c", "s", "r", "e", "tw", "twd", "J")
        return {k: _plain(kin.arrays[k]) for k in keys}
    shape, pose = kin.shape, kin.pose
    n = kin.layout.topo.n
    zero = np.zeros((2,) + shape)
    return {
        "c": _flat(np.stack([np.broadcast_to(x, shape) for x in pose.c]), shape, (n,)),
        "s": _flat(np.stack([np.broadcast_to(x, shape) for x in pose.s]), shape, (n,)),
        "r": _flat(np.stack([np.broadcast_to(x, (2,) + shape) for x in pose.r]), shape, (n, 2)),
        "e": _flat(np.stack([zero if x is None else np.broadcast_to(x, (2,) + shape)
                             for x in pose.e]), shape, (n, 2)),
        "tw": _flat(np.stack([np.broadcast_to(x, (3,) + shape) for x in kin.twists]), shape,
                    (n, 3)),
        "twd": _flat(np.stack([np.broadcast_to(x, (3,) + shape) for x in kin.rates]), shape,
                     (n, 3)),
        "J": _flat(kin.jacobian, shape, kin.jacobian.shape[:2]),
    }


def solve(kin: KinematicSolution, loads: Loads, packed: Packed, internals: bool = False
          ) -> tuple[DynamicSolution, Reactions]:
    """Driver efforts, cut-joint multipliers and joint reactions by the compiled kernel.

    The same results as ``denoc.solve(kin, loads)`` followed by
    ``reactions.solve(model, kin, dyn)``, in the same shapes.

    Parameters
    ----------
    kin : KinematicSolution
        Batch shape ``kin.shape``: (T,) or (D, T). Its ``arrays`` are used when set (compiled
        kinematics), else its per-body lists (numpy kinematics).
    loads : Loads
        Applied wrenches ``loads.wrenches``, (3, ...) per body about O_i, N m / N. When none
        varies in time (each broadcast along the samples, as for a body without loads), the
        kernel reads one sample of them.
    packed : Packed
        ``linkdyn.compiled.pack(kin.layout, len(model.joints))``.
    internals : bool
        Keep the kernel's ``wstar``, ``wtilde``, ``Q`` and tree wrenches ``R_i`` per sample.
        By default the kernel holds them for one block only (Hoeken's dynamics then writes 16
        numbers per sample instead of 46), and the solutions compute them with the numpy
        recursion when they are first read.

    Returns
    -------
    dyn : DynamicSolution
        ``wstar``, ``wtilde`` (3, ...) per body; ``Q`` (..., n), ``lam`` (..., 2 n_cut),
        ``tau`` (..., n_drivers) components last; ``kinetic_energy`` (...) J; ``pivot`` (...).
    reactions : Reactions
        ``on_second`` (3, ...) per model joint ``[M, Fx, Fy]`` by the first body on the second
        about the second's joint point, N m / N; ``tree`` (3, ...) per body, ``R_i`` about O_i.
    """
    shape = kin.shape
    D, T = (shape[0] if len(shape) == 2 else 1), shape[-1]
    x = _inputs(kin)
    n, n_cut = len(packed.parent), len(packed.cut_a)
    n_joints = packed.n_joints
    # w_ext (n, 3, D, Tw): one sample (Tw = 1) when no wrench varies in time (all broadcast
    # along t, stride 0, as a body without loads), else every sample (Tw = T)
    ws = [np.broadcast_to(w, (3,) + shape) for w in loads.wrenches]
    Tw = 1 if all(w.strides[-1] == 0 for w in ws) else T
    w_ext = _plain(np.stack([w[..., :Tw].reshape(3, D, Tw) for w in ws]))
    # zeroed outputs: the pages of the rows the kernel leaves zero are never touched; the
    # internals per sample, or for one block
    block = min(BLOCK, T)
    at = (D, T) if internals else (1, block)
    out = {"wstar": np.zeros((n, 3) + at), "wtilde": np.zeros((n, 3) + at),
           "Q": np.zeros((n,) + at), "lam": np.zeros((2 * n_cut, D, T)),
           "tau": np.zeros((len(packed.drv), D, T)), "ke": np.zeros((D, T)),
           "pivot": np.zeros((D, T)), "on": np.zeros((n_joints, 3, D, T)),
           "tree": np.zeros((n, 3) + at)}
    P = packed
    _kernel(P.parent, P.kind, P.sign, P.dep, P.drv, P.driver_of, P.tree_joint, P.cut_a, P.cut_b,
            P.cut_kind, P.cut_joint, P.joint_point, P.com, P.mass, P.inertia, P.cut_pb,
            P.cut_axis, x["c"], x["s"], x["r"], x["e"], x["tw"], x["twd"], x["J"], w_ext,
            out["wstar"], out["wtilde"], out["Q"], out["lam"], out["tau"], out["ke"],
            out["pivot"], out["on"], out["tree"], block, internals)

    def per(a):  # per-entity views (3, ...) of a (k, 3, D, T) output
        return [w.reshape((3,) + shape) for w in a]

    def comps(a):  # (k, D, T) -> components last (..., k), like the numpy path's last(...)
        return last(a.reshape((len(a),) + shape))

    lam, tau = comps(out["lam"]), comps(out["tau"])
    ke, pivot = out["ke"].reshape(shape), out["pivot"].reshape(shape)
    if not internals:   # (partial, not lambda: the solutions stay picklable)
        dyn = DynamicSolution(lam, tau, ke, pivot, partial(denoc.internals, kin, loads))
        return dyn, Reactions(per(out["on"]), partial(reactions.tree_wrenches, kin, dyn))
    dyn = DynamicSolution(lam, tau, ke, pivot,
                          (per(out["wstar"]), per(out["wtilde"]), comps(out["Q"])))
    # a tree joint whose child is its second body and is not driven reports R_i itself (the
    # same array, as in reactions.solve): the kernel left its rows of ``on`` unwritten
    on, tree = per(out["on"]), per(out["tree"])
    for i in range(1, n):
        if P.sign[i] > 0 and P.driver_of[i] < 0:
            on[P.tree_joint[i]] = tree[i]
    return dyn, Reactions(on, tree)
