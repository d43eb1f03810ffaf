"""Algebra identities of linkdyn.planar, property-based.

Each identity is one a wrong formula breaks: shift composition, the wrench shift as the
transpose of the twist shift (power invariance), the motion and force cross products (v x v = 0,
the duality crf = -crm^T, Jacobi), and motion and force transforms (power invariance,
composition, inverse, a pure translation equal to the shift). Vectors are batched (component
first, a batch of samples), as the solvers use them. Tolerances scale with the inputs.
"""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from linkdyn import planar as pl
from linkdyn.dynamics.dense import propagation

N = 7  # samples per drawn batch


def arrays(k):
    """A component-first batch (k, N) of moderate numbers."""
    return st.lists(st.floats(-10, 10), min_size=k * N, max_size=k * N).map(
        lambda x: np.array(x).reshape(k, N))


angles = st.lists(st.floats(-7, 7), min_size=N, max_size=N).map(np.array)
SETTINGS = settings(max_examples=40, deadline=None)


def close(a, b, scale=1.0):
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-12 * max(1.0, scale))


@SETTINGS
@given(arrays(3), arrays(2), arrays(2))
def test_shift_composes(t, a, b):
    # seen from O + a, then from there + b, equals seen from O + a + b
    close(pl.shift_twist(pl.shift_twist(t, a), b), pl.shift_twist(t, a + b), 1e3)
    close(pl.shift_wrench(pl.shift_wrench(t, a), b), pl.shift_wrench(t, a + b), 1e3)


@SETTINGS
@given(arrays(3), arrays(3), arrays(2))
def test_wrench_shift_is_the_transpose_and_keeps_power(t, w, a):
    # (A(a) t) . w = t . (A(a)^T w): the same power seen from either point
    close(pl.dot(pl.shift_twist(t, a), w), pl.dot(t, pl.shift_wrench(w, a)), 1e4)
    # and both match the explicit matrix A(a) of the dense reference, sample by sample
    for k in range(N):
        A = propagation(a[:, k])
        close(pl.shift_twist(t[:, k:k + 1], a[:, k:k + 1])[:, 0], A @ t[:, k], 1e3)
        close(pl.shift_wrench(w[:, k:k + 1], a[:, k:k + 1])[:, 0], A.T @ w[:, k], 1e3)


def crm(v):
    """The motion cross-product matrix (3, 3) written out, for one sample."""
    w, x, y = v
    return np.array([[0.0, 0.0, 0.0], [y, 0.0, -w], [-x, w, 0.0]])


@SETTINGS
@given(arrays(3), arrays(3), arrays(3), arrays(3))
def test_cross_products(u, v, m, f):
    # v x v = 0; antisymmetry; the duality (v x m) . f = -m . (v x* f)
    close(pl.cross_motion(v, v), np.zeros_like(v), 1e2)
    close(pl.cross_motion(v, m), -pl.cross_motion(m, v), 1e2)
    close(pl.dot(pl.cross_motion(v, m), f), -pl.dot(m, pl.cross_force(v, f)), 1e3)
    # Jacobi: u x (v x m) + v x (m x u) + m x (u x v) = 0
    jac = (pl.cross_motion(u, pl.cross_motion(v, m)) + pl.cross_motion(v, pl.cross_motion(m, u))
           + pl.cross_motion(m, pl.cross_motion(u, v)))
    close(jac, np.zeros_like(jac), 1e3)
    # matrix forms, and crf = -crm^T
    for k in range(N):
        close(pl.cross_motion(v[:, k:k + 1], m[:, k:k + 1])[:, 0], crm(v[:, k]) @ m[:, k], 1e2)
        close(pl.cross_force(v[:, k:k + 1], f[:, k:k + 1])[:, 0], -crm(v[:, k]).T @ f[:, k], 1e2)


@SETTINGS
@given(arrays(3), arrays(2))
def test_cross_motion_is_the_rate_of_a_body_fixed_motion_vector(t, a):
    # a unit rotation about a body point at offset a, the body turning at w about the origin
    # (a' = w perp(a)): the rate of that motion vector, A(a) [1, 0, 0], is [w, 0, 0] x it
    m = np.array([1.0, 0.0, 0.0])[:, None] * np.ones(N)
    h = 1e-6
    a_dot = t[0] * pl.perp(a)
    fd = (pl.shift_twist(m, a + h * a_dot) - pl.shift_twist(m, a - h * a_dot)) / (2 * h)
    exact = pl.cross_motion(pl.motion(t[0], np.zeros((2, N))), pl.shift_twist(m, a))
    np.testing.assert_allclose(fd, exact, rtol=0, atol=1e-6 * (1 + np.max(np.abs(exact))))


@SETTINGS
@given(angles, arrays(2), arrays(3), arrays(3))
def test_transforms_keep_power(angle, r, m, f):
    X = pl.transform(angle, r)
    close(pl.dot(pl.transform_motion(X, m), pl.transform_force(X, f)), pl.dot(m, f), 1e4)


@SETTINGS
@given(angles, arrays(2), angles, arrays(2), arrays(3), arrays(3))
def test_transforms_compose_and_invert(a1, r1, a2, r2, m, f):
    X1, X2 = pl.transform(a1, r1), pl.transform(a2, r2)
    X = pl.compose(X2, X1)
    close(pl.transform_motion(X2, pl.transform_motion(X1, m)), pl.transform_motion(X, m), 1e4)
    close(pl.transform_force(X2, pl.transform_force(X1, f)), pl.transform_force(X, f), 1e4)
    close(np.arctan2(X.s, X.c), pl.wrap(a1 + a2), 10)
    back = pl.inverse(X1)
    close(pl.transform_motion(back, pl.transform_motion(X1, m)), m, 1e3)
    close(pl.transform_force(back, pl.transform_force(X1, f)), f, 1e3)


@SETTINGS
@given(arrays(2), arrays(3), arrays(3))
def test_a_translation_is_the_shift(r, m, f):
    # no rotation: a motion vector transported to r is A(r) m; a force vector to r is the
    # inverse of the wrench shift A(r)^T (which carries a wrench about r back to the origin)
    X = pl.transform(np.zeros(N), r)
    close(pl.transform_motion(X, m), pl.shift_twist(m, r), 1e3)
    close(pl.shift_wrench(pl.transform_force(X, f), r), f, 1e3)


@SETTINGS
@given(angles, arrays(2))
def test_transform_of_a_point_velocity(angle, r):
    # a body turning at w about the old origin: the new origin moves at w perp(r); in the
    # new axes that is R^T (w perp(r))
    w = np.linspace(-3, 3, N)
    X = pl.transform(angle, r)
    got = pl.transform_motion(X, pl.motion(w, np.zeros((2, N))))
    c, s = np.cos(angle), np.sin(angle)
    v = w * pl.perp(r)
    close(got[0], w)
    close(got[1:], np.stack((c * v[0] + s * v[1], -s * v[0] + c * v[1])), 1e2)


def test_parts_and_sizes():
    t = pl.motion(np.arange(4.0), np.ones((2, 4)))
    assert t.shape == (pl.SIZE, 4) and pl.linear(t).shape == (pl.LINEAR_SIZE, 4)
    np.testing.assert_array_equal(pl.angular(t), np.arange(4.0))
    np.testing.assert_array_equal(pl.force(2.0, np.array([3.0, 4.0])), [2.0, 3.0, 4.0])


def test_solve_small_by_lapack_solves_and_flags_singular_samples():
    """``solve_small`` of 9 and 41 unknowns (LAPACK), one array or nested lists alike: the
    solution of ``K x = b`` where regular, NaN and a relative pivot ~0 at a singular sample
    (rank one short, and a zero matrix)."""
    rng = np.random.default_rng(2)
    for n in (9, 41):
        K, b = rng.normal(size=(n, n, 4)), rng.normal(size=(n, 4))
        K[:, 3, 1] = K[:, 2, 1]              # two equal columns
        K[..., 2] = 0.0
        x, rel = pl.solve_small(K, b)
        lists = pl.solve_small([[K[i, j] for j in range(n)] for i in range(n)], list(b))
        np.testing.assert_array_equal(x, lists[0])
        np.testing.assert_array_equal(rel, lists[1])
        for k in (0, 3):
            np.testing.assert_allclose(K[..., k] @ x[:, k], b[:, k], atol=1e-9)
            assert rel[k] > 1e-6
        assert np.all(np.isnan(x[:, 1:3])) and np.all(rel[1:3] < 1e-13)
