"""Batches of designs: ``analyze([m0, m1, ...], t)`` solves every design with its own numbers.

Random designs of one four-bar differ in geometry, masses, inertias, gravity, every load kind
(a point force given by a formula of t, a constant torque, a spring, a damper) and their driver
motions (constant speeds and formulas); the batch must equal each design solved alone, on both
backends, and a design that cannot be assembled, or stops closing, stays flagged in ``valid``
without touching the others. Designs of different topologies are refused with a message naming
the design and what differs.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import linkdyn
from linkdyn import ModelError, compiled, kinematics, model_from_dict
from linkdyn.kinematics import compile_layout
from linkdyn.kinematics.layout import compile_designs

from test_golden import scales

BACKENDS = ["numpy", pytest.param("compiled", marks=pytest.mark.skipif(
    compiled.numba is None, reason="the compiled backend needs numba"))]
T = np.linspace(0.0, 0.9, 37)


def fourbar(rng: np.random.Generator, motion: dict | None = None, crank: float | None = None,
            extra_load: bool = False) -> linkdyn.Model:
    """A crank-rocker (mm, rad) with random numbers and every load kind, in a vertical plane
    whose gravity points anywhere below the horizontal."""
    u = rng.uniform
    a = crank if crank is not None else u(30.0, 40.0)
    c, b, d = u(105.0, 125.0), u(105.0, 125.0), u(85.0, 95.0)
    g = u(5.0, 12.0) * np.array([np.cos(u(-2.6, -0.5)), np.sin(u(-2.6, -0.5))])
    data = {
        "mechanism": {"name": "random four-bar", "gravity": [float(x) for x in g]},
        "units": {"length": "mm", "angle": "rad"},
        "bodies": [
            {"name": "ground", "points": {"O1": [0.0, 0.0], "O4": [d, 0.0], "S": [u(-60, 60), 150.0]}},
            {"name": "crank", "points": {"O1": [0.0, 0.0], "O2": [a, 0.0]},
             "mass": u(0.5, 2.0), "com": [a / 2, u(-3, 3)], "inertia": u(200, 900)},
            {"name": "coupler", "points": {"O2": [0.0, 0.0], "O3": [c, 0.0], "P": [2 * c, u(-20, 20)]},
             "mass": u(2.0, 6.0), "com": [c, u(-5, 5)], "inertia": u(2e4, 9e4)},
            {"name": "rocker", "points": {"O3": [0.0, 0.0], "O4": [b, 0.0], "M": [b / 2, 0.0]},
             "mass": u(1.0, 4.0), "com": [b / 2, 0.0], "inertia": u(5e3, 2e4)},
        ],
        "joints": [
            {"name": "J1", "type": "revolute", "connect": ["ground.O1", "crank.O1"]},
            {"name": "J2", "type": "revolute", "connect": ["crank.O2", "coupler.O2"]},
            {"name": "J3", "type": "revolute", "connect": ["coupler.O3", "rocker.O3"]},
            {"name": "J4", "type": "revolute", "connect": ["ground.O4", "rocker.O4"]},
        ],
        "drivers": [{"joint": "J1", "motion": motion or {
            "kind": "constant_speed", "speed": u(3.0, 7.0), "start": u(-0.3, 0.3)}}],
        "loads": [
            {"kind": "force", "body": "coupler", "point": "P",
             "value": [f"{u(5, 30):.6g}*sin({u(1, 6):.6g}*t)", u(-20, 20)]},
            {"kind": "torque", "body": "rocker", "value": u(-2.0, 2.0)},
            {"kind": "spring", "body": "ground", "point": "S", "body2": "coupler", "point2": "P",
             "stiffness": u(0.1, 1.0), "free_length": u(50.0, 150.0)},
            {"kind": "damper", "body": "ground", "point": "O1", "body2": "rocker", "point2": "M",
             "damping": u(0.001, 0.02)},
        ] + ([{"kind": "torque", "body": "crank", "value": 1.0}] if extra_load else []),
        "assembly": {"phi": {"crank": 0.0, "coupler": 1.35, "rocker": -1.35}},
    }
    return model_from_dict(data)


def random_designs(seed: int = 0) -> list[linkdyn.Model]:
    rng = np.random.default_rng(seed)
    wave = {"kind": "expression", "q": f"0.2 + {rng.uniform(4, 6):.6g}*t + 0.3*sin(3*t)"}
    designs = [fourbar(rng), fourbar(rng), fourbar(rng, wave), fourbar(rng)]
    # a design sharing design 0's driver motion (one evaluation for both)
    designs.append(dataclasses.replace(fourbar(rng), drivers=designs[0].drivers))
    return designs


def assert_same(batch: dict, alone: dict, rtol: float, what: str):
    assert list(batch) == list(alone), what
    scale = scales(alone)
    for c in alone:
        a, b = np.asarray(batch[c]), np.asarray(alone[c])
        assert a.shape == b.shape, f"{what} {c}"
        nan = np.isnan(b)
        assert np.array_equal(np.isnan(a), nan), f"{what} {c}: NaN at other samples"
        err = np.max(np.abs(a - b)[~nan], initial=0.0)
        assert err <= rtol * scale.get(c, 1.0), f"{what} {c}: off by {err:.3g}"


def test_designs_really_differ():
    # the batch test below would pass for designs that give the same numbers: make sure not
    designs = random_designs()
    sols = [linkdyn.analyze(m, T, backend="numpy") for m in designs]
    for c in ("tau_J1", "Fx_J4", "potential_energy", "q_J1", "x_coupler.P"):
        peaks = [float(np.max(np.abs(s.columns[c]))) for s in sols]
        assert max(peaks) - min(peaks) > 1e-3 * max(peaks), c
    # every load kind and gravity contributes to the effort of a design
    for kind in ("force", "torque", "spring", "damper"):
        m = designs[1]
        fewer = dataclasses.replace(m, loads=tuple(x for x in m.loads if x.kind != kind))
        tau = linkdyn.analyze(fewer, T, backend="numpy").dyn.tau
        assert np.max(np.abs(tau - sols[1].dyn.tau)) > 1e-6, kind


@pytest.mark.parametrize("backend", BACKENDS)
def test_batch_equals_one_by_one(backend):
    designs = random_designs()
    sol = linkdyn.analyze(designs, T, backend=backend)
    assert sol.batched and sol.n_designs == len(designs) and sol.valid.shape == (5, len(T))
    assert sol.valid.all()
    for k, m in enumerate(designs):
        alone = linkdyn.analyze(m, T, backend=backend)
        one = sol.design(k)
        assert one.model is m and not one.batched
        assert_same(one.columns, alone.columns, 1e-12, f"design {k} ({backend})")
        # the batch's own arrays (not only design(k)'s) hold the design's numbers
        assert np.allclose(sol.dyn.tau[k], alone.dyn.tau, rtol=0, atol=1e-12 * np.abs(
            alone.dyn.tau).max())
        assert np.allclose(sol.loads.potential_energy[k], alone.loads.potential_energy,
                           rtol=1e-12, atol=0)
        assert np.allclose(sol.reactions.force[k], alone.reactions.force, rtol=0,
                           atol=1e-12 * np.abs(alone.reactions.force).max())
        # the internals computed on first read, taken per design
        for a, b in zip(one.dyn.wstar + one.reactions.tree, alone.dyn.wstar + alone.reactions.tree):
            assert np.allclose(a, b, rtol=1e-12, atol=1e-12 * (np.abs(b).max() + 1e-300))


@pytest.mark.parametrize("backend", BACKENDS)
def test_bad_designs_keep_the_others(backend):
    rng = np.random.default_rng(3)
    good = [fourbar(rng), fourbar(rng)]
    # crank 400 mm: the loop cannot close at t = 0 (no assembly); crank 150 mm: it assembles
    # but stops closing partway round
    bad = fourbar(rng, crank=400.0)
    partial = fourbar(np.random.default_rng(7), crank=150.0)
    designs = [good[0], bad, partial, good[1]]
    sol = linkdyn.analyze(designs, T, backend=backend)   # never raises for a bad design
    assert not sol.valid[1].any()
    assert 0 < sol.valid[2].sum() < len(T)
    assert sol.valid[0].all() and sol.valid[3].all()
    with pytest.raises(linkdyn.AssemblyError, match="cannot be assembled"):
        linkdyn.analyze(bad, T, backend=backend)
    for k in (0, 2, 3):
        alone = linkdyn.analyze(designs[k], T, backend=backend, allow_singular=True)
        assert np.array_equal(sol.valid[k], alone.valid)
        assert_same(sol.design(k).columns, alone.columns, 1e-12, f"design {k} ({backend})")
    # the design that cannot be assembled is NaN through (time excepted)
    cols = sol.design(1).columns
    assert all(np.isnan(v).all() for c, v in cols.items() if c != "t")


def test_newton_path_per_design_drivers():
    # loops solved by Newton's continuation (no closed-form dyads): the nodes are shared by the
    # designs, the drivers' values are each design's own
    designs = random_designs(5)
    lay = dataclasses.replace(compile_designs(designs), dyads=None)
    batch = kinematics.solve(designs, T, layout=lay, backend="numpy")
    for k, m in enumerate(designs):
        alone = kinematics.solve(m, T, layout=dataclasses.replace(compile_layout(m), dyads=None),
                                 backend="numpy")
        assert batch.valid[k].all() and alone.valid.all()
        for a, b in zip(batch.joint_motion, alone.joint_motion):
            for x, y in zip(a, b):
                # a different node grid only moves the Newton guess: equal to the tolerance
                assert np.allclose(x[k], y, rtol=0, atol=1e-9 * max(1.0, np.abs(y).max()))


def test_design_api():
    designs = random_designs()[:2]
    sol = linkdyn.analyze(designs, T, backend="numpy")
    assert sol.design(-1).model is designs[1]
    with pytest.raises(IndexError, match="out of range"):
        sol.design(2)
    with pytest.raises(TypeError):
        sol.design(0.5)
    one = sol.design(1)
    assert one.effort("J1").shape == T.shape
    assert one.reaction("J2").shape == T.shape + (2,)
    assert one.point("coupler", "P").shape == T.shape + (2,)
    df = one.to_dataframe()
    assert len(df) == len(T) and np.array_equal(df["tau_J1"].to_numpy(), one.columns["tau_J1"])
    with pytest.raises(ValueError):
        sol.to_dataframe()
    assert repr(sol) and sol._repr_html_() and repr(one)
    # a single mechanism is its own design 0; a list of one model is a batch of one
    single = linkdyn.analyze(designs[0], T, backend="numpy")
    assert single.design(0) is single and single.n_designs == 1 and not single.batched
    one_batch = linkdyn.analyze(designs[:1], T, backend="numpy")
    assert one_batch.valid.shape == (1, len(T)) and one_batch.dyn.tau.shape == (1, len(T), 1)
    assert_same(one_batch.design(0).columns, single.columns, 0.0, "batch of one")


def test_designs_of_other_topologies_are_refused():
    rng = np.random.default_rng(1)
    m = fourbar(rng)
    other_kind = dataclasses.replace(m, joints=m.joints[:3] + (
        dataclasses.replace(m.joints[3], kind="prismatic"),))
    other_driver = dataclasses.replace(m, drivers=(dataclasses.replace(m.drivers[0], joint="J4"),))
    cases = {"joints": other_kind, "drivers": other_driver,
             "loads": fourbar(rng, extra_load=True)}
    for what, bad in cases.items():
        with pytest.raises(ModelError, match=f"design 2 differs from design 0 in its {what}"):
            linkdyn.analyze([m, m, bad], T, backend="numpy")
    with pytest.raises(ModelError, match="no designs"):
        linkdyn.analyze([], T, backend="numpy")


def test_continuation_steps_cover_every_design():
    # the node grid is sized by the largest driver travel over the designs, computed from each
    # distinct motion once (of the constant speeds, the fastest): it equals the brute force
    from linkdyn.kinematics.layout import motion_steps
    from linkdyn.motion import ConstantSpeed, ExpressionMotion
    probe = np.linspace(-0.5, 2.0, 257)
    speeds = [ConstantSpeed(s, start=b) for s, b in ((3.0, 0.1), (-7.5, 2.0), (5.0, -1.0))]
    wave = ExpressionMotion("0.9*sin(9*t) + t")   # rate up to 9.1 rad/s
    motions = ((speeds[0], wave, speeds[1], speeds[2], speeds[0]),)
    brute = np.max([np.abs(np.diff(m.evaluate(probe)[0])) for m in motions[0]], axis=0)
    got = motion_steps(motions, probe)
    assert got.shape == (1, 256)
    assert np.allclose(got[0], brute, rtol=1e-12, atol=1e-15)
    # the formula is faster than 7.5 rad/s only at some probes: both bound the steps
    assert np.any(got[0] > 7.5 * 2.5 / 256 * (1 + 1e-9)) and np.any(np.isclose(got[0], 7.5 * 2.5 / 256))


def variant(m: linkdyn.Model, f: float) -> linkdyn.Model:
    """Model ``m`` with its numbers changed by the factor ``f`` (about 1): masses, inertias,
    gravity (turned and scaled), load values and constants, constant driver speeds."""
    from linkdyn.motion import ConstantSpeed
    turn = np.array([[np.cos(f - 1), -np.sin(f - 1)], [np.sin(f - 1), np.cos(f - 1)]])
    g = f * turn @ np.asarray(m.gravity) + (f - 1) * np.array([0.0, -9.81])

    def load(ld):
        value = ld.value if ld.value is None else (lambda t, v=ld.value: f * np.asarray(v(t)))
        return dataclasses.replace(ld, value=value, stiffness=f * ld.stiffness,
                                   free_length=ld.free_length * (2 - f), damping=f * ld.damping)

    def driver(d):
        mo = d.motion
        if isinstance(mo, ConstantSpeed):
            mo = ConstantSpeed(mo.speed * f, start=mo.start + (f - 1) * 0.1)
        return dataclasses.replace(d, motion=mo)
    return dataclasses.replace(
        m, gravity=g, loads=tuple(map(load, m.loads)), drivers=tuple(map(driver, m.drivers)),
        bodies=tuple(dataclasses.replace(b, mass=b.mass * f, inertia=b.inertia * f ** 2)
                     for b in m.bodies))


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("name", ["fivebar", "slider_crank", "inverted_slider_crank", "watt2"])
def test_bundled_examples_batch_equals_one_by_one(name, backend):
    # two drivers (fivebar), sliders and a moving slide line, a six-bar: every design its own
    import golden
    m, t = golden.times(name)
    t = t[::3]
    designs = [variant(m, f) for f in (1.0, 1.04, 0.97)]
    sol = linkdyn.analyze(designs, t, backend=backend, allow_singular=True)
    for k, d in enumerate(designs):
        alone = linkdyn.analyze(d, t, backend=backend, allow_singular=True)
        assert np.array_equal(sol.valid[k], alone.valid) and alone.valid.any()
        assert_same(sol.design(k).columns, alone.columns, 1e-12, f"{name} design {k}")
    assert np.max(np.abs(sol.dyn.tau[1] - sol.dyn.tau[0])) > 1e-3 * np.max(np.abs(sol.dyn.tau[0]))


def test_the_stacked_layout_holds_each_design_and_the_kernels_read_it_in_place():
    """One numeric layout for both backends: each per-entity number is one array with the
    design axis (``(n, 2, D, 1)``, ``(n, D, 1)``); design k of the stack is design k's own layout,
    number for number, and so are the designs a ``take`` keeps; the kernels' view of a number
    shares the layout's memory (no copy per call)."""
    designs = random_designs(3)
    stacked = compile_designs(designs)
    n, D = stacked.topo.n, len(designs)
    assert stacked.joint_point.shape == (n, 2, D, 1) and stacked.mass.shape == (n, D, 1)
    assert stacked.cut_pa.shape == (1, 2, D, 1) and stacked.joint_point[2].shape == (2, D, 1)
    kept = stacked.take([3, 1])
    for lay, k in [(stacked.design(j), j) for j in range(D)] + [(kept.design(0), 3),
                                                                (kept.design(1), 1)]:
        alone = compile_layout(designs[k], stacked.topo)
        for name in stacked.NUMBERS:
            assert np.array_equal(getattr(lay, name), getattr(alone, name)), (k, name)
        assert [c.pa.tolist() for c in lay.cuts] == [c.pa.tolist() for c in alone.cuts]
    for name in stacked.NUMBERS:
        view = stacked.per_design(name)
        assert view.shape[-1] == D and np.shares_memory(view, getattr(stacked, name)), name
    one = compile_layout(designs[0])
    assert one.per_design("joint_point").shape == (n, 2, 1)
    assert np.shares_memory(one.per_design("joint_point"), one.joint_point)
