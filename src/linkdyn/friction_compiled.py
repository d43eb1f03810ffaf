"""Compiled friction solve: the stages under the applied loads and under each unit friction
effort on one block's kinematics, and friction's Newton's method per sample, in one kernel.

The method is :func:`linkdyn.friction.solve`'s (docs/theory.md, "Friction that grows with the
joint load"): at a fixed state every reaction, multiplier and effort is affine in the k friction
efforts, ``y = y0 + sum_l dy_l f_l``, ``y0`` under the applied loads and ``dy_l`` the response
to a unit effort in friction load l alone. For each block of samples, :func:`_kernel` runs the
stages of :mod:`linkdyn.dynamics.compiled` (its Newton–Euler, backward recursion, multipliers
and reactions steps, unchanged) under the applied loads straight into the outputs, then on a
block-local copy of the kinematics from ``w_star = -unit`` for each unit effort (no Newton–Euler
step: ``w_star`` is affine in the applied wrench, the motion's share is the first case's), then
solves each sample's friction equations by :func:`linkdyn.friction.residuals` and
:func:`linkdyn.friction.newton_step` (the steps the numpy path runs over arrays; from the
previous sample's solution, else from ``f = 0``) and adds
``sum_l dy_l f_l`` to every joint, multiplier and effort, a block at a time: no stage runs
again with the converged efforts."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from .compiled import inline, njit
from .dynamics import compiled as cd
from .dynamics.denoc import DynamicSolution
from .friction import (MAX_ITERATIONS, TOL, friction_of, newton_step, residuals,
                       sliding_arm, with_efforts)
from .reactions import Reactions


@inline
def _copy(x, d, k0, nb, out):
    """Rows ``x[..., d, k0:k0 + nb]`` (any leading axes, flattened to ``rows``) into the block
    scratch ``out`` (rows, block)."""
    for a in range(x.shape[0]):
        for k in range(nb):
            out[a, k] = x[a, d, k0 + k]


@inline
def _unit(u, d, k0, nb, wstar, wtilde):
    """``w_star = w_tilde = -u`` on the moving bodies over the block from sample ``k0``, ``u``
    (n, 3, D, Tu) a unit effort's wrenches (Tu = 1: the same at every sample); the ground's
    ``w_tilde`` zero: the stages' start for the response to the effort alone (``w_star = M td
    + ... - w_ext`` is affine in ``w_ext``, the motion's share is the applied loads' case)."""
    one = u.shape[3] == 1
    for i in range(1, u.shape[0]):
        for j in range(3):
            for k in range(nb):
                x = -u[i, j, d, 0 if one else k0 + k]
                wstar[i, j, 0, k] = x
                wtilde[i, j, 0, k] = x
    wtilde[0, :, 0, :nb] = 0.0


@njit
def _kernel(L, c, s, r, e, tw, twd, J, w_ext, units, fj, fp, qd, o_on, o_lam, o_tau, o_ke,
            o_pivot, o_f, o_its, o_state, o_res, o_big, block):
    """Every sample's reactions, multipliers, efforts and friction efforts (written in place,
    batch ``(D, T)`` last). Inputs as :func:`linkdyn.dynamics.compiled.solve`'s; ``units``
    (k, n, 3, D, Tu) the unit efforts' wrenches; ``fj`` (k,) each friction load's joint; ``fp``
    (k, 6, Dp) its arm, static arm, stiction speed, transition speed, viscous coefficient and
    preload per design; ``qd`` (k, D, T) its joint's rate. Outputs: ``o_f`` (k, D, T) the
    efforts (NaN where locked), ``o_its`` the iterations, ``o_state`` (:func:`_solved`),
    ``o_res`` (k, D, T) the residuals and ``o_big`` the largest friction effort at the
    solution.

    Per block: the stages under the applied loads write the outputs directly (as
    :func:`linkdyn.dynamics.compiled.solve` and ``reactions`` do); the response of every
    reaction, multiplier and effort to a unit effort in each friction load alone (the stages
    from ``w_star = -unit``: no Newton–Euler, the motion's share is in the first case) goes to
    block scratch; each sample's Newton's method reads the friction joints' rows of both; then
    ``y = y0 + sum_l dy_l f_l`` over the block, in place.
    """
    n, nr, nv, nj, kf = L.parent.shape[0], J.shape[0], L.driven.shape[0], o_on.shape[0], \
        fj.shape[0]
    m = L.dependent.shape[0]
    D, T = c.shape[1], c.shape[2]
    B = block
    # the block's place and keep=False as run-time values, not literals: the stages of
    # linkdyn.dynamics.compiled then reuse their compilations for its kernels
    z, no = np.int64(0), np.bool_(False)
    # one block's kinematics, for the unit efforts' cases
    cb, sb = np.zeros((n, 1, B)), np.zeros((n, 1, B))
    rb, eb = np.zeros((n, 2, 1, B)), np.zeros((n, 2, 1, B))
    Jb = np.zeros((nr, max(n - 1, 1), 1, B))
    # each case's stages over the block
    w_const = np.zeros((n, 3, 1, B))
    wstar, wtilde, Q = np.zeros((n, 3, 1, B)), np.zeros((n, 3, 1, B)), np.zeros((n, 1, B))
    Am, lam, piv, ke = np.zeros((m, m + 1, B)), np.zeros((max(m, 1), B)), np.zeros(B), \
        np.zeros(B)
    # the unit efforts' responses: multipliers, efforts, reactions (joint j's component a is
    # row 3 j + a)
    lam_c, tau_c = np.zeros((kf, max(nr, 1), 1, B)), np.zeros((kf, max(nv, 1), 1, B))
    piv_c, tau_b = np.zeros((1, B)), np.zeros((max(nv, 1), B))
    on_c, tree = np.zeros((kf, nj, 3, 1, B)), np.zeros((n, 3, 1, B))
    wc, zero = np.zeros((n, 3, B)), np.zeros(B)
    on_rows, o_rows = on_c.reshape((kf, nj * 3, 1, B)), o_on.reshape((nj * 3, D, T))
    # the block's friction equations sample by sample (each sample's numbers contiguous): the
    # forces F0, their responses A, the rates' terms, the efforts and residuals
    Fs, As = np.zeros((B, kf, 2)), np.zeros((B, kf, kf, 2))
    Cs, Vs, Xs, Rs = np.zeros((B, kf)), np.zeros((B, kf)), np.zeros((B, kf)), np.zeros((B, kf))
    f_b, ps = np.zeros((kf, B)), np.zeros(kf)
    old, dg, K, x = np.zeros(kf), np.zeros((kf, 2)), np.zeros((kf, kf + 1)), np.zeros(kf)
    prev = np.zeros(kf)
    for d in range(D):
        # the previous sample's solution, Newton's start (none at a design's first sample)
        warm, det0 = False, 1.0
        dp = d if L.mass.shape[1] > 1 else 0
        dq = d if fp.shape[2] > 1 else 0
        cd._constant(w_ext, d, w_const)
        for j in range(kf):
            ps[j] = fp[j, 5, dq]
        for k0 in range(0, T, B):
            nb = min(B, T - k0)
            # the applied loads: the dynamics (w_star, w_tilde, Q, lam, tau), then the
            # reactions, into the outputs at the block's samples
            wtilde[0, :, 0, :nb] = 0.0
            cd._newton_euler(L, d, dp, k0, nb, z, z, c, s, tw, twd, w_ext, w_const, ke, wstar,
                             wtilde)
            o_ke[d, k0:k0 + nb] = ke[:nb]
            cd._composite(L, r, d, k0, nb, z, z, wtilde)
            cd._generalized(L, d, k0, nb, z, z, e, wtilde, Q)
            cd._multipliers(L, d, k0, nb, J, Q[:, 0, 0:nb], Am, lam, piv, o_lam, o_tau,
                            o_pivot)
            for a in range(nv):
                tau_b[a, :nb] = o_tau[a, d, k0:k0 + nb]
            cd._cut_wrenches(L, d, dp, k0, nb, c, s, r, lam, zero, wc, o_on)
            cd._tree_reactions(L, d, dp, k0, nb, z, z, no, c, s, r, e, tau_b, wc, wstar, tree,
                               o_on)
            # each unit effort alone, on the block's kinematics
            _copy(c, d, k0, nb, cb[:, 0])
            _copy(s, d, k0, nb, sb[:, 0])
            for i in range(n):
                _copy(r[i], d, k0, nb, rb[i, :, 0])
                _copy(e[i], d, k0, nb, eb[i, :, 0])
            for a in range(nr):
                _copy(J[a], d, k0, nb, Jb[a, :, 0])
            for case in range(kf):
                _unit(units[case], d, k0, nb, wstar, wtilde)
                cd._composite(L, rb, z, z, nb, z, z, wtilde)
                cd._generalized(L, z, z, nb, z, z, eb, wtilde, Q)
                cd._multipliers(L, z, z, nb, Jb, Q[:, 0, 0:nb], Am, lam, piv, lam_c[case],
                                tau_c[case], piv_c)
                for a in range(nv):
                    tau_b[a, :nb] = tau_c[case, a, 0, :nb]
                cd._cut_wrenches(L, z, dp, z, nb, cb, sb, rb, lam, zero, wc, on_c[case])
                cd._tree_reactions(L, z, dp, z, nb, z, z, no, cb, sb, rb, eb, tau_b, wc,
                                   wstar, tree, on_c[case])
            # each sample's friction equations (T10): the friction joints' forces under the
            # applied loads and their responses to each unit effort; what the friction law
            # reads of the rates, a(qd) sense and the viscous effort
            for j in range(kf):
                jj = fj[j]
                for a in range(2):
                    y0 = o_on[jj, 1 + a, d, k0:k0 + nb]
                    for k in range(nb):
                        Fs[k, j, a] = y0[k]
                    for l in range(kf):
                        dy = on_c[l, jj, 1 + a, 0]
                        for k in range(nb):
                            As[k, j, l, a] = dy[k]
                arm, arm_s, st, sp, vis = fp[j, 0, dq], fp[j, 1, dq], fp[j, 2, dq], \
                    fp[j, 3, dq], fp[j, 4, dq]
                for k in range(nb):
                    q = qd[j, d, k0 + k]
                    Cs[k, j] = sliding_arm(arm, arm_s, st, q, np.tanh(q / sp))
                    Vs[k, j] = vis * q
            for k in range(nb):
                warm, det0 = _solved(Xs[k], old, Fs[k], As[k], Cs[k], Vs[k], ps, Rs[k], dg, K,
                                     x, o_its, o_state, o_big, d, k0 + k, prev, warm, det0)
                if warm:
                    for j in range(kf):
                        prev[j] = Xs[k, j]
            for j in range(kf):
                o_fj, o_rj = o_f[j, d, k0:k0 + nb], o_res[j, d, k0:k0 + nb]
                for k in range(nb):
                    f_b[j, k] = Xs[k, j]
                    o_fj[k] = Xs[k, j]
                    o_rj[k] = Rs[k, j]
            # y = y0 + sum_l dy_l f_l, for every joint, multiplier and effort
            _combine(on_rows, f_b, o_rows, d, k0, nb)
            _combine(lam_c, f_b, o_lam, d, k0, nb)
            _combine(tau_c, f_b, o_tau, d, k0, nb)


@inline
def _combine(cases, f, out, d, k0, nb):
    """``y = y0 + sum_l dy_l f_l`` (T10) of every row of ``out`` (rows, D, T), ``y0`` there
    at the block's samples of design d (updated in place), ``dy_l`` of the unit efforts'
    ``cases`` (k, rows, 1, block), ``f`` (k, block) the block's efforts."""
    for a in range(out.shape[0]):
        y = out[a, d, k0:k0 + nb]
        for n in range(f.shape[0]):
            dy, fn = cases[n, a, 0], f[n]
            for k in range(nb):
                y[k] += dy[k] * fn[k]


#: :func:`_solved`'s outcome of a sample: not iterated (its forces are not finite), solved, locked
NOT_ITERATED, SOLVED, LOCKED = 0, 1, 2


@inline
def _solved(f, old, F0, A, cs, vs, ps, res, dg, K, x, o_its, o_state, o_big, d, kk, start,
            warm, det0):
    """Newton's method on one sample's friction equations, as :func:`linkdyn.friction.newton`
    drives it (the same steps, stop and lock rules), from the previous sample's solution
    ``start`` when ``warm`` (``det0`` the determinant of its last Jacobian), and from ``f = 0``
    again if that start does not reach a solution; ``f`` NaN where it locks, ``res`` its
    residuals. A state whose forces are not finite is not iterated. Returns whether it is
    solved and the determinant of its last Jacobian (the next sample's ``warm`` and ``det0``).
    """
    kf = f.shape[0]
    finite, open_ = True, True
    for j in range(kf):
        finite = finite and np.isfinite(F0[j, 0]) and np.isfinite(F0[j, 1])
        for n in range(kf):
            open_ = open_ and np.isfinite(A[j, n, 0]) and np.isfinite(A[j, n, 1])
    its, ok, det, big_g = 0, False, 1.0, np.nan
    if finite and open_:
        if warm:
            its, ok, det, big_g = _iterate(f, old, F0, A, cs, vs, ps, res, dg, K, x, start,
                                           True, det0)
        if not (ok and det > 0):
            more, ok, det, big_g = _iterate(f, old, F0, A, cs, vs, ps, res, dg, K, x, start,
                                            False, 1.0)
            its += more
    else:
        for j in range(kf):
            f[j], res[j] = 0.0, np.nan
    state = NOT_ITERATED
    if finite:   # locked: no solution reached from f = 0 (J no longer positive there)
        state = SOLVED if ok and det > 0 else LOCKED
    if state == LOCKED:
        for j in range(kf):
            f[j] = np.nan
    o_its[d, kk], o_state[d, kk], o_big[d, kk] = its, state, big_g
    return state == SOLVED, det


@inline
def _iterate(f, old, F0, A, cs, vs, ps, res, dg, K, x, start, warm, det):
    """Newton's method from ``start`` if ``warm``, else from ``f = 0``, ``det`` the
    determinant to report if the start is already a solution. Returns the steps taken, whether
    it converged, the last step's Jacobian's determinant and the largest friction effort."""
    kf = f.shape[0]
    for j in range(kf):
        f[j], res[j] = (start[j] if warm else 0.0), np.nan
    its, ok, big_g = 0, False, np.nan
    for _ in range(MAX_ITERATIONS + 1):
        big_r, big_g = residuals(F0, A, cs, vs, ps, f, res, dg)
        if big_r <= TOL * max(big_g, 1e-300):   # converged: no Jacobian formed
            ok = True
            break
        for j in range(kf):
            old[j] = f[j]
        det_step = newton_step(A, dg, f, res, K, x)
        f_ok = True
        for j in range(kf):
            f_ok = f_ok and np.isfinite(f[j])
        if not f_ok:                               # a singular J: a fold, it ends here
            for j in range(kf):
                f[j] = old[j]
            break
        det = det_step
        its += 1
    return its, ok, det, big_g


def solve(model, kin, applied, units, friction_rows, qd):
    """:func:`linkdyn.friction.solve` on the compiled backend, after its inputs: ``units`` the
    unit efforts' Loads (one per friction load), ``qd`` (k, ...) their joints' rates.

    Returns
    -------
    (Loads, DynamicSolution, Reactions, Friction)
        As :func:`linkdyn.friction.solve`; the dynamics' and reactions' internals computed by
        the compiled stages under the applied loads with the friction in when first read.
    """
    dyn, react, f, iterations, state, res, big_g = _run(kin, applied, units, friction_rows, qd)
    locked = state == LOCKED
    # the load with the largest residual where it locks (a NaN residual the largest)
    lock_joint = (np.where(locked, np.argmax(np.nan_to_num(np.abs(res), nan=np.inf), axis=0),
                           -1) if locked.any() else np.full(locked.shape, -1))
    # the residual at the solution, relative to the largest friction effort of the run
    scale = np.nanmax(big_g, axis=-1, keepdims=True, initial=0.0)
    big_r = np.where(locked, np.nan, np.max(np.abs(res), axis=0, initial=0.0))
    rel = big_r / np.maximum(scale, 1e-300)
    residual = float(np.nanmax(rel, initial=0.0)) if rel.size else 0.0
    final = with_efforts(applied, kin, friction_rows, f)
    dyn, react = lazy(kin, final, dyn, react)
    return final, dyn, react, friction_of(model, friction_rows, f, qd, iterations, residual,
                                          locked, lock_joint)


def _run(kin, applied, units, friction_rows, qd):
    """The kernel over the batch: ``units`` the unit efforts' Loads (one per friction load),
    ``qd`` (k, ...) their joints' rates.

    Returns
    -------
    (DynamicSolution, Reactions, f, iterations, state, res, big_g)
        The dynamics and reactions under the applied loads and the friction (without their
        internals: :func:`lazy`), and per sample the efforts (k, ...), Newton's iterations, its
        outcome (:data:`SOLVED`, :data:`LOCKED`, :data:`NOT_ITERATED`), the residuals (k, ...)
        and the largest friction effort at the solution.
    """
    shape = kin.shape
    D, T = (shape[0] if len(shape) == 2 else 1), shape[-1]
    x = cd._inputs(kin)
    L, topo = kin.layout.view, kin.layout.topo
    k = len(friction_rows)
    w_ext = cd._applied(applied, shape)
    us = [cd._applied(u, shape) for u in units]
    Tu = max(u.shape[3] for u in us)
    units_ = cd._plain(np.stack([np.broadcast_to(u, u.shape[:3] + (Tu,)) for u in us]))
    fj = np.array([row.joint for row in friction_rows], np.int64)
    params = [[row.arm, row.arm_static, row.stiction, row.speed, row.viscous, row.preload]
              for row in friction_rows]
    Dp = max([np.size(p) for row in params for p in row] + [1])
    fp = cd._plain(np.array([[np.broadcast_to(np.asarray(p, float).reshape(-1), (Dp,))
                              for p in row] for row in params]))
    qd_ = cd._flat(qd, shape, (k,))
    on = np.zeros((kin.layout.n_joints, 3, D, T))
    lam, tau = np.zeros((topo.n_rows, D, T)), np.zeros((len(L.driven), D, T))
    ke, pivot, f = np.zeros((D, T)), np.zeros((D, T)), np.zeros((k, D, T))
    its, state = np.zeros((D, T), np.int64), np.zeros((D, T), np.int8)
    res, big_g = np.zeros((k, D, T)), np.zeros((D, T))
    _kernel(L, x["c"], x["s"], x["r"], x["e"], x["tw"], x["twd"], x["J"], w_ext, units_, fj,
            fp, qd_, on, lam, tau, ke, pivot, f, its, state, res, big_g, min(cd.BLOCK, T))
    if not topo.n_rows:   # no multiplier: the pivot is one
        pivot = np.ones((D, T))
    dyn = DynamicSolution(cd._comps(lam, shape), cd._comps(tau, shape), ke.reshape(shape),
                          pivot.reshape(shape), None)
    react = Reactions(cd._per(on, shape), None)
    return (dyn, react, f.reshape((k,) + shape), its.reshape(shape), state.reshape(shape),
            res.reshape((k,) + shape), big_g.reshape(shape))


def lazy(kin, loads, dyn, react):
    """``dyn`` and ``react`` with their internals computed by the compiled stages under
    ``loads`` (the applied loads with the friction in) when first read."""
    dyn = replace(dyn, internals=cd._Again(cd.solve, kin, loads).dynamics)
    return dyn, replace(react, internals=cd._Again(cd.reactions, kin, loads, dyn).tree)
