"""The compiled kinematics kernel and the compiled analysis against the numpy reference.

``kinematics.solve(..., backend="compiled")`` must give what the numpy path gives (itself
checked against closed forms, finite differences, the dense reference and MuJoCo elsewhere):
every joint coordinate, rate and acceleration, every body pose, twist and twist rate, the
closure Jacobian, the pivots, the validity of every sample, to 1e-12 of each quantity's peak,
NaN at the same samples. ``analyze`` must then give the same result columns on either path.
"""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings

import linkdyn
from linkdyn import compiled, kinematics
from linkdyn.cli import example_text
from linkdyn.io import model_from_dict
from linkdyn.kinematics import compiled as kc
from linkdyn.kinematics import dyads, positions

from test_compiled_dynamics import (KERNEL_EXAMPLES, KERNEL_MODELS, hoeken_design, same,
                                   slider_crank_design)
from test_dynamics import MODELS, times
from test_slot import lever_models, slotted_levers


def around(model, n=73):
    """n samples from before t = 0 to past one cycle: both continuation directions."""
    t = times(model, n)
    return np.linspace(-0.3 * t[-1], 1.2 * t[-1], n)


def check_kinematics(fast, ref):
    """Every array of two kinematic solutions."""
    assert fast.arrays is not None and ref.arrays is None
    assert np.array_equal(fast.valid, ref.valid)
    for name in ("q", "qd", "qdd", "phi", "r", "tw", "twd", "J", "pivot"):
        same(getattr(fast, name), getattr(ref, name), name)
    # the closure residual is rounding: compare it absolutely
    both_ok = fast.valid & ref.valid
    assert np.max(np.abs(fast.residual[both_ok] - ref.residual[both_ok]), initial=0) < 1e-12
    for i, (a, b) in enumerate(zip(fast.pose.e, ref.pose.e)):
        assert (a is None) == (b is None), f"slider axis of body {i}"
        if a is not None:
            same(a, np.broadcast_to(b, a.shape), f"e[{i}]")
    for i, (a, b) in enumerate(zip(fast.motion, ref.motion)):
        if b is not None:
            same(np.broadcast_to(a, np.broadcast_shapes(np.shape(a), np.shape(b))),
                 np.broadcast_to(b, np.broadcast_shapes(np.shape(a), np.shape(b))), f"p[{i}]")


def same_columns(fast, ref):
    """Every result column; a column is compared against the peak of its family (``x``,
    ``phi``, ``Fx`` ...), so a fixed point's ``y`` of 1e-17 m is measured against the other
    points' coordinates, not against itself."""
    assert list(fast.columns) == list(ref.columns)
    peaks: dict = {}
    for key, col in ref.columns.items():
        fam = key.split("_")[0]
        peaks[fam] = max(peaks.get(fam, 0.0), float(np.nanmax(np.abs(col), initial=0.0)))
    # a slider's moment (zero in a symmetric load case) against the efforts and forces
    peaks["M"] = max(peaks.get(f, 0.0) for f in ("M", "Fx", "Fy", "tau", "force"))
    for key, col in ref.columns.items():
        peak = max(float(np.nanmax(np.abs(col), initial=0.0)), peaks[key.split("_")[0]])
        same(fast.columns[key], col, key, rtol=1e-12 * peak / max(
            float(np.nanmax(np.abs(col), initial=0.0)), 1e-300))


def solve_both(model, t):
    """(compiled, numpy) kinematics."""
    return (kinematics.solve(model, t, backend="compiled"),
            kinematics.solve(model, t, backend="numpy"))


def closed_by_the_kernel(model, t):
    """The kernel's own closed form (``kc.run`` from the continuation nodes, as
    ``kinematics.solve`` calls it first) of a mechanism of dyads: its outputs, without the numpy
    path's retry that would hide a sample the closed form leaves open."""
    lay = kinematics.compile_layout(model)
    assert lay.dyads is not None
    q0 = positions.assemble([model], lay, lay.driver_values(np.zeros(1))[0][..., 0])[:, 0]
    modes = dyads.sides(lay, lay.dyads, q0[..., None], kinematics.forward_positions)
    nodes, Q, _, reach, _ = positions.continuation(lay, q0, min(0.0, t.min()), max(0.0, t.max()),
                                                   modes)
    return kc.run(lay, t, *lay.driver_values(t), nodes=nodes,
                  Q=Q, modes=modes, lo=reach[..., :1], hi=reach[..., 1:])


def _four_bar_cut(cut):
    return dataclasses.replace(linkdyn.load(linkdyn.example_path("hoeken")), cut=(cut,))


# the bundled mechanisms whose loops are all dyads (the others close by Newton's method)
DYAD_EXAMPLES = [n for n in KERNEL_EXAMPLES
                 if kinematics.compile_layout(linkdyn.load(linkdyn.example_path(n))).dyads]


@pytest.mark.parametrize("name", DYAD_EXAMPLES + ["hoeken J2", "hoeken J4"])
def test_the_kernel_closes_every_dyad_in_closed_form(name):
    """Every sample of a mechanism of dyads closes in the kernel's closed form (to the numpy
    closed form's poses): the numpy retry is for samples it misses, never needed here."""
    model = (_four_bar_cut(name.split()[1]) if " " in name
             else linkdyn.load(linkdyn.example_path(name)))
    assert kinematics.compile_layout(model).dyads is not None
    t = around(model)
    out = closed_by_the_kernel(model, t)
    ref = kinematics.solve(model, t, backend="numpy")
    assert np.all(ref.valid)
    assert np.all(out["err"] <= positions.ACCEPT), np.max(out["err"])
    # the bodies' angles and origins (tree order) of the numpy closed form
    same(out["phi"][1:].reshape((-1,) + t.shape), np.stack(ref.pose.phi[1:]), "phi")
    same(out["r"][1:].reshape((-1, 2) + t.shape), np.stack(ref.pose.r[1:]), "r")


@pytest.mark.parametrize("name", KERNEL_EXAMPLES)
def test_bundled_examples(name):
    model = linkdyn.load(linkdyn.example_path(name))
    fast, ref = solve_both(model, around(model))
    assert np.all(ref.valid) and np.max(np.abs(ref.qdd)) > 0
    check_kinematics(fast, ref)


@pytest.mark.parametrize("name", KERNEL_MODELS)
def test_dynamics_test_models(name):
    """Sliders in the tree, at the cut and driven; two drivers; joints declared child-first."""
    model = MODELS[name]()
    check_kinematics(*solve_both(model, around(model, 41)))


@pytest.mark.parametrize("name", ["scotch-yoke", "slotted-lever"])
@pytest.mark.parametrize("block", [1024, 5])
def test_slot_models(monkeypatch, name, block):
    """The slot joint (one closure row, its slot fixed or turning) in the kinematics kernel."""
    monkeypatch.setattr(kc, "BLOCK", block)
    model = MODELS[name]()
    fast, ref = solve_both(model, around(model, 41))
    assert fast.J.shape[-2] == 1 and np.all(ref.valid)
    check_kinematics(fast, ref)


@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(slotted_levers())
def test_random_slotted_levers(case):
    """Random slotted levers (slot) and their equivalents with a massless block (revolute and
    prismatic joints)."""
    for model in lever_models(case):
        check_kinematics(*solve_both(model, np.linspace(-0.2, 1.1, 13)))


def test_a_batch_of_slot_designs_equals_each_design_alone():
    """Slotted levers of different geometry (crank, pivot distance, slot offset) and start
    angle as one batch, on the kernel: equal to numpy, and each design equal to itself alone."""
    cases = [(50.0, 120.0, 8.0, (0.5, 1.0), (0.0, -9.81), (5.0, 1.0), 1.0, 0.3),
             (70.0, 110.0, -6.0, (1.5, 0.3), (2.0, -3.0), (-9.0, 4.0), -2.0, -1.2),
             (30.0, 160.0, 0.0, (0.2, 0.7), (0.0, 0.0), (0.0, 0.0), 0.0, 2.5)]
    designs = [lever_models(case)[0] for case in cases]
    t = np.linspace(-0.2, 1.1, 17)
    fast, ref = solve_both(designs, t)
    assert fast.shape == (3, 17) and np.all(fast.valid)
    check_kinematics(fast, ref)
    for k, model in enumerate(designs):
        alone = kinematics.solve(model, t, backend="compiled")
        for name in ("q", "qd", "qdd", "tw", "twd", "J"):
            same(getattr(fast, name)[k], getattr(alone, name), f"design {k}: {name}")


@pytest.mark.parametrize("cut, shape", [("J2", "chain"), ("J3", "split"), ("J4", "chain")])
def test_every_cut_of_the_four_bar(cut, shape):
    """Hoeken cut at each of its undriven joints: both RRR dyad shapes, either side."""
    model = _four_bar_cut(cut)
    fast, ref = solve_both(model, around(model))
    assert [d.shape for d in fast.layout.dyads] == [shape]
    check_kinematics(fast, ref)


@pytest.mark.parametrize("connect, side", [('["ground.G", "slider.B"]', "b"),
                                           ('["slider.B", "ground.G"]', "a")])
def test_slide_dyad_either_body_carrying_the_line(connect, side):
    """The slider-crank's RRP dyad with its prismatic joint declared either way: the line fixed
    in the ground (the slider moves along it, side b) or in the slider (the line moves with it,
    side a)."""
    text = example_text("slider_crank").replace('connect = ["ground.G", "slider.B"]',
                                                 f"connect = {connect}")
    model = model_from_dict(tomllib.loads(text))
    fast, ref = solve_both(model, around(model))
    assert [(d.shape, d.side) for d in fast.layout.dyads] == [("slide", side)]
    assert np.all(ref.valid)
    check_kinematics(fast, ref)


def test_designs_one_of_which_cannot_assemble():
    designs = [hoeken_design(38.1), hoeken_design(400.0), hoeken_design(42.0)]
    fast, ref = solve_both(designs, np.linspace(-0.2, 1.5, 29))
    assert fast.shape == (3, 29) and not np.any(fast.valid[1]) and np.all(fast.valid[[0, 2]])
    check_kinematics(fast, ref)


def test_designs_with_a_slider():
    designs = [slider_crank_design(1.0), slider_crank_design(2.0)]
    check_kinematics(*solve_both(designs, around(designs[0], 31)))


def test_samples_past_a_limit_position_are_nan_alike():
    """A non-Grashof Hoeken driven past the angle where its loop stops closing."""
    text = example_text("hoeken").replace("O2 = [38.1, 0.0]", "O2 = [60.0, 0.0]")
    text = text.replace("O4 = [89.5, 0.0] }", "O4 = [180.0, 0.0] }")
    model = model_from_dict(tomllib.loads(text))
    fast, ref = solve_both(model, np.linspace(-1.0, 4 / 3, 61))
    assert 0 < np.sum(~ref.valid) < 61
    check_kinematics(fast, ref)


@pytest.mark.parametrize("block", [1, 7])
def test_any_sample_block_gives_the_same(monkeypatch, block):
    monkeypatch.setattr(kc, "BLOCK", block)
    designs = [slider_crank_design(1.0), hoeken_design(38.1)][:1] + [slider_crank_design(0.5)]
    check_kinematics(*solve_both(designs, around(designs[0], 23)))


def test_a_sample_the_closed_form_misses_goes_to_the_numpy_retry(monkeypatch):
    """Where the kernel's closed form leaves a sample open, the whole batch is redone by the
    numpy path's damped Newton retry (and then finished by the kernel)."""
    model = linkdyn.load(linkdyn.example_path("hoeken"))
    run = kc.run

    def spoiled(*args, **kw):
        out = run(*args, **kw)
        if kw.get("nodes") is not None:
            out["err"][..., 3] = 1.0   # pretend sample 3 did not close
        return out
    monkeypatch.setattr(kc, "run", spoiled)
    fast = kinematics.solve(model, times(model, 9), backend="compiled")
    # without the retry sample 3 would be invalid (and its rates left from the open guess)
    check_kinematics(fast, kinematics.solve(model, times(model, 9), backend="numpy"))


@pytest.mark.parametrize("name", ["hoeken", "slider_crank", "inverted_slider_crank", "fivebar"])
def test_analyze_gives_the_same_columns(name):
    model = linkdyn.load(linkdyn.example_path(name))
    t = times(model, 37)
    fast = linkdyn.analyze(model, t, backend="compiled")
    ref = linkdyn.analyze(model, t, backend="numpy")
    assert fast.kin.arrays is not None and ref.kin.arrays is None
    same_columns(fast, ref)


def test_analyze_allow_singular_flags_the_same_samples():
    text = example_text("hoeken").replace("O2 = [38.1, 0.0]", "O2 = [60.0, 0.0]")
    model = model_from_dict(tomllib.loads(text.replace("O4 = [89.5, 0.0] }",
                                                       "O4 = [180.0, 0.0] }")))
    t = np.linspace(0.0, 4 / 3, 41)
    fast = linkdyn.analyze(model, t, allow_singular=True, backend="compiled")
    ref = linkdyn.analyze(model, t, allow_singular=True, backend="numpy")
    assert np.array_equal(fast.valid, ref.valid) and 0 < np.sum(~ref.valid) < 41
    same_columns(fast, ref)
    with pytest.raises(linkdyn.AssemblyError) as err:
        linkdyn.analyze(model, t, backend="compiled")
    with pytest.raises(linkdyn.AssemblyError) as err_ref:
        linkdyn.analyze(model, t, backend="numpy")
    assert str(err.value) == str(err_ref.value)


def test_factor_of_a_sparse_system():
    """Twelve unknowns, sparse as a long chain's J_dep (where a zero multiplier leaves its row
    as it is): factor and substitute solve every finite sample as LAPACK does, with the
    relative pivot of an LU factorization with partial pivoting; a sample with an infinite
    entry comes out NaN (every row then updated, as in solve_small)."""
    import scipy.linalg as sl

    rng = np.random.default_rng(12)
    m, nb = 12, 30
    K = rng.normal(size=(m, m, nb)) * (rng.random(size=(m, m, nb)) < 0.2)
    K += np.eye(m)[:, :, None] * (0.5 + rng.random(nb))
    K[-1, 0, 3] = np.inf
    b = rng.normal(size=(m, nb))
    A, perm, rel, x = K.copy(), np.zeros((m, nb), np.int64), np.zeros(nb), np.zeros((m, nb))
    compiled.factor(A, m, nb, perm, rel)
    compiled.substitute(A, perm, rel, m, nb, b, x, kc.PIVOT_TOL)
    for k in range(nb):
        if k == 3:
            assert np.all(np.isnan(x[:, k]))
            continue
        np.testing.assert_allclose(x[:, k], np.linalg.solve(K[..., k], b[:, k]), rtol=1e-10,
                                   atol=1e-12)
        U = sl.lu(K[..., k])[2]
        assert np.isclose(rel[k], np.min(np.abs(np.diag(U))) / np.max(np.abs(K[..., k])),
                          rtol=1e-12)


@pytest.mark.parametrize("m", [1, 2, 3, 4, 6])
def test_factor_once_solve_twice_matches_solve_small(m):
    """The kinematics kernel factors J_dep once and solves for the rates and then the
    accelerations: each solve equals planar.solve_small on the same system (values, relative
    pivot, NaN where singular), and equals a fresh elimination of that system bit for bit."""
    rng = np.random.default_rng(m)
    nb = 40
    K = rng.normal(size=(m, m, nb)) * 10.0 ** rng.integers(-3, 4, size=(1, 1, nb))
    K[:, :, 0] = np.tril(K[:, :, 0], -1) + np.eye(m)[::-1]   # every column needs a row swap
    K[:, 0, 1] = 0.0                        # exactly singular
    K[:, -1, 2] = K[:, 0, 2]                # two equal columns (m > 1) or zero-free (m = 1)
    K[:, 0, 3] *= 1e-15                     # relative pivot below the threshold
    K[:, 0, 4] *= 1e-9                      # small, but above it
    K[0, -1, 5] = np.nan
    b1, b2 = rng.normal(size=(m, nb)), rng.normal(size=(m, nb))
    A, perm, rel = K.copy(), np.zeros((m, nb), np.int64), np.zeros(nb)
    compiled.factor(A, m, nb, perm, rel)
    for b in (b1, b2):
        x = np.zeros((m, nb))
        compiled.substitute(A, perm, rel, m, nb, b, x, kc.PIVOT_TOL)
        ref, ref_rel = linkdyn.planar.solve_small(K, b)
        np.testing.assert_array_equal(np.isnan(x), np.isnan(ref))
        np.testing.assert_array_equal(np.isnan(rel), np.isnan(ref_rel))
        ok = np.isfinite(ref)
        assert np.allclose(x[ok], ref[ok], rtol=1e-12, atol=0)
        assert np.allclose(rel[np.isfinite(ref_rel)], ref_rel[np.isfinite(ref_rel)],
                           rtol=1e-14, atol=0)
        aug = np.concatenate([K, b[:, None]], axis=1)
        fresh, fresh_rel = np.zeros((m, nb)), np.zeros(nb)
        compiled.eliminate(aug, m, nb, fresh, fresh_rel, kc.PIVOT_TOL)
        np.testing.assert_array_equal(x, fresh)
        np.testing.assert_array_equal(rel, fresh_rel)
    assert np.all(np.isnan(x[:, [1, 5]]))
    assert m == 1 or np.all(np.isnan(x[:, [2, 3]]))   # a 1 x 1 pivot is its own scale
    assert np.all(np.isfinite(x[:, [0, 4]]))


@compiled.njit
def _arctan2_all(y, x, out):
    """compiled.arctan2 over arrays, in a compiled loop as the kernels call it."""
    for k in range(len(y)):
        out[k] = compiled.arctan2(y[k], x[k])


def test_arctan2_within_three_ulp_of_the_c_library():
    """The kernels' straight-line arctan2 against numpy's (the C library's): within 3 ulp over
    every octant and 16 decades, across the reduction's seams (|y| = |x|, t = tan(pi/8)), near
    +-pi and zero; the same sign (of zero too) and NaN, pi/2 and 0 for one infinite argument."""
    rng = np.random.default_rng(7)
    n = 200_000
    y = rng.standard_normal(n) * 10.0 ** rng.uniform(-8, 8, n)
    x = rng.standard_normal(n) * 10.0 ** rng.uniform(-8, 8, n)
    seam = rng.uniform(-1, 1, (3, 2000))
    t8 = np.tan(np.pi / 8)
    y = np.concatenate([y, seam[0], seam[0] * t8 * (1 + 1e-15 * seam[1]), 1e-300 * seam[1],
                        -np.abs(seam[2]) * 1e-17])
    x = np.concatenate([x, seam[0] * (1 + 1e-15 * seam[1]), seam[0], -np.abs(seam[2]),
                        -np.abs(seam[2])])
    special = np.array([0.0, -0.0, 1.0, -1.0, 5e-324, -5e-324, 1e308, np.inf, -np.inf, np.nan])
    sy, sx = (a.ravel() for a in np.meshgrid(special, special))
    both_infinite = np.isinf(sy) & np.isinf(sx)
    y, x = np.concatenate([y, sy[~both_infinite]]), np.concatenate([x, sx[~both_infinite]])
    got, ref = np.empty_like(y), np.arctan2(y, x)
    _arctan2_all(y, x, got)
    np.testing.assert_array_equal(np.isnan(got), np.isnan(ref))
    ok = ~np.isnan(ref)
    np.testing.assert_array_equal(np.signbit(got[ok]), np.signbit(ref[ok]))
    ulp = np.abs(got[ok] - ref[ok]) / np.spacing(np.abs(ref[ok]))
    assert ulp.max() <= 3, f"{ulp.max()} ulp at y={y[ok][ulp.argmax()]}, x={x[ok][ulp.argmax()]}"
    # both infinite: NaN, where the C library gives an odd multiple of pi/4 (documented)
    out = np.empty(1)
    _arctan2_all(np.array([np.inf]), np.array([-np.inf]), out)
    assert np.isnan(out[0])


def test_the_bracketing_node_is_searchsorted_from_any_guess():
    """The kernel's bracketing continuation node (``kinematics.compiled.bracket``, which
    tries the previous sample's node and the next before bisecting) is numpy's
    ``searchsorted(nodes, t, "right") - 1`` clamped to ``0 .. K - 2`` for every guess: times in
    order and shuffled, before the first node, past the last, on a node; NaN (which compares
    false) the first node, as the bisection alone gave it."""
    rng = np.random.default_rng(7)
    for K in (1, 2, 3, 64):
        nodes = np.sort(rng.uniform(0.0, 1.0, K))
        ts = np.concatenate([np.linspace(-0.2, 1.2, 301), nodes, rng.uniform(-0.1, 1.1, 50),
                             [np.nan]])
        want = np.minimum(np.maximum(np.searchsorted(nodes, ts, side="right") - 1, 0), K - 2)
        want[np.isnan(ts)] = min(0, K - 2)   # every comparison false: the lower end
        j = 0
        for k, tc in enumerate(ts):
            j_in = j if K > 1 else 0
            j = kc.bracket(nodes, tc, j_in)
            assert j == want[k], (K, tc, j_in)
            assert kc.bracket(nodes, tc, int(rng.integers(0, max(K - 1, 1)))) == want[k]
