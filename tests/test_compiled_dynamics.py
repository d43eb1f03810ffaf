"""The compiled dynamics and reactions kernels against the numpy reference.

``linkdyn.dynamics.compiled.solve`` followed by ``compiled.reactions`` must give what
``denoc.solve`` followed by ``reactions.solve`` give on the same kinematic solution: tau, lam, Q, w_star, w_tilde, kinetic
energy, pivot, every joint's ``on_second`` wrench and every tree wrench ``R_i`` (the kernel
keeping its internals), in the same shapes, to 1e-12 of each quantity's peak, NaN at the same
samples. Covered: every bundled example, the dynamics tests' models (loads, gravity, springs,
dampers, prismatic tree, cut and driven joints, joints declared child-first, two drivers, two
loops, slot joints), a slot cut before a prismatic one (cuts of different row counts), random
slotted levers, stacked designs equal to each design alone, a design that cannot assemble,
samples past a limit position, and a closure Jacobian made singular (and nearly singular on both
sides of the pivot threshold) at chosen samples.
"""

from __future__ import annotations

import dataclasses
import pickle
import tomllib

import numpy as np
import pytest

import linkdyn
from linkdyn import kinematics, loads as loads_mod, reactions
from linkdyn.cli import example_names, example_text
from hypothesis import HealthCheck, given, settings

from linkdyn.dynamics import compiled, denoc
from linkdyn.io import model_from_dict
from linkdyn.kinematics.layout import compile_designs
from linkdyn.model import Model

from builders import body, rev
from test_dynamics import MODELS, scotch_yoke, times
from test_slot import lever_models, slotted_levers

RTOL = 1e-12

# the examples and test models every compiled stage runs (tests/test_compiled.py; the compiled
# kinematics has no code for the slot yet, the dynamics kernel runs every kind)
KERNEL_EXAMPLES = [n for n in example_names() if not linkdyn.compiled.unsupported(
    j.kind for j in linkdyn.load(linkdyn.example_path(n)).joints)]
KERNEL_MODELS = [n for n, build in MODELS.items()
                 if not linkdyn.compiled.unsupported(j.kind for j in build().joints)]


def numpy_kinematics(model, t):
    """The numpy kinematics."""
    return kinematics.solve(model, t, backend="numpy")


def both(model, kin):
    """(numpy dyn, numpy reactions), (compiled dyn, compiled reactions) on ``kin``."""
    first = model if isinstance(model, linkdyn.Model) else list(model)[0]
    # a batch's loads come from its layout, per design
    applied = loads_mod.wrenches(model if isinstance(model, linkdyn.Model) else None, kin)
    dyn = denoc.solve(kin, applied)
    ref = (dyn, reactions.solve(first, kin, dyn))
    return ref, compiled_stages(kin, applied, internals=True)


def compiled_stages(kin, applied, internals=False):
    """(compiled dyn, compiled reactions) on ``kin`` under ``applied``: the two stages."""
    dyn = compiled.solve(kin, applied, internals=internals)
    return dyn, compiled.reactions(kin, applied, dyn, internals=internals)


def same(actual, expected, what, rtol=RTOL, floor=0.0):
    """Equal shapes, NaN at the same places, finite values within ``rtol`` x peak |expected|
    (at least ``floor``: the scale of a quantity that may be all rounding)."""
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    assert actual.shape == expected.shape, f"{what}: shape {actual.shape} != {expected.shape}"
    nan_a, nan_e = np.isnan(actual), np.isnan(expected)
    assert np.array_equal(nan_a, nan_e), (
        f"{what}: NaN at {np.argwhere(nan_a != nan_e)[:5].tolist()} differs")
    a, e = actual[~nan_e], expected[~nan_e]
    if e.size == 0:
        return
    peak = max(float(np.max(np.abs(e))), floor)
    err = float(np.max(np.abs(a - e)))
    assert err <= rtol * peak, f"{what}: |difference| {err:.3e} > {rtol:.0e} x peak {peak:.3e}"


def check_all(ref, fast, size=0.0):
    """Every field of the dynamic solution and the reactions (``size``, m: the moments'
    scale is the peak force times it, for a model whose joints carry no moment but rounding)."""
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
    same(r1.moment, r0.moment, "moment", floor=float(np.max(np.abs(r0.force))) * size)


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
    check_all(ref, fast, size=float(np.max(kin.layout.size)))


@pytest.mark.parametrize("name", list(MODELS))
def test_dynamics_test_models(name):
    model = MODELS[name]()
    kin = numpy_kinematics(model, times(model, 33))
    check_all(*both(model, kin), size=float(np.max(kin.layout.size)))


def yoke_and_rocker():
    """The Scotch yoke with a second loop (a link and a rocker on the yoke), its slot declared
    first: the slot's one row comes before the prismatic cut's two."""
    base = scotch_yoke()
    ground = body("ground", {"O": (0, 0), "G": (0, 0), "O6": (200, 200)})
    bodies = (ground,) + tuple(b for b in base.bodies if b.name != "ground") + (
        body("link", {"P": (0, 0), "Q": (150, 0)}, 0.3, (75, 0), 600.0),
        body("rocker", {"O": (0, 0), "Q": (100, 0)}, 0.5, (50, 5), 400.0))
    joints = (base.joints[2],) + base.joints[:2] + (
        rev("J5", "yoke.P", "link.P"), rev("J6", "link.Q", "rocker.Q"),
        rev("J7", "ground.O6", "rocker.O"))
    return Model("yoke and rocker", bodies, joints, base.drivers, base.loads, base.gravity,
                 assembly_phi={**base.assembly_phi, "link": 1.9, "rocker": -1.1},
                 assembly_q=base.assembly_q)


def test_cuts_of_different_row_counts():
    """A slot (one row) cut before a prismatic joint (two rows): each cut reads its own
    multipliers."""
    model = yoke_and_rocker()
    kin = numpy_kinematics(model, times(model, 21))
    lay = kin.layout
    assert [c.kind for c in lay.cuts] == ["slot", "prismatic"] and lay.topo.rows == (1, 2)
    ref, fast = both(model, kin)
    assert np.all(np.isfinite(ref[0].lam)) and np.min(np.max(np.abs(ref[0].lam), axis=0)) > 0
    check_all(ref, fast)


@settings(max_examples=4, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(slotted_levers())
def test_random_slotted_levers(case):
    """Random slotted levers (geometry, masses, loads, gravity; tests/test_slot.py) and their
    massless-block equivalent (revolute and prismatic joints)."""
    for model in lever_models(case):
        kin = numpy_kinematics(model, np.linspace(0.0, 1.0, 9))
        check_all(*both(model, kin))


def scaled(model, scale):
    """``model`` with its masses and inertias scaled by ``scale``."""
    bodies = tuple(dataclasses.replace(b, mass=b.mass * scale, inertia=b.inertia * scale)
                   for b in model.bodies)
    return dataclasses.replace(model, bodies=bodies)


@pytest.mark.parametrize("build", [scotch_yoke, yoke_and_rocker])
def test_a_batch_of_designs_equals_each_design_alone(build):
    """Stacked designs (different masses) through the kernel at once give each design's own
    kernel results (and numpy's)."""
    designs = [scaled(build(), 1.0), scaled(build(), 1.6)]
    t = times(designs[0], 17)
    kin = numpy_kinematics(designs, t)
    ref, fast = both(designs, kin)
    check_all(ref, fast)
    for k, model in enumerate(designs):
        one = both(model, numpy_kinematics(model, t))[1]
        for name in ("tau", "lam", "kinetic_energy", "pivot"):
            same(getattr(fast[0], name)[k], getattr(one[0], name), name)
        same(fast[1].force[k], one[1].force, "force")
        same(fast[1].moment[k], one[1].moment, "moment")
    assert np.max(np.abs(fast[0].tau[0] - fast[0].tau[1])) > 1e-3 * np.max(np.abs(fast[0].tau))


def test_loads_are_in_the_comparison():
    """The loaded models really load the kernel: without ``w_ext`` tau changes."""
    model = MODELS["hoeken-loaded"]()
    kin = numpy_kinematics(model, times(model, 17))
    applied = loads_mod.wrenches(model, kin)
    assert any(np.max(np.abs(w)) > 0 for w in applied.wrenches)
    free = dataclasses.replace(applied, wrenches=[np.zeros_like(w) for w in applied.wrenches])
    loaded, _ = compiled_stages(kin, applied)
    unloaded, _ = compiled_stages(kin, free)
    assert np.max(np.abs(loaded.tau - unloaded.tau)) > 1e-3 * np.max(np.abs(loaded.tau))


def test_comparison_detects_a_wrong_kernel_input():
    """A 0.1 % heavier coupler in the layout the kernels read is caught by :func:`check_all`."""
    model = linkdyn.load(linkdyn.example_path("hoeken"))
    kin = numpy_kinematics(model, times(model, 9))
    ref, _ = both(model, kin)
    mass = np.multiply(kin.layout.mass, [1.0, 1.0, 1.001, 1.0])
    heavy = dataclasses.replace(kin, layout=dataclasses.replace(kin.layout, mass=mass))
    wrong = compiled_stages(heavy, loads_mod.wrenches(model, kin), internals=True)
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
    check_all(ref, compiled_stages(with_arrays, applied, internals=True))
    arrays["twd"] = arrays["twd"] * 1.01
    changed, _ = compiled_stages(with_arrays, applied)
    assert np.max(np.abs(changed.tau - ref[0].tau)) > 1e-4 * np.max(np.abs(ref[0].tau))


@pytest.mark.parametrize("block", [1, 5, 16])
def test_any_sample_block_gives_the_same(monkeypatch, block):
    """The kernel takes the samples in blocks: several blocks and a short last one per design
    (33 samples, two designs) give the numpy results too."""
    monkeypatch.setattr(compiled, "BLOCK", block)
    designs = [slider_crank_design(1.0), slider_crank_design(0.6)]
    kin = numpy_kinematics(designs, times(designs[0], 33))
    check_all(*both(designs, kin))


def test_bodies_without_loads_cost_no_memory_per_sample():
    """No per-sample memory for a body without loads, nor for the ground's share when nothing
    is anchored on it (measured: numpy's allocations while the loads stage runs stay below one
    (3, T) wrench, where the four bodies' and the ground's would take five); every wrench keeps
    the shape (3, ...), and the numpy solver's ``w_star`` of the ground is a full, writable
    zero."""
    import tracemalloc

    model = linkdyn.load(linkdyn.example_path("hoeken"))   # no gravity, no loads
    T = 20001
    kin = numpy_kinematics(model, times(model, T))
    tracemalloc.start()                                    # numpy reports its data to it
    try:
        applied = loads_mod.wrenches(model, kin)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 3 * T * 8, f"{peak} bytes allocated for loads that are all zero"
    for w in applied.wrenches + [applied.on_ground]:
        assert w.shape == (3, T) and not np.any(w)
    assert applied.w_ext.shape == (T, 4, 3)
    kin = numpy_kinematics(model, times(model, 9))
    dyn = denoc.solve(kin, loads_mod.wrenches(model, kin))
    assert dyn.wstar[0].shape == (3, 9) and dyn.wstar[0].flags.writeable
    # a spring anchored on the ground: its share is nonzero at every sample, as are the
    # loaded bodies'; the crank carries no load
    model = MODELS["hoeken-loaded"]()
    applied = loads_mod.wrenches(model, numpy_kinematics(model, times(model, 9)))
    assert applied.wrenches[0].shape == (3, 9) and not np.any(applied.wrenches[0])
    assert applied.on_ground.shape == (3, 9) and np.all(np.abs(applied.on_ground[1:]) > 0)
    assert all(w.shape == (3, 9) and np.any(w) for w in applied.wrenches[1:])


def constant_loads(applied, values):
    """``applied`` with the wrench of body i the constant ``values[i]`` (3, ...) broadcast
    over the samples (stride 0 along them)."""
    shape = applied.wrenches[0].shape
    return dataclasses.replace(applied, wrenches=[np.broadcast_to(v, shape) for v in values])


@pytest.mark.parametrize("designs", [1, 2])
def test_constant_applied_wrenches_equal_the_same_at_every_sample(monkeypatch, designs):
    """Wrenches constant in time (broadcast along the samples, per design when stacked) give
    numpy's results, and the same bits as the same wrenches given as full arrays; with no
    loads at all too."""
    monkeypatch.setattr(compiled, "BLOCK", 8)   # several blocks
    models = [hoeken_design(38.1), hoeken_design(42.0)][:designs]
    kin = numpy_kinematics(models if designs > 1 else models[0], times(models[0], 21))
    D = designs
    applied = loads_mod.wrenches(models[0] if designs == 1 else None, kin)
    dyn = denoc.solve(kin, applied)   # no loads at all
    check_all((dyn, reactions.solve(models[0], kin, dyn)),
              compiled_stages(kin, applied, internals=True))
    # constant per body (the ground's zero), and per design when stacked: (3, D, 1) or (3, 1)
    scale = np.linspace(1.0, 1.3, D)[:, None]
    values = [np.zeros(3)] + [np.array([0.2 * i, -1.5 + i, 0.7]) for i in (1, 2, 3)]
    values = [v[:, None, None] * scale if designs > 1 else v[:, None] for v in values]
    const = constant_loads(applied, values)
    dyn = denoc.solve(kin, const)
    ref = (dyn, reactions.solve(models[0], kin, dyn))
    fast = compiled_stages(kin, const, internals=True)
    check_all(ref, fast)
    assert np.max(np.abs(fast[0].tau - dyn.tau)) <= RTOL * np.max(np.abs(dyn.tau))
    # the same wrenches at every sample: the same bits
    full = dataclasses.replace(const, wrenches=[np.array(w) for w in const.wrenches])
    again = compiled_stages(kin, full, internals=True)
    for name in ("tau", "lam", "Q", "w_star", "w_tilde"):
        assert np.array_equal(getattr(again[0], name), getattr(fast[0], name)), name
    assert np.array_equal(again[1].force, fast[1].force)
    assert np.array_equal(np.stack(again[1].tree), np.stack(fast[1].tree))


def test_a_load_varying_in_time_without_gravity():
    """A torque varying in time on one body, none elsewhere and no gravity: the kernel
    matches numpy, and the torque changes the driver's."""
    model = linkdyn.load(linkdyn.example_path("hoeken"))
    assert not np.any(model.gravity) and not model.loads
    torque = linkdyn.Load("torque", "rocker", value=lambda t: 0.3 * np.sin(5.0 * np.asarray(t)))
    model = dataclasses.replace(model, loads=(torque,))
    kin = numpy_kinematics(model, times(model, 31))
    ref, fast = both(model, kin)
    unloaded = both(dataclasses.replace(model, loads=()), kin)[1]
    assert np.max(np.abs(fast[0].tau - unloaded[0].tau)) > 1e-3 * np.max(np.abs(fast[0].tau))
    check_all(ref, fast)


@pytest.mark.parametrize("name", ["hoeken", "stephenson", "inverted_slider_crank",
                                  "scotch_yoke"])
@pytest.mark.parametrize("block", [5, 1024])
def test_internals_not_kept_are_computed_when_first_read(monkeypatch, name, block):
    """By default the solutions hold no per-sample ``w_star``, ``w_tilde``, ``Q``, ``R_i``:
    every other output is the same to the bit as with them kept, and reading one gives the
    kept ones, to the bit (the kernel runs again, keeping them)."""
    monkeypatch.setattr(compiled, "BLOCK", block)
    model = linkdyn.load(linkdyn.example_path(name))
    kin = numpy_kinematics(model, times(model, 41))
    applied = loads_mod.wrenches(model, kin)
    kept = compiled_stages(kin, applied, internals=True)
    lean = compiled_stages(kin, applied)
    for name_ in ("tau", "lam", "kinetic_energy", "pivot"):
        assert np.array_equal(getattr(lean[0], name_), getattr(kept[0], name_)), name_
    for j, (a, b) in enumerate(zip(lean[1].on_second, kept[1].on_second)):
        assert np.array_equal(a, b), f"on_second[{j}]"
    assert not callable(kept[0].internals) and callable(lean[0].internals)
    for name_ in ("w_star", "w_tilde", "Q"):
        assert np.array_equal(getattr(lean[0], name_), getattr(kept[0], name_)), name_
    assert np.array_equal(np.stack(lean[1].tree), np.stack(kept[1].tree))
    dyn = denoc.solve(kin, applied)
    check_all((dyn, reactions.solve(model, kin, dyn)), lean)


@pytest.mark.parametrize("name", ["hoeken", "stephenson", "inverted_slider_crank",
                                  "scotch_yoke", "slider_crank"])
@pytest.mark.parametrize("block", [5, 1024])
def test_dynamics_and_reactions_in_one_kernel_equal_the_two_stages(monkeypatch, name, block):
    """``compiled.inverse`` (the reactions taken in the dynamics kernel's blocks, as
    ``analyze`` runs them) gives the two stages' numbers to the bit, their internals when read
    too, and the numpy solvers' to rounding; ``analyze`` on the compiled backend gives them."""
    monkeypatch.setattr(compiled, "BLOCK", block)
    model = linkdyn.load(linkdyn.example_path(name))
    kin = kinematics.solve(model, times(model, 41), backend="compiled")
    applied = loads_mod.wrenches(model, kin)
    two = compiled_stages(kin, applied)
    one = compiled.inverse(kin, applied)
    for name_ in ("tau", "lam", "kinetic_energy", "pivot", "w_star", "w_tilde", "Q"):
        assert np.array_equal(getattr(one[0], name_), getattr(two[0], name_)), name_
    assert np.array_equal(np.stack(one[1].on_second), np.stack(two[1].on_second))
    assert np.array_equal(np.stack(one[1].tree), np.stack(two[1].tree))
    dyn = denoc.solve(kin, applied)
    check_all((dyn, reactions.solve(model, kin, dyn)), one, size=float(np.max(kin.layout.size)))
    sol = linkdyn.analyze(model, kin.t, backend="compiled")
    assert np.array_equal(sol.reactions.force, one[1].force)
    assert np.array_equal(sol.dyn.tau, one[0].tau)


def test_a_solution_without_kept_internals_pickles():
    """The internals computed on first read survive a pickle round trip (a design sweep may
    send solutions between processes)."""
    model = linkdyn.load(linkdyn.example_path("hoeken"))
    kin = numpy_kinematics(model, times(model, 9))
    applied = loads_mod.wrenches(model, kin)
    dyn, react = compiled_stages(kin, applied)
    dyn2, react2 = pickle.loads(pickle.dumps((dyn, react)))
    assert np.array_equal(dyn2.w_star, dyn.w_star) and np.array_equal(dyn2.tau, dyn.tau)
    assert np.array_equal(np.stack(react2.tree), np.stack(react.tree))


@pytest.mark.parametrize("backend", ["numpy", "compiled"])
def test_the_reactions_stage_runs_only_when_read(monkeypatch, backend):
    """``analyze_layout(..., reactions=False)`` leaves the reactions stage to run when
    ``Solution.reactions`` is first read: nothing else differs, the reactions then equal the
    eager ones to the bit (per design too), and no reactions stage runs if they are not read."""
    from linkdyn import analysis

    designs = [hoeken_design(38.1), hoeken_design(42.0)]
    t = times(designs[0], 19)
    lay = compile_designs(designs)
    eager = analysis.analyze_layout(designs, lay, t, backend=backend)
    calls = []
    for name in ("_numpy_reactions", "_compiled_reactions"):
        stage = getattr(analysis, name)
        monkeypatch.setattr(analysis, name,
                            lambda *a, _stage=stage: calls.append(1) or _stage(*a))
    lazy = analysis.analyze_layout(designs, lay, t, backend=backend, reactions=False)
    assert np.array_equal(lazy.dyn.tau, eager.dyn.tau) and np.array_equal(lazy.valid, eager.valid)
    assert callable(lazy.react) and not calls
    one = lazy.design(1)
    assert not calls
    assert np.array_equal(one.reactions.force, eager.design(1).reactions.force)
    assert np.array_equal(lazy.reactions.force, eager.reactions.force) and len(calls) == 1
