"""Planar twist and wrench algebra on component-first arrays.

Inside the solvers a planar vector is an array ``(2, ...)``, a twist ``t = [w, vx, vy]`` and a
wrench ``w = [n, fx, fy]`` are arrays ``(3, ...)``: the component axis comes *first*, so each
component is a contiguous array over all samples and every operation runs at full vector speed.
(Results handed to users are re-stacked with components last, see ``DESIGN.md``.) A constant
local vector may be given as a plain ``(2,)`` array: it broadcasts.

In the plane the cross-product tensor of the seed paper becomes the 90-degree rotation ``perp``:
``z x a = perp(a) = [-a_y, a_x]``; a twist seen from another point is ``A(a) t`` and a wrench
carried back is ``A(a)^T w`` (eq. 2).

The motion/force API is the one a spatial module would share, with 6-vectors
``[w (3), v (3)]`` in place of ``[w, vx, vy]`` (Featherstone's spatial algebra restricted to
the plane): a motion vector (twist) and a force vector (wrench) are component groups, an
angular part and a linear part (:func:`motion`, :func:`force`, :func:`angular`,
:func:`linear`); :func:`shift_twist` and :func:`shift_wrench` transport them between points;
:func:`cross_motion` (``v x m``) and :func:`cross_force` (``v x* f``) are the two cross
products; a :class:`Transform` (rotation and origin of a new frame) maps motion vectors with
:func:`transform_motion` and force vectors with :func:`transform_force`, so that power
``m . f`` is invariant. Only the size of the groups and the bodies of these functions would
change for 6-D loops.
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from .steps import atan2, step


def _empty(k: int, *parts) -> np.ndarray:
    """An output of k components over the broadcast shape of ``parts`` (written in place by the
    kernels below, so no component is copied twice)."""
    return np.empty((k,) + np.broadcast_shapes(*(np.shape(x) for x in parts)))


def _stack(parts) -> np.ndarray:
    """A component-first array (k, ...) from a step's tuple of components."""
    out = _empty(len(parts), *parts)
    for k, x in enumerate(parts):
        out[k] = x
    return out


# --- steps on component tuples (linkdyn.steps): the algebra, written once for both backends ---

@step
def normal(a):
    """``perp(a) = z x a = (-a_y, a_x)`` of a vector ``(x, y)``."""
    return (-a[1], a[0])


@step
def turned(c, s, a):
    """The vector ``a`` ``(x, y)`` turned by the angle of cosine ``c`` and sine ``s``:
    ``R a``."""
    return (c * a[0] - s * a[1], s * a[0] + c * a[1])


@step
def at(t, a):
    """The twist ``t`` ``(w, vx, vy)`` of a body at a point O, taken at O + a: ``A(a) t``
    (eq. 2; the velocity gains ``w perp(a)``)."""
    return (t[0], t[1] - t[0] * a[1], t[0] * a[0] + t[2])


@step
def about(w, a):
    """The wrench ``w`` ``(n, fx, fy)`` about a point P, taken about P - a: ``A(a)^T w`` (the
    moment gains ``a x f``)."""
    return ((a[0] * w[2] - a[1] * w[1]) + w[0], w[1], w[2])


@step
def wrapped(angle):
    """``angle`` wrapped into [-pi, pi] (by its sine and cosine: an angle at +-pi keeps its
    side, which the branch an assembly without a guess takes depends on; a floor,
    ``angle + 2 pi floor((pi - angle) / 2 pi)``, costs less but sends -pi to pi)."""
    return atan2(np.sin(angle), np.cos(angle))


def perp(a: np.ndarray) -> np.ndarray:
    """Rotate ``a`` (2, ...) by +90 degrees: ``z x a``."""
    return _stack(normal(a))


@step
def cross(a, b):
    """Scalar planar cross product ``a x b = a_x b_y - a_y b_x``; (2, ...), (2, ...) -> (...)."""
    return a[0] * b[1] - a[1] * b[0]


@step
def dot(a, b):
    """Dot product over the leading component axis; (k, ...), (k, ...) -> (...)."""
    out = a[0] * b[0]
    for k in range(1, len(a)):
        out = out + a[k] * b[k]
    return out


def rotate_cs(c: np.ndarray, s: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Rotate vectors ``a`` (2, ...) by angles given by their cosines and sines (...)."""
    return _stack(turned(c, s, a))


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
    return _stack(at(t, a))


def shift_wrench(w: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Wrench ``w`` (3, ...) about point P, expressed about point P - a: ``A(a)^T w``.

    The moment gains ``a x f``; the transpose of :func:`shift_twist`, so power is invariant.
    """
    return _stack(about(w, a))


# --- the motion/force API (shared in shape with a spatial module) ------------------------------

#: Components of a motion or force vector, and of its linear part.
SIZE, LINEAR_SIZE = 3, 2


def motion(w, v) -> np.ndarray:
    """A motion vector (twist) (3, ...) from its angular part ``w`` (...) and linear part
    ``v`` (2, ...), the velocity of the point it is taken at."""
    return twist(w, v)


def force(n, f) -> np.ndarray:
    """A force vector (wrench) (3, ...) from its moment ``n`` (...) about the point it is taken
    at and its force ``f`` (2, ...)."""
    return twist(n, f)


def angular(x: np.ndarray) -> np.ndarray:
    """Angular part (...) of a motion or force vector (3, ...): ``w`` or the moment ``n``."""
    return x[0]


def linear(x: np.ndarray) -> np.ndarray:
    """Linear part (2, ...) of a motion or force vector (3, ...): ``v`` or the force ``f``."""
    return x[1:]


def cross_motion(v: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Motion cross product ``v x m`` (3, ...) of motion vectors at one point:
    ``[0, w_v perp(m_lin) - w_m perp(v_lin)]`` (the rate of ``m`` fixed in a body moving at
    ``v``); in matrix form ``crm(v) = [[0, 0, 0], [v_y, 0, -w], [-v_x, w, 0]]``."""
    w, a = v[0], v[1:]
    return motion(np.zeros(np.broadcast_shapes(np.shape(w), np.shape(m[0]))),
                  w * perp(m[1:]) - m[0] * perp(a))


def cross_force(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Force cross product ``v x* f`` (3, ...) of a motion vector and a force vector at one
    point: ``[v_lin x f_lin, w perp(f_lin)]``, the dual of :func:`cross_motion`:
    ``crf(v) = -crm(v)^T``, so ``(v x m) . f = -m . (v x* f)``."""
    w, a = v[0], v[1:]
    return force(cross(a, f[1:]), w * perp(f[1:]))


class Transform(NamedTuple):
    """A change of frame, as a component group ``(c, s, r)``: the new frame's axes are the old
    ones turned by the angle whose cosine and sine are ``c``, ``s`` (...), and its origin is at
    ``r`` (2, ...) in the old frame's coordinates. Build one with :func:`transform`."""

    c: Any
    s: Any
    r: Any


def transform(angle, r) -> Transform:
    """The :class:`Transform` to a frame turned by ``angle`` (...) rad with its origin at ``r``
    (2, ...) (old frame's coordinates)."""
    return Transform(np.cos(angle), np.sin(angle), np.asarray(r, float))


def _unrotate(X: Transform, a):
    """``R^T a`` (2, ...): the old frame's vector ``a`` in the new frame's axes."""
    return rotate_cs(X.c, -X.s, a)


def transform_motion(X: Transform, m: np.ndarray) -> np.ndarray:
    """A motion vector (3, ...) at the old origin, old axes, seen at the new origin in the new
    axes: ``[w, R^T (v + w perp(r))]`` (the shift, then the rotation)."""
    t = shift_twist(m, X.r)
    return motion(t[0], _unrotate(X, t[1:]))


def transform_force(X: Transform, f: np.ndarray) -> np.ndarray:
    """A force vector (3, ...) about the old origin, old axes, taken about the new origin in the
    new axes: ``[n - r x f, R^T f]``; with :func:`transform_motion`, power is invariant."""
    return force(f[0] - cross(X.r, f[1:]), _unrotate(X, f[1:]))


def compose(X2: Transform, X1: Transform) -> Transform:
    """The transform applying ``X1`` then ``X2`` (``X2`` given in the frame ``X1`` leads to)."""
    c = X1.c * X2.c - X1.s * X2.s
    s = X1.s * X2.c + X1.c * X2.s
    return Transform(c, s, X1.r + rotate_cs(X1.c, X1.s, X2.r))


def inverse(X: Transform) -> Transform:
    """The transform back: turned by minus the angle, its origin at ``-R^T r``."""
    return Transform(X.c, -X.s, -_unrotate(X, X.r))


def wrap(angle: np.ndarray) -> np.ndarray:
    """Angle wrapped into (-pi, pi]."""
    return wrapped(angle)


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


LAPACK_FROM = 8   # systems of this size and larger go to LAPACK (the loops grow as n^3)


def _solve_lapack(K, b, n, shape):
    """:func:`solve_small` by LAPACK for larger systems (long chains of loops): the same
    results and the same relative pivot (of an LU factorization with partial pivoting)."""
    from scipy.linalg import lu

    if isinstance(K, np.ndarray) and isinstance(b, np.ndarray):
        # one array each (the Jacobians' slices): the samples first, by moving axes
        A = np.moveaxis(np.broadcast_to(K, (n, n) + shape), (0, 1), (-2, -1))
        B = np.moveaxis(np.broadcast_to(b, (n,) + shape), 0, -1)
    else:
        A = np.empty(shape + (n, n))
        B = np.empty(shape + (n,))
        for i in range(n):
            B[..., i] = b[i]
            for j in range(n):
                A[..., i, j] = K[i][j]
    scale = np.max(np.abs(A), axis=(-2, -1))
    finite = np.all(np.isfinite(A), axis=(-2, -1)) & np.all(np.isfinite(B), axis=-1)
    A = np.where(finite[..., None, None], A, np.eye(n))
    U = lu(A)[2]
    rel = np.min(np.abs(np.diagonal(U, axis1=-2, axis2=-1)), axis=-1) / np.where(
        scale > 0, scale, 1.0)
    bad = ~(rel > 1e-13) | ~finite
    x = np.linalg.solve(np.where(bad[..., None, None], np.eye(n), A),
                        np.where(bad[..., None], 0.0, B)[..., None])[..., 0]
    x = np.where(bad[..., None], np.nan, x)
    return np.moveaxis(x, -1, 0), np.where(finite, rel, np.nan)


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
    if isinstance(K, np.ndarray) and isinstance(b, np.ndarray):
        shape = np.broadcast_shapes(K.shape[2:], b.shape[1:])
    else:
        shape = np.broadcast_shapes(*(np.shape(K[i][j]) for i in range(n) for j in range(n)),
                                    *(np.shape(b[i]) for i in range(n)))
    if n >= LAPACK_FROM:
        return _solve_lapack(K, b, n, shape)
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
