"""Model files: SI conversion, TOML/JSON equivalence, and precise messages for bad input."""

from __future__ import annotations

import dataclasses
import json
import math
import tomllib

import numpy as np
import pytest

from linkdyn.expr import Expr
from linkdyn.errors import ModelError
from linkdyn.io import load_model, model_from_dict

MM, DEG = 1e-3, math.pi / 180

# Hoeken's straight-line four-bar (the seed paper's Table 1) in mm, deg and rpm.
# Table inertias are about each link's origin O_i, hence inertia_about.
HOEKEN = """\
[mechanism]
name = "Hoeken straight-line linkage"
gravity = [0.0, -9.81]
description = "Seed paper example"

[units]
length = "mm"
angle = "deg"

[[bodies]]
name = "ground"
points = { O1 = [0, 0], O4 = [89.5, 0] }

[[bodies]]
name = "crank"
points = { O1 = [0, 0], O2 = [38.1, 0] }
mass = 1.5
com = [19.05, 0]
inertia = 725.80
inertia_about = "O1"

[[bodies]]
name = "coupler"
points = { O2 = [0, 0], O3 = [115.2, 0], C = [230.4, 0] }
mass = 5.0
com = "O3"
inertia = 88473.60
inertia_about = "O2"

[[bodies]]
name = "rocker"
points = { O3 = [0, 0], O4 = [115.2, 0] }
mass = 3.0
com = [57.6, 0]
inertia = 13271.76
inertia_about = "O3"

[[joints]]
name = "J1"
type = "revolute"
connect = ["ground.O1", "crank.O1"]

[[joints]]
name = "J2"
type = "revolute"
connect = ["crank.O2", "coupler.O2"]

[[joints]]
name = "J3"
type = "revolute"
connect = ["coupler.O3", "rocker.O3"]

[[joints]]
name = "J4"
type = "revolute"
connect = ["rocker.O4", "ground.O4"]

[[drivers]]
joint = "J1"
motion = { kind = "constant_speed", rpm = 45.0, start = 10.0 }

[[loads]]
kind = "force"
body = "coupler"
point = "C"
value = [-20.0, 35.0]

[[loads]]
kind = "torque"
name = "brake"
body = "rocker"
value = "2*sin(t)"

[assembly]
phi = { crank = 0.0, coupler = 77.12, rocker = -77.12 }

[topology]
cut = ["J4"]

[analysis]
cycles = 1
samples = 361
"""

# A slider-crank in cm with a prismatic driver, a table-free expression, a spring and a damper.
SLIDER = """\
[units]
length = "cm"
angle = "deg"

[[bodies]]
name = "ground"
points = { O = [0, 0], S = [0, 0] }

[[bodies]]
name = "crank"
points = { O = [0, 0], A = [5, 0] }
mass = 0.5
inertia = 20.0

[[bodies]]
name = "rod"
points = { A = [0, 0], B = [20, 0] }
mass = 1.0
com = [10, 0]
inertia = 400.0

[[bodies]]
name = "slider"
points = { B = [0, 0] }
mass = 2.0
inertia = 1.0

[[joints]]
name = "R1"
type = "revolute"
connect = ["ground.O", "crank.O"]

[[joints]]
name = "R2"
type = "revolute"
connect = ["crank.A", "rod.A"]

[[joints]]
name = "R3"
type = "revolute"
connect = ["rod.B", "slider.B"]

[[joints]]
name = "P"
type = "prismatic"
connect = ["ground.S", "slider.B"]
axis = [3, 4]
angle = 90

[[drivers]]
joint = "P"
motion = { kind = "constant_speed", speed = 10.0, start = 22.0 }

[[loads]]
kind = "spring"
body = "ground"
point = "O"
body2 = "slider"
point2 = "B"
stiffness = 50.0
free_length = 20.0

[[loads]]
kind = "damper"
body = "crank"
point = "A"
body2 = "slider"
point2 = "B"
damping = 3.0

[assembly]
q = { P = 22.0, R1 = 30 }

[analysis]
duration = 2.5
samples = 11
"""


def write(tmp_path, text, name="model.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def assert_same(a, b, where="model"):
    """Deep equality of models: dataclasses, containers, arrays, motions and load callables."""
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        assert type(a) is type(b), where
        for f in dataclasses.fields(a):
            assert_same(getattr(a, f.name), getattr(b, f.name), f"{where}.{f.name}")
    elif isinstance(a, dict):
        assert a.keys() == b.keys(), where
        for k in a:
            assert_same(a[k], b[k], f"{where}[{k!r}]")
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b)):
            assert_same(x, y, f"{where}[{i}]")
    elif isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b, err_msg=where)
    elif isinstance(a, Expr):  # equal expressions are one object
        assert a is b, where
    elif hasattr(a, "evaluate"):  # a Motion
        t = np.linspace(0.0, 2.0, 7)
        for x, y in zip(a.evaluate(t), b.evaluate(t)):
            np.testing.assert_array_equal(x, y, err_msg=where)
    elif callable(a):  # a load value
        t = np.linspace(0.0, 2.0, 7)
        np.testing.assert_array_equal(a(t), b(t), err_msg=where)
    else:
        assert a == b, where


# ------------------------------------------------------------------ conversions

def test_hoeken_si_conversion(tmp_path):
    m = load_model(write(tmp_path, HOEKEN))
    assert m.name == "Hoeken straight-line linkage"
    assert m.description == "Seed paper example"
    assert m.source == str(tmp_path / "model.toml")
    assert [b.name for b in m.bodies] == ["ground", "crank", "coupler", "rocker"]
    assert [b.name for b in m.moving_bodies] == ["crank", "coupler", "rocker"]
    np.testing.assert_array_equal(m.gravity, [0.0, -9.81])  # m/s^2 whatever the length unit

    ground, crank, coupler, rocker = m.bodies
    assert ground.mass == 0.0 and ground.inertia == 0.0
    np.testing.assert_allclose(ground.points["O4"], [0.0895, 0.0])
    np.testing.assert_allclose(crank.points["O2"], [0.0381, 0.0])
    np.testing.assert_allclose(crank.com, [0.01905, 0.0])
    assert crank.mass == 1.5
    # Parallel-axis theorem in kg mm^2, then to kg m^2.
    assert crank.inertia == pytest.approx((725.80 - 1.5 * 19.05**2) * 1e-6, rel=1e-12)
    assert crank.inertia == pytest.approx(1.5 * 0.0381**2 / 12, rel=1e-3)  # a uniform bar
    np.testing.assert_allclose(coupler.com, [0.1152, 0.0])  # com = "O3"
    assert coupler.inertia == pytest.approx((88473.60 - 5.0 * 115.2**2) * 1e-6, rel=1e-12)
    assert rocker.inertia == pytest.approx((13271.76 - 3.0 * 57.6**2) * 1e-6, rel=1e-12)

    j1, j2, j3, j4 = m.joints
    assert (j2.name, j2.kind, j2.body_a, j2.point_a, j2.body_b, j2.point_b) == (
        "J2", "revolute", "crank", "O2", "coupler", "O2")
    assert m.joint("J4").body_b == "ground"

    (drv,) = m.drivers
    omega = 45.0 * 2 * math.pi / 60
    q, qd, qdd = drv.motion.evaluate(np.array([0.0, 1.0]))
    np.testing.assert_allclose(q, [10 * DEG, 10 * DEG + omega])
    np.testing.assert_allclose(qd, [omega, omega])
    np.testing.assert_allclose(qdd, [0.0, 0.0], atol=0)
    assert drv.joint == "J1"
    assert drv.period == pytest.approx(60 / 45)
    assert drv.description

    force, torque = m.loads
    assert (force.kind, force.body, force.point) == ("force", "coupler", "C")
    t = np.linspace(0, 1, 5)
    np.testing.assert_array_equal(force.value(t), np.tile([-20.0, 35.0], (5, 1)))
    assert force.value(np.zeros((2, 3))).shape == (2, 3, 2)
    assert (torque.kind, torque.name, torque.point) == ("torque", "brake", None)
    np.testing.assert_allclose(torque.value(t), 2 * np.sin(t))
    assert torque.value(1.0).shape == ()

    assert m.assembly_phi == pytest.approx(
        {"crank": 0.0, "coupler": 77.12 * DEG, "rocker": -77.12 * DEG})
    assert m.assembly_q == {}
    assert m.cut == ("J4",)
    assert (m.duration, m.cycles, m.samples) == (None, 1.0, 361)


def test_prismatic_spring_damper_conversion(tmp_path):
    m = load_model(write(tmp_path, SLIDER, "slider.toml"))
    assert m.name == "slider"  # default: the file stem
    assert m.cut is None and m.gravity.tolist() == [0.0, 0.0]
    p = m.joint("P")
    np.testing.assert_allclose(p.axis, [0.6, 0.8])
    assert p.angle == pytest.approx(math.pi / 2)
    assert m.body("slider").inertia == pytest.approx(1e-4)  # kg cm^2 -> kg m^2
    assert m.body("crank").com.tolist() == [0.0, 0.0]  # default com

    (drv,) = m.drivers
    q, qd, _ = drv.motion.evaluate(np.array([0.0, 1.0]))
    np.testing.assert_allclose(q, [0.22, 0.32])  # cm and cm/s -> m and m/s
    np.testing.assert_allclose(qd, [0.1, 0.1])
    assert drv.period is None  # a prismatic driver does not cycle

    spring, damper = m.loads
    assert spring.stiffness == pytest.approx(5000.0)  # 50 N/cm
    assert spring.free_length == pytest.approx(0.2)
    assert (spring.body, spring.point, spring.body2, spring.point2) == (
        "ground", "O", "slider", "B")
    assert damper.damping == pytest.approx(300.0)  # 3 N s/cm
    assert m.assembly_q == pytest.approx({"P": 0.22, "R1": 30 * DEG})
    assert (m.duration, m.cycles, m.samples) == (2.5, None, 11)


def test_expression_and_table_motions(tmp_path):
    text = SLIDER.replace('joint = "P"', 'joint = "R1"').replace(
        'motion = { kind = "constant_speed", speed = 10.0, start = 22.0 }',
        'motion = { kind = "expression", q = "30 + 90*t + 10*sin(2*t)" }')
    (drv,) = load_model(write(tmp_path, text)).drivers
    q, qd, qdd = drv.motion.evaluate(np.array([0.0, 0.5]))
    t = np.array([0.0, 0.5])
    np.testing.assert_allclose(q, (30 + 90 * t + 10 * np.sin(2 * t)) * DEG)
    np.testing.assert_allclose(qd, (90 + 20 * np.cos(2 * t)) * DEG)
    np.testing.assert_allclose(qdd, -40 * np.sin(2 * t) * DEG, atol=1e-15)

    sub = tmp_path / "profiles"
    sub.mkdir()
    ts = np.linspace(0, 2, 41)
    np.savetxt(sub / "lift.csv", np.c_[ts, 5 * ts], delimiter=",", header="t,q", comments="")
    text = SLIDER.replace('motion = { kind = "constant_speed", speed = 10.0, start = 22.0 }',
                          'motion = { kind = "table", file = "profiles/lift.csv" }')
    (drv,) = load_model(write(tmp_path, text)).drivers  # found relative to the model file
    q, qd, _ = drv.motion.evaluate(np.array([0.5, 1.0]))
    np.testing.assert_allclose(q, [0.025, 0.05], rtol=1e-6)  # cm -> m
    np.testing.assert_allclose(qd, [0.05, 0.05], rtol=1e-6)


@pytest.mark.parametrize("text", [HOEKEN, SLIDER])
def test_json_equals_toml(tmp_path, text):
    from_toml = load_model(write(tmp_path, text, "m.toml"))
    from_json = load_model(write(tmp_path, json.dumps(tomllib.loads(text), indent=2), "m.json"))
    assert from_json.source.endswith("m.json")
    assert_same(dataclasses.replace(from_json, source=from_toml.source), from_toml)


def test_time_varying_force():
    data = tomllib.loads(HOEKEN)
    data["loads"][0]["value"] = ["-20*cos(pi*t)", 35]
    (force, _) = model_from_dict(data).loads
    t = np.array([[0.0, 0.5], [1.0, 2.0]])
    f = force.value(t)
    assert f.shape == (2, 2, 2)
    np.testing.assert_allclose(f[..., 0], -20 * np.cos(np.pi * t))
    np.testing.assert_array_equal(f[..., 1], 35.0)


def test_model_from_dict_without_files():
    data = tomllib.loads(HOEKEN)
    m = model_from_dict(data)
    assert m.source == "" and m.name == "Hoeken straight-line linkage"
    del data["mechanism"]
    assert model_from_dict(data).name == "mechanism"
    with pytest.raises(ModelError) as e:
        model_from_dict({"bodies": [{"name": "ground", "points": {"O": [0, 0]}, "mass": 1}]})
    assert e.value.file == "" and e.value.field == "bodies.ground.mass"


# ------------------------------------------------------------------ bad input

_SYNTAX_LINE = f"line {HOEKEN.splitlines().index('mass = 1.5') + 1}"
_RPM = '{ kind = "constant_speed", rpm = 45.0, start = 10.0 }'
_J2 = '["crank.O2", "coupler.O2"]'
_J3 = '["coupler.O3", "rocker.O3"]'

# id: (text in HOEKEN, its replacement, expected field, substrings of str(ModelError))
BAD = {
    "unknown body in connect": (
        _J2, '["crank.O2", "couplr.O2"]', "joints.J2.connect[1]",
        ["unknown body 'couplr'", "Did you mean 'coupler'?", "Valid bodies: ground, crank"]),
    "unknown point in connect": (
        _J3, '["coupler.O3", "rocker.P3"]', "joints.J3.connect[1]",
        ["no point 'P3'", "Did you mean 'O3'?", "points of 'rocker': O3, O4"]),
    "connect not body.point": (
        _J3, '["coupler.O3", "rocker"]', "joints.J3.connect[1]", ['"body.point"', "crank.O2"]),
    "misspelt body key": (
        "mass = 1.5", "mas = 1.5", "bodies.crank", ["unknown key 'mas'", "Did you mean 'mass'?"]),
    "misspelt section": (
        "[analysis]", "[analysys]", "", ["unknown section 'analysys'", "Did you mean 'analysis'?"]),
    "misspelt motion key": (
        "rpm = 45.0", "rmp = 45.0", "drivers[0].motion",
        ["unknown key 'rmp'", "Did you mean 'rpm'?", 'keys for kind = "constant_speed"']),
    "negative mass": (
        "mass = 3.0", "mass = -1", "bodies.rocker.mass", ["must not be negative", "0 or more"]),
    "missing mass": ("mass = 3.0\n", "", "bodies.rocker.mass", ["needs a mass", "kg"]),
    "negative inertia": (
        "inertia = 13271.76", "inertia = -5.0", "bodies.rocker.inertia",
        ["must not be negative", "moment of inertia in kg mm^2, 0 or more"]),
    "negative centroidal inertia": (
        "inertia = 725.80", "inertia = 500.0", "bodies.crank.inertia",
        ["about point 'O1'", "m d^2 = 544.354", "parallel-axis"]),
    "ground with mass": (
        "points = { O1 = [0, 0], O4 = [89.5, 0] }",
        "points = { O1 = [0, 0], O4 = [89.5, 0] }\nmass = 2.0", "bodies.ground.mass",
        ["no mass properties", "Remove 'mass'"]),
    "joint to itself": (
        _J2, '["crank.O2", "crank.O1"]', "joints.J2.connect",
        ["'crank' to itself", "two different bodies"]),
    "duplicate body name": (
        'name = "rocker"', 'name = "coupler"', "bodies[3].name",
        ["duplicate body name 'coupler'", "different name"]),
    "missing ground": (
        'name = "ground"', 'name = "base"', "bodies",
        ["no body is named 'ground'", "If body 'base' is the fixed frame, rename it \"ground\""]),
    "ground misspelt": (
        'name = "ground"', 'name = "Ground"', "bodies",
        ["no body is named 'ground'", "Did you mean 'Ground'? Rename it"]),
    "unknown joint type": (
        'type = "revolute"', 'type = "revolut"', "joints.J1.type",
        ["unknown joint type 'revolut'", "Did you mean 'revolute'?"]),
    "revolute with axis": (
        'connect = ["ground.O1", "crank.O1"]', 'connect = ["ground.O1", "crank.O1"]\naxis = [1, 0]',
        "joints.J1.axis", ["revolute joint has no axis", "prismatic"]),
    "driver on unknown joint": (
        'joint = "J1"', 'joint = "J9"', "drivers[0].joint",
        ["unknown joint 'J9'", "Valid joints: J1, J2, J3, J4"]),
    "two drivers on one joint": (
        "[analysis]", '[[drivers]]\njoint = "J1"\nmotion = { kind = "expression", q = "t" }\n[analysis]',
        "drivers[1].joint", ["already driven by drivers[0]", "at most one driver"]),
    "speed and rpm": (
        "rpm = 45.0", "rpm = 45.0, speed = 270.0", "drivers[0].motion",
        ["exactly one of speed and rpm", "deg/s"]),
    "expression with a bad name": (
        _RPM, '{ kind = "expression", q = "10 + 270*t + sine(t)" }', "drivers[0].motion.q",
        ["'sine'", "did you mean 'sin'?", "formula of time t"]),
    "table file does not exist": (
        _RPM, '{ kind = "table", file = "nope.csv" }', "drivers[0].motion.file",
        ["not found", "nope.csv", "relative to the model file"]),
    "unknown motion kind": (
        'kind = "constant_speed"', 'kind = "constant"', "drivers[0].motion.kind",
        ["unknown motion kind 'constant'", "Did you mean 'constant_speed'?"]),
    "cut of a driven joint": (
        'cut = ["J4"]', 'cut = ["J1"]', "topology.cut[0]", ["'J1' is driven", "Cut another joint"]),
    "cut of an unknown joint": (
        'cut = ["J4"]', 'cut = ["J5"]', "topology.cut[0]", ["unknown joint 'J5'", "Did you mean"]),
    "bad length unit": (
        'length = "mm"', 'length = "millimetre"', "units.length",
        ["unknown length unit 'millimetre'", "Valid length units: m, mm, cm, in"]),
    "bad angle unit": (
        'angle = "deg"', 'angle = "degrees"', "units.angle", ["Did you mean 'deg'?", "rad, deg"]),
    "mass unit given": (
        'angle = "deg"', 'angle = "deg"\nmass = "g"', "units",
        ["unknown key 'mass'", "Mass is always kg"]),
    "wrong vector length": (
        "com = [57.6, 0]", "com = [57.6, 0, 0]", "bodies.rocker.com",
        ["[x, y] of 2 numbers", "got 3 values"]),
    "string for a number": (
        "mass = 1.5", 'mass = "1.5"', "bodies.crank.mass",
        ["expected a number", "number without quotes"]),
    "nan": ("mass = 1.5", "mass = nan", "bodies.crank.mass", ["finite"]),
    "inf in a vector": (
        "gravity = [0.0, -9.81]", "gravity = [0.0, -inf]", "mechanism.gravity[1]", ["finite"]),
    "unknown body in assembly": (
        "crank = 0.0,", "crank_ = 0.0,", "assembly.phi",
        ["unknown moving body 'crank_'", "Did you mean 'crank'?"]),
    "unknown point in load": (
        'point = "C"', 'point = "D"', "loads[0].point", ["no point 'D'", "O2, O3, C"]),
    "unknown load kind": (
        'kind = "force"', 'kind = "forse"', "loads[0].kind", ["Did you mean 'force'?"]),
    "load expression": (
        'value = "2*sin(t)"', 'value = "2*sin(x)"', "loads.brake.value", ["'x'", "giving N m"]),
    "duration and cycles": (
        "cycles = 1", "cycles = 1\nduration = 2.0", "analysis",
        ["either duration or cycles", "Remove one"]),
    "samples too few": (
        "samples = 361", "samples = 1", "analysis.samples", ["from 2 to 10,000,000", "samples = 361"]),
    "TOML syntax error": (
        "mass = 1.5", "mass = ", _SYNTAX_LINE, ["invalid TOML", "Invalid value", "key = value"]),
}


@pytest.mark.parametrize("case", BAD.values(), ids=BAD.keys())
def test_bad_input(tmp_path, case):
    old, new, field, parts = case
    assert old in HOEKEN
    path = write(tmp_path, HOEKEN.replace(old, new, 1))
    with pytest.raises(ModelError) as e:
        load_model(path)
    err = e.value
    text = str(err)
    assert err.field == field, text
    assert err.file == str(path) and text.startswith(f"{path}: {field}: " if field else f"{path}: ")
    assert err.fix, text
    for part in parts:
        assert part in text, f"{part!r} not in {text!r}"
    assert "Traceback" not in text


_GROUND = {"name": "ground", "points": {"O": [0, 0]}}


@pytest.mark.parametrize("data, field, part", [
    ({"bodies": {"name": "ground"}}, "bodies", "[[bodies]]"),
    ({"bodies": [_GROUND], "joints": [[1]]}, "joints[0]", "a table"),
    ({"bodies": [{"name": "ground", "points": {"O.1": [0, 0]}}]}, "bodies.ground.points", "no dots"),
    ({"bodies": [{"name": "ground", "points": {}}]}, "bodies.ground.points", "one named point"),
    ({"bodies": [_GROUND], "analysis": {"samples": 2.5}}, "analysis.samples", "whole number"),
    ({"bodies": [_GROUND], "mechanism": {"name": 3}}, "mechanism.name", "double quotes"),
    ({"bodies": [_GROUND], "assembly": {"phi": {"ground": 0}}}, "assembly.phi", "always 0"),
    ({"bodies": [_GROUND], "joints": [{"name": "J", "connect": ["ground.O", "ground.O"]}]},
     "joints.J.type", "missing required key 'type'"),
    ({"bodies": [_GROUND], "loads": [{"kind": "torque", "body": "ground", "value": 1.0}]},
     "loads[0].body", "no effect"),
    ([1, 2], "", "table of sections"),
])
def test_bad_structure(data, field, part):
    with pytest.raises(ModelError) as e:
        model_from_dict(data, source="x.toml")
    assert e.value.field == field and part in str(e.value) and e.value.fix


def test_json_syntax_error_names_line(tmp_path):
    text = json.dumps(tomllib.loads(HOEKEN), indent=2).replace('"mass": 1.5', '"mass": 1.5,,', 1)
    path = write(tmp_path, text, "m.json")
    with pytest.raises(ModelError) as e:
        load_model(path)
    line = next(i for i, s in enumerate(text.splitlines(), 1) if ",," in s)
    assert e.value.field == f"line {line}" and "invalid JSON" in str(e.value)


def test_json_duplicate_key(tmp_path):
    path = write(tmp_path, '{"bodies": [], "bodies": []}', "m.json")
    with pytest.raises(ModelError, match="'bodies' appears twice"):
        load_model(path)


def test_file_problems(tmp_path):
    with pytest.raises(ModelError, match="file not found"):
        load_model(tmp_path / "missing.toml")
    with pytest.raises(ModelError, match=r"\*\.toml"):
        load_model(write(tmp_path, HOEKEN, "model.yaml"))
    with pytest.raises(ModelError, match="no bodies"):
        load_model(write(tmp_path, "[units]\nlength = 'mm'\n"))


def test_cycles_needs_a_rotating_driver(tmp_path):
    text = SLIDER.replace("duration = 2.5", "cycles = 2")
    with pytest.raises(ModelError) as e:
        load_model(write(tmp_path, text))
    assert e.value.field == "analysis.cycles" and "duration" in e.value.fix


def test_rpm_on_prismatic_driver(tmp_path):
    text = SLIDER.replace("speed = 10.0", "rpm = 10.0")
    with pytest.raises(ModelError) as e:
        load_model(write(tmp_path, text))
    assert e.value.field == "drivers[0].motion.rpm" and "cm/s" in str(e.value)


# ------------------------------------------- extreme inputs (issue 11): clear, fast, never echoed

def _load_error(path, **kw) -> ModelError:
    """The ModelError of loading ``path``, within 2 s of CPU time, whose message is short."""
    import time
    start = time.process_time()
    with pytest.raises(ModelError) as info:
        load_model(path, **kw)
    assert time.process_time() - start < 2.0
    assert len(str(info.value)) < 600 and "\n" not in str(info.value)
    return info.value


def test_only_regular_files_of_bounded_size_are_read(tmp_path):
    import os
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)                                     # reading it would block forever
    assert "named pipe (FIFO), not a regular file" in str(_load_error(fifo))
    zero = tmp_path / "zero.toml"
    zero.symlink_to("/dev/zero")                        # reading it would never end
    assert "character device, not a regular file" in str(_load_error(zero))
    (tmp_path / "dir.toml").mkdir()
    assert "a directory" in str(_load_error(tmp_path / "dir.toml"))
    big = write(tmp_path, "# " + "x" * 10_000_000 + "\n" + HOEKEN)
    assert "more than the limit of 10,000,000 bytes" in str(_load_error(big))
    with pytest.raises(TypeError, match="path"):
        load_model(5)


@pytest.mark.parametrize("name, text, field, parts", [
    ("toml 500 deep", HOEKEN.replace("[analysis]", "[analysis]\nx = " + "[" * 500 + "]" * 500),
     "", ["nested too deeply"]),
    ("toml 100 deep", HOEKEN.replace("[analysis]", "[analysis]\nx = " + "[" * 100 + "]" * 100),
     "analysis.x[0][0][0]", ["nested more than 64 levels"]),
    ("400 digits", HOEKEN.replace("mass = 1.5", "mass = 1" + "0" * 399), "bodies.crank.mass",
     ["finite number", "integer of about 400 digits"]),
    ("5000 digits", HOEKEN.replace("mass = 1.5", "mass = 1" + "0" * 4999), _SYNTAX_LINE,
     ["5,000 digits", "key 'mass'", "at most 17 significant digits"]),
    ("huge com", HOEKEN.replace("com = [19.05, 0]", "com = [19.05, 1e308]"),
     "bodies.crank.com[1]", ["magnitude of 1e+308 mm is out of range", "1e+12"]),
    ("tiny speed", HOEKEN.replace("rpm = 45.0", "speed = 1e-300"), "drivers[0].motion.speed",
     ["out of range", "1e-30"]),
    ("rpm -1e308", HOEKEN.replace("rpm = 45.0", "rpm = -1e308"), "drivers[0].motion.rpm",
     ["magnitude of -1e+308 rev/min"]),
    ("samples 1e308", HOEKEN.replace("samples = 361", "samples = 1e308"), "analysis.samples",
     ["from 2 to 10,000,000", "1e+308"]),
    ("samples 1e12", HOEKEN.replace("samples = 361", "samples = 1000000000000"),
     "analysis.samples", ["from 2 to 10,000,000"]),
    ("20 MB line", HOEKEN + "\nbad = " + "x" * 2_000_000 + "\n", f"line {HOEKEN.count(chr(10)) + 2}",
     ["invalid TOML", "(2,000,006 characters)"]),
    ("1 MB name", HOEKEN.replace('name = "crank"', 'name = "' + "c" * 1_000_000 + '"', 1),
     "bodies[1].name", ["longer than 100 characters", "(1,000,000 characters)"]),
    ("1 MB key", HOEKEN.replace("mass = 1.5", "k" * 1_000_000 + " = 1\nmass = 1.5", 1),
     "bodies.crank", ["unknown key 'kkkkkkkk", "(1,000,000 characters)"]),
    ("1 MB reference", HOEKEN.replace('"crank.O1"', '"' + "c" * 1_000_000 + '.O1"', 1),
     "joints.J1.connect[1]", ["unknown body 'cccc", "(1,000,000 characters)"]),
    ("1 MB formula", HOEKEN.replace(_RPM, '{ kind = "expression", q = "' + "t+" * 500_000 + 't" }'),
     "drivers[0].motion.q", ["longer than the limit of 10,000 characters"]),
], ids=lambda x: x if isinstance(x, str) and len(x) < 20 else "")
def test_extreme_values_get_a_short_message_naming_the_field(tmp_path, name, text, field, parts):
    err = _load_error(write(tmp_path, text))
    assert err.field.startswith(field) if field.endswith("]") else err.field == field, str(err)
    for part in parts:
        assert part in str(err), str(err)


def test_json_nested_100000_deep_and_long_integers(tmp_path):
    data = json.dumps(tomllib.loads(HOEKEN))
    deep = write(tmp_path, data[:-1] + ', "x": ' + "[" * 100_000 + "]" * 100_000 + "}", "deep.json")
    assert "nested too deeply" in str(_load_error(deep))
    long = write(tmp_path, data.replace('"mass": 1.5', '"mass": 1' + "0" * 5000), "long.json")
    assert "5,001 digits" in str(_load_error(long))
    dup = write(tmp_path, data[:-1] + ', "units": {}}', "dup.json")
    assert "key 'units' appears twice" in str(_load_error(dup))


SINE_ROWS = "t,q\n" + "".join(f"{t:.3f},{10 * math.sin(t):.6f}\n" for t in np.linspace(0, 2, 21))


def test_table_files_are_confined_to_the_model_folder(tmp_path):
    model_dir = tmp_path / "model"
    (model_dir / "profiles").mkdir(parents=True)
    (tmp_path / "secret.txt").write_text("t,q\nSECRET-LINE-2\n")
    (model_dir / "profiles" / "ok.csv").write_text(SINE_ROWS)
    (model_dir / "link.csv").symlink_to(tmp_path / "secret.txt")

    def with_table(file):
        return write(model_dir, HOEKEN.replace(_RPM, f'{{ kind = "table", file = "{file}" }}')
                     .replace("cycles = 1", "duration = 1.5"))

    for file in ("../secret.txt", str(tmp_path / "secret.txt"), "link.csv",
                 "profiles/../../secret.txt"):
        err = _load_error(with_table(file))
        assert err.field == "drivers[0].motion.file"
        assert "outside the model file's folder" in str(err) and "allow_outside=True" in str(err)
        assert "SECRET" not in str(err)
    # explicitly allowed: read, and its content is quoted only as a short excerpt
    err = _load_error(with_table("../secret.txt"), allow_outside=True)
    assert "line 2" in str(err) and "'SECRET-LINE-2'" in str(err)
    (tmp_path / "secret.txt").write_text("t,q\n" + "S" * 1_000_000 + "\n")
    err = _load_error(with_table("../secret.txt"), allow_outside=True)
    assert "(1,000,000 characters)" in str(err) and "S" * 100 not in str(err)
    (drv,) = load_model(with_table("profiles/ok.csv")).drivers       # inside: fine
    assert drv.motion.origin == "profiles/ok.csv"
    fifo = model_dir / "fifo.csv"
    import os
    os.mkfifo(fifo)
    assert "named pipe" in str(_load_error(with_table("fifo.csv")))


def test_a_table_that_does_not_cover_the_run_names_its_range(tmp_path):
    import linkdyn
    path = tmp_path / "hoeken.toml"
    text = HOEKEN.replace(_RPM, '{ kind = "table", file = "crank.csv" }').replace("cycles = 1",
                                                                                  "duration = 1.5")
    (tmp_path / "crank.csv").write_text(SINE_ROWS)                  # t from 0 to 2 s
    path.write_text(text)
    model = load_model(path)
    with pytest.raises(ModelError) as info:
        linkdyn.analyze(model, np.linspace(0.0, 3.0, 7))             # ends before the run
    err = info.value
    assert err.file == str(path) and err.field == "drivers[0].motion.file"
    assert "'crank.csv' covers t = 0 to 2 s, but the run needs t = 0 to 3 s" in str(err)
    late = "t,q\n" + "".join(f"{t:.3f},{t:.3f}\n" for t in np.linspace(0.5, 2, 7))
    (tmp_path / "crank.csv").write_text(late)                         # starts after t = 0
    with pytest.raises(ModelError, match=r"covers t = 0.5 to 2 s, but the run needs t = 0 to"):
        linkdyn.analyze(load_model(path), np.linspace(0.0, 1.0, 5))


def test_cli_refuses_outside_tables_unless_allowed(tmp_path):
    from click.testing import CliRunner

    from linkdyn.cli import main

    (tmp_path / "model").mkdir()
    (tmp_path / "crank.csv").write_text(SINE_ROWS)
    path = write(tmp_path / "model", HOEKEN.replace(_RPM, '{ kind = "table", file = "../crank.csv" }')
                 .replace("cycles = 1", "duration = 1.5"))
    refused = CliRunner().invoke(main, ["check", str(path)])
    assert refused.exit_code == 2 and "outside the model file's folder" in refused.output
    assert "--allow-outside-tables" in refused.output
    allowed = CliRunner().invoke(main, ["check", "--allow-outside-tables", str(path)])
    assert allowed.exit_code == 0 and "model OK" in allowed.output, allowed.output
