"""Compiled continuation nodes of a mechanism of dyads: each node's loops closed in closed form
and its dependent rates, for :func:`.positions.follow` on the compiled backend.

The numpy path (:func:`.positions._follow_dyads`) closes every node at once with
:func:`.dyads.solve` and solves ``J_dep qd_dep = -J_drv qd_drv`` (eqs. 4-5) by
:func:`.recursion.dependent_rates`: a few hundred array passes over (designs x nodes). This
kernel does the same per node, with the block helpers of the kinematics kernel
(:mod:`.compiled`: ``_place``, ``_close``, ``_cut_frames``, ``_jacobian``, the LU of
``J_dep``), which call the same steps (:func:`.recursion.child_pose`, the dyads' shape steps,
:func:`.recursion.jacobian_column`), then unwinds the dependent angles along the nodes by the
same step as the numpy path (:func:`.positions.unwrap_step`). It writes only what the branch
keeps: the coordinates, the dependent rates and which nodes close; the poses and the Jacobian
are scratch.

A mechanism whose loops are not all dyads (a cam's) has its nodes followed by
:func:`follow` (:func:`.compiled.newton` node by node, with the nodes' rates and
accelerations for the samples' quintic Hermite guesses); its samples are closed by the
kinematics kernel itself (:func:`.compiled.run` with ``newton=True``: Newton's method in each
block, from the guesses the nodes give, :func:`.state.close`'s Newton stage), and the samples
it leaves open by :func:`.state.close` (its damped restart).
"""

from __future__ import annotations

import math

import numpy as np

from ..compiled import njit
from .compiled import (BLOCK, _bias, _close, _coordinates, _cut_frames, _driven_rhs,
                       _factor_dep, _jacobian, _place, _solve_dep, _twist_rates, _twists, fixed,
                       newton, scratch)
from .layout import Layout
from .positions import ACCEPT, unwrap_step


@njit
def kernel(L, modes, q, qd_drv, q0, k_zero, x, ok, phi, c, s, r, e, J, block):
    """Close the loops of the layout whose view is ``L`` (:attr:`.Layout.view`) at the
    coordinates ``q`` (n, D, K) in place, dyad by dyad in the
    assembly ``modes`` (n_dyads, D) (the dependent coordinates of ``q`` are the guess that
    sets their winding, the driven ones the drivers' values), and write the dependent rates
    for the driver rates ``qd_drv`` (n_drivers, D, K) into ``x[dep]`` (n, D, K; NaN where
    ``J_dep`` is singular). ``ok`` (D, K): the node closes and its rates are finite. Then the
    dependent angles are unwound along the nodes from the assembly ``q0`` (n, D) at node
    ``k_zero`` (t = 0; :func:`.positions.unwrap_step`), NaN where a node is not ``ok``.
    ``phi`` ... ``J``: zeroed scratch shaped as the kinematics kernel's outputs
    (:func:`.compiled.run`)."""
    dep, drv = L.dependent, L.driven
    n, nd = len(L.parent), len(dep)
    D, K = q.shape[1], q.shape[2]
    cq, sq, up, low, rhs, P, A, sol, col, perm, _ = scratch(n, len(L.cut_a), nd, J.shape[0],
                                                            block)
    path = np.zeros(K)
    for d in range(D):
        for k0 in range(0, K, block):
            nb = min(block, K - k0)
            ks = slice(k0, k0 + nb)
            for i in range(1, n):   # cosines and sines of the guess's joint angles
                _coordinates(L, i, q[i, d, ks], q[i, d, ks], cq[i], sq[i], nb)
            # design d's numbers, and its nodes in the arrays at d, k0
            _place(L, d, d, k0, nb, q, cq, sq, phi, c, s, r, e)
            _close(L, modes, d, d, k0, nb, q, phi, c, s, r, e, up, low)
            _cut_frames(L, d, d, k0, nb, c, s, r, P, False)
            _jacobian(L, d, d, k0, nb, r, e, P, J)
            # rates: J_dep qd_dep = -J_drv qd_drv                           (eqs. 4-5)
            _driven_rhs(drv, nd, J, d, ks, qd_drv, d, ks, nb, rhs)
            if nd:
                _factor_dep(dep, J, d, k0, nb, A, perm, col)
                _solve_dep(dep, A, perm, col, d, k0, nb, rhs, x, sol)
        ok_d = ok[d]   # the node closes and its rates are finite
        for k in range(K):
            ok_d[k] = True
            for m in range(nd):
                i = dep[m]
                ok_d[k] = ok_d[k] & math.isfinite(q[i, d, k]) & math.isfinite(x[i, d, k])
        for m in range(nd):   # unwind along the nodes, anchored at the assembly (t = 0)
            i = dep[m]
            if not L.angular[i]:
                continue
            q_i = q[i, d]
            path[0] = 0.0
            for k in range(1, K):
                path[k] = path[k - 1] + unwrap_step(ok_d[k - 1], ok_d[k], q_i[k - 1], q_i[k])
            for k in range(K):
                q_i[k] = q0[i, d] + path[k] - path[k_zero] if ok_d[k] else math.nan


def close(lay: Layout, Q: np.ndarray, qd_drv: np.ndarray, modes, q0: np.ndarray, k0: int):
    """The nodes' coordinates ``Q`` (n, ..., K) closed in the dyads' assembly ``modes`` (each
    (..., 1)) with their dependent angles unwound from the assembly ``q0`` (n, ...) at node
    ``k0``, the dependent rates (n_dep, ..., K) for the driver rates ``qd_drv``
    (n_drivers, ..., K), and whether each node closes with finite rates (..., K): what
    :func:`.positions._follow_dyads` gives by :func:`.dyads.solve`,
    :func:`.recursion.dependent_rates` and :func:`.positions.unwrap_step`, by :func:`kernel`."""
    topo, L = lay.topo, lay.view
    n, K = topo.n, Q.shape[-1]
    D = max(lay.designs, 1)
    batch = Q.shape[1:]
    q = np.array(np.broadcast_to(Q.reshape(n, -1, K), (n, D, K)), dtype=float)   # a copy
    drv = L.driven
    # the inputs as one array type, so that the kernel compiles once (compiled.fixed)
    qd = fixed(np.broadcast_to(qd_drv.reshape(len(drv), -1, K), (len(drv), D, K)).astype(float))
    start = fixed(np.broadcast_to(q0.reshape(n, -1), (n, D)).astype(float))
    md = np.zeros((len(modes), D))
    for k, m in enumerate(modes):
        md[k] = np.reshape(m, -1)
    x, ok = np.zeros((n, D, K)), np.zeros((D, K), np.bool_)
    scratch = [np.zeros(shape + (D, K)) for shape in ((n,), (n,), (n,), (n, 2), (n, 2),
                                                       (topo.n_rows, n - 1))]
    kernel(L, fixed(md), q, qd, start, int(k0), x, ok, *scratch, min(BLOCK, K))
    return (q.reshape((n,) + batch), x[L.dependent].reshape((-1,) + batch),
            ok.reshape(batch))


@njit
def follow_kernel(L, Q, QD, QDD, qd_drv, qdd_drv, times, alive, phi, c, s, r, e, J, tw, td,
                  err):
    """Newton continuation of the layout whose view is ``L`` through the node ``times`` (K,),
    design by design, node by node, as :func:`.positions._continuation`: at each node the
    predictor ``q_dep += qd_dep dt`` from the last, Newton's method on the loops
    (:func:`.compiled.newton`), the dependent rates ``J_dep qd_dep = -J_drv qd_drv``
    (eqs. 4-5) and accelerations ``J_dep qdd_dep = -bias`` (eqs. 6-7; for the samples'
    quintic Hermite guesses, :meth:`.positions.Branch.guess`). ``Q`` (n, D, K): node 0's
    dependent rows the start, every node's driven rows the drivers' values; written in place,
    with the rates into ``QD`` and the accelerations into ``QDD`` (n, D, K; their driven rows
    the drivers' rates ``qd_drv`` and accelerations ``qdd_drv`` (n_drivers, D, K)).
    ``alive`` (D, K): the node closes (scaled residual at most ``ACCEPT``) with finite rates
    and accelerations; from a design's first node that does not, its nodes are NaN. ``phi``
    ... ``err``: zeroed scratch shaped as the kinematics kernel's outputs
    (:func:`.compiled.run`, T = K)."""
    dep, drv = L.dependent, L.driven
    n, nd = len(L.parent), len(dep)
    D, K = Q.shape[1], Q.shape[2]
    cq, sq, _, _, rhs, P, A, sol, col, perm, _ = scratch(n, len(L.cut_a), nd, J.shape[0], 1)
    one = np.int64(1)
    for d in range(D):
        dead = False
        for k in range(K):
            ks = slice(k, k + 1)
            kk = np.int64(k)
            if k and not dead:   # the predictor from the last node
                for m in range(nd):
                    i = dep[m]
                    Q[i, d, k] = Q[i, d, k - 1] + QD[i, d, k - 1] * (times[k] - times[k - 1])
            if not dead:
                for i in range(1, n):
                    _coordinates(L, i, Q[i, d, ks], Q[i, d, ks], cq[i], sq[i], one)
                # the corrector, its steps unlimited as :func:`.positions.newton`'s
                newton(L, d, kk, one, Q, cq, sq, phi, c, s, r, e, J, P, rhs, err, A, perm, col,
                       sol, math.inf)
                _jacobian(L, d, d, kk, one, r, e, P, J)
                _driven_rhs(drv, nd, J, d, ks, qd_drv, d, ks, one, rhs)
                if nd:
                    _factor_dep(dep, J, d, kk, one, A, perm, col)
                    _solve_dep(dep, A, perm, col, d, kk, one, rhs, QD, sol)
                    # accelerations: J_dep qdd_dep = -bias(qdd_dep = 0)    (eqs. 6-7)
                    _twists(L, d, kk, one, r, e, QD, tw)
                    for m in range(nd):
                        QDD[dep[m], d, k] = 0.0
                    _twist_rates(L, d, kk, one, r, e, tw, QD, QDD, td)
                    _bias(L, d, d, kk, one, r, tw, td, P, rhs)
                    for m in range(nd):
                        rhs[m, 0] = -rhs[m, 0]
                    _solve_dep(dep, A, perm, col, d, kk, one, rhs, QDD, sol)
                ok = err[d, k] <= ACCEPT
                for m in range(nd):
                    ok = ok and math.isfinite(QD[dep[m], d, k]) and math.isfinite(
                        QDD[dep[m], d, k])
                dead = not ok
            alive[d, k] = not dead
            if dead:
                for i in range(n):
                    Q[i, d, k], QD[i, d, k], QDD[i, d, k] = math.nan, math.nan, math.nan


def follow(lay: Layout, q_start: np.ndarray, times: np.ndarray):
    """:func:`.positions._continuation` by :func:`follow_kernel`: the branch from ``q_start``
    (n, ...) followed through the node ``times`` (K,). Returns node coordinates and rates
    (n, ..., K), the last node time (...) where the loops still close (NaN: none) and the
    node accelerations (n, ..., K)."""
    topo, L = lay.topo, lay.view
    n, K = topo.n, len(times)
    batch = q_start.shape[1:]
    D = max(lay.designs, 1)
    drv = list(topo.driven)
    nq, nqd, nqdd = lay.driver_values(times)
    Q = np.array(np.broadcast_to(q_start.reshape(n, -1, 1), (n, D, K)), dtype=float)
    Q[drv] = np.broadcast_to(nq.reshape(len(drv), -1, K), (len(drv), D, K))
    qd, qdd = (fixed(np.broadcast_to(x.reshape(len(drv), -1, K), (len(drv), D, K)).astype(
        float)) for x in (nqd, nqdd))
    QD, QDD = np.zeros((n, D, K)), np.zeros((n, D, K))
    QD[drv], QDD[drv] = qd, qdd
    alive = np.zeros((D, K), np.bool_)
    scratch_ = [np.zeros(shape + (D, K)) for shape in ((n,), (n,), (n,), (n, 2), (n, 2),
                                                        (topo.n_rows, n - 1), (n, 3), (n, 3))]
    follow_kernel(L, Q, QD, QDD, qd, qdd, fixed(np.asarray(times, float)), alive, *scratch_,
                  np.zeros((D, K)))
    last = np.where(alive.any(axis=-1), np.asarray(times, float)[
        np.maximum(alive.sum(axis=-1) - 1, 0)], np.nan)
    return (Q.reshape(q_start.shape + (K,)), QD.reshape(q_start.shape + (K,)),
            last.reshape(batch), QDD.reshape(q_start.shape + (K,)))
