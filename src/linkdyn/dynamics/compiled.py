"""Compiled DeNOC inverse dynamics and joint reactions: two kernels, two stages.

The steps of :mod:`linkdyn.dynamics.denoc` and :mod:`linkdyn.reactions` (Newton–Euler
:func:`~linkdyn.dynamics.denoc.newton_euler_wrench`, the backward recursion
:func:`~linkdyn.dynamics.denoc.plus_child`, ``Q_i`` by
:func:`~linkdyn.dynamics.denoc.generalized_force`, the efforts by
:func:`~linkdyn.dynamics.denoc.less_cut`; then the reactions:
:func:`~linkdyn.reactions.cut_wrench`, :func:`~linkdyn.reactions.without_effort`,
:func:`~linkdyn.reactions.flipped`), called inside the sample loops of numba kernels
(:mod:`linkdyn.compiled`); this file holds only the data movement, the loops and the linear
algebra of the multipliers (``J_dep^T lam = Q_dep`` by :func:`~linkdyn.compiled.eliminate`, the
pivot rule of :func:`linkdyn.planar.solve_small`). Joint kinds enter by their codes
(:data:`linkdyn.joints.CODES`) through the dispatching steps of :mod:`linkdyn.joints`.

The stages are those of the numpy path: :func:`solve`, the dynamics (``w_star``, ``w_tilde``,
``Q``, ``lam``, ``tau``, the kinetic energy), as ``denoc.solve``; then :func:`reactions` (the
cut wrenches, ``R_i`` by the same backward recursion, every joint's reaction), as
``reactions.solve``, run only when the reactions are wanted. Each kernel takes the samples a
block at a time (:data:`BLOCK`): each stage walks the bodies and, for each body, the samples of
the block, which are independent, so the loops vectorize and every array is read and written in
contiguous runs. A stage takes a body's rows over the block as 1-D views
(:func:`~linkdyn.compiled.vector_views`, :func:`~linkdyn.compiled.screw_views`) before its
sample loop, gathers each sample's components into the steps' tuples and writes their tuples
back. The reactions kernel forms each block's ``w_star`` again by the same step (cheaper than
writing and reading it per sample). The tests hold the two backends to agree to rounding, NaN
at the same samples.
"""
from __future__ import annotations

import math
from collections import namedtuple
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .. import joints as jk
from ..compiled import eliminate, inline, inner, njit, screw_views, vector_views
from ..kinematics import KinematicSolution
from ..kinematics import compiled as kc
from ..compiled.loads import weights
from ..design.reduce import larger_magnitude, plus_square
from ..loads import Loads
from ..planar import last, turned
from ..kinematics.compiled import cut_numbers
from ..kinematics.positions import singular
from ..kinematics.recursion import cut_frame
from ..reactions import Reactions, cut_wrench, flipped, minus, plus, without_effort
from .denoc import (DynamicSolution, generalized_force, less_cut, newton_euler_wrench,
                    plus_child)

#: a relative pivot at or below this marks ``J_dep^T`` singular (as in ``solve_small``)
SINGULAR_PIVOT = 1e-13
#: samples per block of the kernel: each step runs over a block, whose samples are independent
BLOCK = 1024


# --- the dynamics stage -----------------------------------------------------------------------

@inner
def _composite(L, r, d, k0, nb, di, ki, w):
    """The backward recursion :func:`~linkdyn.dynamics.denoc.plus_child` (``w_p += A(r_i -
    r_p)^T w_i``), leaves first, in place on the wrenches ``w`` (n, 3, ., .) of a block, taken at
    design ``di`` from sample ``ki`` (denoc.composite)."""
    ks, kw = slice(k0, k0 + nb), slice(ki, ki + nb)   # the block's samples, in r and in w
    for i in range(len(L.parent) - 1, 0, -1):
        p = L.parent[i]
        r_i, r_p = vector_views(r, i, d, ks), vector_views(r, p, d, ks)
        w_i, w_p = screw_views(w, i, di, kw), screw_views(w, p, di, kw)
        for k in range(nb):
            w_p[0][k], w_p[1][k], w_p[2][k] = plus_child(
                (w_p[0][k], w_p[1][k], w_p[2][k]), (w_i[0][k], w_i[1][k], w_i[2][k]),
                (r_i[0][k], r_i[1][k]), (r_p[0][k], r_p[1][k]))


@inner
def _newton_euler(L, d, dp, k0, nb, di, ki, c, s, tw, twd, w_ext, w_const, ke, o_wstar,
                  o_wtilde):
    """:func:`~linkdyn.dynamics.denoc.newton_euler_wrench` of every body over a block into
    ``w_star``, copied into ``w_tilde`` to start its recursion, and the kinetic energy summed
    over the bodies into ``ke`` (block,). The ground's rows stay as allocated (zero). ``w_const`` (n, 3, 1, block):
    ``w_ext`` repeated over a block when it is constant in time (one sample, ``w_ext``
    (n, 3, D, 1))."""
    n = L.mass.shape[0]
    ks = slice(k0, k0 + nb)   # the block's samples
    kw = slice(ki, ki + nb)   # the block's samples in the internals (see _dynamics)
    ke[:nb] = 0.0
    for i in range(1, n):
        mi, ii = L.mass[i, dp], L.inertia[i, dp]
        com_i = (L.com[i, 0, dp], L.com[i, 1, dp])
        c_i, s_i = c[i, d, ks], s[i, d, ks]
        tw_i, twd_i = screw_views(tw, i, d, ks), screw_views(twd, i, d, ks)
        if w_ext.shape[3] == 1:   # constant in time
            w_ext_i = screw_views(w_const, i, 0, slice(0, nb))
        else:
            w_ext_i = screw_views(w_ext, i, d, ks)
        wstar_i, wtilde_i = screw_views(o_wstar, i, di, kw), screw_views(o_wtilde, i, di, kw)
        for k in range(nb):
            w, ke_k = newton_euler_wrench(
                mi, ii, com_i, c_i[k], s_i[k], (tw_i[0][k], tw_i[1][k], tw_i[2][k]),
                (twd_i[0][k], twd_i[1][k], twd_i[2][k]),
                (w_ext_i[0][k], w_ext_i[1][k], w_ext_i[2][k]))
            wstar_i[0][k], wstar_i[1][k], wstar_i[2][k] = w
            wtilde_i[0][k], wtilde_i[1][k], wtilde_i[2][k] = w
            ke[k] += ke_k


@inner
def _generalized(L, d, k0, nb, di, ki, e, o_wtilde, o_Q):
    """:func:`~linkdyn.dynamics.denoc.generalized_force` ``Q_i = p_i . w_tilde_i`` into ``o_Q``
    (the ground's row stays as allocated, zero)."""
    ks = slice(k0, k0 + nb)   # the block's samples
    for i in range(1, len(L.kind)):
        code, si = L.kind[i], L.sign[i]
        wtilde_i = screw_views(o_wtilde, i, di, slice(ki, ki + nb))
        e_i = vector_views(e, i, d, ks)
        o_Q_i = o_Q[i, di, ki:ki + nb]
        for k in range(nb):
            o_Q_i[k] = generalized_force(code, si, (e_i[0][k], e_i[1][k]),
                                         (wtilde_i[0][k], wtilde_i[1][k], wtilde_i[2][k]))


@inner
def _multipliers(L, d, k0, nb, J, Q, A, lam, piv, o_lam, o_tau, o_pivot):
    """``J_dep^T lam = Q_dep``, then ``tau = Q_drv - J_drv^T lam`` (eq. 27) cut by cut
    (:func:`~linkdyn.dynamics.denoc.less_cut`), a block at a time; ``Q`` (n, block) the block's
    generalized forces (a view of ``o_Q``)."""
    dep, drv, cut_row, cut_rows = L.dependent, L.driven, L.cut_row, L.cut_rows
    m, n_rows, n_drv = dep.shape[0], J.shape[0], drv.shape[0]
    last = max(n_rows - 1, 0)
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
    # tau_j = Q_j less each cut's share (its rows of J_drv^T lam, padded to three)
    for jd in range(n_drv):
        i = drv[jd]
        o_tau_j = o_tau[jd, d, ks]
        o_tau_j[:] = Q[i, :nb]
        for cc in range(cut_row.shape[0]):
            row, rows = cut_row[cc], cut_rows[cc]
            r1, r2 = min(row + 1, last), min(row + 2, last)
            J0, J1, J2 = J[row, i - 1, d, ks], J[r1, i - 1, d, ks], J[r2, i - 1, d, ks]
            l0, l1, l2 = lam[row], lam[r1], lam[r2]
            for k in range(nb):
                o_tau_j[k] = less_cut(o_tau_j[k],
                                      (J0[k], J1[k] if rows > 1 else 0.0,
                                       J2[k] if rows > 2 else 0.0),
                                      (l0[k], l1[k] if rows > 1 else 0.0,
                                       l2[k] if rows > 2 else 0.0))


# --- the reactions stage ----------------------------------------------------------------------

@inner
def _cut_wrenches(L, d, dp, k0, nb, c, s, r, lam, zero, wc, o_on):
    """:func:`~linkdyn.reactions.cut_wrench` of every cut joint over a block: ``S^T lam`` summed
    on both bodies about their O into ``wc`` (n, 3, block), and the cut joints' reactions
    (each cut's rows of ``lam`` from ``L.cut_row``, ``L.cut_rows`` of them); ``zero``
    (block,): zeros, the padding of a cut with fewer than three rows."""
    ks = slice(k0, k0 + nb)   # the block's samples
    wc[:, :, :nb] = 0.0
    for cc in range(L.cut_a.shape[0]):
        a, b, code = L.cut_a[cc], L.cut_b[cc], L.cut_kind[cc]
        row, rows = L.cut_row[cc], L.cut_rows[cc]
        pa = (L.cut_pa[cc, 0, dp], L.cut_pa[cc, 1, dp])
        pb = (L.cut_pb[cc, 0, dp], L.cut_pb[cc, 1, dp])
        axis = (L.cut_axis[cc, 0, dp], L.cut_axis[cc, 1, dp])
        nums = cut_numbers(L, cc, dp)
        c_a, s_a, r_a = c[a, d, ks], s[a, d, ks], vector_views(r, a, d, ks)
        c_b, s_b, r_b = c[b, d, ks], s[b, d, ks], vector_views(r, b, d, ks)
        wc_a = wc[a, 0, :nb], wc[a, 1, :nb], wc[a, 2, :nb]
        wc_b = wc[b, 0, :nb], wc[b, 1, :nb], wc[b, 2, :nb]
        # the cut's multipliers, padded with zeros to three
        lam_c = (lam[row, :nb], lam[row + 1, :nb] if rows > 1 else zero[:nb],
                 lam[row + 2, :nb] if rows > 2 else zero[:nb])
        on_c = screw_views(o_on, L.cut_joint[cc], d, ks)
        t0 = np.nan   # the contact's search starts from the last sample's
        for k in range(nb):
            x_a, x_b = (r_a[0][k], r_a[1][k]), (r_b[0][k], r_b[1][k])
            r_pa, r_pb, e_a = cut_frame(code, nums, c_a[k], s_a[k], x_a, c_b[k], s_b[k], x_b,
                                        pa, pb, axis, t0)
            t0 = e_a[4]
            on, w_b, w_a = cut_wrench(code, nums, e_a, (lam_c[0][k], lam_c[1][k], lam_c[2][k]),
                                      r_pa, r_pb, x_a, x_b)
            wc_b[0][k], wc_b[1][k], wc_b[2][k] = plus((wc_b[0][k], wc_b[1][k], wc_b[2][k]), w_b)
            wc_a[0][k], wc_a[1][k], wc_a[2][k] = plus((wc_a[0][k], wc_a[1][k], wc_a[2][k]), w_a)
            on_c[0][k], on_c[1][k], on_c[2][k] = on


@inner
def _tree_reactions(L, d, dp, k0, nb, di, ki, keep, c, s, r, e, tau, wc, ws, o_tree, o_on):
    """``R_i`` by the backward recursion of ``w_star - w_cut`` (reactions.tree_wrenches) and
    the reaction of every tree joint from it (reactions.solve): the driver's effort removed by
    :func:`~linkdyn.reactions.without_effort`, the opposite taken about the parent's joint point
    by :func:`~linkdyn.reactions.flipped` where the parent is the second body. ``ws``
    (n, 3, 1, block): the block's ``w_star``. With the internals ``keep``, a joint whose
    reaction is ``R_i`` itself (the child is its second body, not driven) is not written:
    :func:`reactions` gives it ``R_i``'s rows."""
    n = L.parent.shape[0]
    ks, kw = slice(k0, k0 + nb), slice(ki, ki + nb)   # the block's samples, in the internals
    # R_i = w_star_i - w_cut_i (the ground's w_star_0 = 0), then R_p += A(r_i - r_p)^T R_i
    for i in range(n):
        R_i, wstar_i = screw_views(o_tree, i, di, kw), screw_views(ws, i, 0, slice(0, nb))
        wc_i = wc[i, 0, :nb], wc[i, 1, :nb], wc[i, 2, :nb]
        for k in range(nb):
            R_i[0][k], R_i[1][k], R_i[2][k] = minus((wstar_i[0][k], wstar_i[1][k], wstar_i[2][k]),
                                                    (wc_i[0][k], wc_i[1][k], wc_i[2][k]))
    _composite(L, r, d, k0, nb, di, ki, o_tree)
    for i in range(1, n):
        si, dr, p = L.sign[i], L.driver_of[i], L.parent[i]
        if keep and si > 0 and dr < 0:   # R_i as is
            continue
        code, jp = L.kind[i], (L.joint_point[i, 0, dp], L.joint_point[i, 1, dp])
        R_i, on_i = screw_views(o_tree, i, di, kw), screw_views(o_on, L.tree_joint[i], d, ks)
        e_i, r_i = vector_views(e, i, d, ks), vector_views(r, i, d, ks)
        r_p, c_p, s_p = vector_views(r, p, d, ks), c[p, d, ks], s[p, d, ks]
        tau_i = tau[max(dr, 0), :nb]
        for k in range(nb):
            o = (R_i[0][k], R_i[1][k], R_i[2][k])
            if dr >= 0:   # body i's driver: R_i - tau p_i
                o = without_effort(code, si, (e_i[0][k], e_i[1][k]), o, tau_i[k])
            if si < 0:   # the parent is the joint's second body: the opposite, about its point
                o = flipped(o, (r_i[0][k], r_i[1][k]), c_p[k], s_p[k], (r_p[0][k], r_p[1][k]),
                            jp)
            on_i[0][k], on_i[1][k], on_i[2][k] = o


@inline
def _constant(w_ext, d, w_const):
    """Design d's applied wrenches repeated over a block into ``w_const`` (n, 3, 1, block) when
    they are constant in time (``w_ext`` (n, 3, D, 1))."""
    if w_ext.shape[3] == 1:
        for i in range(w_ext.shape[0]):
            for j in range(3):
                w_const[i, j, 0, :] = w_ext[i, j, d, 0]


# --- the kernels ------------------------------------------------------------------------------

@njit
def _dynamics(L, c, s, r, e, tw, twd, J, w_ext, o_wstar, o_wtilde, o_Q, o_lam, o_tau, o_ke,
              o_pivot, o_on, block, keep):
    """The dynamics of every sample: ``w_star``, ``w_tilde = N_l^T w_star``, ``Q = N_d^T
    w_tilde``, ``lam``, ``tau`` and the kinetic energy; arguments as in :func:`solve`, outputs
    written in place (component-first, batch ``(D, T)`` last) into zeroed arrays (the ground's
    ``w_star`` and ``Q`` rows, zero by construction, are not written); ``L`` the layout's view
    (:attr:`linkdyn.kinematics.layout.Layout.view`).

    The internals ``o_wstar``, ``o_wtilde``, ``o_Q`` are outputs like the others when ``keep``;
    else one block's scratch, (n, 3, 1, block) and (n, 1, block). The samples are taken
    ``block`` at a time: each stage runs over the bodies, and for each body over the samples
    of the block, which are independent.

    ``o_on`` (n_joints, 3, D, T), or no row: with rows (and without ``keep``), the reactions
    stage of :func:`_reactions` runs on each block too, from the block's ``w_star``,
    multipliers and efforts while they are at hand (:func:`inverse`), and writes every joint's
    reaction into it; ``R_i`` is then one block's scratch.
    """
    n, m = L.parent.shape[0], L.dependent.shape[0]   # m = the cut rows: J_dep^T lam = Q_dep
    D, T = c.shape[1], c.shape[2]
    n_designs = L.mass.shape[1]
    n_rows, n_drv = o_lam.shape[0], o_tau.shape[0]
    react = o_on.shape[0] > 0 and not keep
    B = block
    # scratch for one block of samples, allocated once per call
    w_const = np.zeros((n, 3, 1, B))   # w_ext constant in time, repeated over a block
    A = np.zeros((m, m + 1, B))        # [J_dep^T | Q_dep]
    lam = np.zeros((max(m, n_rows, 1), B))   # rows past m (none in a full-rank J_dep) zero
    ke = np.zeros(B)
    piv = np.zeros(B)
    # the reactions' scratch (_reactions): cut wrenches, R_i, the efforts of the block
    nr = B if react else 0
    wc, tree = np.zeros((n, 3, nr)), np.zeros((n, 3, 1, nr))
    tau_b, zero = np.zeros((max(n_drv, 1), nr)), np.zeros(nr)
    z = np.int64(0)
    for d in range(D):
        dp = d if n_designs > 1 else 0
        _constant(w_ext, d, w_const)
        for k0 in range(0, T, B):
            nb = min(B, T - k0)
            # the internals' design and first sample: the block's, or the scratch's
            di, ki = (d, k0) if keep else (0, 0)
            if not keep:   # the ground's w_tilde only accumulates
                o_wtilde[0, :, 0, :nb] = 0.0
            _newton_euler(L, d, dp, k0, nb, di, ki, c, s, tw, twd, w_ext, w_const, ke, o_wstar,
                          o_wtilde)
            o_ke[d, k0:k0 + nb] = ke[:nb]
            _composite(L, r, d, k0, nb, di, ki, o_wtilde)
            _generalized(L, d, k0, nb, di, ki, e, o_wtilde, o_Q)
            _multipliers(L, d, k0, nb, J, o_Q[:, di, ki:ki + nb], A, lam, piv, o_lam, o_tau,
                         o_pivot)
            if react:   # the block's w_star (o_wstar, the scratch), lam and tau as _reactions
                for a in range(n_drv):
                    tau_b[a, :nb] = o_tau[a, d, k0:k0 + nb]
                _cut_wrenches(L, d, dp, k0, nb, c, s, r, lam, zero, wc, o_on)
                _tree_reactions(L, d, dp, k0, nb, z, z, False, c, s, r, e, tau_b, wc, o_wstar,
                                tree, o_on)


@njit
def _reactions(L, c, s, r, e, tw, twd, w_ext, lam, tau, o_on, o_tree, block, keep):
    """Every joint's reaction at every sample from the multipliers ``lam`` (n_rows, D, T) and
    the efforts ``tau`` (n_drivers, D, T): the cut wrenches, ``R_i`` by the backward recursion
    of ``w_star - w_cut`` (``w_star`` of the block by the same step as the dynamics), then
    every tree joint's reaction; arguments as in :func:`reactions`, outputs written in place
    into zeroed arrays. ``o_tree`` per sample when ``keep``, else one block's scratch
    (n, 3, 1, block)."""
    n, n_rows, n_drv = L.parent.shape[0], lam.shape[0], tau.shape[0]
    D, T = c.shape[1], c.shape[2]
    n_designs = L.mass.shape[1]
    B = block
    w_const = np.zeros((n, 3, 1, B))
    ws, ws2 = np.zeros((n, 3, 1, B)), np.zeros((n, 3, 1, B))   # w_star of the block
    wc = np.zeros((n, 3, B))      # cut-joint wrenches on the bodies
    lam_b, tau_b = np.zeros((max(n_rows, 1), B)), np.zeros((max(n_drv, 1), B))
    zero, ke = np.zeros(B), np.zeros(B)
    z = np.int64(0)   # the scratch's place as an int64: _newton_euler compiles once (_sweep)
    for d in range(D):
        dp = d if n_designs > 1 else 0
        _constant(w_ext, d, w_const)
        for k0 in range(0, T, B):
            nb = min(B, T - k0)
            di, ki = (d, k0) if keep else (0, 0)
            for a in range(n_rows):
                lam_b[a, :nb] = lam[a, d, k0:k0 + nb]
            for a in range(n_drv):
                tau_b[a, :nb] = tau[a, d, k0:k0 + nb]
            _newton_euler(L, d, dp, k0, nb, z, z, c, s, tw, twd, w_ext, w_const, ke, ws, ws2)
            _cut_wrenches(L, d, dp, k0, nb, c, s, r, lam_b, zero, wc, o_on)
            _tree_reactions(L, d, dp, k0, nb, di, ki, keep, c, s, r, e, tau_b, wc, ws, o_tree,
                            o_on)


# --- the sweep: the kinematics kernel's blocks and the dynamics, fused -------------------------

#: what the fused kernel keeps per sample of the kinematics (:func:`sweep`)
KEPT = ("q", "phi", "c", "s", "r", "e", "qd", "qdd", "cut")


@inline
def _keep(x, out, d, k0, nb):
    """Rows ``x`` (k, 1, block) of one block's scratch into ``out`` (k, D, T) at design d,
    samples ``k0`` .. ``k0 + nb``."""
    for i in range(x.shape[0]):
        o_i, x_i = out[i, d, k0:k0 + nb], x[i, 0]
        for k in range(nb):
            o_i[k] = x_i[k]


#: the reductions of the metrics-only sweep (:data:`Reduce`): ``peak`` (the running largest
#: |x|, :func:`~linkdyn.design.reduce.larger_magnitude`) and the sum of squares of ``rms``
#: (:func:`~linkdyn.design.reduce.plus_square`)
PEAK, SQUARES = 0, 1

#: What the metrics-only sweep keeps of each design (:func:`sweep` with ``metrics=``): the
#: reductions over its samples ``kind`` (n_red,) (:data:`PEAK`, :data:`SQUARES`) of the
#: drivers' efforts ``col`` (n_red,), into ``out`` (n_red, D); the path ``xy`` (2, D, T) of the
#: point ``point`` (2, D) of body ``body`` (no design: no path); ``ok`` (D,) whether every
#: sample of the design is valid as :func:`linkdyn.analysis.analyze_layout` counts it (closed
#: within ``accept``, the pivots of ``J_dep`` clear of a singular position, every joint's
#: motion, effort and the kinetic energy finite).
Reduce = namedtuple("Reduce", ("kind", "col", "out", "body", "point", "xy", "ok", "accept"),
                    module=__name__)


@njit
def _sweep(L, X, axes, q, phi, c, s, r, e, qd, qdd, cut, pivot, err, fin, o_lam, o_tau, o_ke,
           o_pivot, block, R):
    """The kinematics of every sample (:func:`linkdyn.kinematics.compiled.block` on one
    block's scratch), then its dynamics (the stages of :func:`_dynamics`, on the same block,
    under the weights of :func:`linkdyn.compiled.loads.weights`): only ``KEPT`` of the
    kinematics (``e``: the rows ``axes``) and the dynamics' ``lam``, ``tau``, kinetic energy
    and pivot reach the outputs (component-first, batch ``(D, T)`` last; written in place).
    ``L``: the layout's view, ``X`` the kinematics kernel's inputs
    (:func:`linkdyn.kinematics.compiled.inputs`).

    Outputs without designs (``q`` (n, 0, 0), ...): the metrics only, :data:`Reduce` ``R``
    (else its arrays are empty): each design's reductions taken as its blocks are solved, its
    path point and its validity, nothing else per sample.
    """
    n, nc, m, nv, n_rows = len(L.parent), len(L.cut_a), len(L.dependent), len(L.driven), \
        o_lam.shape[0]
    D, T = L.size.shape[0], X.t_s.shape[0]
    keep = q.shape[1] > 0   # every sample's outputs, else the metrics of R
    n_red, path = R.kind.shape[0], R.xy.shape[1] > 0
    gravity = L.gravity
    B = block
    # the work arrays' place as an int64, not a literal 0: the callees then reuse the
    # compilation of the other kernels' calls instead of one of their own
    z = np.int64(0)
    # the kinematics of one block: its work arrays and scratch
    tmp = kc.scratch(n, nc, m, n_rows, B)
    work = (np.zeros((n, 1, B)), np.zeros((n, 1, B)), np.zeros((n, 1, B)), np.zeros((n, 1, B)),
            np.zeros((n, 2, 1, B)), np.zeros((n, 2, 1, B)), np.zeros((n_rows, n - 1, 1, B)),
            np.zeros((n, 1, B)), np.zeros((n, 1, B)), np.zeros((n, 3, 1, B)),
            np.zeros((n, 3, 1, B)))
    q_w, phi_w, c_w, s_w, r_w, e_w, J_w, qd_w, qdd_w, tw_w, td_w = work
    cut_w = np.zeros((nc, 3, 1, B))
    err_w, piv_w, fin_w = np.zeros((1, B)), np.zeros((1, B)), np.zeros((1, B), np.bool_)
    # the dynamics of one block (as _dynamics without its internals), its applied wrenches
    w_b = np.zeros((n, 3, 1, B))
    A = np.zeros((m, m + 1, B))
    lam, ke, piv, pe_b = np.zeros((max(m, 1), B)), np.zeros(B), np.zeros(B), np.zeros(B)
    wstar, wtilde, Q = np.zeros((n, 3, 1, B)), np.zeros((n, 3, 1, B)), np.zeros((n, 1, B))
    lam_b, tau_b, pivot_b = np.zeros((n_rows, 1, B)), np.zeros((nv, 1, B)), np.zeros((1, B))
    for d in range(D):
        dp = d if L.mass.shape[1] > 1 else 0
        dg = d if gravity.shape[1] > 1 else 0
        g = (gravity[0, dg], gravity[1, dg])
        ok, total = True, 0.0   # the design's samples valid; the sum of its outputs
        for a in range(n_red):
            R.out[a, d] = 0.0
        for k0 in range(0, T, B):
            nb = min(B, T - k0)
            kc.block(L, X, d, k0, nb, work, z, z, err_w, piv_w, fin_w, tmp)
            kc._cut_motion(L, d, z, z, nb, phi_w, r_w, tw_w, td_w, tmp[5], cut_w)
            if keep:
                for x, out in ((q_w, q), (phi_w, phi), (c_w, c), (s_w, s), (qd_w, qd),
                               (qdd_w, qdd)):
                    _keep(x, out, d, k0, nb)
                for i in range(n):
                    _keep(r_w[i], r[i], d, k0, nb)
                for i in axes:
                    _keep(e_w[i], e[i], d, k0, nb)
                for ci in range(nc):
                    _keep(cut_w[ci], cut[ci], d, k0, nb)
                for k in range(nb):
                    err[d, k0 + k], pivot[d, k0 + k] = err_w[0, k], piv_w[0, k]
                    fin[d, k0 + k] = fin_w[0, k]
            # the dynamics of the block (the ground's w_tilde only accumulates)
            if g[0] != 0.0 or g[1] != 0.0:   # else no applied wrench: w_b stays zero
                weights(L, g, dp, nb, c_w, s_w, r_w, w_b, pe_b)
            wtilde[0, :, 0, :nb] = 0.0
            _newton_euler(L, z, dp, z, nb, z, z, c_w, s_w, tw_w, td_w, w_b, w_b, ke, wstar,
                          wtilde)
            _composite(L, r_w, z, z, nb, z, z, wtilde)
            _generalized(L, z, z, nb, z, z, e_w, wtilde, Q)
            _multipliers(L, z, z, nb, J_w, Q[:, 0, 0:nb], A, lam, piv, lam_b, tau_b, pivot_b)
            if keep:
                o_ke[d, k0:k0 + nb] = ke[:nb]
                _keep(lam_b, o_lam, d, k0, nb)
                _keep(tau_b, o_tau, d, k0, nb)
                o_pivot[d, k0:k0 + nb] = pivot_b[0, :nb]
                continue
            ok = ok and _valid(R, nb, err_w, piv_w, fin_w, pivot_b)
            total += _total(nb, q_w, cut_w, tau_b, ke)
            for a in range(n_red):   # each metric's reduction, one sample at a time
                acc, x = R.out[a, d], tau_b[R.col[a], 0]
                if R.kind[a] == PEAK:
                    for k in range(nb):
                        acc = larger_magnitude(acc, x[k])
                else:
                    for k in range(nb):
                        acc = plus_square(acc, x[k])
                R.out[a, d] = acc
            if path:   # the path point, as KinematicSolution.point
                i = R.body
                dq = d if R.point.shape[1] > 1 else 0
                p = (R.point[0, dq], R.point[1, dq])
                c_i, s_i, rx, ry = c_w[i, 0], s_w[i, 0], r_w[i, 0, 0], r_w[i, 1, 0]
                x_o, y_o = R.xy[0, d, k0:k0 + nb], R.xy[1, d, k0:k0 + nb]
                for k in range(nb):
                    u = turned(c_i[k], s_i[k], p)
                    x_o[k], y_o[k] = rx[k] + u[0], ry[k] + u[1]
        if not keep:
            R.ok[d] = ok and math.isfinite(total)


@inline
def _valid(R, nb, err, piv, fin, dyn_piv):
    """Whether every sample of a block is valid (closed within ``R.accept``, ``J_dep``'s
    pivots of the kinematics and the dynamics clear of a singular position for the sample's
    closure residual, :func:`linkdyn.kinematics.positions.singular`, rates and accelerations
    finite: :func:`linkdyn.analysis.analyze_layout`'s ``valid`` (:func:`linkdyn.analysis.regular`)
    before the outputs' check)."""
    good = True
    for k in range(nb):
        good = good and (err[0, k] <= R.accept and fin[0, k] and not singular(piv[0, k], err[0, k])
                         and not singular(dyn_piv[0, k], err[0, k]))
    return good


@inline
def _total(nb, q, cut, tau, ke):
    """The sum of a block's joint coordinates, cut joints' motion, efforts and kinetic
    energy: finite when every one of them is (the outputs :func:`linkdyn.analysis._finite`
    checks; the rates and accelerations are in :func:`_valid`)."""
    total = 0.0
    for k in range(nb):
        total += ke[k]
    for i in range(1, q.shape[0]):
        for k in range(nb):
            total += q[i, 0, k]
    for ci in range(cut.shape[0]):
        for j in range(3):
            for k in range(nb):
                total += cut[ci, j, 0, k]
    for a in range(tau.shape[0]):
        for k in range(nb):
            total += tau[a, 0, k]
    return total


def fusable(lay) -> bool:
    """Whether :func:`sweep` can run the layout ``lay``'s dynamics in the kinematics' blocks:
    no applied load but gravity (the kernel applies the weights; the other loads, their
    formulas among them, are applied by :func:`linkdyn.loads.wrenches` once the kinematics
    are solved)."""
    return not lay.loads


def sweep(lay, t, q_drv, qd_drv, qdd_drv, *, metrics=None, **closing) -> dict:
    """The kinematics of :func:`linkdyn.kinematics.compiled.run` (same arguments) fused with
    the dynamics of :func:`solve` in one kernel (:func:`_sweep`), for a layout without
    applied loads but gravity (:func:`fusable`): the loops are closed, the rates and
    accelerations solved and the dynamics done a block of samples at a time, and only ``KEPT``
    of the kinematics (no twists, twist rates or Jacobian) is written per sample.

    ``metrics``: a :class:`Metrics`, to keep only what a sweep's metrics read (nothing of
    the above per sample).

    Returns
    -------
    dict
        ``run``'s outputs named in ``KEPT`` (``e``: the rows of the joints with a slider axis,
        the others zero), ``pivot``, ``err``, ``finite``, and the dynamics' ``lam``
        (n_rows, D, T), ``tau`` (n_drivers, D, T), ``ke`` and ``dyn_pivot`` (D, T). With
        ``metrics``: ``ok`` (D,) every sample of the design valid, ``reduced`` (n_red, D) the
        reductions of ``metrics.efforts`` (peak: the largest |effort|; rms: the sum of squares)
        and ``path`` (2, D, T) the point ``metrics.point`` (none: (2, 0, 0)), m.
    """
    args = kc.inputs(lay, t, q_drv, qd_drv, qdd_drv, **closing)
    topo, L = lay.topo, lay.view
    n, nc, D, T = topo.n, topo.n_loops, max(lay.designs, 1), len(t)
    at = (0, 0) if metrics else (D, T)   # per sample, or nothing
    shapes = {"q": (n,), "phi": (n,), "c": (n,), "s": (n,), "r": (n, 2), "e": (n, 2),
              "qd": (n,), "qdd": (n,), "cut": (nc, 3), "pivot": (), "err": ()}
    # every number of these is written (the ground's rows too), but e's rows without an axis
    out = {k: (np.zeros if k == "e" else np.empty)(shape + at) for k, shape in shapes.items()}
    out["finite"] = np.empty(at, np.bool_)
    dyn = {"lam": np.empty((topo.n_rows,) + at), "tau": np.empty((len(L.driven),) + at),
           "ke": np.empty(at), "dyn_pivot": np.empty(at)}
    axes = np.array([i for i in range(1, n) if "axis" in jk.get(lay.kind[i]).keys], np.int64)
    R = _reduce(lay, metrics, D, T)
    _sweep(L, args, axes, *out.values(), *dyn.values(), min(BLOCK, T), R)
    if metrics:
        return {"ok": R.ok, "reduced": R.out, "path": R.xy}
    out.update(dyn)
    return out


@dataclass(frozen=True)
class Metrics:
    """What a metrics-only :func:`sweep` keeps: ``efforts``, pairs ``(driver, how)`` (the
    driver's index in the model's drivers, ``'peak'`` or ``'rms'``); ``point``, ``(body,
    point)`` names of the path point, or None; ``accept``, the closure residual of a valid
    sample (:data:`linkdyn.kinematics.positions.ACCEPT`)."""

    efforts: tuple
    point: tuple | None
    accept: float


def _reduce(lay, metrics: Metrics | None, D: int, T: int) -> Reduce:
    """The kernel's :data:`Reduce` for ``metrics`` (None: every array empty)."""
    if metrics is None:
        return Reduce(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, D)),
                      np.int64(0), np.zeros((2, 1)), np.zeros((2, 0, 0)),
                      np.zeros(0, np.bool_), 0.0)
    kind = np.array([PEAK if how == "peak" else SQUARES for _, how in metrics.efforts],
                    np.int64)
    col = np.array([k for k, _ in metrics.efforts], np.int64)
    body, point, xy = 0, np.zeros((2, 1)), np.zeros((2, 0, 0))
    if metrics.point is not None:
        body = lay.topo.bodies.index(metrics.point[0])
        p = np.asarray(lay.points[body][metrics.point[1]], float)
        point = np.ascontiguousarray(np.reshape(p, (2, -1)))
        xy = np.empty((2, D, T))
    return Reduce(kind, col, np.zeros((len(kind), D)), np.int64(body), point, xy,
                  np.zeros(D, np.bool_), float(metrics.accept))


def swept(kin: KinematicSolution, loads: Loads) -> DynamicSolution:
    """The dynamics :func:`sweep` solved with the kinematics ``kin`` (its ``swept`` outputs),
    as :func:`solve` would give them; the internals by :func:`solve` when first read."""
    out, shape = kin.swept, kin.shape
    lam, tau = _comps(out["lam"], shape), _comps(out["tau"], shape)
    ke, pivot = out["ke"].reshape(shape), out["dyn_pivot"].reshape(shape)
    if not kin.layout.topo.n_rows:   # no multiplier: the pivot is one (blanked with the rest)
        pivot = np.ones(shape)
    return DynamicSolution(lam, tau, ke, pivot, _Again(solve, kin, loads).dynamics)


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


def _applied(loads: Loads, shape) -> np.ndarray:
    """``w_ext`` (n, 3, D, Tw) of ``loads``: one sample (Tw = 1) when no wrench varies in time
    (all broadcast along t, stride 0, as a body without loads), else every sample (Tw = T)."""
    D, T = (shape[0] if len(shape) == 2 else 1), shape[-1]
    ws = [np.broadcast_to(w, (3,) + shape) for w in loads.wrenches]
    Tw = 1 if all(w.strides[-1] == 0 for w in ws) else T
    return _plain(np.stack([w[..., :Tw].reshape(3, D, Tw) for w in ws]))


def _per(a, shape) -> list:
    """Per-entity views (3, ...) of a (k, 3, D, T) output."""
    return [w.reshape((3,) + shape) for w in a]


def _comps(a, shape) -> np.ndarray:
    """(k, D, T) -> components last (..., k), like the numpy path's ``last(...)``."""
    return last(a.reshape((len(a),) + shape))


def solve(kin: KinematicSolution, loads: Loads, internals: bool = False) -> DynamicSolution:
    """Driver efforts and cut-joint multipliers by the compiled kernel: the same results as
    ``denoc.solve(kin, loads)``, in the same shapes.

    Parameters
    ----------
    kin : KinematicSolution
        Batch shape ``kin.shape``: (T,) or (D, T). Its ``arrays`` are used when set (compiled
        kinematics), else its per-body lists (numpy kinematics).
    loads : Loads
        Applied wrenches ``loads.wrenches``, (3, ...) per body about O_i, N m / N. When none
        varies in time (each broadcast along the samples, as for a body without loads), the
        kernel reads one sample of them.
    internals : bool
        Keep the kernel's ``wstar``, ``wtilde`` and ``Q`` per sample. By default the kernel
        holds them for one block only (Hoeken's dynamics then writes 4 numbers per sample
        instead of 31), and the solution runs the kernel again, keeping them, when one of them
        is first read.

    Returns
    -------
    DynamicSolution
        ``wstar``, ``wtilde`` (3, ...) per body; ``Q`` (..., n), ``lam`` (..., n_rows),
        ``tau`` (..., n_drivers) components last; ``kinetic_energy`` (...) J; ``pivot`` (...).
    """
    return _solve(kin, loads, internals, False)[0]


def inverse(kin: KinematicSolution, loads: Loads) -> tuple[DynamicSolution, Reactions]:
    """The dynamics of :func:`solve` and the reactions of :func:`reactions` by one kernel
    (each block's ``w_star``, multipliers and efforts taken by the reactions stage while they
    are at hand, instead of a second kernel reading the kinematics again and forming
    ``w_star`` again): the same numbers as the two stages, ``(dyn, react)``; their internals
    by the stages, as theirs, when first read."""
    return _solve(kin, loads, False, True)


def _solve(kin, loads, internals: bool, react: bool) -> tuple:
    """:func:`solve`'s dynamics, and with ``react`` the reactions (else None) of the same
    kernel call: ``(dyn, react)``."""
    shape = kin.shape
    D, T = (shape[0] if len(shape) == 2 else 1), shape[-1]
    x = _inputs(kin)
    L = kin.layout.view
    n, n_rows = kin.layout.topo.n, kin.layout.topo.n_rows
    # zeroed outputs: the pages of the rows the kernel leaves zero are never touched; the
    # internals per sample, or for one block
    block = min(BLOCK, T)
    at = (D, T) if internals else (1, block)
    out = {"wstar": np.zeros((n, 3) + at), "wtilde": np.zeros((n, 3) + at),
           "Q": np.zeros((n,) + at), "lam": np.zeros((n_rows, D, T)),
           "tau": np.zeros((len(L.driven), D, T)), "ke": np.zeros((D, T)),
           "pivot": np.zeros((D, T)),
           "on": np.zeros(((kin.layout.n_joints if react else 0), 3, D, T))}
    applied = _applied(loads, shape)
    _dynamics(L, x["c"], x["s"], x["r"], x["e"], x["tw"], x["twd"], x["J"], applied,
              out["wstar"], out["wtilde"], out["Q"], out["lam"], out["tau"], out["ke"],
              out["pivot"], out["on"], block, internals)
    lam, tau = _comps(out["lam"], shape), _comps(out["tau"], shape)
    ke, pivot = out["ke"].reshape(shape), out["pivot"].reshape(shape)
    if not internals:   # the kernel again, keeping them, when first read
        dyn = DynamicSolution(lam, tau, ke, pivot, _Again(solve, kin, loads).dynamics)
    else:
        dyn = DynamicSolution(lam, tau, ke, pivot, (_per(out["wstar"], shape),
                                                    _per(out["wtilde"], shape),
                                                    _comps(out["Q"], shape)))
    if not react:
        return dyn, None
    return dyn, Reactions(_per(out["on"], shape), _Again(reactions, kin, loads, dyn).tree)


def reactions(kin: KinematicSolution, loads: Loads, dyn: DynamicSolution,
              internals: bool = False) -> Reactions:
    """Every joint's reaction by the compiled kernel: the same results as
    ``reactions.solve(model, kin, dyn)``, in the same shapes.

    Parameters
    ----------
    kin, loads
        As for :func:`solve` (the kernel forms each block's ``w_star`` again from them, by the
        same step, rather than reading a per-sample copy).
    dyn : DynamicSolution
        Its multipliers ``lam`` and efforts ``tau``.
    internals : bool
        Keep the tree wrenches ``R_i`` per sample; by default they are computed again, kept,
        when first read.

    Returns
    -------
    Reactions
        ``on_second`` (3, ...) per model joint ``[M, Fx, Fy]`` by the first body on the second
        about the second's joint point, N m / N; ``tree`` (3, ...) per body, ``R_i`` about O_i.
    """
    shape = kin.shape
    D, T = (shape[0] if len(shape) == 2 else 1), shape[-1]
    x = _inputs(kin)
    L = kin.layout.view
    n = kin.layout.topo.n
    block = min(BLOCK, T)
    on = np.zeros((kin.layout.n_joints, 3, D, T))
    tree = np.zeros((n, 3) + ((D, T) if internals else (1, block)))
    lam, tau = (_plain(np.moveaxis(a, -1, 0).reshape(a.shape[-1], D, T))
                for a in (dyn.lam, dyn.tau))
    _reactions(L, x["c"], x["s"], x["r"], x["e"], x["tw"], x["twd"], _applied(loads, shape),
               lam, tau, on, tree, block, internals)
    if not internals:   # the kernel again, keeping them, when first read
        return Reactions(_per(on, shape), _Again(reactions, kin, loads, dyn).tree)
    # a tree joint whose child is its second body and is not driven reports R_i itself (the
    # same array, as in reactions.solve): the kernel left its rows of ``on`` unwritten
    on_second, tree = _per(on, shape), _per(tree, shape)
    for i in range(1, n):
        if L.sign[i] > 0 and L.driver_of[i] < 0:
            on_second[L.tree_joint[i]] = tree[i]
    return Reactions(on_second, tree)


class _Again:
    """A stage run again on the same input, keeping its internals, once, when the first of
    them is read (a plain class, so that the solutions holding it stay picklable)."""

    def __init__(self, stage, *args):
        self.stage, self.args = stage, args

    @cached_property
    def kept(self):
        return self.stage(*self.args, internals=True)

    def dynamics(self) -> tuple:
        """``(wstar, wtilde, Q)``, as :attr:`DynamicSolution.internals`."""
        return self.kept._internals

    def tree(self) -> list:
        """``R_i`` per body, as :attr:`Reactions.internals`."""
        return self.kept.tree
