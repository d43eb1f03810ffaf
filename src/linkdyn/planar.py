"""Planar twist and wrench algebra on component-first arrays.

Inside the solvers a planar vector is an array ``(2, ...)``, a twist ``t = [w, vx, vy]`` and a
wrench ``w = [n, fx, fy]`` are arrays ``(3, ...)``: the component axis comes *first*, so each
component is a contiguous array over all samples and every operation runs at full vector speed.
(Results handed to users are re-stacked with components last, see ``DESIGN.md``.) A constant
local vector may be given as a plain ``(2,)`` array: it broadcasts.

In the plane the cross-product tensor of the seed paper becomes the 90-degree rotation ``perp``:
``z x a = perp(a) = [-a_y, a_x]``; a twist seen from another point is ``A(a) t`` and a wrench
carried back is ``A(a)^T w`` (eq. 2).
"""

from __future__ import annotations

import numpy as np


def _empty(k: int, *parts) -> np.ndarray:
    """An output of k components over the broadcast shape of ``parts`` (written in place by the
    kernels below, so no component is copied twice)."""
    return np.empty((k,) + np.broadcast_shapes(*(np.shape(x) for x in parts)))


def perp(a: np.ndarray) -> np.ndarray:
    """Rotate ``a`` (2, ...) by +90 degrees: ``z x a``."""
    out = _empty(2, a[0])
    np.negative(a[1], out=out[0, ...])
    out[1] = a[0]
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Scalar planar cross product ``a x b = a_x b_y - a_y b_x``; (2, ...), (2, ...) -> (...)."""
    return a[0] * b[1] - a[1] * b[0]


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Dot product over the leading component axis; (k, ...), (k, ...) -> (...)."""
    out = a[0] * b[0]
    for k in range(1, len(a)):
        out = out + a[k] * b[k]
    return out


def rotate_cs(c: np.ndarray, s: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Rotate vectors ``a`` (2, ...) by angles given by their cosines and sines (...)."""
    out = _empty(2, c, a[0])
    np.multiply(c, a[0], out=out[0, ...])
    out[0] -= s * a[1]
    np.multiply(s, a[0], out=out[1, ...])
    out[1] += c * a[1]
    return out


def rotate(phi: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Rotate vectors ``a`` (2, ...) by angles ``phi`` (...) rad: ``R(phi) a``."""
    return rotate_cs(np.cos(phi), np.sin(phi), a)


def twist(w: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Pack an angular part (...) and a linear part (2, ...) into a twist or wrench (3, ...)."""
    out = _empty(3, w, v[0])
    out[0], out[1:] = w, v
    return out


def shift_twist(t: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Twist ``t`` (3, ...) of a body at point O, expressed at point O + a: ``A(a) t``,
    with ``A(a) = [[1, 0], [perp(a), 1]]`` the planar twist-propagation matrix (eq. 2)."""
    out = _empty(3, t[0], a[0])
    out[0] = t[0]
    np.multiply(t[0], a[1], out=out[1, ...])
    np.subtract(t[1], out[1], out=out[1, ...])
    np.multiply(t[0], a[0], out=out[2, ...])
    out[2] += t[2]
    return out


def shift_wrench(w: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Wrench ``w`` (3, ...) about point P, expressed about point P - a: ``A(a)^T w``.

    The moment gains ``a x f``; the transpose of :func:`shift_twist`, so power is invariant.
    """
    out = _empty(3, w[0], a[0])
    np.multiply(a[0], w[2], out=out[0, ...])
    out[0] -= a[1] * w[1]
    out[0] += w[0]
    out[1:] = w[1:]
    return out


def wrap(angle: np.ndarray) -> np.ndarray:
    """Angle wrapped into (-pi, pi]."""
    return np.arctan2(np.sin(angle), np.cos(angle))


def last(x: np.ndarray, k: int = 1) -> np.ndarray:
    """Move the ``k`` leading component axes of ``x`` to the end (the users' layout)."""
    return np.moveaxis(x, tuple(range(k)), tuple(range(-k, 0)))


def stack_last(per_body: list) -> np.ndarray:
    """Stack one component-first array (k, ...) per entity into the users' layout
    (..., n_entities, k)."""
    return np.stack([last(x) for x in per_body], axis=-2)


def first(x: np.ndarray) -> np.ndarray:
    """Move the last (component) axis of ``x`` to the front (the solvers' layout)."""
    return np.moveaxis(x, -1, 0)


def solve_small(K, b):
    """Solve many small systems ``K x = b`` by Gaussian elimination with partial pivoting.

    The loops run over the (few) rows and columns; every sample is processed at once, which is
    far faster than per-matrix LAPACK calls for the 2x2 to 8x8 systems of linkages.

    Parameters
    ----------
    K : array (n, n, ...)
        Component-first: ``K[i][j]`` is an array over the samples.
    b : array (n, ...)

    Returns
    -------
    x : ndarray (n, ...)
        NaN where ``K`` is numerically singular.
    pivot : ndarray (...)
        Smallest pivot magnitude relative to the largest entry of ``K``: ~0 means singular.
    """
    n = len(b)
    shape = np.broadcast_shapes(*(np.shape(K[i][j]) for i in range(n) for j in range(n)),
                                *(np.shape(b[i]) for i in range(n)))
    A = [[np.broadcast_to(K[i][j], shape) for j in range(n)] + [np.broadcast_to(b[i], shape)]
         for i in range(n)]
    scale = np.max(np.abs(np.stack([A[i][j] for i in range(n) for j in range(n)])), axis=0)
    pivot = np.full(shape, np.inf)
    for k in range(n):
        # partial pivoting: swap the row with the largest |A[i][k]|, i >= k, into row k
        for i in range(k + 1, n):
            swap = np.abs(A[i][k]) > np.abs(A[k][k])
            if np.any(swap):
                A[k], A[i] = ([np.where(swap, x, y) for x, y in zip(A[i], A[k])],
                              [np.where(swap, y, x) for x, y in zip(A[i], A[k])])
        pk = A[k][k]
        pivot = np.minimum(pivot, np.abs(pk))
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / pk
            for i in range(k + 1, n):
                f = A[i][k] * inv
                A[i] = [A[i][j] - f * A[k][j] if j > k else A[i][j] for j in range(n + 1)]
    x = [None] * n
    with np.errstate(divide="ignore", invalid="ignore"):
        for k in range(n - 1, -1, -1):
            acc = A[k][n]
            for j in range(k + 1, n):
                acc = acc - A[k][j] * x[j]
            x[k] = acc / A[k][k]
        rel = pivot / np.where(scale > 0, scale, 1.0)
    x = np.stack(x) if n else np.zeros((0,) + shape)
    bad = ~(rel > 1e-13)
    if np.any(bad):
        x = np.where(bad, np.nan, x)
    return x, rel
