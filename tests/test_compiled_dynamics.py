"""The compiled dynamics + reactions kernel against the numpy reference.

``linkdyn.dynamics.compiled.solve`` must give what ``denoc.solve`` followed by
``reactions.solve`` give on the same kinematic solution: tau, lam, Q, w_star, w_tilde, kinetic
energy, pivot, every joint's ``on_second`` wrench and every tree wrench ``R_i``, in the same
shapes, to 1e-12 of each quantity's peak, NaN at the same samples. Covered: every bundled
example, the dynamics tests' models (loads, gravity, springs, dampers, prismatic tree, cut and
driven joints, joints declared child-first, two drivers, two loops), stacked designs, a design
that cannot assemble, samples past a limit position, and a closure Jacobian made singular (and
nearly singular on both sides of the pivot threshold) at chosen samples.
"""

from __future__ import annotations

import dataclasses
import tomllib

import numpy as np
import pytest

import linkdyn
from linkdyn import kinematics, loads as loads_mod, reactions
from linkdyn.cli import example_names, example_text
from linkdyn.compiled import pack
from linkdyn.dynamics import compiled, denoc
from linkdyn.io import model_from_dict

from test_dynamics import MODELS, times

RTOL = 1e-12


def numpy_kinematics(model, t):
    """The numpy kinematics."""
    return kinematics.solve(model, t, backend="numpy")


def both(model, kin):
    """(numpy dyn, numpy reactions), (compiled dyn, compiled reactions) on ``kin``."""
    first = model if isinstance(model, linkdyn.Model) else list(model)[0]
    applied = loads_mod.wrenches(first, kin)
    dyn = denoc.solve(kin, applied)
    ref = (dyn, reactions.solve(first, kin, dyn))
    return ref, compiled.solve(kin, applied, pack(kin.layout, len(first.joints)))


def same(actual, expected, what, rtol=RTOL):
    """Equal shapes, NaN at the same places, finite values within ``rtol`` x peak |expected|."""
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    nan_a, nan_e = np.isnan(actual), np.isnan(expected)
    assert np.array_equal(nan_a, nan_e), (
        f"{what}: NaN at {np.argwhere(nan_a != nan_e)[:5].tolist()} differs")
    a, e = actual[~nan_e], expected[~nan_e]
    if e.size == 0:
        return
    peak = float(np.max(np.abs(e)))
    err = float(np.max(np.abs(a - e)))
    assert err <= rtol * peak, f"{what}: |difference| {err:.3e} > {rtol:.0e} x peak {peak:.3e}"


def check_all(ref, fast):
    """Every field of the dynamic solution and the reactions."""
    (d0, r0), (d1, r1) = ref, fast
    for name in ("tau", "lam", "Q", "kinetic_energy", "pivot", "w_star", "w_tilde"):
        same(getattr(d1, name), getattr(d0, name), name)
    assert len(d1.wstar) == len(d0.wstar) and len(d1.wtilde) == len(d0.wtilde)
    for i, (a, b) in enumerate(zip(d1.wstar, d0.wstar)):
        same(a, np.broadcast_to(b, a.shape), f"wstar[{i}]")
    for i, (a, b) in enumerate(zip(d1.wtilde, d0.wtilde)):
        same(a, b, f"wtilde[{i}]")
    assert len(r1.on_second) == len(r0.on_second) and len(r1.tree) == len(r0.tree)
    for j, (a, b) in enumerate(zip(r1.on_second, r0.on_second)):
        same(a, b, f"on_second[{j}]")
    for i, (a, b) in enumerate(zip(r1.tree, r0.tree)):
        same(a, b, f"tree[{i}]")
    same(r1.force, r0.force, "force")
    same(r1.moment, r0.moment, "moment")


def hoeken_design(crank_mm):
    text = example_text("hoeken")
    assert "O2 = [38.1, 0.0]" in text
    return model_from_dict(tomllib.loads(text.replace("O2 = [38.1, 0.0]",
                                                      f"O2 = [{float(crank_mm)!r}, 0.0]")))


def slider_crank_design(scale):
    """The bundled slider-crank with its masses and inertias scaled by ``scale``."""
    model = linkdyn.load(linkdyn.example_path("slider_crank"))
    bodies = tuple(dataclasses.replace(b, mass=b.mass * scale, inertia=b.inertia * scale)
                   for b in model.bodies)
    return dataclasses.replace(model, bodies=bodies)


# ----------------------------------------------------------------------------------------------


@pytest.mark.parametrize("name", example_names())
def test_bundled_examples(name):
    model = linkdyn.load(linkdyn.example_path(name))
    kin = numpy_kinematics(model, times(model, 41))
    ref, fast = both(model, kin)
    assert np.all(np.isfinite(ref[0].tau)) and np.max(np.abs(ref[0].tau)) > 0
    check_all(ref, fast)


@pytest.mark.parametrize("name", list(MODELS))
def test_dynamics_test_models(name):
    model = MODELS[name]()
    kin = numpy_kinematics(model, times(model, 33))
    check_all(*both(model, kin))


def test_loads_are_in_the_comparison():
    """The loaded models really load the kernel: without ``w_ext`` tau changes."""
    model = MODELS["hoeken-loaded"]()
    kin = numpy_kinematics(model, times(model, 17))
    applied = loads_mod.wrenches(model, kin)
    assert any(np.max(np.abs(w)) > 0 for w in applied.wrenches)
    free = dataclasses.replace(applied, wrenches=[np.zeros_like(w) for w in applied.wrenches])
    packed = pack(kin.layout, len(model.joints))
    loaded, _ = compiled.solve(kin, applied, packed)
    unloaded, _ = compiled.solve(kin, free, packed)
    assert np.max(np.abs(loaded.tau - unloaded.tau)) > 1e-3 * np.max(np.abs(loaded.tau))


def test_comparison_detects_a_wrong_kernel_input():
    """A 0.1 % heavier coupler in the packed layout is caught by :func:`check_all`."""
    model = linkdyn.load(linkdyn.example_path("hoeken"))
    kin = numpy_kinematics(model, times(model, 9))
    ref, _ = both(model, kin)
    packed = pack(kin.layout, len(model.joints))
    heavy = dataclasses.replace(packed, mass=packed.mass * np.array([1.0, 1.0, 1.001, 1.0]))
    wrong = compiled.solve(kin, loads_mod.wrenches(model, kin), heavy)
    with pytest.raises(AssertionError):
        check_all(ref, wrong)


def test_two_hoeken_designs_stacked():
    designs = [hoeken_design(38.1), hoeken_design(42.0)]
    kin = numpy_kinematics(designs, times(designs[0], 25))
    assert kin.shape == (2, 25)
    ref, fast = both(designs, kin)
    assert fast[0].tau.shape == (2, 25, 1) and fast[1].force.shape == (2, 25, 4, 2)
    assert np.max(np.abs(ref[0].tau[0] - ref[0].tau[1])) > 1e-3  # the designs differ
    check_all(ref, fast)


def test_two_slider_crank_designs_stacked():
    """Per-design masses with a prismatic joint, gravity and a process force."""
    designs = [slider_crank_design(1.0), slider_crank_design(1.7)]
    kin = numpy_kinematics(designs, times(designs[0], 25))
    ref, fast = both(designs, kin)
    assert np.max(np.abs(ref[0].tau[0] - ref[0].tau[1])) > 1e-3
    check_all(ref, fast)


def test_a_design_that_cannot_assemble_is_nan_in_its_samples_only():
    designs = [hoeken_design(38.1), hoeken_design(400.0), hoeken_design(40.0)]
    kin = numpy_kinematics(designs, np.linspace(0.0, 0.5, 7))
    ref, fast = both(designs, kin)
    assert np.all(np.isnan(fast[0].tau[1])) and np.all(np.isfinite(fast[0].tau[[0, 2]]))
    check_all(ref, fast)


def test_samples_past_a_limit_position_are_nan_alike():
    """A non-Grashof Hoeken driven past the angle where the loop stops closing."""
    text = example_text("hoeken").replace("O2 = [38.1, 0.0]", "O2 = [60.0, 0.0]")
    text = text.replace("O4 = [89.5, 0.0] }", "O4 = [180.0, 0.0] }")
    model = model_from_dict(tomllib.loads(text))
    kin = numpy_kinematics(model, np.linspace(0.0, 4 / 3, 61))
    assert 0 < np.sum(~kin.valid) < 61
    ref, fast = both(model, kin)
    assert np.array_equal(np.isnan(fast[0].tau[:, 0]), ~kin.valid)
    check_all(ref, fast)


@pytest.mark.parametrize("name", ["hoeken-loaded", "stephenson",
                                  "inverted-slider-crank-cut-prismatic", "five-bar"])
def test_singular_and_nearly_singular_closure_jacobian(name):
    """Finite kinematics but ``J_dep`` made singular, nearly singular on either side of the
    pivot threshold, and partly NaN at chosen samples: lam, tau and the reactions that depend
    on them are NaN exactly where the numpy path has NaN."""
    model = MODELS[name]()
    kin = numpy_kinematics(model, times(model, 12))
    dep = np.array(kin.layout.topo.dependent) - 1
    J = np.array(kin.jacobian)
    J[:, dep[0], 1] = 0.0                        # exactly singular
    J[:, dep[-1], 3] = J[:, dep[0], 3]           # two equal columns
    J[:, dep[0], 5] *= 1e-15                     # relative pivot ~1e-15: singular
    J[:, dep[0], 7] *= 1e-9                      # small, but above the threshold
    J[0, dep[-1], 9] = np.nan                    # one NaN entry
    J[-1, dep[0], 10] = np.inf
    bad = dataclasses.replace(kin, jacobian=J)
    ref, fast = both(model, bad)
    lam = ref[0].lam
    assert np.all(np.isnan(lam[[1, 3, 5, 9, 10]])) and np.all(np.isfinite(lam[[0, 2, 4, 7]]))
    assert not np.any(ref[0].pivot[[1, 3, 5]] > 1e-13) and ref[0].pivot[7] > 1e-13
    check_all(ref, fast)


def test_kinematic_arrays_are_used_when_set():
    """With ``kin.arrays`` (compiled kinematics) the kernel reads them: the same results as
    from the per-body lists, and different when the arrays differ from the lists."""
    model = MODELS["slider-crank-cut-J3"]()
    kin = numpy_kinematics(model, times(model, 15))
    shape, n = kin.shape, kin.layout.topo.n

    def flat(x, lead):
        return np.ascontiguousarray(np.broadcast_to(x, lead + shape).reshape(lead + (1,) + shape))

    pose = kin.pose
    arrays = {"c": flat(np.stack(pose.c), (n,)), "s": flat(np.stack(pose.s), (n,)),
              "r": flat(np.stack(pose.r), (n, 2)),
              "e": flat(np.stack([np.zeros((2,) + shape) if x is None else x for x in pose.e]),
                        (n, 2)),
              "tw": flat(np.stack(kin.twists), (n, 3)), "twd": flat(np.stack(kin.rates), (n, 3)),
              "J": flat(kin.jacobian, kin.jacobian.shape[:2])}
    ref, _ = both(model, kin)
    with_arrays = dataclasses.replace(kin, arrays=arrays)
    applied = loads_mod.wrenches(model, kin)
    packed = pack(kin.layout, len(model.joints))
    check_all(ref, compiled.solve(with_arrays, applied, packed))
    arrays["twd"] = arrays["twd"] * 1.01
    changed, _ = compiled.solve(with_arrays, applied, packed)
    assert np.max(np.abs(changed.tau - ref[0].tau)) > 1e-4 * np.max(np.abs(ref[0].tau))


@pytest.mark.parametrize("block", [1, 5, 16])
def test_any_sample_block_gives_the_same(monkeypatch, block):
    """The kernel takes the samples in blocks: several blocks and a short last one per design
    (33 samples, two designs) give the numpy results too."""
    monkeypatch.setattr(compiled, "BLOCK", block)
    designs = [slider_crank_design(1.0), slider_crank_design(0.6)]
    kin = numpy_kinematics(designs, times(designs[0], 33))
    check_all(*both(designs, kin))
