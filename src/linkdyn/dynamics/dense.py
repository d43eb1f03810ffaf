"""Slow explicit-matrix reference of the DeNOC inverse dynamics, for tests only.

This module forms every matrix of the seed paper's method explicitly, one sample at a time (a
Python loop over samples, which the production code never has), and solves the resulting square
systems with :func:`numpy.linalg.solve`. It shares no code with the recursions of
:mod:`linkdyn.dynamics.denoc` and :mod:`linkdyn.reactions`; it only reads the positions, twists
and twist rates of a :class:`~linkdyn.kinematics.KinematicSolution` and the applied wrenches
``w_ext`` of :func:`linkdyn.loads.wrenches`.

Planar reduction (``docs/theory.md``): a twist is ``[w, vx, vy]`` at a body's reference point O_i
(its tree joint's point), a wrench ``[n, fx, fy]`` about O_i, and every 6x6 block of the paper
becomes 3x3. With ``n`` bodies in tree order (index 0 = ground, not part of the stacked vectors),
the stacked generalized twist has ``3 (n - 1)`` rows and the tree joint rates ``n - 1``.

Matrices (per sample)
---------------------
``A(a)``
    Twist-propagation matrix (eq. 2): the twist at O, expressed at O + a,
    ``A(a) = [[1, 0, 0], [-a_y, 1, 0], [a_x, 0, 1]]``; ``A(a)^T`` carries a wrench about O + a to
    one about O.
``N_l``
    Block lower-triangular (eq. 9): block ``(i, j) = A(r_i - r_j)`` when joint j lies on the
    tree path from the ground to body i (``j = i`` included), zero otherwise.
``N_d``
    Block-diagonal (eq. 9), column i is the joint-motion propagation vector ``p_i`` (eq. 3)
    given by the joint's kind (:meth:`linkdyn.joints.JointKind.motion_vector`): revolute
    ``[s, 0, 0]``, prismatic ``[0, s e]``, ``s = +1`` if body i is the joint's second body.
    ``N = N_l N_d`` (eq. 8) maps the tree joint rates to the stacked twists.
``M``
    Block-diagonal generalized mass about O_i (eq. 10),
    ``M_i = [[I_O, -m d_y, m d_x], [-m d_y, m, 0], [m d_x, 0, m]]`` with ``d`` from O_i to the
    mass centre and ``I_O = I_C + m |d|^2``.
``W M E t``
    Coupling term (eq. 10-12): ``E_i = diag(1, 0, 0)`` keeps the angular rate,
    ``W_i = [[0, 0, 0], [0, 0, -w], [0, w, 0]]`` is ``w x`` acting on the force rows, so the
    term is ``[0, -m w^2 d]``.
``S_c``, ``G_c``, ``J``
    For a cut joint c between bodies a (first) and b (second), at the second body's point P:
    the cut-row selection ``S_c`` (rows x 3, the kind's :meth:`~linkdyn.joints.JointKind.selection`;
    revolute: ``[[0, 1, 0], [0, 0, 1]]``; prismatic: ``[[1, 0, 0], [0, n_x, n_y]]``; slot:
    ``[[0, n_x, n_y]]``, with ``n`` the axis normal, fixed in a). ``G_c = U_b^T A(P - r_b)^T S_c^T
    - U_a^T A(P - r_a)^T S_c^T`` places the cut wrench ``S_c^T lam`` on b (and its opposite on
    a) about their O's, so ``w^lam = G lam`` (eqs. 16-19), and ``J = G^T N`` is the constraint
    Jacobian ``S [A_{P,j} p_j ...]`` of eqs. (20-24).
``D``
    Driver selection (eqs. 25-26): ``D[k, d] = 1`` when tree joint k is driven by driver d.

Equations
---------
- Eq. (27): ``[J^T | D] [lam; tau] = N^T (M td + W M E t - w_ext)``, square because the mobility
  equals the number of drivers.
- Reactions: each body's wrench balance about O_i,
  ``M_i td_i + W_i M_i E_i t_i - w_ext_i - w^lam_i = R_i - sum_{children c} A(r_c - r_i)^T R_c``,
  stacked as ``B R = w_star - w^lam`` and solved at once, ``w^lam`` placing each cut's contact
  wrench ``W_c`` (the kind's :meth:`~linkdyn.joints.JointKind.contact`: ``S_c^T lam_c``, and
  for a gear or a rack its radial tooth force, which does no work while the tree holds the
  centre distance, so ``G lam`` in eq. (27) is unchanged) as ``G`` places ``S_c^T lam``; ``R_i`` is the wrench the parent
  exerts on body i through its tree joint (driver effort included), about O_i.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kinematics import KinematicSolution
from .. import joints as jk
from ..model import Model


@dataclass(frozen=True)
class DenseSolution:
    """Results of the explicit-matrix solve.

    Attributes
    ----------
    tau : ndarray (..., T, n_drivers)
        Driver efforts, order of ``model.drivers``, N m or N.
    lam : ndarray (..., T, n_rows)
        Cut-joint multipliers, each cut's rows in turn: revolute ``[Fx, Fy]`` by the first body
        on the second, N; prismatic ``[M, F_n]`` (N m about the second body's point; N along the
        axis normal); slot ``[F_n]``.
    force : ndarray (..., T, n_joints, 2)
        Reaction force by each joint's first body on its second, global, N (model joint order).
    moment : ndarray (..., T, n_joints)
        Reaction moment by the first body on the second about the second body's point, N m
        (~0 for revolute joints: a residual, not forced to zero).
    twist : ndarray (..., T, n, 3)
        ``N qd`` (eq. 8) in tree order (ground row zero), for checking the kinematics.
    J : ndarray (..., T, n_rows, n - 1)
        Constraint Jacobian ``G^T N`` (eqs. 20-24).
    Q : ndarray (..., T, n - 1)
        ``N^T (M td + W M E t - w_ext)``, the right-hand side of eq. (27).
    """

    tau: np.ndarray
    lam: np.ndarray
    force: np.ndarray
    moment: np.ndarray
    twist: np.ndarray
    J: np.ndarray
    Q: np.ndarray


def propagation(a: np.ndarray) -> np.ndarray:
    """Planar twist-propagation matrix ``A(a)`` (3, 3) for the offset ``a`` (2,) (eq. 2)."""
    return np.array([[1.0, 0.0, 0.0], [-a[1], 1.0, 0.0], [a[0], 0.0, 1.0]])


def _rot(phi: float) -> np.ndarray:
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]])


def _poses(kin: KinematicSolution) -> tuple[np.ndarray, np.ndarray]:
    """Body angles (..., T, n) and reference points O_i (..., T, n, 2), tree order."""
    if hasattr(kin, "phi") and hasattr(kin, "r"):
        return np.asarray(kin.phi), np.asarray(kin.r)
    return np.asarray(kin.pose.phi), np.asarray(kin.pose.r)


def _on_path(parent: tuple[int, ...]) -> np.ndarray:
    """``path[i, j]``: body j's tree joint lies on the path from the ground to body i."""
    n = len(parent)
    path = np.zeros((n, n), dtype=bool)
    for i in range(1, n):
        j = i
        while j > 0:
            path[i, j] = True
            j = parent[j]
    return path


def solve(model: Model, kin: KinematicSolution, w_ext: np.ndarray) -> DenseSolution:
    """Driver efforts, cut-joint multipliers and all joint reactions by explicit matrices.

    Parameters
    ----------
    model : Model
    kin : KinematicSolution
        Positions, twists ``tw`` and twist rates ``twd`` (..., T, n, 3), tree order.
    w_ext : ndarray (..., T, n, 3)
        Applied wrenches about O_i (tree order), N m / N.

    Returns
    -------
    DenseSolution
    """
    topo = kin.layout.topo
    n = topo.n
    m = n - 1                       # moving bodies = tree joints
    names = topo.bodies
    path = _on_path(topo.parent)
    driven = {topo.driven[d]: d for d in range(len(model.drivers))}
    children = [[c for c in range(1, n) if topo.parent[c] == i] for i in range(n)]
    bodies = [model.body(name) for name in names]
    # O_i in body i's own frame: the point of its tree joint on it
    origin = [np.zeros(2)]
    for i in range(1, n):
        jt = model.joints[topo.tree_joint[i]]
        own = jt.point_b if jt.body_b == names[i] else jt.point_a
        origin.append(np.asarray(bodies[i].points[own], float))
    n_rows = topo.n_rows
    nj = len(model.joints)

    batch = np.shape(kin.valid)       # (..., T)
    tau = np.full(batch + (len(model.drivers),), np.nan)
    lam = np.full(batch + (n_rows,), np.nan)
    force = np.full(batch + (nj, 2), np.nan)
    moment = np.full(batch + (nj,), np.nan)
    twist_out = np.full(batch + (n, 3), np.nan)
    J_out = np.full(batch + (n_rows, m), np.nan)
    Q_out = np.full(batch + (m,), np.nan)

    def blk(i):
        """Rows of body i (1..n-1) in the stacked vectors."""
        return slice(3 * (i - 1), 3 * i)

    phi_all, r_all = _poses(kin)
    tw_all, twd_all, qd_all = np.asarray(kin.tw), np.asarray(kin.twd), np.asarray(kin.qd)
    w_ext = np.asarray(w_ext, float)
    for idx in np.ndindex(*batch):
        if not kin.valid[idx]:
            continue
        phi = phi_all[idx]                # (n,)
        r = r_all[idx]                    # (n, 2)  O_i
        tw = tw_all[idx]                  # (n, 3)
        twd = twd_all[idx]                # (n, 3)

        def point(i, name):
            """Global position of body i's named point (model's body frame)."""
            local = np.asarray(bodies[i].points[name], float) - origin[i]
            return r[i] + _rot(phi[i]) @ local

        def axis(jt):
            """A joint's unit axis, fixed in its first body, global."""
            e = _rot(phi[names.index(jt.body_a)]) @ np.asarray(jt.axis, float)
            return e / np.linalg.norm(e)

        # --- DeNOC matrices N_l, N_d (eqs. 8-9) -----------------------------------------------
        N_l = np.zeros((3 * m, 3 * m))
        N_d = np.zeros((3 * m, m))
        for i in range(1, n):
            for j in range(1, n):
                if path[i, j]:
                    N_l[blk(i), blk(j)] = propagation(r[i] - r[j])
            jt = model.joints[topo.tree_joint[i]]
            s = 1.0 if jt.body_b == names[i] else -1.0
            # p_i (eq. 3): revolute [s, 0, 0], prismatic [0, s e]
            N_d[blk(i), i - 1] = jk.get(jt.kind).motion_vector(s, axis(jt), 0)
        N = N_l @ N_d

        # tree joint rates in tree order; N qd must reproduce the twists (eq. 8)
        qd_tree = np.array([qd_all[idx][topo.tree_joint[i]] for i in range(1, n)])
        twist_out[idx][0] = 0.0
        twist_out[idx][1:] = (N @ qd_tree).reshape(m, 3)

        # --- generalized mass M and W M E t (eqs. 10-12) ---------------------------------------
        M = np.zeros((3 * m, 3 * m))
        WMEt = np.zeros(3 * m)
        for i in range(1, n):
            mass = float(bodies[i].mass)
            d = _rot(phi[i]) @ (np.asarray(bodies[i].com, float) - origin[i])
            i_o = bodies[i].inertia + mass * d @ d
            M_i = np.array([[i_o, -mass * d[1], mass * d[0]],
                            [-mass * d[1], mass, 0.0],
                            [mass * d[0], 0.0, mass]])
            w = tw[i, 0]
            W_i = np.array([[0.0, 0.0, 0.0], [0.0, 0.0, -w], [0.0, w, 0.0]])
            E_i = np.diag([1.0, 0.0, 0.0])
            M[blk(i), blk(i)] = M_i
            WMEt[blk(i)] = W_i @ M_i @ E_i @ tw[i]
        td = twd[1:].reshape(-1)
        w_star = M @ td + WMEt - w_ext[idx][1:].reshape(-1)

        # --- cut joints: S_c, G_c and J = G^T N (eqs. 16-24) -----------------------------------
        G = np.zeros((3 * m, n_rows))
        cut_args = []
        for k, j in enumerate(topo.cut):
            jt = model.joints[j]
            kind = jk.get(jt.kind)
            a, b = names.index(jt.body_a), names.index(jt.body_b)
            P = point(b, jt.point_b)
            # the kind's numbers and frame: its axis, d = r_Pb - r_Pa and b's x axis
            args = (kind.own(jt.numbers), axis(jt), P - point(a, jt.point_a),
                    _rot(phi[b]) @ np.array([1.0, 0.0]))
            S = kind.selection(*args)
            cut_args.append((kind, a, b, P, args))
            cols = topo.row_slice(k)
            if b > 0:
                G[blk(b), cols] += propagation(P - r[b]).T @ S.T
            if a > 0:
                G[blk(a), cols] -= propagation(P - r[a]).T @ S.T
        J = G.T @ N
        J_out[idx] = J

        # --- driver selection D (eqs. 25-26) and eq. (27) --------------------------------------
        D = np.zeros((m, len(model.drivers)))
        for i, k in driven.items():
            D[i - 1, k] = 1.0
        Q = N.T @ w_star
        Q_out[idx] = Q
        x = np.linalg.solve(np.hstack((J.T, D)), Q)
        lam_i, tau_i = x[:n_rows], x[n_rows:]
        lam[idx], tau[idx] = lam_i, tau_i

        # --- reactions: every body's wrench balance, B R = w_star - G lam ----------------------
        B = np.eye(3 * m)
        for i in range(1, n):
            for c in children[i]:
                B[blk(i), blk(c)] = -propagation(r[c] - r[i]).T
        # the cut wrenches on the bodies: the kinds' contact wrenches W_c (S_c^T lam_c, and a
        # gear's radial force) placed as G places S^T lam
        w_lam = np.zeros(3 * m)
        W = []
        for k, (kind, a, b, P, args) in enumerate(cut_args):
            W.append(kind.contact(*args, lam_i[topo.row_slice(k)]))
            if b > 0:
                w_lam[blk(b)] += propagation(P - r[b]).T @ W[k]
            if a > 0:
                w_lam[blk(a)] -= propagation(P - r[a]).T @ W[k]
        R = np.linalg.solve(B, w_star - w_lam).reshape(m, 3)

        for i in range(1, n):
            j = topo.tree_joint[i]
            jt = model.joints[j]
            p = topo.parent[i]
            if jt.body_b == names[i]:
                # child is the second body: R_i is already by A on B about B's point O_i
                w_ab = R[i - 1].copy()
            else:
                # child is the first body: by A on B = -R_i, moved to B's point (on the parent)
                P_b = point(p, jt.point_b)
                f = -R[i - 1, 1:]
                arm = r[i] - P_b
                n_b = -R[i - 1, 0] + arm[0] * f[1] - arm[1] * f[0]
                w_ab = np.array([n_b, f[0], f[1]])
            if i in driven:
                # the actuator applies tau p (p of the second body: a moment; or a force along
                # the axis through B's point) on B and -tau p on A: not part of the reaction
                w_ab -= tau_i[driven[i]] * jk.get(jt.kind).motion_vector(1.0, axis(jt), 0)
            force[idx][j] = w_ab[1:]
            moment[idx][j] = w_ab[0]
        for k, j in enumerate(topo.cut):
            w_ab = W[k]   # on the second body, about its point
            force[idx][j] = w_ab[1:]
            moment[idx][j] = w_ab[0]

    return DenseSolution(tau, lam, force, moment, twist_out, J_out, Q_out)


__all__ = ["DenseSolution", "propagation", "solve"]
