"""The compiled right-hand side of :func:`linkdyn.simulate` (docs/theory.md, F2-F8).

One numba function, :func:`rhs_kernel`, evaluates ``y' = F(t, y)`` at one state: the guess
extrapolated from the reference state, Newton's method closing the loops (F2), the rates, the
twists, the applied loads (formulas run by :func:`run_program` on their op codes,
:func:`linkdyn.expr.flatten`), then for ``qdd_f = 0`` and for each unit free acceleration the
accelerations and the DeNOC inverse dynamics (F4-F5), the free accelerations of
``H qdd_f = -h`` (F6) and the power of the drivers and non-conservative loads (F8). Every
equation is a step (:mod:`linkdyn.steps`) that the numpy path runs on arrays:
:mod:`linkdyn.kinematics.recursion`'s ``child_pose``, ``cut_frame``, ``jacobian_column``,
``child_twist``, ``child_twist_rate``, ``cut_bias``, ``cut_coordinate``, the joint kinds'
``residual``; :mod:`linkdyn.loads`' ``body_point``, ``force_at``, ``weight``, ``spring_force``,
``damper_force``; :mod:`linkdyn.dynamics.denoc`'s ``newton_euler_wrench``, ``plus_child``,
``generalized_force``, ``less_cut``; the linear systems by the LU primitives of
:mod:`linkdyn.compiled`. This file holds the loops and the data movement.

Where Newton's method from the guess does not close the loops, the kernel says so and the
caller evaluates that state by the numpy path (whose damped restart takes over).
"""

from __future__ import annotations

import math

import numpy as np

from . import expr
from . import joints as jk
from .analysis import SINGULAR
from .compiled import factor, inline, njit, substitute
from .dynamics.denoc import generalized_force, less_cut, newton_euler_wrench, plus_child
from .kinematics.compiled import PIVOT_TOL, cut_numbers
from .kinematics.positions import ACCEPT, scaled_error
from .kinematics.recursion import (child_pose, child_twist, child_twist_rate, cut_bias,
                                   cut_coordinate, cut_frame, jacobian_column)
from .kinematics.state import MAXITER, STEP_TOL
from .loads import body_point, damper_force, force_at, spring_force, weight
from .planar import turned


# load kinds (loads (L, 6): [kind, body, body2, joint, value row 1, value row 2])
LOAD_KINDS = {"force": 0, "torque": 1, "joint_torque": 2, "joint_force": 3, "spring": 4,
              "damper": 5}
FORCE, TORQUE, JOINT_TORQUE, JOINT_FORCE, SPRING, DAMPER = range(6)
OP = expr.OPCODES


# --- the formulas: a register machine over op codes -------------------------------------------

@njit
def run_program(code, value, x, reg):
    """Evaluate a flattened program (:func:`linkdyn.expr.flatten`) at the variables ``x``:
    ``reg[k]`` the value of row k (children first), as :meth:`linkdyn.expr.Expr.evaluate`
    (numpy's rules: NaN outside a function's domain, a comparison 1 or 0)."""
    for k in range(code.shape[0]):
        op, a, b, c = code[k, 0], code[k, 1], code[k, 2], code[k, 3]
        u = reg[a] if a >= 0 else 0.0
        v = reg[b] if b >= 0 else 0.0
        if op == 0:                              # num
            reg[k] = value[k]
        elif op == 1:                            # var: x[slot] / scale
            reg[k] = x[a] / value[k]
        elif op == 2:
            reg[k] = u + v
        elif op == 3:
            reg[k] = u - v
        elif op == 4:
            reg[k] = u * v
        elif op == 5:
            reg[k] = u / v
        elif op == 6:
            reg[k] = u ** v
        elif op == 7:
            reg[k] = -u
        elif op == 8:
            reg[k] = math.sin(u)
        elif op == 9:
            reg[k] = math.cos(u)
        elif op == 10:
            reg[k] = math.tan(u)
        elif op == 11:
            reg[k] = math.exp(u)
        elif op == 12:
            reg[k] = math.log(u) if u >= 0 else math.nan
        elif op == 13:
            reg[k] = math.sqrt(u) if u >= 0 else math.nan
        elif op == 14:
            reg[k] = math.sinh(u)
        elif op == 15:
            reg[k] = math.cosh(u)
        elif op == 16:
            reg[k] = math.tanh(u)
        elif op == 17:
            reg[k] = math.asin(u) if abs(u) <= 1 else math.nan
        elif op == 18:
            reg[k] = math.acos(u) if abs(u) <= 1 else math.nan
        elif op == 19:
            reg[k] = math.atan(u)
        elif op == 20:
            reg[k] = abs(u)
        elif op == 21:                           # sign: NaN stays NaN
            reg[k] = 1.0 if u > 0 else (-1.0 if u < 0 else (0.0 if u == 0 else u))
        elif op == 22:                           # min, max, clip: NaN propagates (np.minimum)
            reg[k] = u if u != u or u <= v else v
            reg[k] = math.nan if v != v else reg[k]
        elif op == 23:
            reg[k] = u if u != u or u >= v else v
            reg[k] = math.nan if v != v else reg[k]
        elif op == 24:
            w = reg[c]
            m = math.nan if u != u or v != v else (u if u >= v else v)
            reg[k] = math.nan if m != m or w != w else (m if m <= w else w)
        elif op == 25:                           # where(condition, a, b)
            reg[k] = v if u != 0 else reg[c]
        elif op == 26:
            reg[k] = 1.0 if u < v else 0.0
        elif op == 27:
            reg[k] = 1.0 if u <= v else 0.0
        elif op == 28:
            reg[k] = 1.0 if u > v else 0.0
        else:
            reg[k] = 1.0 if u >= v else 0.0


# --- the stages of one state -------------------------------------------------------------------

# The stages read the layout's view ``L`` (:attr:`linkdyn.kinematics.layout.Layout.view`) by
# name, its one design (index 0 of the design axis).

@njit
def _place(L, q, phi, c, s, r, e):
    """Poses of all bodies from the tree coordinates ``q`` (:func:`child_pose`)."""
    for i in range(1, L.parent.shape[0]):
        p, code, sign = L.parent[i], L.kind[i], float(L.sign[i])
        turn = (math.cos(sign * q[i]), math.sin(sign * q[i])) if L.angular[i] else (1.0, 0.0)
        ph, co, si, o, ax = child_pose(code, sign, q[i], turn, L.angle[i, 0],
                                       (L.axis[i, 0, 0], L.axis[i, 1, 0]),
                                       (L.joint_point[i, 0, 0], L.joint_point[i, 1, 0]),
                                       phi[p], c[p], s[p], (r[p, 0], r[p, 1]))
        phi[i], c[i], s[i], r[i, 0], r[i, 1], e[i, 0], e[i, 1] = ph, co, si, o[0], o[1], ax[0], ax[1]


@njit
def _frames(L, c, s, r, P):
    """Every cut's points on its bodies and its axis, global (:func:`cut_frame`): ``P``
    (nc, 8) rows ``[r_Pa, r_Pb, e_a, e_b]``."""
    for k in range(L.cut_a.shape[0]):
        a, b = L.cut_a[k], L.cut_b[k]
        r_pa, r_pb, e_a = cut_frame(c[a], s[a], (r[a, 0], r[a, 1]), c[b], s[b],
                                    (r[b, 0], r[b, 1]), (L.cut_pa[k, 0, 0], L.cut_pa[k, 1, 0]),
                                    (L.cut_pb[k, 0, 0], L.cut_pb[k, 1, 0]),
                                    (L.cut_axis[k, 0, 0], L.cut_axis[k, 1, 0]))
        P[k, 0], P[k, 1], P[k, 2], P[k, 3], P[k, 4], P[k, 5] = (r_pa[0], r_pa[1], r_pb[0],
                                                                 r_pb[1], e_a[0], e_a[1])
        P[k, 6], P[k, 7] = e_a[2], e_a[3]


@inline
def _axes(P, k):
    """Cut k's axes ``(e_a, e_b)`` from its rows of ``P`` (:func:`_frames`)."""
    return (P[k, 4], P[k, 5], P[k, 6], P[k, 7])


@njit
def _residual(L, phi, P, g):
    """The closure residual ``g`` (n_rows,) (the kinds' ``residual``); returns it scaled, the
    largest row with the metres over the size (:func:`~linkdyn.kinematics.positions.scaled_error`)."""
    err, size = 0.0, L.size[0]
    for k in range(L.cut_a.shape[0]):
        a, b, row, rows = L.cut_a[k], L.cut_b[k], L.cut_row[k], L.cut_rows[k]
        x = jk.residual(L.cut_kind[k], cut_numbers(L, k, 0),
                        jk.frame((P[k, 0], P[k, 1]), (P[k, 2], P[k, 3]), _axes(P, k)),
                        phi[a], phi[b])
        for j in range(rows):
            g[row + j] = x[j]
            err = scaled_error(err, x[j], L.cut_metres[k, j] != 0, size)
    return err


@njit
def _jacobian(L, r, e, P, J):
    """The closure Jacobian ``J`` (n_rows, n - 1) (:func:`jacobian_column`)."""
    J[:, :] = 0.0
    for k in range(L.cut_a.shape[0]):
        row, rows = L.cut_row[k], L.cut_rows[k]
        for j in range(1, L.parent.shape[0]):
            if L.side[k, j] == 0:
                continue
            x = jacobian_column(L.cut_kind[k], cut_numbers(L, k, 0), L.kind[j],
                                float(L.sign[j]), L.side[k, j], (e[j, 0], e[j, 1]),
                                (r[j, 0], r[j, 1]), (P[k, 0], P[k, 1]), (P[k, 2], P[k, 3]),
                                _axes(P, k))
            for m in range(rows):
                J[row + m, j - 1] = x[m]


@njit
def _twists(L, r, e, qd, tw):
    """Twists of all bodies (:func:`child_twist`, eq. 2)."""
    for i in range(1, L.parent.shape[0]):
        p = L.parent[i]
        tw[i, 0], tw[i, 1], tw[i, 2] = child_twist(
            L.kind[i], float(L.sign[i]), (e[i, 0], e[i, 1]),
            (tw[p, 0], tw[p, 1], tw[p, 2]), (r[p, 0], r[p, 1]), (r[i, 0], r[i, 1]), qd[i])


@njit
def _twist_rates(L, r, e, tw, qd, qdd, td):
    """Twist rates of all bodies (:func:`child_twist_rate`)."""
    for i in range(1, L.parent.shape[0]):
        p = L.parent[i]
        td[i, 0], td[i, 1], td[i, 2] = child_twist_rate(
            L.kind[i], float(L.sign[i]), (e[i, 0], e[i, 1]),
            (tw[p, 0], tw[p, 1], tw[p, 2]), (td[p, 0], td[p, 1], td[p, 2]),
            (tw[i, 0], tw[i, 1], tw[i, 2]), (r[p, 0], r[p, 1]), (r[i, 0], r[i, 1]), qd[i],
            qdd[i])


@njit
def _bias(L, r, tw, td, P, b):
    """Minus the rate of the cut rows, ``-d/dt (S x)`` (:func:`cut_bias`), into ``b``."""
    for k in range(L.cut_a.shape[0]):
        a, bb, row, rows = L.cut_a[k], L.cut_b[k], L.cut_row[k], L.cut_rows[k]
        x = cut_bias(L.cut_kind[k], cut_numbers(L, k, 0), _axes(P, k),
                     (tw[a, 0], tw[a, 1], tw[a, 2]), (td[a, 0], td[a, 1], td[a, 2]),
                     (r[a, 0], r[a, 1]), (tw[bb, 0], tw[bb, 1], tw[bb, 2]),
                     (td[bb, 0], td[bb, 1], td[bb, 2]), (r[bb, 0], r[bb, 1]),
                     (P[k, 0], P[k, 1]), (P[k, 2], P[k, 3]))
        for m in range(rows):
            b[row + m, 0] = -x[m]


@njit
def _joint_motion(L, phi, r, tw, P, jq, jqd):
    """Coordinate and rate of every model joint: a tree joint's from the tree coordinates
    (already in ``jq``, ``jqd`` by the caller), a cut joint's by :func:`cut_coordinate`."""
    for k in range(L.cut_a.shape[0]):
        a, b = L.cut_a[k], L.cut_b[k]
        x = cut_coordinate(L.cut_kind[k], cut_numbers(L, k, 0), _axes(P, k), phi[a],
                           (tw[a, 0], tw[a, 1], tw[a, 2]), (0.0, 0.0, 0.0), (r[a, 0], r[a, 1]),
                           phi[b], (tw[b, 0], tw[b, 1], tw[b, 2]), (0.0, 0.0, 0.0),
                           (r[b, 0], r[b, 1]), (P[k, 0], P[k, 1]), (P[k, 2], P[k, 3]))
        jq[L.cut_joint[k]], jqd[L.cut_joint[k]] = x[0], x[1]


@njit
def _add(w, i, x):
    """``w[i] += x`` for a wrench ``x``."""
    w[i, 0] += x[0]
    w[i, 1] += x[1]
    w[i, 2] += x[2]


@njit
def _loads(L, loads, lnum, roots, reg, c, s, r, tw, jqd, w):
    """Applied wrenches ``w`` (n, 3) about each O_i (the ground's row is not used) and the
    potential energy and power of the loads (loads.wrenches), the formulas' values in ``reg``
    (``roots`` (L, 2) their rows)."""
    pe, power = 0.0, 0.0
    w[:, :] = 0.0
    gravity = (L.gravity[0, 0], L.gravity[1, 0])
    if gravity[0] != 0 or gravity[1] != 0:
        for i in range(1, L.parent.shape[0]):
            r_c, _ = body_point(c[i], s[i], (r[i, 0], r[i, 1]), (tw[i, 0], tw[i, 1], tw[i, 2]),
                                (L.com[i, 0, 0], L.com[i, 1, 0]))
            f, pe_i = weight(L.mass[i, 0], gravity, r_c)
            _add(w, i, force_at(f, (r[i, 0], r[i, 1]), r_c))
            pe += pe_i
    for m in range(loads.shape[0]):
        kind, i, j = loads[m, 0], loads[m, 1], loads[m, 2]
        x = reg[roots[m, 0]]
        r_i, r_j = (r[i, 0], r[i, 1]), (r[j, 0], r[j, 1])
        p1, v1 = body_point(c[i], s[i], r_i, (tw[i, 0], tw[i, 1], tw[i, 2]),
                            (lnum[m, 0], lnum[m, 1]))
        if kind == FORCE:
            f = (x, reg[roots[m, 1]])
            _add(w, i, force_at(f, r_i, p1))
            power += f[0] * v1[0] + f[1] * v1[1]
        elif kind == TORQUE:
            w[i, 0] += x
            power += x * tw[i, 0]
        elif kind == JOINT_TORQUE or kind == JOINT_FORCE:
            if kind == JOINT_TORQUE:   # x on the joint's second body, -x on its first
                w[i, 0] += x
                w[j, 0] -= x
            else:   # x e at the second body's point, -x e on the first, e = R_a axis
                ex, ey = turned(c[j], s[j], (lnum[m, 4], lnum[m, 5]))
                _add(w, i, force_at((x * ex, x * ey), r_i, p1))
                _add(w, j, force_at((-(x * ex), -(x * ey)), r_j, p1))
            power += x * jqd[loads[m, 3]]
        else:
            p2, v2 = body_point(c[j], s[j], r_j, (tw[j, 0], tw[j, 1], tw[j, 2]),
                                (lnum[m, 2], lnum[m, 3]))
            if kind == SPRING:
                f, pe_m, _ = spring_force(lnum[m, 6], lnum[m, 7], p1, p2)
                pe += pe_m
            else:
                f, pw, _ = damper_force(lnum[m, 8], p1, v1, p2, v2)
                power += pw
            _add(w, i, force_at(f, r_i, p1))
            _add(w, j, force_at((-f[0], -f[1]), r_j, p2))
    return pe, power


@njit
def _inverse_dynamics(L, c, s, r, e, tw, td, w_ext, wt, Q):
    """``Q`` (n,) of the motion ``tw``, ``td`` under ``w_ext``: Newton–Euler
    (:func:`newton_euler_wrench`), the backward recursion (:func:`plus_child`) and
    :func:`generalized_force`; returns the kinetic energy."""
    n, ke = L.parent.shape[0], 0.0
    for i in range(1, n):
        x, ke_i = newton_euler_wrench(L.mass[i, 0], L.inertia[i, 0],
                                      (L.com[i, 0, 0], L.com[i, 1, 0]), c[i], s[i],
                                      (tw[i, 0], tw[i, 1], tw[i, 2]),
                                      (td[i, 0], td[i, 1], td[i, 2]),
                                      (w_ext[i, 0], w_ext[i, 1], w_ext[i, 2]))
        wt[i, 0], wt[i, 1], wt[i, 2] = x
        ke += ke_i
    wt[0, :] = 0.0
    for i in range(n - 1, 0, -1):
        p = L.parent[i]
        wt[p, 0], wt[p, 1], wt[p, 2] = plus_child((wt[p, 0], wt[p, 1], wt[p, 2]),
                                                  (wt[i, 0], wt[i, 1], wt[i, 2]),
                                                  (r[i, 0], r[i, 1]), (r[p, 0], r[p, 1]))
    for i in range(1, n):
        Q[i] = generalized_force(L.kind[i], float(L.sign[i]), (e[i, 0], e[i, 1]),
                                 (wt[i, 0], wt[i, 1], wt[i, 2]))
    return ke


# --- the kernel --------------------------------------------------------------------------------

@njit
def rhs_kernel(held, loads, lnum, roots, code, value, t0, t, y, drv, ext, ref, S, o_y, o_state,
               o_J, o_e):
    """``y' = F(t, y)`` (F7) at one state, ``y = [q_f, qd_f, W]``.

    Parameters
    ----------
    held : numba typed List
        Of one item, ``L``: the partition's layout as the kernels read it
        (:attr:`.kinematics.layout.Layout.view`, one design; ``L.driven`` the independent tree
        bodies, drivers' then free, ``L.dependent`` the dependent ones), held in a list so that
        a call passes one object, not the view's forty arrays (:class:`Kernel`).
    loads, lnum, roots, code, value
        The loads (:func:`_loads`) and their formulas' program (:func:`run_program`), whose
        variables are ``[t, q of each joint, qd of each joint, ext]``.
    t, y : float, (2 nf + 1,)
        The state.
    drv : float (3, nd)
        The drivers' coordinates, rates and accelerations at ``t``.
    ext : float (E,)
        Values of the loads that are functions of time only, at ``t``, where they have no
        formula.
    t0 : float
        The reference state's time.
    ref : float (3, n)
        The reference state's tree coordinates, rates and accelerations at ``t0``; ``S``
        (m, k) the dependent coordinates' share of the independent ones there (0 x 0: none).
    o_y : float (2 nf + 1,)
        ``y'``; ``o_state`` (3, n) the tree coordinates, rates and accelerations; ``o_J``
        (n_rows, n - 1) the closure Jacobian; ``o_e`` (2,) the kinetic and potential energy.

    Returns
    -------
    int
        0: done (``y'`` NaN where the state is singular); 1: Newton's method from the guess
        did not close the loops (nothing written: the caller takes the numpy path).
    """
    L = held[0]
    ind, dep = L.driven, L.dependent
    n, m, k_ind, nc = L.parent.shape[0], dep.shape[0], ind.shape[0], L.cut_a.shape[0]
    nd = drv.shape[1]
    nf = k_ind - nd
    nj = n - 1 + nc   # the model's joints: every one is a tree joint or a cut joint
    size = L.size[0]
    # the guess: the reference extrapolated, its dependent rows moved by their share of the
    # independent coordinates' deviation from the extrapolation                     (F2)
    dt = t - t0
    q = np.empty(n)
    for i in range(n):
        q[i] = ref[0, i] + ref[1, i] * dt + 0.5 * ref[2, i] * dt ** 2
    q_ind = np.empty(k_ind)
    for j in range(nd):
        q_ind[j] = drv[0, j]
    for j in range(nf):
        q_ind[nd + j] = y[j]
    if S.shape[0] > 0:
        dev = np.empty(k_ind)
        for j in range(k_ind):
            dev[j] = q_ind[j] - q[ind[j]]
        for a in range(m):
            acc = 0.0
            for j in range(k_ind):
                acc += S[a, j] * dev[j]
            q[dep[a]] += acc
    for j in range(k_ind):
        q[ind[j]] = q_ind[j]
    # positions: Newton's method on the dependent coordinates until a step is below STEP_TOL
    phi, c, s = np.zeros(n), np.ones(n), np.zeros(n)
    r, e = np.zeros((n, 2)), np.zeros((n, 2))
    P = np.zeros((nc, 8))
    g = np.zeros(m)
    J = o_J
    A = np.empty((m, m, 1))
    perm = np.empty((m, 1), np.int64)
    rel = np.empty(1)
    b, x = np.empty((m, 1)), np.empty((m, 1))
    _place(L, q, phi, c, s, r, e)
    _frames(L, c, s, r, P)
    err = _residual(L, phi, P, g)
    if m > 0:
        for _ in range(MAXITER):
            _jacobian(L, r, e, P, J)
            for a in range(m):
                b[a, 0] = -g[a]
                for k in range(m):
                    A[a, k, 0] = J[a, dep[k] - 1]
            factor(A, m, 1, perm, rel)
            substitute(A, perm, rel, m, 1, b, x, 0.0)
            step = 0.0
            for a in range(m):
                # Newton's step in rad, or in m relative to the size
                u = abs(x[a, 0]) * (1.0 if L.angular[dep[a]] else 1.0 / size)
                step = math.nan if u != u or step != step else max(step, u)
            # a step of a radian or the mechanism's size is no correction of a nearby guess
            for a in range(m):
                if math.isfinite(x[a, 0]) and step < 1.0:
                    q[dep[a]] += x[a, 0]
            _place(L, q, phi, c, s, r, e)
            _frames(L, c, s, r, P)
            err = _residual(L, phi, P, g)
            if not step > STEP_TOL:
                break
    if not err <= ACCEPT:
        return 1
    _jacobian(L, r, e, P, J)
    # rates: J_dep qd_dep = -J_ind qd_ind                                          (eqs. 4-5)
    qd = np.zeros(n)
    for j in range(nd):
        qd[ind[j]] = drv[1, j]
    for j in range(nf):
        qd[ind[nd + j]] = y[nf + j]
    piv_kin, piv_dyn = 1.0, 1.0
    At = np.empty((m, m, 1))
    perm_t = np.empty((m, 1), np.int64)
    rel_t = np.ones(1)
    if m > 0:
        for a in range(m):
            acc = 0.0
            for j in range(k_ind):
                acc += J[a, ind[j] - 1] * qd[ind[j]]
            b[a, 0] = -acc
            for k in range(m):
                A[a, k, 0] = J[a, dep[k] - 1]
                At[a, k, 0] = J[k, dep[a] - 1]
        factor(A, m, 1, perm, rel)
        piv_kin = rel[0]
        substitute(A, perm, rel, m, 1, b, x, PIVOT_TOL)
        for a in range(m):
            qd[dep[a]] = x[a, 0]
        # J_dep^T for the multipliers, factored once for every acceleration case      (eq. 27)
        factor(At, m, 1, perm_t, rel_t)
        piv_dyn = rel_t[0]
    tw, td = np.zeros((n, 3)), np.zeros((n, 3))
    _twists(L, r, e, qd, tw)
    # the loads: formulas of t and the joints' motion, then the wrenches
    jq, jqd = np.zeros(nj), np.zeros(nj)
    for i in range(1, n):
        jq[L.tree_joint[i]], jqd[L.tree_joint[i]] = q[i], qd[i]
    _joint_motion(L, phi, r, tw, P, jq, jqd)
    xv = np.empty(1 + 2 * nj + ext.shape[0])
    xv[0] = t
    xv[1:1 + nj], xv[1 + nj:1 + 2 * nj], xv[1 + 2 * nj:] = jq, jqd, ext
    reg = np.empty(code.shape[0])
    run_program(code, value, xv, reg)
    w_ext = np.zeros((n, 3))
    pe, power = _loads(L, loads, lnum, roots, reg, c, s, r, tw, jqd, w_ext)
    # 1 + nf acceleration cases: qdd_f = 0, then each unit free acceleration        (F5)
    qdd = np.zeros((1 + nf, n))
    tau = np.zeros((k_ind, 1 + nf))
    wt, Q, lam = np.zeros((n, 3)), np.zeros(n), np.zeros((m, 1))
    ok = math.isfinite(piv_kin)
    for cs in range(1 + nf):
        qdd_c = qdd[cs]
        for j in range(nd):
            qdd_c[ind[j]] = drv[2, j]
        if cs > 0:
            qdd_c[ind[nd + cs - 1]] = 1.0
        # J_dep qdd_dep = -bias(qdd_dep = 0)                                       (eqs. 6-7)
        _twist_rates(L, r, e, tw, qd, qdd_c, td)
        if m > 0:
            _bias(L, r, tw, td, P, b)
            substitute(A, perm, rel, m, 1, b, x, PIVOT_TOL)
            for a in range(m):
                qdd_c[dep[a]] = x[a, 0]
            _twist_rates(L, r, e, tw, qd, qdd_c, td)
        for i in range(n):
            ok = ok and math.isfinite(qd[i]) and math.isfinite(qdd_c[i])
        # the DeNOC inverse dynamics: Q, then J_dep^T lam = Q_dep, tau = Q_ind - J_ind^T lam
        ke = _inverse_dynamics(L, c, s, r, e, tw, td, w_ext, wt, Q)
        if cs == 0:
            o_e[0], o_e[1] = ke, pe
        if m > 0:
            for a in range(m):
                b[a, 0] = Q[dep[a]]
            substitute(At, perm_t, rel_t, m, 1, b, lam, PIVOT_TOL)
        for j in range(k_ind):
            col, tau_j = ind[j] - 1, Q[ind[j]]
            for k in range(nc):   # one cut's share at a time: tau = Q_ind - J_ind^T lam
                row, rows = L.cut_row[k], L.cut_rows[k]
                tau_j = less_cut(tau_j, (J[row, col], J[row + 1, col] if rows > 1 else 0.0,
                                         J[row + 2, col] if rows > 2 else 0.0),
                                 (lam[row, 0], lam[row + 1, 0] if rows > 1 else 0.0,
                                  lam[row + 2, 0] if rows > 2 else 0.0))
            tau[j, cs] = tau_j
    # tau_f = H qdd_f + h; no actuator in a free joint: H qdd_f = -h              (F4-F6)
    qdd_f = np.zeros(nf)
    if nf == 1:
        qdd_f[0] = -tau[nd, 0] / (tau[nd, 1] - tau[nd, 0])
    elif nf > 1:
        H = np.empty((nf, nf, 1))
        hb, hx = np.empty((nf, 1)), np.empty((nf, 1))
        hperm, hrel = np.empty((nf, 1), np.int64), np.empty(1)
        for a in range(nf):
            hb[a, 0] = -tau[nd + a, 0]
            for k in range(nf):
                H[a, k, 0] = tau[nd + a, 1 + k] - tau[nd + a, 0]
        factor(H, nf, 1, hperm, hrel)
        substitute(H, hperm, hrel, nf, 1, hb, hx, PIVOT_TOL)
        for a in range(nf):
            qdd_f[a] = hx[a, 0]
    # the drivers' efforts at the solution and the power balance                  (F8)
    for j in range(nd):
        eff = tau[j, 0]
        for k in range(nf):
            eff += (tau[j, 1 + k] - tau[j, 0]) * qdd_f[k]
        power += eff * drv[1, j]
    ok = ok and piv_kin > SINGULAR and piv_dyn > SINGULAR
    for k in range(nf):
        o_y[k] = y[nf + k]
        o_y[nf + k] = qdd_f[k] if ok else math.nan
    o_y[2 * nf] = power
    # the tree state at the solution (accelerations affine in qdd_f)
    for i in range(n):
        o_state[0, i], o_state[1, i] = q[i], qd[i]
        acc = qdd[0, i]
        for k in range(nf):
            acc += qdd_f[k] * (qdd[1 + k, i] - qdd[0, i])
        o_state[2, i] = acc
    return 0


# --- the layout and the loads as the kernel's arrays ------------------------------------------

def tables(part) -> dict:
    """The kernel's arrays of a simulation's partition (:class:`linkdyn.forward.Partition`):
    its layout's view (``view``, :attr:`linkdyn.kinematics.layout.Layout.view`, one design)
    and its loads' tables (:func:`_load_tables`)."""
    lay = part.layout
    out = dict(view=_held(lay.view))
    out.update(_load_tables(lay, len(part.inner.joints)))
    return {k: np.ascontiguousarray(v) if isinstance(v, np.ndarray) else v
            for k, v in out.items()}


def _held(view):
    """The view in a numba typed List of one item (the kernel then unboxes one object per call;
    the view itself without numba)."""
    try:
        from numba.typed import List
    except ImportError:  # pragma: no cover
        return [view]
    held = List()
    held.append(view)
    return held


def _load_tables(lay, n_joints: int) -> dict:
    """The loads of layout ``lay`` as the kernel's ``loads``, ``lnum``, ``roots``, and their
    formulas' program ``code``, ``value``; ``external``: the loads whose value is a function of
    time without a formula (evaluated by the caller into ``ext``)."""
    slots = {"t": (0, 1.0)}
    rows, nums, formulas, external = [], [], [], []
    for m, row in enumerate(lay.loads):
        f = row.values[0]
        comps = getattr(f, "components", None)
        state = {name: (1 + k * n_joints + joint, unit)
                 for name, joint, k, unit in getattr(f, "state", ())}
        slots.update(state)
        count = 2 if row.kind == "force" else 1
        if row.kind in ("spring", "damper"):   # no value: their constants
            parts = [0.0]
        elif comps is not None and all(isinstance(x, (expr.Expr, float, int)) for x in comps):
            parts = list(comps)
        else:   # an opaque function of time: its values come in ``ext``
            parts = []
            for k in range(count):
                name = f"__ext{len(external)}"
                slots[name] = (1 + 2 * n_joints + len(external), 1.0)
                external.append((m, k))
                parts.append(expr.Expr("var", (name,)))
        roots = list(range(len(formulas), len(formulas) + len(parts)))
        formulas.extend(parts)
        p1 = lay.points[row.body][row.point] if row.point else np.zeros(2)
        p2 = lay.points[row.body2][row.point2] if row.point2 else np.zeros(2)
        axis = np.zeros(2) if row.axis is None else row.axis
        rows.append([LOAD_KINDS[row.kind], row.body, max(row.body2, 0), row.joint,
                     roots[0], roots[-1]])
        nums.append([*p1, *p2, *axis, float(row.stiffness), float(row.free_length),
                     float(row.damping)])
    code, value, at = expr.flatten(formulas, slots) if formulas else (
        np.zeros((0, 4), np.int64), np.zeros(0), np.zeros(0, np.int64))
    loads = np.array(rows, np.int64).reshape(-1, 6)
    roots = at[loads[:, 4:6]] if len(rows) else np.zeros((0, 2), np.int64)
    return dict(loads=loads[:, :4].copy(), lnum=np.array(nums, float).reshape(-1, 9),
                roots=np.ascontiguousarray(roots), code=code, value=value, external=external)


class Kernel:
    """The compiled right-hand side of one partition: its arrays, and :meth:`__call__`."""

    def __init__(self, part):
        self.part = part
        tab = tables(part)
        self.external = tab.pop("external")
        self.args = tuple(tab[k] for k in ("view", "loads", "lnum", "roots", "code", "value"))
        self.nd = part.n_drivers
        n, rows = part.layout.topo.n, len(part.layout.topo.dependent)
        self.noS = np.zeros((0, 0))
        self.drv_none = np.zeros((3, 0))
        self.ext_none = np.zeros(0)
        self.state = np.zeros((3, n))
        self.J = np.zeros((rows, n - 1))
        self.energy = np.zeros(2)

    def __call__(self, t: float, y: np.ndarray, ref) -> np.ndarray | None:
        """``y'`` (2 nf + 1,) at ``(t, y)`` from the reference ``ref`` = ``(t0, q, qd, qdd,
        S)`` (``System.ref``), else None where Newton's method from the guess does not close
        the loops; :attr:`state` (3, n) and :attr:`J` hold the tree state and the closure
        Jacobian of the last call, :attr:`energy` its kinetic and potential energy."""
        from .kinematics.positions import driver_values
        t0, q, qd, qdd, S = ref
        drv = self.drv_none
        if self.nd:
            drv = np.ascontiguousarray(np.stack(driver_values(self.part.model, np.array([t])))
                                       [:, :, 0])
        ext = self.ext_none
        if self.external:
            lay, tt = self.part.layout, np.array([float(t)])
            ext = np.array([np.reshape(lay.load_values(lay.loads[m], tt), -1)[k]
                            for m, k in self.external])
        out = np.empty(len(y))
        status = rhs_kernel(*self.args, float(t0), float(t),
                            np.ascontiguousarray(y, dtype=float), drv, ext,
                            np.stack((q, qd, qdd)),
                            self.noS if S is None else np.ascontiguousarray(S), out,
                            self.state, self.J, self.energy)
        return out if status == 0 else None
