"""Spatial (6-D) vector algebra in global coordinates, referred to the global origin O.

As spatial_v2 (Featherstone) writes it: a twist ``V = [w; v_O]`` (angular velocity, and the
velocity of the body point passing through O), a wrench ``W = [n_O; f]`` (moment about O,
force). The power is ``W . V``. Arrays are sample-first: a vector ``(..., 3)``, a twist or
wrench ``(..., 6)``, a matrix ``(..., 3, 3)`` or ``(..., 6, 6)``; every function broadcasts
over the leading axes. Poses are rotation matrices (body frame to global); unit quaternions
only for output (:func:`quaternion`).
"""

from __future__ import annotations

import numpy as np


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a x b`` (..., 3), broadcast over the leading axes (by components: numpy's cross costs
    several times more on the small stacks of one evaluation)."""
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack(np.broadcast_arrays(a1 * b2 - a2 * b1, a2 * b0 - a0 * b2,
                                        a0 * b1 - a1 * b0), -1)


def skew(u: np.ndarray) -> np.ndarray:
    """``[u]x`` (..., 3, 3) with ``[u]x v = u x v``."""
    z = np.zeros_like(u[..., 0])
    x, y, w = u[..., 0], u[..., 1], u[..., 2]
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1),
                     np.stack([-y, x, z], -1)], -2)


def vee(m: np.ndarray) -> np.ndarray:
    """The vector of the skew part of ``m`` (..., 3, 3): ``vee((M - M^T) / 2)``."""
    return 0.5 * np.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0],
                           m[..., 1, 0] - m[..., 0, 1]], -1)


def rotation(axis: np.ndarray, angle) -> np.ndarray:
    """Rodrigues: the rotation (..., 3, 3) by ``angle`` (rad, (...)) about the unit ``axis``
    (3,) or (..., 3): ``R = I + sin a [e]x + (1 - cos a) [e]x^2``, with ``[e]x^2 = e e^T -
    (e . e) I`` (formed once for a fixed axis)."""
    angle = np.asarray(angle, float)
    axis = np.asarray(axis, float)
    k = skew(axis)
    k2 = axis[..., :, None] * axis[..., None, :] - np.sum(axis * axis, -1)[..., None, None] \
        * np.eye(3)
    s, c = np.sin(angle)[..., None, None], np.cos(angle)[..., None, None]
    return np.eye(3) + s * k + (1 - c) * k2


def rotation_vector(r: np.ndarray) -> np.ndarray:
    """The rotation (3, 3) of the rotation vector ``r`` (3,), rad (its norm the angle)."""
    a = float(np.linalg.norm(r))
    return np.eye(3) if a == 0 else rotation(np.asarray(r) / a, a)


def angle_about(r: np.ndarray, e: np.ndarray) -> np.ndarray:
    """The angle (...) of a rotation ``r`` (..., 3, 3) about its axis ``e`` (..., 3), rad in
    (-pi, pi]: ``atan2(e . vee(R), (tr R - 1) / 2)`` (exact for a rotation about e)."""
    return np.arctan2(np.sum(e * vee(r), -1), 0.5 * (np.trace(r, axis1=-2, axis2=-1) - 1))


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a . b`` over the last axis."""
    return np.sum(a * b, -1)


def matvec(m: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``m x`` (..., k) for ``m`` (..., k, l) and ``x`` (..., l)."""
    return np.einsum("...ij,...j->...i", m, x)


def transpose(m: np.ndarray) -> np.ndarray:
    """``m^T`` (..., l, k) of ``m`` (..., k, l)."""
    return np.swapaxes(m, -1, -2)


def crm(v: np.ndarray) -> np.ndarray:
    """The twist cross operator (..., 6, 6): ``crm(V) U = V x U`` (rate of a twist ``U``
    carried by a body moving with ``V``): ``[[w]x, 0], [[v]x, [w]x]]``."""
    w, u = skew(v[..., :3]), skew(v[..., 3:])
    z = np.zeros_like(w)
    return np.concatenate([np.concatenate([w, z], -1), np.concatenate([u, w], -1)], -2)


def crf(v: np.ndarray) -> np.ndarray:
    """The wrench cross operator (..., 6, 6): ``crf(V) = -crm(V)^T``."""
    return -np.swapaxes(crm(v), -1, -2)


def cross_twist(v: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``crm(V) U`` without the matrix: ``[w x u_w; w x u_v + v x u_w]``."""
    w, vo = v[..., :3], v[..., 3:]
    return np.concatenate([cross(w, u[..., :3]),
                           cross(w, u[..., 3:]) + cross(vo, u[..., :3])], -1)


def cross_wrench(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """``crf(V) F`` without the matrix: ``[w x n + v x f; w x f]``."""
    w, vo = v[..., :3], v[..., 3:]
    return np.concatenate([cross(w, f[..., :3]) + cross(vo, f[..., 3:]),
                           cross(w, f[..., 3:])], -1)


def line_screw(u: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The unit twist of a rotation about the line through ``c`` along ``u`` (..., 3):
    ``[u; c x u]`` (a revolute freedom)."""
    return np.concatenate([u, cross(c, u)], -1)


def force_wrench(f: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The wrench of a force ``f`` acting at the point ``c`` (..., 3): ``[c x f; f]``."""
    n = cross(c, f)
    return np.concatenate([n, np.broadcast_to(f, n.shape)], -1)


def free_vector(u: np.ndarray, angular: bool) -> np.ndarray:
    """``[u; 0]`` (angular: a couple, or a rotation's twist without translation) or ``[0; u]``
    (a translation along ``u``, a prismatic freedom)."""
    z = np.zeros_like(u)
    return np.concatenate([u, z] if angular else [z, u], -1)


def point_velocity(v: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Velocity (..., 3) of the body point at ``r`` of a body moving with twist ``V``:
    ``v_O + w x r``."""
    return v[..., 3:] + cross(v[..., :3], r)


def point_acceleration(v: np.ndarray, a: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Acceleration (..., 3) of the body point at ``r`` from the twist ``V`` and its rate
    ``A = dV/dt`` (about the fixed O): ``a_O + alpha x r + w x (v_O + w x r)``."""
    return a[..., 3:] + cross(a[..., :3], r) + cross(v[..., :3], point_velocity(v, r))


def inertia_about_origin(mass, com: np.ndarray, inertia: np.ndarray) -> np.ndarray:
    """Spatial inertia (..., 6, 6) about O of a body of ``mass`` (kg, (...)), mass centre
    ``com`` (..., 3) global and centroidal inertia ``inertia`` (..., 3, 3) global:
    ``[[I_c + m [c]x [c]x^T, m [c]x], [m [c]x^T, m 1]]``."""
    m = np.asarray(mass, float)[..., None, None]
    cx = skew(com)
    ct = np.swapaxes(cx, -1, -2)
    return np.concatenate([np.concatenate([inertia + m * cx @ ct, m * cx], -1),
                           np.concatenate([m * ct, m * np.eye(3)], -1)], -2)


def wrench_about(f: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A wrench ``[n_O; f]`` (..., 6) as its force (..., 3) and moment about the point ``r``:
    ``n_r = n_O - r x f``."""
    return f[..., 3:], f[..., :3] - cross(r, f[..., 3:])


def quaternion(r: np.ndarray) -> np.ndarray:
    """Unit quaternions ``[w, x, y, z]`` (T, 4) of rotations ``r`` (T, 3, 3), continuous in
    the sample order (each the sign nearer its predecessor) and ``w >= 0`` at the first."""
    tr = np.trace(r, axis1=-2, axis2=-1)
    # Shepperd's method: from the largest of 4 w^2, 4 x^2, 4 y^2, 4 z^2
    d = np.stack([1 + tr, 1 + 2 * r[..., 0, 0] - tr, 1 + 2 * r[..., 1, 1] - tr,
                  1 + 2 * r[..., 2, 2] - tr], -1)
    k = np.argmax(d, -1)
    s = np.sqrt(np.maximum(np.take_along_axis(d, k[..., None], -1)[..., 0], 1e-300))
    pairs = {  # 4 q_k q_j for each j, given q_k
        0: (d[..., 0], r[..., 2, 1] - r[..., 1, 2], r[..., 0, 2] - r[..., 2, 0],
            r[..., 1, 0] - r[..., 0, 1]),
        1: (r[..., 2, 1] - r[..., 1, 2], d[..., 1], r[..., 0, 1] + r[..., 1, 0],
            r[..., 0, 2] + r[..., 2, 0]),
        2: (r[..., 0, 2] - r[..., 2, 0], r[..., 0, 1] + r[..., 1, 0], d[..., 2],
            r[..., 1, 2] + r[..., 2, 1]),
        3: (r[..., 1, 0] - r[..., 0, 1], r[..., 0, 2] + r[..., 2, 0], r[..., 1, 2] + r[..., 2, 1],
            d[..., 3])}
    q = np.zeros(r.shape[:-2] + (4,))
    for j, comps in pairs.items():
        q = np.where((k == j)[..., None], np.stack(comps, -1) / (2 * s[..., None]), q)
    q /= np.linalg.norm(q, axis=-1, keepdims=True)
    # continuity: flip where the sign jumps from the previous sample; w >= 0 at the first
    # (over the finite samples: a gap, NaN, is skipped)
    ok = np.all(np.isfinite(q), -1) if q.ndim == 2 else None
    if q.ndim == 2 and np.any(ok):
        f = q[ok]
        flips = np.sum(f[1:] * f[:-1], -1) < 0
        sign = np.concatenate([[1.0 if f[0, 0] >= 0 else -1.0], np.where(flips, -1.0, 1.0)])
        q[ok] = f * np.cumprod(sign)[:, None]
    return q


#: a square system is solved by Gaussian elimination (partial pivoting) where its smallest
#: pivot is at least this fraction of its largest; elsewhere by the SVD
PIVOT = 1e-6
#: a tall system (more rows than columns) by its normal equations where their pivots are
#: within this of each other (so ``cond(a)^2`` times rounding stays below 1e-12)
TALL_PIVOT = 1e-3


class Solver:
    """The stacked systems ``a x = b`` (``a`` (..., m, n)) factored once, for one or more
    right-hand sides: minimum-norm least-squares solutions, singular values below ``rcond``
    times the largest of each system dropped.

    A square system whose elimination is well conditioned (its pivots within :data:`PIVOT`
    of each other) is solved by Gaussian elimination with partial pivoting, vectorized over
    the stack (a Python loop over the n columns; about 20 times cheaper than the SVD for
    n = 15): it has full rank and its one solution is the least-squares one. A tall system
    (m > n) by the same elimination of its normal equations ``a^T a x = a^T b`` where their
    pivots are within :data:`TALL_PIVOT` of each other (full column rank, well conditioned:
    its one least-squares solution). Every other system (wide, or near a loss of rank) by
    the SVD, as :func:`lstsq` always did.

    Attributes
    ----------
    rank : ndarray of int (...)
        Each system's rank (n where elimination served).
    """

    def __init__(self, a: np.ndarray, rcond: float = 1e-10):
        self.lead, (m, n) = a.shape[:-2], a.shape[-2:]
        N = int(np.prod(self.lead))
        A = a.reshape((N, m, n))
        ok = np.zeros(N, bool)
        self.tall = m > n
        if m >= n and n and N:
            self.A = A
            self.lu, self.perm, piv = _lu(np.swapaxes(A, -1, -2) @ A if self.tall else A)
            ok = np.min(piv, 0) >= (TALL_PIVOT if self.tall else PIVOT) * np.max(piv, 0)
            ok &= np.max(piv, 0) > 0
        self.ok = ok
        # the systems the SVD solves (none of an empty matrix: x = 0, rank 0)
        self.rows = np.flatnonzero(~ok) if m and n else np.zeros(0, int)
        rank = np.full(N, min(m, n))
        if len(self.rows):
            u, s, vt = np.linalg.svd(A[self.rows], full_matrices=False)
            keep = s > rcond * s[..., :1]
            self.svd = (u, np.where(keep, 1.0 / np.where(keep, s, 1.0), 0.0), vt)
            rank[self.rows] = np.sum(keep, -1)
        self.rank = rank.reshape(self.lead)
        self.n = n

    def solve(self, b: np.ndarray) -> np.ndarray:
        """The solutions (..., n) or (..., n, k) for ``b`` (..., m) or (..., m, k)."""
        vec = b.ndim == len(self.lead) + 1
        B = (b[..., None] if vec else b)
        B = B.reshape((len(self.ok),) + B.shape[-2:])
        x = np.zeros((len(B), self.n, B.shape[-1]))
        if np.any(self.ok):
            rhs = np.swapaxes(self.A, -1, -2) @ B if self.tall else B
            x[self.ok] = _lu_solve(self.lu, self.perm, rhs)[self.ok]
        if len(self.rows):
            u, inv, vt = self.svd
            x[self.rows] = np.swapaxes(vt, -1, -2) @ (inv[..., None] * (
                np.swapaxes(u, -1, -2) @ B[self.rows]))
        x = x.reshape(self.lead + x.shape[-2:])
        return x[..., 0] if vec else x


def _block(n: int) -> int:
    """Samples per block of the eliminations: a block's n x n matrices stay in the cache."""
    return int(np.clip((1 << 18) // (n * n), 256, 8192))


def _lu(A: np.ndarray):
    """Gaussian elimination with partial pivoting of the N systems ``A`` (N, n, n), block by
    block of samples (each block's matrices turned to samples-last, (n, n, K), so that every
    step is a pass over the samples): returns the factors ``L\\U`` (n, n, N), the row swapped
    with row j at step j (n, N) and the pivots' magnitudes (n, N)."""
    n, N = A.shape[-1], len(A)
    F = np.empty((n, n, N))
    perm = np.empty((n, N), dtype=np.intp)
    piv = np.empty((n, N))
    step = _block(n)
    with np.errstate(divide="ignore", invalid="ignore"):
        for a in range(0, N, step):
            G = np.moveaxis(A[a:a + step], 0, -1).copy()   # (n, n, K)
            every = np.arange(G.shape[-1])
            for j in range(n):
                p = j + np.argmax(np.abs(G[j:, j]), axis=0)
                perm[j, a:a + step] = p
                row = G[p, :, every].T                       # (n, K): row p of each system
                G[p, :, every] = G[j].T
                G[j] = row
                d = G[j, j]
                piv[j, a:a + step] = np.abs(d)
                if j + 1 < n:
                    l = G[j + 1:, j] / np.where(d == 0, 1.0, d)
                    G[j + 1:, j] = l
                    G[j + 1:, j + 1:] -= l[:, None, :] * G[j, None, j + 1:]
            F[..., a:a + step] = G
    return F, perm, piv


def _lu_solve(F: np.ndarray, perm: np.ndarray, B: np.ndarray) -> np.ndarray:
    """The solutions (N, n, k) of the factored systems (:func:`_lu`) for ``B`` (N, n, k)."""
    n, N = F.shape[0], F.shape[-1]
    out = np.empty(B.shape)
    step = _block(n)
    with np.errstate(divide="ignore", invalid="ignore"):
        for a in range(0, N, step):
            G, P = F[..., a:a + step], perm[:, a:a + step]
            Y = np.moveaxis(B[a:a + step], 0, -1).copy()   # (n, k, K)
            every = np.arange(Y.shape[-1])
            for j in range(n):                             # the row swaps, in their order
                row = Y[P[j], :, every].T
                Y[P[j], :, every] = Y[j].T
                Y[j] = row
            for j in range(n - 1):                         # L y = P b
                Y[j + 1:] -= G[j + 1:, j, None, :] * Y[j, None]
            for j in range(n - 1, -1, -1):                 # U x = y
                if j + 1 < n:
                    Y[j] -= np.einsum("in,ikn->kn", G[j, j + 1:], Y[j + 1:])
                Y[j] /= G[j, j]
            out[a:a + step] = np.moveaxis(Y, -1, 0)
    return out


def lstsq(a: np.ndarray, b: np.ndarray, rcond: float = 1e-10):
    """Minimum-norm least-squares solutions of the stacked systems ``a x = b``
    (:class:`Solver`).

    ``a`` (..., m, n), ``b`` (..., m) or (..., m, k). Singular values below ``rcond`` times
    the largest of each system are dropped. Returns ``(x, rank)``: the solutions and each
    system's rank (...)."""
    f = Solver(a, rcond)
    return f.solve(b), f.rank


def null_space(a: np.ndarray, rank: int, rcond: float = 1e-10) -> np.ndarray:
    """An orthonormal basis (..., n, n - rank) of the null space of ``a`` (..., m, n), given
    its rank (the same for every system of the stack)."""
    _, _, vt = np.linalg.svd(a, full_matrices=True)
    return np.swapaxes(vt[..., rank:, :], -1, -2)
