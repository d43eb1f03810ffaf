"""``linkdyn import FILE``: pylinkage's mechanism files as linkdyn models.

The reference is pylinkage itself: each file is loaded by pylinkage
(``mechanism_from_json``) and stepped through a crank turn in 1 degree steps; the model that
``linkdyn import`` writes is loaded and analysed at the same crank angles, and every joint (and
tracker) must stand where pylinkage puts it, to 1e-12 of the mechanism's size.

``tests/data/pylinkage/`` holds pylinkage's own example list as pylinkage 1.3.0 wrote it (see
its README): the planar 1-DOF ones (four-bar, crank-slider, Strider) are reproduced; the others
are refused by name (an oscillating crank, a link pinned twice to the ground, a mobility of 0),
or, for ``fourbar_linkage`` (saved at its change point), imported but not analysable at t = 0.
Models built here with pylinkage's own builder add a coupler tracker and a ternary link.
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main
from linkdyn.io.pylinkage import BAR_MASS, import_pylinkage

DATA = Path(__file__).parent / "data" / "pylinkage"
METRES = {"m": 1.0, "mm": 1e-3}


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def pylinkage_positions(file: Path, steps: int = 360):
    """pylinkage's joint positions (steps, joints, 2) over ``steps`` steps of 1 degree of crank
    turn, the joint ids, and the time step (s: one pylinkage step is 1 s in the import)."""
    ser = pytest.importorskip("pylinkage.mechanism.serialization", reason="the import check needs pylinkage (the test extra)")
    mech = ser.mechanism_from_json(file)
    w = next(lk for lk in json.loads(file.read_text())["links"]
             if lk["type"] == "driver")["angular_velocity"]
    dt = math.radians(1.0) / abs(w)
    pos = np.array(list(mech.step(iterations=steps, dt=dt)), float)
    return pos, [j.id for j in mech.joints], dt


def check_reproduces(file: Path, tmp_path: Path, suffix: str = ".toml", unit: str = "m"):
    ref, ids, dt = pylinkage_positions(file)
    out = tmp_path / f"model{suffix}"
    res = run("import", file, "-o", out, "--length-unit", unit)
    assert res.exit_code == 0, res.output
    assert "placeholders" in res.output and f"wrote {out}" in res.output
    model = linkdyn.load(out)
    where = import_pylinkage(file, length_unit=unit).points
    sol = linkdyn.analyze(model, dt * np.arange(1, len(ref) + 1))
    got = np.stack([sol.point(*where[j]) for j in ids], axis=1) / METRES[unit]
    size = np.abs(ref).max()
    err = np.abs(got - ref).max() / size
    assert err < 1e-12, f"{file.name}: positions differ from pylinkage's by {err:.2e} of the size"
    return model


@pytest.mark.parametrize("name, suffix, unit", [
    ("four-bar", ".toml", "m"), ("crank-slider", ".json", "mm"), ("strider", ".toml", "m")])
def test_pylinkage_examples_reproduce_pylinkage_positions(name, suffix, unit, tmp_path):
    check_reproduces(DATA / f"{name}.json", tmp_path, suffix, unit)


def builder_fourbar(tmp_path: Path, **tracker) -> Path:
    """pylinkage's four-bar example (its API example list) built by pylinkage's builder, with a
    coupler tracker, saved by ``mechanism_to_json``."""
    pytest.importorskip("pylinkage", reason="the import check needs pylinkage (the test extra)")
    from pylinkage.mechanism import MechanismBuilder
    from pylinkage.mechanism.serialization import mechanism_to_json

    b = (MechanismBuilder("Four-bar with a coupler point")
         .add_ground_link("ground", ports={"O1": (0, 0), "O2": (100, 0)})
         .add_driver_link("crank", length=25, motor_port="O1", omega=-0.07, initial_angle=2.0)
         .add_link("coupler", length=70).add_link("rocker", length=60)
         .connect("crank.tip", "coupler.0").connect("coupler.1", "rocker.0")
         .connect("rocker.1", "ground.O2"))
    if tracker:
        b = b.add_point_tracker("P", "coupler.0", "coupler.1", **tracker)
    file = tmp_path / "built.json"
    mechanism_to_json(b.build(), file)
    return file


def test_a_tracker_is_a_point_of_its_link(tmp_path):
    file = builder_fourbar(tmp_path, distance=40.0, angle=0.6)
    assert "tracker" in file.read_text()
    check_reproduces(file, tmp_path)


def test_a_ternary_link_and_its_placeholder_mass(tmp_path):
    """A four-bar whose coupler holds a third joint P off its line: pylinkage keeps the triangle
    rigid; its placeholder mass is 1 kg spread uniformly along the outline B-C-P, integrated
    here point by point."""
    data = json.loads((DATA / "four-bar.json").read_text())
    data["joints"].append({"id": "P", "type": "revolute", "position": [70.0, 60.0]})
    coupler = next(lk for lk in data["links"] if lk["id"] == "coupler")
    coupler["joints"].append("P")
    file = tmp_path / "ternary.json"
    file.write_text(json.dumps(data))
    model = check_reproduces(file, tmp_path)
    body = next(b for b in model.bodies if b.name == "coupler")
    corners = np.array(list(body.points.values()))
    assert len(corners) == 3
    # the outline sampled at the midpoints of 20000 equal pieces per side, each piece's mass
    # proportional to its length
    u = (np.arange(20000) + 0.5) / 20000
    pieces = [(a + u[:, None] * (b - a), np.full(u.size, np.hypot(*(b - a)) / u.size))
              for a, b in zip(corners, np.roll(corners, -1, axis=0))]
    x = np.concatenate([p for p, _ in pieces])
    m = np.concatenate([w for _, w in pieces])
    m *= BAR_MASS / m.sum()
    com = (m[:, None] * x).sum(axis=0)
    inertia = (m * ((x - com) ** 2).sum(axis=1)).sum()
    assert body.mass == BAR_MASS
    np.testing.assert_allclose(body.com, com, rtol=0, atol=1e-12 * np.abs(corners).max())
    # the midpoint rule misses each piece's own l^2/12: a relative 1 / (12 * 20000^2) at most
    assert abs(body.inertia - inertia) < 1e-8 * inertia


def test_a_binary_link_is_a_uniform_bar(tmp_path):
    out = tmp_path / "m.toml"
    assert run("import", DATA / "four-bar.json", "-o", out, "--length-unit", "mm").exit_code == 0
    for body in linkdyn.load(out).bodies[1:]:
        a, b = body.points.values()
        length = np.hypot(*(b - a))
        np.testing.assert_allclose(body.com, (a + b) / 2, atol=1e-15)
        assert body.inertia == pytest.approx(BAR_MASS * length ** 2 / 12, rel=1e-14)


def test_a_crank_saved_off_its_initial_angle(tmp_path):
    """The saved pose has the crank 0.05 rad from initial_angle: t = 0 is at initial_angle,
    assembled on the saved pose's branch, as pylinkage's first step (which jumps there)."""
    data = json.loads((DATA / "four-bar.json").read_text())
    crank = next(lk for lk in data["links"] if lk["type"] == "driver")
    crank["initial_angle"] += 0.05
    file = tmp_path / "off.json"
    file.write_text(json.dumps(data))
    check_reproduces(file, tmp_path)
    assert any("the saved pose has the crank at" in n for n in import_pylinkage(file).notes)


def _mutated(change):
    data = json.loads((DATA / "four-bar.json").read_text())
    change(data)
    return data


def _second_driver(d):
    rocker = next(lk for lk in d["links"] if lk["id"] == "rocker")
    rocker.update(type="driver", motor_joint="ground.O2_rocker.1", angular_velocity=0.1)


def _legacy(d):
    next(j for j in d["joints"] if j["id"] == "coupler.0_crank.tip")["type"] = "Crank"


def _free_tracker(d):
    d["joints"].append({"id": "T", "type": "tracker", "position": [1, 1]})


def _slot_of_no_link(d):
    d["joints"].append({"id": "S", "type": "prismatic", "position": [1, 1], "line_link": "nope"})


@pytest.mark.parametrize("case, words", [
    ("chebyshev", ["link 'crank'", "'arc_driver'"]),
    ("inverted_stroke_engine", ["link 'Slider_guide'", "pinned to the ground at 2 joints"]),
    ("pantograph", ["mobility 0"]),
    (_second_driver, ["2 driver links", "crank, rocker"]),
    (_legacy, ["joint 'coupler.0_crank.tip'", "'Crank'"]),
    (_free_tracker, ["joint 'T'", "'tracker'", "no reference joints"]),
    (_slot_of_no_link, ["joint 'S'", "'prismatic'", "link 'nope'"]),
], ids=["arc_driver", "pinned-twice", "mobility-0", "two-drivers", "legacy-type", "free-tracker",
        "slot-of-no-link"])
def test_what_linkdyn_cannot_represent_is_refused_by_name(case, words, tmp_path):
    if isinstance(case, str):
        file = DATA / f"{case}.json"
    else:
        file = tmp_path / "case.json"
        file.write_text(json.dumps(_mutated(case)))
    out = tmp_path / "never.toml"
    res = run("import", file, "-o", out)
    assert res.exit_code == 2, res.output
    assert res.output.startswith("error: ") and res.output.count("\n") == 1, res.output
    assert "Traceback" not in res.output
    for w in words:
        assert w in res.output
    assert not out.exists() and list(tmp_path.glob("*.toml")) == []


def test_bad_files_and_options(tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("{ not json")
    for args, word in [((bad,), "invalid JSON"), ((tmp_path / "none.json",), "file not found"),
                       ((DATA / "four-bar.json", "-o", tmp_path / "m.csv"), "*.toml or *.json"),
                       ((DATA / "four-bar.json", "--length-unit", "furlong"), "furlong")]:
        res = run("import", *args)
        assert res.exit_code == 2 and word in res.output, res.output
    assert list(tmp_path.iterdir()) == [bad]


def test_written_file_is_the_imported_model_and_keeps_an_earlier_file_on_failure(tmp_path):
    out = tmp_path / "m.toml"
    assert run("import", DATA / "strider.json", "-o", out).exit_code == 0
    text = out.read_text()
    assert text.startswith("# Imported from pylinkage") and "placeholders" in text
    first = linkdyn.load(out)
    direct = import_pylinkage(DATA / "strider.json").model
    assert [b.name for b in first.bodies] == [b.name for b in direct.bodies]
    for a, b in zip(first.bodies, direct.bodies):
        assert a.points.keys() == b.points.keys() and a.mass == b.mass
        for p in a.points:
            np.testing.assert_allclose(a.points[p], b.points[p], rtol=0, atol=1e-15)
    assert run("import", DATA / "chebyshev.json", "-o", out).exit_code == 2
    assert out.read_text() == text


def test_fourbar_example_saved_at_its_change_point(tmp_path):
    """pylinkage's fourbar_linkage example (crank 1, coupler 3, rocker 1, ground 3: a change-point
    four-bar) is saved with coupler and rocker in line: it imports, but analyze stops at t = 0
    (exit 3), where linkdyn's position solve is singular."""
    out = tmp_path / "fl.toml"
    assert run("import", DATA / "fourbar_linkage.json", "-o", out).exit_code == 0
    res = run("analyze", out, "-o", tmp_path / "out")
    assert res.exit_code == 3 and "t = 0 s" in res.output, res.output


def test_the_example_list_fixtures_are_pylinkages(tmp_path):
    """The fixtures are what pylinkage writes: loading and saving one again gives it back."""
    ser = pytest.importorskip("pylinkage.mechanism.serialization", reason="the import check needs pylinkage (the test extra)")
    for file in sorted(DATA.glob("*.json")):
        data = json.loads(file.read_text())
        again = ser.mechanism_to_dict(ser.mechanism_from_dict(copy.deepcopy(data)))
        assert again == data, file.name
