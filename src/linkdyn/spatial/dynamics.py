"""Spatial inverse dynamics by the DeNOC method, and the joint reactions.

Every body's wrench ``w* = I_O A + crf(V) I_O V - w_ext`` (global, about O); composites
``w~_i = w*_i + sum_children w~_c`` from the leaves; the generalized forces ``Q = S^T w~``
of the tree coordinates; the driver efforts ``tau`` and the cut multipliers ``lam`` from
``[E_d, J^T] [tau; lam] = Q`` by least squares. The reactions follow body by body: the
wrench a tree joint passes to its child is ``w~_i`` less the cut wrenches on the child's
subtree. With redundant constraints ``lam`` is not unique: the reported reactions are the
minimum-norm stacked ``[F; M about q]`` of all joints among those that satisfy every body's
Newton-Euler equations (docs/theory.md, "Spatial mechanisms").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import algebra as sa
from . import kinematics as sk
from .kinematics import Motion, Plan


@dataclass(frozen=True)
class Loads:
    """Applied wrenches ``w_ext`` (T, n, 6) about O, the potential energy (T,) (gravity
    ``-m g . r_C``, springs ``k (l - l0)^2 / 2``) and the loads' power (T,) (``w_ext . V``)."""

    w_ext: np.ndarray
    potential_energy: np.ndarray
    power: np.ndarray
    #: the power (T,) of the loads that are not gravity or springs (forces, torques, dampers,
    #: loads inside joints): the rate of the work of simulate's energy balance, W
    work_power: np.ndarray = None


def mass_centres(p: Plan, m: Motion) -> np.ndarray:
    """Mass centres (T, n, 3), global."""
    return m.tree.o + sa.matvec(m.tree.R, p.com)


def inertia_times(p: Plan, m: Motion, *X):
    """Each body's spatial inertia about O times each twist (or twist rate) of ``X``, each
    (T, n, 6), global: ``I_O X = [I_c x_w + c x h; h]``, ``h = m (x_v + x_w x c)`` (the
    product :func:`~.algebra.inertia_about_origin`'s 6 x 6 matrix gives, without forming it;
    ``I_c x_w = R (I (R^T x_w))``, the centroidal tensor in the body frame)."""
    R = m.tree.R
    c = mass_centres(p, m)
    mass = np.broadcast_to(p.mass, c.shape[:-1])[..., None]
    out = []
    for x in X:
        h = mass * (x[..., 3:] + sa.cross(x[..., :3], c))
        Iw = sa.matvec(R, sa.matvec(p.inertia, sa.matvec(sa.transpose(R), x[..., :3])))
        out.append(np.concatenate([Iw + sa.cross(c, h), h], -1))
    return out


def point_of(p: Plan, m: Motion, body: str, r_local: np.ndarray):
    """A body point's position, velocity and acceleration (T, 3) each, global (``r_local``
    (3,), or (N, 3) at a batch's rows)."""
    i = p.topo.bodies.index(body)
    r = m.tree.o[:, i] + sa.matvec(m.tree.R[:, i], r_local)
    return r, sa.point_velocity(m.V[:, i], r), sa.point_acceleration(m.V[:, i], m.A[:, i], r)


def _number(p: Plan, model, f):
    """``f(model)``; at a batch's rows (``Plan.row``) each row's design's, (N, ...)."""
    if p.row is None:
        return f(model)
    return np.asarray([f(x) for x in p.models], float)[p.row]


def _value(p: Plan, model, k: int, t: np.ndarray, motion):
    """The value of load ``k`` at the times ``t`` (T,) (``motion``: the joints' coordinates
    and rates, for formulas in ``q_``/``qd_``); at a batch's rows each design's own, on its
    rows (``t`` then the rows' times)."""
    def one(mod, sl):
        v = mod.loads[k].value
        if v is None:
            return None
        if getattr(v, "state_variables", ()):
            return v(t[sl], tuple([None if x is None else x[sl] for x in part]
                                  for part in motion))
        return v(t[sl])
    if p.row is None:
        return one(model, slice(None))
    edges = np.flatnonzero(np.diff(p.row)) + 1
    blocks = zip(np.concatenate([[0], edges]), np.concatenate([edges, [len(p.row)]]))
    parts = [one(p.models[p.row[a]], slice(a, b)) for a, b in blocks]
    return None if parts[0] is None else np.concatenate(parts)


def loads(model, p: Plan, m: Motion, coords: dict) -> Loads:
    """Gravity and every load of ``model`` as wrenches on the bodies. ``coords``: the joints'
    coordinates (:func:`kinematics.joint_coordinates`), for formulas in ``q_``/``qd_``. At a
    batch's rows (``Plan.row``) every number of a load is each row's design's."""
    T, n = m.q.shape[0], p.topo.n
    w = np.zeros((T, n, 6))
    c = mass_centres(p, m)
    g = _number(p, model, lambda x: np.asarray(x.gravity, float))[..., None, :]
    # gravity: m g at the mass centre
    w += sa.force_wrench(p.mass[..., None] * g, c)
    pe = -np.sum(p.mass * np.sum(c * g, -1), -1)
    names = [jt.name for jt in model.joints]
    # the joints' coordinates and rates, for formulas in q_/qd_ (when a load has one)
    motion = (([coords[x][0][:, 0] if coords[x][0].shape[1] == 1 else None for x in names],
               [coords[x][1][:, 0] if coords[x][1].shape[1] == 1 else None for x in names])
              if any(getattr(ld.value, "state_variables", ()) for ld in model.loads) else None)
    conservative = w.copy()            # gravity's and the springs' wrenches
    idx = p.topo.bodies.index
    for k, load in enumerate(model.loads):
        value = _value(p, model, k, m.t, motion)
        b = idx(load.body)

        def point(x, k=k, which="point"):     # a load's end point on its body, body frame
            ld = x.loads[k]
            return (x.body(ld.body).points[ld.point] if which == "point"
                    else x.body(ld.body2).points[ld.point2])
        if load.kind == "force":           # F at the point: [r x F; F]
            r, _, _ = point_of(p, m, load.body, _number(p, model, point))
            w[:, b] += sa.force_wrench(value, r)
        elif load.kind == "torque":        # a couple [T; 0]
            w[:, b] += sa.free_vector(value, True)
        elif load.kind in ("spring", "damper"):
            r1, v1, _ = point_of(p, m, load.body, _number(p, model, point))
            r2, v2, _ = point_of(p, m, load.body2,
                                 _number(p, model, lambda x: point(x, which="point2")))
            d = r2 - r1
            length = np.linalg.norm(d, axis=-1)
            u = d / np.where(length > 0, length, 1.0)[:, None]
            if load.kind == "spring":      # tension k (l - l0) pulls the ends together
                stiffness = _number(p, model, lambda x, k=k: x.loads[k].stiffness)
                stretch = length - _number(p, model, lambda x, k=k: x.loads[k].free_length)
                tension = stiffness * stretch
                pe = pe + 0.5 * stiffness * stretch ** 2
            else:                          # c dl/dt
                tension = (_number(p, model, lambda x, k=k: x.loads[k].damping)
                           * np.sum(u * (v2 - v1), -1))
            w[:, b] += sa.force_wrench(tension[:, None] * u, r1)
            w[:, idx(load.body2)] -= sa.force_wrench(tension[:, None] * u, r2)
            if load.kind == "spring":
                conservative[:, b] += sa.force_wrench(tension[:, None] * u, r1)
                conservative[:, idx(load.body2)] -= sa.force_wrench(tension[:, None] * u, r2)
        else:                              # joint_torque / joint_force: on B, minus on A
            j = names.index(load.joint)
            jt = model.joints[j]
            pose = sk.joint_pose(p, m.tree, j, jt)
            e = sa.matvec(pose.RA, p.geometry[j].e)
            unit = (sa.free_vector(e, True) if p.kinds[j].angular
                    else sa.force_wrench(e, pose.rq))
            w[:, idx(jt.body_b)] += value[:, None] * unit
            w[:, idx(jt.body_a)] -= value[:, None] * unit
    power = np.einsum("tns,tns->t", w[:, 1:], m.V[:, 1:])
    work = power - np.einsum("tns,tns->t", conservative[:, 1:], m.V[:, 1:])
    return Loads(w, pe, power, work)


@dataclass(frozen=True)
class Dynamics:
    """Inverse dynamics at the samples: ``w_star``, ``w_tilde`` (T, n, 6), ``Q`` (T, n_q),
    driver efforts ``tau`` (T, n_d), multipliers ``lam`` (T, rows) (the ones of the
    minimum-norm reactions), ``reactions`` (T, n_joints, 6) ``[F; M about q]`` by A on B,
    the kinetic energy (T,), and ``redundancy``: the basis (T, 6 n_joints, k) of the
    reaction components statics leaves undetermined (k = 0: none)."""

    w_star: np.ndarray
    w_tilde: np.ndarray
    Q: np.ndarray
    tau: np.ndarray
    lam: np.ndarray
    reactions: np.ndarray
    kinetic_energy: np.ndarray
    undetermined: np.ndarray


def solve(model, p: Plan, m: Motion, applied: Loads) -> Dynamics:
    """DeNOC inverse dynamics and the minimum-norm reactions (module docstring)."""
    T = m.q.shape[0]
    w_star, w_tilde, Q, ke = generalized(model, p, m, applied)
    nd = len(p.driven)
    M, x, rank = efforts(p, m, Q)
    # the rank of [E_d, J^T]: the largest over each design's samples
    if p.row is None:
        r_row = np.full(T, int(np.max(rank, initial=0)))
    else:
        top = np.zeros(len(p.models), int)
        np.maximum.at(top, p.row, rank)
        r_row = top[p.row]
    r = int(np.min(r_row, initial=M.shape[2]))
    # (T, nd + rows, k); none where [E_d, J^T] has full column rank everywhere
    N = (sa.null_space(M, r) if r < M.shape[2] else np.zeros(M.shape[:1] + (M.shape[2], 0)))
    # a batch's designs of a higher rank: their extra columns zero (no part in z)
    N = N * ((r + np.arange(N.shape[2])) >= r_row[:, None])[:, None, :]
    R0 = reactions(model, p, m, w_tilde, x[:, :nd], x[:, nd:])
    if N.shape[2]:
        # the reactions of each null column (no inertia, no load): R(x_p) + G z
        zero = np.zeros((T, N.shape[2]) + w_tilde.shape[1:])
        G = reactions(model, p, m, zero, np.swapaxes(N[:, :nd], 1, 2),
                      np.swapaxes(N[:, nd:], 1, 2))              # (T, k, nj, 6)
        G = np.swapaxes(G.reshape(T, N.shape[2], -1), 1, 2)       # (T, 6 nj, k)
        z, _ = sa.lstsq(G, -R0.reshape(T, -1), 1e-10)
        x = x + np.einsum("tik,tk->ti", N, z)
        R0 = R0 + np.einsum("tik,tk->ti", G, z).reshape(R0.shape)
        basis = _range(G)
    else:
        basis = np.zeros((T, R0.shape[1] * 6, 0))
    return Dynamics(w_star, w_tilde, Q, x[:, :nd], x[:, nd:], R0, ke, basis)


def generalized(model, p: Plan, m: Motion, applied: Loads):
    """Every body's wrench ``w*`` and composite ``w~`` (T, n, 6), the generalized forces ``Q``
    (T, n_q) of the tree coordinates and the kinetic energy (T,), J."""
    T, n = m.q.shape[0], p.topo.n
    IV, IA = inertia_times(p, m, m.V, m.A)
    # w* = I_O A + crf(V) I_O V - w_ext
    w_star = IA + sa.cross_wrench(m.V, IV) - applied.w_ext
    w_star[:, 0] = 0.0
    w_tilde = composite(p, w_star)
    # Q = S^T w~ for every tree coordinate
    Q = np.zeros((T, p.n_q))
    for i in range(1, n):
        Q[:, p.cols[i]] = np.einsum("tks,ts->tk", m.tree.S[i], w_tilde[:, i])
    return w_star, w_tilde, Q, 0.5 * np.einsum("tni,tni->t", m.V, IV)


def efforts(p: Plan, m: Motion, Q: np.ndarray):
    """``[E_d, J^T] x = Q`` (T, n_q, n_d + rows) by least squares: returns that matrix, ``x``
    (T, n_d + rows) (the independent coordinates' efforts ``tau`` first, unique where the
    mobility is the number of independent coordinates, then the multipliers) and the rank."""
    T, nd = m.q.shape[0], len(p.driven)
    M = np.concatenate([np.broadcast_to(np.eye(p.n_q)[:, p.driven], (T, p.n_q, nd)),
                        np.swapaxes(m.J, 1, 2)], 2)
    x, rank = sa.lstsq(M, Q, 1e-10)
    return M, x, rank


def composite(p: Plan, w_star: np.ndarray) -> np.ndarray:
    """``w~_i = w*_i + sum over children w~_c`` (..., n, 6), from the leaves."""
    w = w_star.copy()
    for i in range(p.topo.n - 1, 0, -1):
        w[..., p.topo.parent[i], :] += w[..., i, :]
    return w


def _range(G: np.ndarray) -> np.ndarray:
    """An orthonormal basis (T, m, k') of the column space of ``G`` (T, m, k), k' its rank
    (the largest over the samples)."""
    u, s, _ = np.linalg.svd(G, full_matrices=False)
    k = int(np.max(np.sum(s > 1e-9 * np.maximum(s[:, :1], 1e-300), axis=1)))
    return u[:, :, :k]


def reactions(model, p: Plan, m: Motion, w_tilde, tau, lam) -> np.ndarray:
    """Every joint's reaction ``[F; M about B's point q]`` (..., n_joints, 6) by A on B, from
    composite wrenches ``w_tilde`` (..., n, 6), efforts ``tau`` (..., n_d) and multipliers
    ``lam`` (..., rows); the leading axes are the samples (T,) then any batch. A cut joint's
    is ``phi lam``; a tree joint's the wrench its parent passes to the child, ``w~_i`` less
    the cut wrenches on the child's subtree, less the driver's effort, turned to A on B."""
    T = m.q.shape[0]
    extra = w_tilde.ndim - 3                              # batch axes after the samples
    ex = (slice(None),) + (None,) * extra
    anc = p.topo.ancestors
    idx = p.topo.bodies.index
    out = np.zeros(w_tilde.shape[:-2] + (len(model.joints), 6))
    sub = np.zeros_like(w_tilde)                      # cut wrenches on each body's subtree
    r0 = 0
    for j in p.topo.cut:
        jt = model.joints[j]
        k = p.kinds[j].rows
        f = np.einsum("t...r,trs->t...s", lam[..., r0:r0 + k], m.phi[:, r0:r0 + k])
        r0 += k
        a, b = idx(jt.body_a), idx(jt.body_b)
        out[..., j, :] = f
        for i in range(1, p.topo.n):
            sub[..., i, :] += (int(anc[b, i]) - int(anc[a, i])) * f
    driven = {p.topo.tree_joint[i]: d for d, i in enumerate(p.topo.driven)}
    for i in range(1, p.topo.n):
        j, s = p.topo.tree_joint[i], p.topo.sign[i]
        f = w_tilde[..., i, :] - sub[..., i, :]          # on the child, by the parent
        if j in driven:
            jt = model.joints[j]
            pose = sk.joint_pose(p, m.tree, j, jt)
            e = sa.matvec(pose.RA, p.geometry[j].e)
            unit = (sa.free_vector(e, True) if p.kinds[j].angular
                    else sa.force_wrench(e, pose.rq))             # the effort's wrench on B
            f = f - s * tau[..., driven[j], None] * unit[ex]
        out[..., j, :] = s * f
    # [n_O; f] -> [F; M about B's point]
    for j, jt in enumerate(model.joints):
        rq = m.tree.o[:, idx(jt.body_b)] + sa.matvec(m.tree.R[:, idx(jt.body_b)], p.geometry[j].q)
        F, M = sa.wrench_about(out[..., j, :], rq[ex])
        out[..., j, :] = np.concatenate([F, M], -1)
    return out
