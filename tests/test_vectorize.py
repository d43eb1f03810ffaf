"""The layouts of a chunk of designs built at once from the parameter arrays (studies.vectorize)
equal the per-design path (a model per design by the loader, then compile_designs), number by
number, and so do the sweep's validity, reasons and metrics. Links of zero length are refused in
a model file and in a sweep's ranges, and make a sampled design invalid."""

from __future__ import annotations

import copy

import numpy as np
import pytest

import linkdyn
from linkdyn.errors import ModelError
from linkdyn.io import read_model_data
from linkdyn.kinematics.layout import compile_designs
from linkdyn.kinematics.positions import assembly_guess
from linkdyn.studies import Task, sample, space
from linkdyn.studies.params import check_ranges
from linkdyn.studies.runner import evaluate_models, evaluate
from linkdyn.studies.vectorize import derive

HOEKEN = linkdyn.example_path("hoeken")
T = np.linspace(0.0, 4.0 / 3.0, 41)


def loaded_hoeken() -> dict:
    """Hoeken's file with gravity and a load of every kind whose numbers a study may vary."""
    data = copy.deepcopy(read_model_data(HOEKEN))
    data["mechanism"]["gravity"] = [0.0, -9.81]
    data["loads"] = [
        {"kind": "force", "name": "push", "body": "coupler", "point": "P",
         "value": [10.0, "5*sin(t)"]},
        {"kind": "torque", "name": "brake", "body": "rocker", "value": -0.5},
        {"kind": "spring", "name": "k", "body": "ground", "point": "O4", "body2": "coupler",
         "point2": "P", "stiffness": 2.0, "free_length": 100.0},
        {"kind": "damper", "name": "c", "body": "ground", "point": "O1", "body2": "rocker",
         "point2": "O3", "damping": 0.01},
        {"kind": "joint_torque", "name": "rub", "joint": "J3", "value": "-0.01*qd_J3"},
        {"kind": "joint_torque", "name": "stop", "joint": "J2", "value": 0.2},
    ]
    return data


# every kind of number a design parameter can be: points, mass, inertia, driver speed and start,
# gravity, load values, spring and damper constants, an assembly guess
RANGES = {
    "bodies.ground.points.O4[0]": (60.0, 120.0),     # wide: some designs cannot assemble
    "bodies.coupler.points.O3[0]": (100.0, 130.0),
    "bodies.coupler.points.P[1]": (-10.0, 10.0),
    "bodies.crank.mass": (1.0, 2.0),
    "bodies.coupler.inertia": (90000.0, 100000.0),
    "drivers[0].motion.rpm": (30.0, 60.0),
    "drivers[0].motion.start": (0.0, 10.0),
    "mechanism.gravity[1]": (-9.81, 0.0),
    "loads.push.value[0]": (-20.0, 20.0),
    "loads.brake.value": (-1.0, 1.0),
    "loads.k.stiffness": (0.0, 5.0),
    "loads.k.free_length": (50.0, 150.0),
    "loads.c.damping": (0.0, 0.1),
    "loads.stop.value": (-0.5, 0.5),
    "assembly.phi.coupler": (70.0, 85.0),
}


def numbers(lay) -> dict:
    """Every number of a stacked layout, by name."""
    out = {"size": lay.size, "gravity": lay.gravity}
    for f in ("joint_point", "axis", "origin", "com", "angle", "mass", "inertia"):
        out.update({(f, i): np.asarray(x) for i, x in enumerate(getattr(lay, f))})
    for i, pts in enumerate(lay.points):
        out.update({("points", i, p): x for p, x in pts.items()})
    for k, c in enumerate(lay.cuts):
        out.update({("cut", k, f): np.asarray(getattr(c, f)) for f in ("pa", "pb", "axis", "angle")})
    for k, r in enumerate(lay.loads):
        out.update({("load", k, f): getattr(r, f) for f in ("stiffness", "free_length", "damping")})
        if r.axis is not None:
            out[("load", k, "axis")] = r.axis
        if r.kind != "spring" and r.kind != "damper" and not r.values[0].state_variables:
            out[("load value", k)] = lay.load_values(r, T)
    q, qd, qdd = lay.driver_values(T)
    out.update({"q driver": q, "qd driver": qd, "qdd driver": qdd})
    return out


def close(a, b, rtol=1e-12) -> bool:
    """Equal to ``rtol`` of the reference's scale (its largest magnitude)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return a.shape == b.shape and bool(np.all(np.abs(a - b) <= rtol * max(np.max(np.abs(b)), 1e-300)))


def test_the_stacked_layout_of_random_designs_is_the_per_design_one():
    sp = space(loaded_hoeken(), list(RANGES))
    lo, hi = np.array(list(RANGES.values())).T
    builder = derive(sp, lo, hi)
    assert builder.vectorized, builder.why
    values = sample(list(RANGES.values()), "random", 30, seed=3)
    models = [sp.model(v) for v in values]
    Z = builder.numbers(values)
    lay, guesses = builder.stacked(Z)
    ref = compile_designs(models)
    got, want = numbers(lay), numbers(ref)
    assert got.keys() == want.keys()
    for key in want:
        assert close(got[key], want[key]), key
    # the assembly starts from each design's own guess
    mine = np.stack([assembly_guess(m, lay) for m in builder.guess_models(guesses, len(values))], -1)
    assert close(mine, np.stack([assembly_guess(m, ref) for m in models], -1))
    # taking designs out of it keeps them
    idx = np.array([4, 0, 17])
    sub = numbers(lay.take(idx))
    for key, x in numbers(compile_designs([models[k] for k in idx])).items():
        assert close(sub[key], x), key


@pytest.mark.parametrize("backend", ["numpy", "compiled"])
def test_a_chunk_built_at_once_gives_the_per_design_paths_rows(backend):
    sp = space(loaded_hoeken(), list(RANGES))
    lo, hi = np.array(list(RANGES.values())).T
    names = tuple(linkdyn.studies.metric_names(sp.model()))
    task = Task(sp, T, names, backend).with_builder(lo, hi)
    values = sample(list(RANGES.values()), "sobol", 24, seed=5)
    values[3, 0] = 250.0     # the ground too long: the loops cannot close
    values[7, 3] = -1.0      # a negative mass: the loader's message
    values[9, 0] = 150.0     # assembles, then stops closing
    got, want = evaluate(task, values), evaluate_models(task, values)
    assert 0 < want["valid"].sum() < len(values)       # both valid and invalid designs
    assert np.array_equal(got["valid"], want["valid"])
    assert list(got["reason"]) == list(want["reason"])
    for name in names:
        ok = want["valid"]
        assert close(got[name][ok], want[name][ok]), name
        assert np.all(np.isnan(got[name][~ok]))


def test_a_parameter_that_is_not_affine_stays_on_the_per_design_path():
    # the rocker's inertia is given about O3: its centroidal inertia is quadratic in its com
    sp = space(HOEKEN, ["bodies.rocker.com[1]", "bodies.ground.points.O4[0]"])
    builder = derive(sp, [-20.0, 80.0], [20.0, 100.0])
    assert not builder.vectorized and "bodies.rocker.com[1]" in builder.why
    task = Task(sp, T, ("peak_tau_J1",), "numpy").with_builder([-20.0, 80.0], [20.0, 100.0])
    values = sample([(-20.0, 20.0), (80.0, 100.0)], "random", 4, seed=0)
    got = evaluate(task, values)["peak_tau_J1"]
    want = [linkdyn.analyze(sp.model(v), T, backend="numpy").dyn.tau[:, 0] for v in values]
    assert close(got, [np.max(np.abs(w)) for w in want])


# --- links of zero length -------------------------------------------------------------------------

def test_a_model_file_with_a_zero_length_link_exits_2_naming_the_point(tmp_path):
    from click.testing import CliRunner

    from linkdyn.cli import main

    text = open(HOEKEN).read().replace("O3 = [115.2, 0.0], P", "O3 = [0.0, 0.0], P")
    path = tmp_path / "flat.toml"
    path.write_text(text)
    res = CliRunner().invoke(main, ["analyze", str(path), "-o", str(tmp_path / "out")])
    assert res.exit_code == 2
    assert "bodies.coupler.points.O3" in res.output and "zero length" in res.output
    assert "J2" in res.output and "J3" in res.output and "Move O3 away from O2" in res.output
    assert "Traceback" not in res.output and not (tmp_path / "out").exists()


def test_a_range_that_allows_a_zero_length_link_is_refused_naming_it():
    sp = space(HOEKEN, ["bodies.crank.points.O2[0]", "bodies.crank.points.O2[1]"])
    with pytest.raises(ModelError) as e:
        check_ranges(sp, [(-10.0, 10.0), (-5.0, 5.0)])
    msg = str(e.value)
    assert "zero length" in msg and "bodies.crank.points.O2[0] = 0 mm" in msg
    assert e.value.field == "bodies.crank.points.O2[0], bodies.crank.points.O2[1]"
    check_ranges(sp, [(-10.0, 10.0), (1.0, 5.0)])    # O2 stays off O1


def test_sampled_designs_with_a_zero_length_link_are_invalid_with_the_reason():
    # the crank pin on the crank's pivot, and 1e-7 mm from it (under 1e-9 of the size)
    df = linkdyn.sweep(HOEKEN, {"bodies.crank.points.O2[0]": np.array([38.1, 0.0, 1e-7]),
                                "bodies.crank.points.O2[1]": np.array([0.0, 0.0, 0.0])},
                       T, metrics=["peak_tau_J1"])
    assert list(df.valid) == [True, False, False]
    for reason in df.reason[1:]:
        assert "bodies.crank.points.O2" in reason and "zero length" in reason
    assert df.reason[0] == ""
