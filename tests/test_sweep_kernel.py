"""The sweep kernel (kinematics and dynamics fused, ``linkdyn.dynamics.compiled.sweep``) against
the full kinematics kernel followed by the compiled dynamics stage.

A sweep whose metrics read no reaction runs the dynamics inside the kinematics kernel's blocks
and keeps only part of the kinematics per sample (the joints' motion, the poses). What it keeps
must equal the full kernel's, and its dynamics (lam, tau, kinetic energy, pivot) the dynamics
stage's on the full kinematics, to 1e-12 of each quantity's peak with NaN at the same samples;
what it leaves out (twists, their rates, the Jacobian) comes from the full kernel when read.
Covered: every bundled example and the dynamics tests' models, their loads removed (the sweep
kernel runs layouts whose only applied load is gravity), with gravity and without: one and two
loops, prismatic tree and cut joints, slot joints, two drivers; two designs stacked (a cam's
two lifts among them, so that each design's cut numbers are its own); several
blocks of samples with a partial last one; a design that cannot assemble and one driven past a
limit position.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib

import numpy as np
import pytest

import linkdyn
from linkdyn import analysis, kinematics, loads as loads_mod
from linkdyn.cli import example_names, example_text
from linkdyn.dynamics import compiled
from linkdyn.io import model_from_dict
from linkdyn.kinematics import compiled as kc
from linkdyn.kinematics.layout import compile_designs
from linkdyn.kinematics.solution import Swept

from test_compiled_dynamics import hoeken_design, same
from test_dynamics import MODELS, times

pytest.importorskip("numba", reason="the sweep kernel is compiled by numba")


def unloaded(model, scale=1.0):
    """``model`` without its loads (gravity kept), its masses and inertias scaled by
    ``scale``."""
    bodies = tuple(dataclasses.replace(b, mass=b.mass * scale, inertia=b.inertia * scale)
                   for b in model.bodies)
    return dataclasses.replace(model, bodies=bodies, loads=())


def _limit_design():
    """A non-Grashof Hoeken driven past the angle where its loop stops closing."""
    text = example_text("hoeken").replace("O2 = [38.1, 0.0]", "O2 = [60.0, 0.0]")
    return model_from_dict(tomllib.loads(text.replace("O4 = [89.5, 0.0] }", "O4 = [180.0, 0.0] }")))


CASES = {f"example-{n}": (lambda n=n: [unloaded(linkdyn.load(linkdyn.example_path(n)), s)
                                       for s in (1.0, 1.6)]) for n in example_names()}
CASES.update({f"model-{n}": (lambda n=n: [unloaded(MODELS[n](), s) for s in (1.0, 1.6)])
              for n in ("slider-crank-cut-J3", "inverted-slider-crank-cut-prismatic",
                        "boom-offset", "five-bar", "slotted-lever")})


def _numbers(model, kind, **numbers):
    """``model`` with the numbers of its joints of ``kind`` replaced."""
    return dataclasses.replace(model, joints=tuple(
        dataclasses.replace(j, numbers={**j.numbers, **numbers}) if j.kind == kind else j
        for j in model.joints))


# two designs whose cut joints' own numbers differ: each design's rows of the closure Jacobian,
# its bias and its cut motion from its own numbers (design 0's took the others' once)
CASES["cam-lift"] = lambda: [_numbers(unloaded(linkdyn.load(linkdyn.example_path(
    "cam_follower"))), "cam", lift=x) for x in (0.02, 0.03)]
# two designs that close, one that cannot assemble, one past a limit position
CASES["hoeken-invalid"] = lambda: [hoeken_design(38.1), hoeken_design(42.0),
                                   hoeken_design(400.0), _limit_design()]


def _pair(designs, t, monkeypatch):
    """The full kernel's kinematics and the sweep kernel's, several blocks of 7 samples."""
    monkeypatch.setattr(kc, "BLOCK", 7)
    monkeypatch.setattr(compiled, "BLOCK", 7)
    lay = compile_designs(designs)
    assert compiled.fusable(lay)
    full = kinematics.solve(designs, t, layout=lay, backend="compiled")
    lean = kinematics.solve(designs, t, layout=lay, backend="compiled", run=compiled.sweep)
    return full, lean


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_sweep_kernel_equals_the_kinematics_and_dynamics_stages(case, monkeypatch):
    designs = CASES[case]()
    t = times(designs[0], 23)
    full, lean = _pair(designs, t, monkeypatch)
    assert isinstance(lean, Swept) and "twists" not in vars(lean)   # not computed yet
    # what it keeps: the joints' motion, the poses, p_i, pivots, residuals, validity
    assert np.array_equal(lean.valid, full.valid) and np.array_equal(lean.pivot, full.pivot,
                                                                     equal_nan=True)
    assert np.array_equal(lean.residual, full.residual, equal_nan=True)
    for part, name in zip(range(3), ("q", "qd", "qdd")):
        for j, (a, b) in enumerate(zip(lean.joint_motion[part], full.joint_motion[part])):
            same(a, b, f"{name} of joint {j}")
    for key in ("phi", "c", "s", "r", "e"):
        for i, (a, b) in enumerate(zip(getattr(lean.pose, key), getattr(full.pose, key))):
            assert (a is None) == (b is None), f"pose {key} of body {i}"
            if a is not None:
                same(a, b, f"pose {key} of body {i}")
    for i, (a, b) in enumerate(zip(lean.motion[1:], full.motion[1:])):
        same(np.broadcast_to(a, np.shape(b)), b, f"p of body {i + 1}")
    # its dynamics: the dynamics stage's on the full kinematics
    applied = loads_mod.wrenches(None, full)
    ref, dyn = compiled.solve(full, applied), compiled.swept(lean, applied)
    for key in ("lam", "tau", "kinetic_energy", "pivot"):
        same(getattr(dyn, key), getattr(ref, key), key)
    assert np.any(np.abs(dyn.tau) > 0)
    if np.any(full.layout.gravity != 0):   # the weights are in the comparison
        weightless = compiled.solve(full, loads_mod.wrenches(None, dataclasses.replace(
            full, layout=dataclasses.replace(full.layout, gravity=0.0 * full.layout.gravity))))
        assert not np.allclose(weightless.tau, ref.tau, equal_nan=True)
    # what it leaves out, from the full kernel when first read
    same(np.stack(lean.twists), np.stack(full.twists), "twists")
    same(np.stack(lean.rates), np.stack(full.rates), "twist rates")
    same(lean.jacobian, full.jacobian, "Jacobian")
    same(dyn.w_star, ref.w_star, "w_star (the internals, solved again)")


def test_invalid_designs_are_nan_alike(monkeypatch):
    """The designs that do not assemble or stop closing are NaN in the sweep kernel's outputs
    at the samples the full path has NaN (the comparison above would pass on all-finite)."""
    designs = CASES["hoeken-invalid"]()
    full, lean = _pair(designs, np.linspace(0.0, 4 / 3, 41), monkeypatch)
    assert np.all(~lean.valid[2]) and 0 < np.sum(~lean.valid[3]) < 41
    dyn = compiled.swept(lean, loads_mod.wrenches(None, full))
    assert np.array_equal(np.isnan(dyn.tau[..., 0]), ~full.valid)
    assert np.array_equal(np.isnan(lean.joint_motion[0][2]), ~full.valid)


def test_a_sweep_without_reactions_runs_the_sweep_kernel():
    """``analyze_layout(..., reactions=False)`` of designs without applied loads on the
    compiled backend is the sweep kernel's (its kinematics a :class:`Swept`), and gives the
    solution of the two stages; with a load it is not."""
    designs = [hoeken_design(38.1), hoeken_design(42.0)]
    t = times(designs[0], 19)
    lay = compile_designs(designs)
    eager = analysis.analyze_layout(designs, lay, t, backend="compiled")
    lazy = analysis.analyze_layout(designs, lay, t, backend="compiled", reactions=False)
    assert isinstance(lazy.kin, Swept) and not isinstance(eager.kin, Swept)
    same(lazy.dyn.tau, eager.dyn.tau, "tau")
    assert np.array_equal(lazy.valid, eager.valid)
    same(lazy.reactions.force, eager.reactions.force, "reactions")
    loaded = [MODELS["hoeken-loaded"]()] * 2
    sol = analysis.analyze_layout(loaded, compile_designs(loaded), t, backend="compiled",
                                  reactions=False)
    assert not isinstance(sol.kin, Swept)


# --- the metrics-only sweep ---------------------------------------------------------------------

def _recorded(monkeypatch):
    """Calls of the sweep kernel with ``metrics`` (the metrics-only form), counted."""
    calls = []
    real = compiled.sweep

    def sweep(*args, metrics=None, **kw):
        if metrics is not None:
            calls.append(metrics)
        return real(*args, metrics=metrics, **kw)
    monkeypatch.setattr(compiled, "sweep", sweep)
    return calls


def _analyzed(model, t, wanted, **path):
    """Each metric of ``model`` alone, by analyze and :func:`linkdyn.studies.metrics.evaluate`
    (None if analyze refuses it)."""
    try:
        sol = linkdyn.analyze(model, t, backend="numpy")
    except linkdyn.AssemblyError:
        return None
    return linkdyn.studies.metrics.evaluate(sol, wanted, **path)


def _same_metrics(df, models, t, wanted, **path):
    """Every row of the sweep table ``df`` is analyze's metrics of its design within 1e-12 of
    the metric's largest value, invalid where analyze refuses the design."""
    ref = [_analyzed(m, t, wanted, **path) for m in models]
    assert df.valid.tolist() == [r is not None for r in ref]
    for name in wanted:
        want = np.array([np.nan if r is None else float(r[name]) for r in ref])
        got = df[name].to_numpy(float)
        assert np.array_equal(np.isnan(got), np.isnan(want)), name
        scale = np.nanmax(np.abs(want))
        assert scale > 0 and np.nanmax(np.abs(got - want)) <= 1e-12 * scale, name


HOEKEN_BOX = {"bodies.ground.points.O4[0]": [89.5, 60.0, 120.0, 75.0, 50.3, 150.0],
              "bodies.coupler.points.O3[0]": [114.3, 90.0, 140.0, 130.0, 83.7, 60.0]}


@pytest.mark.parametrize("path_range", [None, (0.5, 2.5)])
def test_a_metrics_only_sweep_gives_analyzes_metrics_of_each_design(path_range, monkeypatch):
    """A sweep of Hoeken designs (one that cannot be assembled, one that stops closing) whose
    metrics are the driver's peak and rms effort and the path's deviation runs the kernel's
    metrics-only form, several blocks of samples with a partial last one, and gives each
    design's metrics as analyze does."""
    monkeypatch.setattr(kc, "BLOCK", 7)
    monkeypatch.setattr(compiled, "BLOCK", 7)
    calls = _recorded(monkeypatch)
    wanted = ["peak_tau_J1", "rms_tau_J1", "path_deviation"]
    t = np.linspace(0.0, 4.0 / 3.0, 45)
    df = linkdyn.sweep(linkdyn.example_path("hoeken"), HOEKEN_BOX, t, wanted,
                       backend="compiled", path_range=path_range)
    assert calls and calls[0].point == ("coupler", "P") and not df.valid[4] and not df.valid[5]
    assert "cannot be assembled" in df.reason[4] and "stop closing" in df.reason[5]
    space = linkdyn.studies.space(linkdyn.example_path("hoeken"), list(HOEKEN_BOX))
    models = [space.model(v) for v in np.array(list(HOEKEN_BOX.values())).T]
    _same_metrics(df, models, t, wanted, path_range=path_range)


def test_the_peak_at_the_last_sample_and_a_negative_peak(monkeypatch):
    """Hoeken's largest |effort| is a negative torque: a run that ends at that sample has its
    peak there (a kernel that left out the last sample, or took the largest effort instead of
    the largest |effort|, would miss it); and the block boundary falls just before it."""
    monkeypatch.setattr(kc, "BLOCK", 3)
    monkeypatch.setattr(compiled, "BLOCK", 3)
    calls = _recorded(monkeypatch)
    model = hoeken_design(38.1)
    full = np.linspace(0.0, 4.0 / 3.0, 61)
    tau = linkdyn.analyze(model, full, backend="numpy").dyn.tau[:, 0]
    k = int(np.argmax(np.abs(tau)))
    assert tau[k] < 0 and k % 3 == 0 and np.max(np.abs(tau[:k])) < np.abs(tau[k])
    t = full[:k + 1]
    df = linkdyn.sweep(model, {"bodies.crank.mass": [model.body("crank").mass] * 2}, t,
                       ["peak_tau_J1", "rms_tau_J1"], backend="compiled")
    assert calls and df.valid.all()
    assert np.allclose(df.peak_tau_J1, -tau[k], rtol=1e-12, atol=0)
    assert np.allclose(df.rms_tau_J1, np.sqrt(np.mean(tau[:k + 1] ** 2)), rtol=1e-12, atol=0)


def test_two_drivers_reduce_their_own_columns(monkeypatch):
    """The five-bar's two drivers: each effort metric is its own driver's (a kernel that read
    the other column would give the other's numbers), with a path point of a distal link."""
    calls = _recorded(monkeypatch)
    path = "bodies.crank2.points.B[0]"
    values = {path: [40.0, 45.0, 35.0]}
    wanted = ["peak_tau_J1", "rms_tau_J5", "peak_tau_J5", "rms_tau_J1", "path_deviation"]
    source = linkdyn.example_path("fivebar")
    t = np.linspace(0.0, 1.0, 37)
    df = linkdyn.sweep(source, values, t, wanted, backend="compiled", path_point="link3.P")
    assert calls and [k for k, _ in calls[0].efforts] == [0, 1, 1, 0]
    space = linkdyn.studies.space(source, [path])
    models = [space.model([v]) for v in values[path]]
    _same_metrics(df, models, t, wanted, path_point="link3.P")
    assert not np.allclose(df.peak_tau_J1, df.peak_tau_J5)


def test_a_design_at_a_dead_centre_is_invalid_as_analyze_says(tmp_path, monkeypatch):
    """The offset slider-crank driven by its slider into its dead centre (crank and rod in line,
    s* = sqrt(230^2 - 20^2) mm) at the last sample: closed in closed form to rounding, J_dep's
    relative pivot there ~6e-9, above a fixed 1e-10 but within the closure's resolution
    (:func:`linkdyn.kinematics.positions.singular`). The metrics-only kernel counts the sample
    as analyze does: every design invalid, with analyze's reason, never a finite peak force."""
    from linkdyn.io.writer import dumps_toml

    calls = _recorded(monkeypatch)
    d = tomllib.loads(linkdyn.example_path("slider_crank").read_text())
    s_star = math.sqrt(230.0**2 - 20.0**2)
    d["drivers"] = [{"joint": "J4", "motion": {"kind": "expression",
                                               "q": f"{s_star!r} - 60*(1 - t)**2"}}]
    d["assembly"] = {"phi": {"crank": 20.0, "rod": 354.0, "slider": 0.0}}
    for key in ("analysis", "loads"):
        d.pop(key, None)
    path = tmp_path / "dead_centre.toml"
    path.write_text(dumps_toml(d))
    t = np.linspace(0.0, 1.0, 21)
    ref = linkdyn.analyze(linkdyn.load(path), t, backend="numpy", allow_singular=True)
    assert np.flatnonzero(~ref.valid).tolist() == [20]
    df = linkdyn.sweep(path, {"bodies.slider.mass": [0.8, 1.0]}, t, ["peak_force_J4"],
                       backend="compiled")
    assert calls, "the metrics-only kernel ran"
    assert not df.valid.any() and df["peak_force_J4"].isna().all()
    assert all("singular" in r and "t = 1 s" in r for r in df.reason)
