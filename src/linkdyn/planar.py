"""Planar twist and wrench algebra on component-first arrays.

Inside the solvers a planar vector is an array ``(2, ...)``, a twist ``t = [w, vx, vy]`` and a
wrench ``w = [n, fx, fy]`` are arrays ``(3, ...)``: the component axis comes *first*, so each
component is a contiguous array over all samples and every operation runs at full vector speed.
(Results handed to users are re-stacked with components last, see ``DESIGN.md``.) A constant
local vector may be given as a plain ``(2,)`` array: it broadcasts.

In the plane the cross-product tensor of the seed paper becomes the 90-degree rotation ``perp``:
``z x a = perp(a) = [-a_y, a_x]``; a twist seen from another point is ``A(a) t`` and a wrench
carried back is ``A(a)^T w`` (eq. 2).

The solvers are written in this algebra: every per-body equation (twist propagation, the
Jacobian, the twist rates and the closure bias, Newton-Euler, the DeNOC reduction, the reactions,
the loads) is a step (:mod:`linkdyn.steps`) calling the operations below on component tuples,
which numpy runs on whole arrays and numba inlines in its sample loops: :func:`at` and
:func:`about` (the shift ``A(a)`` of a motion vector and its transpose on a force vector),
:func:`crm` and :func:`crf` (the motion and force cross products, ``crf(v) = -crm(v)^T``),
:func:`at_moving` (a shift and its rate to a moving point), :func:`inertia_times` (``M_O x``),
:func:`turned`, :func:`placed` (a vector rotated, a body point placed), the parts
:func:`angular`, :func:`linear`, :func:`translation`, :func:`pure_force`, :func:`couple` and
the vector-space steps :func:`plus`, :func:`minus`, :func:`scaled`, :func:`negated`.

The same names are the API a spatial module would define, with 6-vectors ``[w (3), v (3)]`` in
place of ``[w, vx, vy]`` (Featherstone's spatial algebra restricted to the plane), so 6-D loops
add an algebra module and joint kinds, not a second solver. On arrays: :func:`motion`,
:func:`force` pack a motion vector (twist) and a force vector (wrench); :func:`shift_twist`
and :func:`shift_wrench` transport them between points; :func:`cross_motion` (``v x m``) and
:func:`cross_force` (``v x* f``); a :class:`Transform` (rotation and origin of a new frame)
maps motion vectors with :func:`transform_motion` and force vectors with
:func:`transform_force`, so that power ``m . f`` is invariant.
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
#
# Every solver step (the recursions, Newton-Euler, the reduction, the reactions, the loads)
# spells its equation with these operations, on component tuples: a vector ``(x, y)``, a motion
# vector (twist) ``(w, vx, vy)``, a force vector (wrench) ``(n, fx, fy)``. A spatial module
# would define the same names on 3-vectors and 6-tuples ``(w (3), v (3))``; only their bodies
# would change.

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
def relative(a, b):
    """The vector ``b - a`` of two vectors ``(x, y)``."""
    return (b[0] - a[0], b[1] - a[1])


@step
def offset(r, a):
    """The point ``r + a`` of a point and a vector ``(x, y)``."""
    return (r[0] + a[0], r[1] + a[1])


@step
def placed(c, s, r, p):
    """The point ``p`` of a body (its frame, from its origin) in global coordinates,
    ``r + R p``, the body's origin at ``r`` and its angle of cosine ``c``, sine ``s``."""
    return offset(r, turned(c, s, p))


@step
def angular(x):
    """Angular part of a motion or force vector: ``w`` of a twist, the moment ``n`` of a
    wrench (a scalar in the plane)."""
    return x[0]


@step
def linear(x):
    """Linear part of a motion or force vector ``(x, y)``: the velocity of the point a twist is
    taken at, or the force of a wrench."""
    return x[1:]


@step
def translation(v):
    """The motion vector ``[0, v]`` of a translation at velocity ``v`` ``(x, y)``."""
    return (0.0, v[0], v[1])


@step
def pure_force(f):
    """The force vector ``[0, f]`` of a force ``f`` ``(x, y)`` through the point it is taken
    about."""
    return (0.0, f[0], f[1])


@step
def couple(n):
    """The force vector ``[n, 0]`` of a couple ``n`` (N m)."""
    return (n, 0.0, 0.0)


@step
def plus(x, y):
    """``x + y`` of two motion or two force vectors."""
    return (x[0] + y[0], x[1] + y[1], x[2] + y[2])


@step
def minus(x, y):
    """``x - y`` of two motion or two force vectors."""
    return (x[0] - y[0], x[1] - y[1], x[2] - y[2])


@step
def scaled(k, x):
    """``k x`` of a scalar and a motion or force vector."""
    return (k * x[0], k * x[1], k * x[2])


@step
def negated(x):
    """``-x`` of a motion or force vector."""
    return (-x[0], -x[1], -x[2])


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
def crm(v, m):
    """Motion cross product ``v x m`` of two motion vectors at one point:
    ``[0, w_v perp(m_lin) - w_m perp(v_lin)]``; ``crm(v) = [[0, 0, 0], [v_y, 0, -w],
    [-v_x, w, 0]]`` (spatial: ``[w x m_w, w x m_v + v x m_w]``)."""
    return (0.0, -(v[0] * m[2]) + m[0] * v[2], v[0] * m[1] - m[0] * v[1])


@step
def crf(v, f):
    """Force cross product ``v x* f`` of a motion vector and a force vector at one point:
    ``[v_lin x f_lin, w perp(f_lin)]``, ``crf(v) = -crm(v)^T`` (spatial: ``[w x n + v x f,
    w x f]``), so ``(v x m) . f = -m . (v x* f)``."""
    return (v[1] * f[2] - v[2] * f[1], -(v[0] * f[2]), v[0] * f[1])


@step
def at_moving(t, td, a, da):
    """A body's twist ``t`` and twist rate ``td`` at O, taken at the point O + a that moves at
    ``da`` relative to O (not a point of the body, in general): ``A(a) t`` and its rate
    ``A(a) td + crm(t, [0, da])`` (the shift turning with the body, ``d/dt A(a) =
    [[0, 0], [perp(da), 0]]``)."""
    return at(t, a), plus(at(td, a), crm(t, translation(da)))


@step
def inertia_times(mass, inertia, d, x):
    """``M_O x``: the spatial inertia about O of a body of ``mass`` (kg) and moment of inertia
    ``inertia`` about its mass centre (kg m^2), the mass centre at ``d`` ``(x, y)`` from O, times
    the motion vector ``x`` at O: ``M_O = A(d)^T diag(I_C, m, m) A(d)`` (a twist gives the
    momentum about O, a twist rate the rate of change of momentum it causes)."""
    x_c = at(x, d)
    return about((inertia * x_c[0], mass * x_c[1], mass * x_c[2]), d)


@step
def wrapped(angle):
    """``angle`` wrapped into (-pi, pi] (by its sine and cosine)."""
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


def cross_motion(v: np.ndarray, m: np.ndarray) -> np.ndarray:
    """Motion cross product ``v x m`` (3, ...) of motion vectors (3, ...) at one point
    (:func:`crm`; the rate of ``m`` fixed in a body moving at ``v``)."""
    return _stack(crm(v, m))


def cross_force(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    """Force cross product ``v x* f`` (3, ...) of a motion vector and a force vector (3, ...)
    at one point (:func:`crf`, the dual of :func:`cross_motion`)."""
    return _stack(crf(v, f))


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
