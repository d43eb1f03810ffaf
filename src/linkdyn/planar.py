"""Planar twist and wrench algebra, batched over leading axes.

A planar twist is ``t = [w, vx, vy]`` (angular velocity, rad/s; velocity of the reference point,
m/s) and a planar wrench ``w = [n, fx, fy]`` (moment about the reference point, N m; force, N).
Points and free vectors are ``(..., 2)`` arrays in the global frame. In the plane the
cross-product tensor of the seed paper becomes the 90-degree rotation ``perp``:
``z x a = perp(a) = [-a_y, a_x]``.
"""

from __future__ import annotations

import numpy as np


def perp(a: np.ndarray) -> np.ndarray:
    """Rotate ``a`` (..., 2) by +90 degrees: ``z x a``."""
    out = np.empty(a.shape)
    out[..., 0] = -a[..., 1]
    out[..., 1] = a[..., 0]
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Scalar planar cross product ``a x b = a_x b_y - a_y b_x``; (..., 2), (..., 2) -> (...)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot product over the last axis; (..., k), (..., k) -> (...)."""
    return np.einsum("...i,...i->...", a, b)


def rotate(phi: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Rotate local vectors ``a`` (..., 2) by angles ``phi`` (...) rad: ``R(phi) a``."""
    return rotate_cs(np.cos(phi), np.sin(phi), a)


def rotate_cs(c: np.ndarray, s: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Rotate local vectors ``a`` (..., 2) by angles given by their cosines and sines (...)."""
    out = np.empty(np.broadcast_shapes(np.shape(c), a.shape[:-1]) + (2,))
    out[..., 0] = c * a[..., 0] - s * a[..., 1]
    out[..., 1] = s * a[..., 0] + c * a[..., 1]
    return out


def twist(w: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Pack angular part (...) and linear part (..., 2) into a twist or wrench (..., 3)."""
    out = np.empty(np.broadcast_shapes(np.shape(w), v.shape[:-1]) + (v.shape[-1] + 1,))
    out[..., 0] = w
    out[..., 1:] = v
    return out


def shift_twist(t: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Twist ``t`` (..., 3) of a body at point O, expressed at point O + a: ``A(a) t``.

    ``A(a) = [[1, 0], [perp(a), 1]]`` is the planar twist-propagation matrix (eq. 2).
    """
    out = np.array(np.broadcast_to(t, np.broadcast_shapes(t.shape, a.shape[:-1] + (3,))))
    out[..., 1] -= t[..., 0] * a[..., 1]
    out[..., 2] += t[..., 0] * a[..., 0]
    return out


def shift_wrench(w: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Wrench ``w`` (..., 3) about point P, expressed about point P - a: ``A(a)^T w``.

    The moment gains ``a x f``; this is the transpose of :func:`shift_twist`, so power
    ``w . t`` is invariant.
    """
    out = np.array(np.broadcast_to(w, np.broadcast_shapes(w.shape, a.shape[:-1] + (3,))))
    out[..., 0] += cross(a, w[..., 1:])
    return out


def wrap(angle: np.ndarray) -> np.ndarray:
    """Angle wrapped into (-pi, pi]."""
    return np.arctan2(np.sin(angle), np.cos(angle))


def solve_small(K: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Solve many small systems ``K x = b`` by Gaussian elimination with partial pivoting.

    The loop runs over the (few) columns; every sample is processed at once, which is far
    faster than LAPACK's per-matrix calls for the 2x2 to 8x8 systems of linkages.

    Parameters
    ----------
    K : ndarray (..., n, n)
    b : ndarray (..., n) or (..., n, m)

    Returns
    -------
    x : ndarray, shape of ``b``
        NaN where ``K`` is numerically singular.
    pivot : ndarray (...)
        Smallest pivot magnitude relative to the largest entry of ``K``: ~0 means singular.
    """
    n = K.shape[-1]
    vec = b.ndim == K.ndim - 1
    A = np.concatenate((K, b[..., None] if vec else b), axis=-1).astype(float, copy=True)
    A, _ = np.broadcast_arrays(A, np.empty(K.shape[:-2] + (1, 1)))
    A = np.array(A)
    scale = np.max(np.abs(K), axis=(-2, -1))
    pivot = np.full(K.shape[:-2], np.inf)
    for k in range(n):
        # partial pivoting: bring the largest |A[i, k]|, i >= k, to row k
        i = k + np.argmax(np.abs(A[..., k:, k]), axis=-1)
        if np.any(i != k):
            rows = np.take_along_axis(A, i[..., None, None], axis=-2)
            rowk = A[..., k, :].copy()
            np.put_along_axis(A, i[..., None, None], rowk[..., None, :], axis=-2)
            A[..., k, :] = rows[..., 0, :]
        pk = A[..., k, k]
        pivot = np.minimum(pivot, np.abs(pk))
        with np.errstate(divide="ignore", invalid="ignore"):
            A[..., k, :] /= pk[..., None]
            f = A[..., k + 1:, k].copy()
            A[..., k + 1:, :] -= f[..., None] * A[..., k, None, :]
    # back substitution
    for k in range(n - 1, 0, -1):
        f = A[..., :k, k].copy()
        A[..., :k, n:] -= f[..., None] * A[..., k, None, n:]
    x = A[..., n:]
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = pivot / np.where(scale > 0, scale, 1.0)
    bad = ~(rel > 1e-13)
    x = np.where(bad[..., None, None], np.nan, x)
    return (x[..., 0] if vec else x), rel
