"""Design quantities against hand-computable cases and their definitions."""

from __future__ import annotations

import json
import math
import tomllib

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn import design
from linkdyn.cli import main
from linkdyn.errors import ModelError

MM = 1e-3


def example_dict(name: str) -> dict:
    return tomllib.loads(linkdyn.example_path(name).read_text("utf-8"))


def solve_example(name: str, samples: int = 361, cycles: float = 1.0):
    m = linkdyn.load(linkdyn.example_path(name))
    period = m.drivers[0].period
    return linkdyn.analyze(m, np.linspace(0.0, cycles * period, samples))


def four_bar_dict(a, b, c, d, *, start, speed, phi, gravity=(0.0, 0.0), loads=()):
    """Four-bar in SI: ground O1-O4 = d, crank a, coupler b, rocker c (rocker frame O4 -> B)."""
    bar = lambda L, m: {"mass": m, "com": [L / 2, 0.0], "inertia": m * L * L / 12}  # noqa: E731
    return {
        "mechanism": {"name": "four-bar", "gravity": list(gravity)},
        "bodies": [
            {"name": "ground", "points": {"O1": [0.0, 0.0], "O4": [d, 0.0]}},
            {"name": "crank", "points": {"O1": [0.0, 0.0], "A": [a, 0.0]}, **bar(a, 0.2)},
            {"name": "coupler", "points": {"A": [0.0, 0.0], "B": [b, 0.0]}, **bar(b, 0.5)},
            {"name": "rocker", "points": {"O4": [0.0, 0.0], "B": [c, 0.0]}, **bar(c, 0.3)},
        ],
        "joints": [
            {"name": "J1", "type": "revolute", "connect": ["ground.O1", "crank.O1"]},
            {"name": "J2", "type": "revolute", "connect": ["crank.A", "coupler.A"]},
            {"name": "J3", "type": "revolute", "connect": ["coupler.B", "rocker.B"]},
            {"name": "J4", "type": "revolute", "connect": ["ground.O4", "rocker.O4"]},
        ],
        "drivers": [{"joint": "J1", "motion": {"kind": "constant_speed", "speed": speed,
                                                "start": start}}],
        "loads": list(loads),
        "assembly": {"phi": phi},
    }


# ---------------------------------------------------------------------------- four-bar loops

@pytest.fixture(scope="module")
def parallelogram():
    """Crank = rocker = 0.1 m, coupler = ground = 0.3 m, crank from 0.3 to 2.8 rad (no toggle)."""
    m = linkdyn.model_from_dict(four_bar_dict(0.1, 0.3, 0.1, 0.3, start=0.3, speed=1.0,
                                              phi={"crank": 0.3, "coupler": 0.0, "rocker": 0.3}))
    return linkdyn.analyze(m, np.linspace(0.0, 2.5, 251))


def test_parallelogram_translates_with_unit_mechanical_advantage(parallelogram):
    sol = parallelogram
    (fb,) = design.four_bars(sol.model)
    assert (fb.input, fb.coupler, fb.output, fb.frame) == ("crank", "coupler", "rocker", "ground")
    assert fb.type == "change-point"
    np.testing.assert_allclose(sol.omega("coupler"), 0.0, atol=1e-12)
    np.testing.assert_allclose(design.mechanical_advantage(sol, fb), 1.0, rtol=1e-10)
    np.testing.assert_allclose(design.velocity_ratio(sol, fb), 1.0, rtol=1e-10)
    # the coupler stays parallel to the ground, so the transmission angle is the crank angle
    theta = sol.kin.q[:, 0]
    np.testing.assert_allclose(design.transmission_angle(sol, fb), theta, rtol=0, atol=1e-10)
    s = design.summary(sol)["four_bars"][0]
    assert s["mechanical_advantage"]["min"] == pytest.approx(1.0, rel=1e-10)
    assert s["mechanical_advantage"]["max"] == pytest.approx(1.0, rel=1e-10)
    assert s["transmission_angle_deg"]["min"] == pytest.approx(math.degrees(0.3), rel=1e-9)
    assert s["transmission_angle_deg"]["min_time_s"] == pytest.approx(0.0)
    assert s["transmission_angle_deg"]["max"] == pytest.approx(math.degrees(2.8), rel=1e-9)


@pytest.mark.parametrize("name", ["hoeken", "drag_link", "stephenson"])
def test_transmission_angle_extremes_by_the_cosine_law(name):
    """At crank angles 0 and 180 deg, cos mu = (b^2 + c^2 - a^2 - d^2 +- 2 a d) / (2 b c); for
    these linkages those are the extremes over the turn."""
    sol = solve_example(name)
    fb = design.four_bars(sol.model)[0]
    d, a, b, c = fb.lengths
    mu = design.transmission_angle(sol, fb)
    theta = sol.kin.q[:, 0]
    k0, k180 = int(np.argmin(np.abs(theta))), int(np.argmin(np.abs(theta - np.pi)))
    assert theta[k0] == pytest.approx(0.0, abs=1e-12)
    assert theta[k180] == pytest.approx(np.pi, rel=1e-12)
    mu0 = math.acos((b * b + c * c - a * a - d * d + 2 * a * d) / (2 * b * c))
    mu180 = math.acos((b * b + c * c - a * a - d * d - 2 * a * d) / (2 * b * c))
    assert mu[k0] == pytest.approx(mu0, rel=1e-9)
    assert mu[k180] == pytest.approx(mu180, rel=1e-9)
    ta = design.summary(sol)["four_bars"][0]["transmission_angle_deg"]
    assert ta["min"] == pytest.approx(math.degrees(min(mu0, mu180)), rel=1e-9)
    assert ta["max"] == pytest.approx(math.degrees(max(mu0, mu180)), rel=1e-9)


def test_hoeken_numbers_match_its_table():
    """Hoeken (seed paper's Table 1): 38.1 crank, 89.5 ground, 115.2 coupler and rocker."""
    (fb,) = design.four_bars(linkdyn.load(linkdyn.example_path("hoeken")))
    np.testing.assert_allclose(fb.lengths, np.array([89.5, 38.1, 115.2, 115.2]) * MM, rtol=1e-12)
    assert fb.pins == ("J1", "J2", "J3", "J4")


@pytest.mark.parametrize("name, expected", [
    ("drag_link", [("ground", "crank", "coupler", "follower", "double-crank")]),
    ("hoeken", [("ground", "crank", "coupler", "rocker", "crank-rocker")]),
    ("stephenson", [("ground", "crank", "coupler", "rocker", "crank-rocker")]),
    # Watt II: the second loop is driven by the ternary rocker, not from the ground; its
    # 40 mm output lever is the shortest link (s + l = 120 < 133.2 mm): Grashof rocker-crank
    ("watt2", [("ground", "crank", "coupler1", "rocker1", "crank-rocker"),
               ("ground", "rocker1", "coupler2", "output", "rocker-crank")]),
    ("fivebar", []),
    ("slider_crank", []),
    ("inverted_slider_crank", []),
    ("scotch_yoke", []),
])
def test_grashof_type_of_every_four_bar_loop_of_the_examples(name, expected):
    found = design.four_bars(linkdyn.load(linkdyn.example_path(name)))
    assert [(f.frame, f.input, f.coupler, f.output, f.type) for f in found] == expected


def test_non_grashof_triple_rocker():
    # s + l = 60 + 100 > 70 + 80
    m = linkdyn.model_from_dict(four_bar_dict(0.07, 0.08, 0.06, 0.1, start=1.5, speed=0.1,
                                              phi={"crank": 1.5, "coupler": 0.0, "rocker": 1.5}))
    (fb,) = design.four_bars(m)
    assert fb.type == "triple-rocker"
    assert "non-Grashof" in fb.grashof


def test_floating_loop_is_classified_relative_to_the_link_nearest_the_ground():
    """Watt-I six-bar: the loop coupler-link5-link6-rocker does not contain the ground; its frame
    is the rocker (pivoted on the ground), its input the coupler (nearer the driven crank)."""
    data = {
        "bodies": [
            {"name": "ground", "points": {"O1": [0, 0], "O4": [1, 0]}},
            {"name": "crank", "points": {"O1": [0, 0], "A": [0.2, 0]}, "mass": 1, "inertia": 1},
            {"name": "coupler", "points": {"A": [0, 0], "B": [1, 0], "E": [0.5, 0.5]},
             "mass": 1, "inertia": 1},
            {"name": "rocker", "points": {"O4": [0, 0], "B": [0.9, 0], "F": [1.2, 0.3]},
             "mass": 1, "inertia": 1},
            {"name": "link5", "points": {"E": [0, 0], "G": [0.7, 0]}, "mass": 1, "inertia": 1},
            {"name": "link6", "points": {"G": [0, 0], "F": [0.4, 0]}, "mass": 1, "inertia": 1},
        ],
        "joints": [
            {"name": "J1", "type": "revolute", "connect": ["ground.O1", "crank.O1"]},
            {"name": "J2", "type": "revolute", "connect": ["crank.A", "coupler.A"]},
            {"name": "J3", "type": "revolute", "connect": ["coupler.B", "rocker.B"]},
            {"name": "J4", "type": "revolute", "connect": ["ground.O4", "rocker.O4"]},
            {"name": "J5", "type": "revolute", "connect": ["coupler.E", "link5.E"]},
            {"name": "J6", "type": "revolute", "connect": ["link5.G", "link6.G"]},
            {"name": "J7", "type": "revolute", "connect": ["link6.F", "rocker.F"]},
        ],
        "drivers": [{"joint": "J1", "motion": {"kind": "constant_speed", "speed": 1.0}}],
    }
    m = linkdyn.model_from_dict(data)
    first, second = design.four_bars(m)
    assert (first.frame, first.input, first.output) == ("ground", "crank", "rocker")
    assert (second.frame, second.input, second.coupler, second.output) == (
        "rocker", "coupler", "link5", "link6")
    assert second.pins == ("J3", "J5", "J6", "J7")
    np.testing.assert_allclose(
        second.lengths, [math.hypot(0.3, 0.3), math.hypot(0.5, 0.5), 0.7, 0.4], rtol=1e-12)


def test_mechanical_advantage_is_the_ideal_torque_ratio():
    """Nearly massless Hoeken with 1 N m on the rocker: |tau_in| = 1 N m / MA."""
    data = example_dict("hoeken")
    for b in data["bodies"][1:]:
        b.update(mass=1e-9, inertia=1e-9)
        b.pop("inertia_about", None)
    data["loads"] = [{"kind": "torque", "body": "rocker", "value": 1.0}]
    m = linkdyn.model_from_dict(data)
    sol = linkdyn.analyze(m, np.linspace(0.0, 4 / 3, 361))
    ma = design.mechanical_advantage(sol, design.four_bars(m)[0])
    np.testing.assert_allclose(np.abs(sol.effort("J1")), 1.0 / ma, atol=1e-8)


# ---------------------------------------------------------------------------- travel

def test_slider_crank_stroke():
    sol = solve_example("slider_crank")
    r, l, e = 50 * MM, 180 * MM, 20 * MM
    stroke = math.sqrt((l + r) ** 2 - e ** 2) - math.sqrt((l - r) ** 2 - e ** 2)
    lo, hi = design.joint_travel(sol, "J4")
    assert hi - lo == pytest.approx(stroke, rel=1e-9)
    assert hi == pytest.approx(math.sqrt((l + r) ** 2 - e ** 2), rel=1e-9)
    travel = design.summary(sol)["joint_travel"]
    assert travel["J4"]["range"] == pytest.approx(stroke, rel=1e-9)
    assert travel["J4"]["unit"] == "m"
    assert travel["J1"]["full_turn"] and not travel["J3"]["full_turn"]


# ---------------------------------------------------------------------------- shaking

def loaded_hoeken():
    """Hoeken in a vertical plane with a force on P, a torque on the rocker, a spring from P to
    the ground pivot O4 and a damper between two moving links; points G at the mass centres."""
    data = example_dict("hoeken")
    data["mechanism"]["gravity"] = [0.0, -9.81]
    for b in data["bodies"][1:]:
        b["points"]["G"] = b["com"]
    data["loads"] = [
        {"kind": "force", "body": "coupler", "point": "P", "value": [-20.0, 35.0]},
        {"kind": "torque", "body": "rocker", "value": 0.5},
        {"kind": "spring", "body": "coupler", "point": "P", "body2": "ground", "point2": "O4",
         "stiffness": 0.5, "free_length": 100.0},
        {"kind": "damper", "body": "crank", "point": "O2", "body2": "rocker", "point2": "O3",
         "damping": 0.01},
    ]
    return linkdyn.model_from_dict(data)


def test_shaking_wrench_is_the_external_load_minus_the_momentum_rate():
    """Independent check from mass-centre paths by finite differences:
    F_s = sum(m g + F_applied) - sum(m a_G),
    M_s = sum(r_G x m g + r_P x F + torques) - sum(r_G x m a_G + I_G alpha)  (about the origin).
    The spring to the ground is transmitted to it, so it is not an external load here."""
    m = loaded_hoeken()
    t = np.linspace(0.0, 4 / 3, 4001)
    h = t[1] - t[0]
    sol = linkdyn.analyze(m, t)
    g = np.array([0.0, -9.81])
    force = np.zeros((len(t), 2))
    moment = np.zeros(len(t))
    for b in m.moving_bodies:
        r_g = sol.point(b.name, "G")
        a_g = np.full_like(r_g, np.nan)
        a_g[1:-1] = (r_g[2:] - 2 * r_g[1:-1] + r_g[:-2]) / h ** 2
        phi = sol.phi(b.name)
        alpha = np.full_like(phi, np.nan)
        alpha[1:-1] = (phi[2:] - 2 * phi[1:-1] + phi[:-2]) / h ** 2
        f = b.mass * (g - a_g)
        force += f
        moment += r_g[:, 0] * f[:, 1] - r_g[:, 1] * f[:, 0] - b.inertia * alpha
    r_p, f_p = sol.point("coupler", "P"), np.array([-20.0, 35.0])
    force += f_p
    moment += r_p[:, 0] * f_p[1] - r_p[:, 1] * f_p[0] + 0.5
    inner = slice(1, -1)
    fs, ms = design.shaking_force(sol), design.shaking_moment(sol)
    assert np.max(np.abs(fs)) > 50  # the check is not trivially small
    np.testing.assert_allclose(fs[inner], force[inner], rtol=0, atol=1e-5 * np.max(np.abs(fs)))
    np.testing.assert_allclose(ms[inner], moment[inner], rtol=0, atol=1e-5 * np.max(np.abs(ms)))


def test_shaking_equals_inertia_load_without_loads():
    sol = solve_example("hoeken")
    np.testing.assert_allclose(design.shaking_wrench(sol), design.inertia_wrench(sol),
                               rtol=0, atol=1e-9)
    s = design.summary(sol)["shaking"]
    mag = np.linalg.norm(design.shaking_force(sol), axis=-1)
    assert s["force_N"]["peak"] == pytest.approx(mag.max())
    assert s["force_N"]["rms"] == pytest.approx(math.sqrt(np.mean(mag ** 2)))
    assert s["moment_Nm"]["peak"] == pytest.approx(np.abs(design.shaking_moment(sol)).max())


def test_shaking_moment_includes_the_driver_reaction():
    """A prismatic guide on the ground: the slider-crank's shaking wrench closes the moving
    links' balance too (driver torque reaction, guide moment, gas load)."""
    sol = solve_example("slider_crank", samples=3601)
    ws = design.shaking_wrench(sol)
    iw = design.inertia_wrench(sol)
    m = sol.model
    f_gas = np.array([-200.0, 0.0])
    weight = sum(b.mass for b in m.moving_bodies) * np.array([0.0, -9.81])
    np.testing.assert_allclose(ws[:, 1:], iw[:, 1:] + weight + f_gas, atol=1e-9)
    r_f = sol.point("slider", "F")
    n_ext = r_f[:, 0] * f_gas[1] - r_f[:, 1] * f_gas[0]
    for b in m.moving_bodies:
        p_name, p_loc = next(iter(b.points.items()))
        phi = sol.phi(b.name)
        d = np.asarray(b.com) - np.asarray(p_loc)
        r_g = sol.point(b.name, p_name) + np.stack(
            (np.cos(phi) * d[0] - np.sin(phi) * d[1], np.sin(phi) * d[0] + np.cos(phi) * d[1]), -1)
        n_ext += r_g[:, 0] * b.mass * -9.81
    np.testing.assert_allclose(ws[:, 0], iw[:, 0] + n_ext, atol=1e-9)
    # without the driver's reaction torque the balance would be off by tau
    assert np.max(np.abs(sol.effort("J1"))) > 1.0


# ---------------------------------------------------------------------------- energy

def test_energy_fluctuation_of_a_harmonic_power():
    # P = A cos(w t) over one period: E = (A / w) sin(w t), Delta E = 2 A / w
    w, amp = 3.0, 5.0
    t = np.linspace(0.0, 2 * np.pi / w, 20001)
    assert design.energy_fluctuation(t, amp * np.cos(w * t) + 7.0) == pytest.approx(
        2 * amp / w, rel=1e-7)
    assert design.flywheel_inertia(2.0, 10.0, 0.02) == pytest.approx(2.0 / (0.02 * 100.0))


@pytest.mark.parametrize("name", ["hoeken", "drag_link"])
def test_flywheel_from_the_kinetic_energy_swing(name):
    """Without loads the driver's work is the kinetic energy's change, so Delta E over a cycle
    is max KE - min KE (computed here from the mass-centre velocities by finite differences)."""
    sol = solve_example(name, samples=3601)
    t, h = sol.t, sol.t[1] - sol.t[0]
    ke = np.zeros(len(t))
    for b in sol.model.moving_bodies:
        p_name, p_loc = next(iter(b.points.items()))
        phi = sol.phi(b.name)
        d = np.asarray(b.com) - np.asarray(p_loc)
        r_g = sol.point(b.name, p_name) + np.stack(
            (np.cos(phi) * d[0] - np.sin(phi) * d[1], np.sin(phi) * d[0] + np.cos(phi) * d[1]), -1)
        v = np.gradient(r_g, h, axis=0, edge_order=2)
        w = np.gradient(phi, h, edge_order=2)
        ke += 0.5 * b.mass * np.sum(v ** 2, -1) + 0.5 * b.inertia * w ** 2
    energy = design.driver_energy(sol, fluctuation=0.05)["J1"]
    de = ke.max() - ke.min()
    omega = abs(sol.model.drivers[0].motion.speed)
    assert energy["work_J"] == pytest.approx(0.0, abs=1e-9 * de)
    assert energy["positive_work_J"] == pytest.approx(-energy["negative_work_J"], rel=1e-9)
    assert energy["fluctuation_over"] == "first cycle"
    assert energy["energy_fluctuation_J"] == pytest.approx(de, rel=1e-5)
    assert energy["flywheel"]["inertia_kg_m2"] == pytest.approx(de / (0.05 * omega ** 2), rel=1e-5)
    assert energy["flywheel"]["mean_speed_rad_s"] == pytest.approx(omega)


def test_driver_power_per_driver_sums_to_the_total():
    sol = solve_example("fivebar")
    p = design.driver_power(sol)
    assert p.shape == (361, 2)
    np.testing.assert_allclose(p.sum(-1), sol.driver_power, rtol=1e-12, atol=1e-15)
    e = design.driver_energy(sol)
    assert e["J5"]["flywheel"] is None  # an oscillating driver needs no flywheel size
    assert e["J1"]["flywheel"] is not None


# ---------------------------------------------------------------------------- straight line

def test_a_point_on_an_exact_line_has_no_deviation():
    sol = solve_example("slider_crank")
    s = design.path_straightness(sol, "slider.F")
    assert s["max_deviation_m"] < 1e-12 and s["rms_deviation_m"] < 1e-12
    lo, hi = design.joint_travel(sol, "J4")
    assert s["length_m"] == pytest.approx(hi - lo, rel=1e-5)  # sampled extremes
    assert abs(s["direction"][1]) < 1e-12


def test_a_circular_arc_deviates_by_its_sagitta():
    """Crank tip (R = 38.1 mm) over crank angles 330..30 deg (a range through 0): the band is
    the sagitta R (1 - cos 30 deg), the length the chord 2 R sin 30 deg; the best line is
    parallel to the chord through the mean, by symmetry."""
    m = linkdyn.load(linkdyn.example_path("hoeken"))
    sol = linkdyn.analyze(m, np.linspace(0.0, 4 / 3, 3601)[:-1])  # 0.1 deg steps, one turn
    R, half = 38.1 * MM, math.radians(30)
    s = design.path_straightness(sol, "crank.O2", (math.radians(330), math.radians(30)))
    assert s["samples"] == 601
    assert s["band_m"] == pytest.approx(R * (1 - math.cos(half)), rel=1e-9)
    assert s["length_m"] == pytest.approx(2 * R * math.sin(half), rel=1e-9)
    np.testing.assert_allclose(np.abs(s["direction"]), [0.0, 1.0], atol=1e-12)
    x = R * np.cos(np.radians(np.linspace(-30, 30, 601)))
    assert s["max_deviation_m"] == pytest.approx(np.max(np.abs(x - x.mean())), rel=1e-9)
    assert s["rms_deviation_m"] == pytest.approx(np.std(x), rel=1e-9)


def test_hoeken_straight_portion():
    sol = solve_example("hoeken")
    summ = design.summary(sol)  # default point: the free coupler point, whole run
    assert summ["path_straightness"]["point"] == "coupler.P"
    assert summ["path_straightness"]["range"] is None
    s = design.path_straightness(sol, "coupler.P", (math.radians(110), math.radians(250)))
    assert s["samples"] == 141
    assert s["max_deviation_m"] < 0.1 * MM < summ["path_straightness"]["max_deviation_m"]
    assert s["length_m"] > 130 * MM
    assert abs(s["direction"][1]) < 1e-9  # symmetric about the crank at 180 deg: horizontal


def test_bad_path_point_and_range_are_user_errors():
    sol = solve_example("hoeken")
    with pytest.raises(ModelError, match="no point 'Q'"):
        design.path_straightness(sol, "coupler.Q")
    with pytest.raises(ModelError, match="no body"):
        design.path_straightness(sol, "nothing.P")
    with pytest.raises(ModelError, match="samples"):
        design.path_straightness(sol, "coupler.P", (0.001, 0.002))


# ---------------------------------------------------------------------------- summary and CLI

def test_summary_is_json_and_keeps_its_keys():
    sol = solve_example("watt2")
    s = design.summary(sol)
    for key in ("model", "samples", "mobility", "loops", "cut_joints", "drivers", "reactions",
                "four_bars", "health", "joint_travel", "shaking", "driver_energy",
                "path_straightness"):
        assert key in s
    for fb in s["four_bars"]:
        assert {"links", "lengths_m", "grashof", "transmission_angle_deg", "type", "frame",
                "mechanical_advantage"} <= set(fb)
    assert s["path_straightness"] is None  # Watt II has no free coupler point
    json.loads(json.dumps(s, allow_nan=True))


def test_cli_options_reach_the_summary(tmp_path):
    path = str(linkdyn.example_path("hoeken"))
    res = CliRunner().invoke(main, ["analyze", path, "-o", str(tmp_path), "--fluctuation", "0.05",
                                    "--path-point", "coupler.P", "--path-range", "110:250"])
    assert res.exit_code == 0, res.output
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["driver_energy"]["J1"]["flywheel"]["speed_fluctuation"] == 0.05
    # the range is in the file's angle unit (Hoeken's is deg); summary.json holds it in SI
    assert s["path_straightness"]["range"] == pytest.approx(np.radians([110, 250]), rel=1e-15)
    assert s["path_straightness"]["range_unit"] == "rad"
    assert "flywheel" in res.output and "shaking force" in res.output
    bad = CliRunner().invoke(main, ["analyze", path, "-o", str(tmp_path / "x"),
                                    "--path-range", "1:x"])
    assert bad.exit_code == 2 and "--path-range" in bad.output
    bad = CliRunner().invoke(main, ["analyze", path, "-o", str(tmp_path / "y"),
                                    "--path-point", "coupler.Q"])
    assert bad.exit_code == 2 and not (tmp_path / "y" / "summary.json").exists()
