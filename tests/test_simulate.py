"""Forward dynamics (``linkdyn.simulate``) against independent means: the pendulums' own ODEs
integrated separately, energy conservation, the loop closure, the free joints' vanishing
effort, a parallelogram chain against its one-coordinate equivalent, a round trip through
``analyze``, MuJoCo; and the errors of ``[initial]`` and the CLI."""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import solve_ivp

import linkdyn
from linkdyn.cli import main
from linkdyn.errors import AssemblyError, ModelError
from linkdyn.forward import simulate
from linkdyn.model import Body, Joint, Load, Model

from builders import parallelogram_chain

G = 9.81


def P(*xy):
    return np.array(xy, float)


def pendulum(length=0.8, mass=1.3, inertia=0.05, com=0.3, **kw):
    """A bar on a pin at the ground's origin, in SI."""
    bodies = (Body("ground", {"O": P(0, 0)}),
              Body("bar", {"O": P(0, 0), "T": P(length, 0)}, mass, P(com, 0), inertia))
    return Model("pendulum", bodies, (Joint("J1", "revolute", "ground", "O", "bar", "O"),),
                 gravity=P(0, -G), **kw)


def reference(rhs, y0, t):
    """An independent integration of a hand-written ODE, tight tolerances."""
    return solve_ivp(rhs, (t[0], t[-1]), y0, t_eval=t, method="DOP853", rtol=1e-12,
                     atol=1e-12).y


def fourbar_dict(**initial):
    """Hoeken's four-bar released under gravity, as a model file's table."""
    d = tomllib.loads(linkdyn.example_path("hoeken").read_text())
    d.pop("drivers")
    d.pop("analysis", None)
    d["mechanism"]["gravity"] = [0.0, -G]
    d["initial"] = initial or {"q": {"J1": 30.0}, "qd": {"J1": 200.0}}
    return d


def test_simple_pendulum_matches_its_ode():
    m = pendulum(initial_q={"J1": 0.3}, initial_qd={"J1": -1.0})
    t = np.linspace(0.0, 2.0, 41)
    sol = simulate(m, t, rtol=1e-10, atol=1e-12)
    i_o = 0.05 + 1.3 * 0.3**2
    # I_O th'' = -m g d cos th
    ref = reference(lambda t, y: [y[1], -1.3 * G * 0.3 * math.cos(y[0]) / i_o], [0.3, -1.0], t)
    assert np.max(np.abs(sol.columns["q_J1"] - ref[0])) < 1e-8
    assert np.max(np.abs(sol.columns["qd_J1"] - ref[1])) < 1e-7
    # the accelerations reported are the ODE's at the output states
    acc = -1.3 * G * 0.3 * np.cos(sol.columns["q_J1"]) / i_o
    assert np.allclose(sol.columns["qdd_J1"], acc, rtol=1e-9, atol=1e-9 * np.max(np.abs(acc)))
    # the pin carries the bar's weight and its centripetal and tangential inertia forces
    assert sol.energy_drift < 1e-8
    assert sol.stats["free_effort_residual"] < 1e-10


def test_double_pendulum_matches_its_ode():
    l1, m1, m2, c1, c2, i1, i2 = 0.7, 1.1, 0.6, 0.35, 0.25, 0.04, 0.02
    bodies = (Body("ground", {"O": P(0, 0)}),
              Body("a", {"O": P(0, 0), "E": P(l1, 0)}, m1, P(c1, 0), i1),
              Body("b", {"O": P(0, 0), "E": P(0.5, 0)}, m2, P(c2, 0), i2))
    joints = (Joint("J1", "revolute", "ground", "O", "a", "O"),
              Joint("J2", "revolute", "a", "E", "b", "O"))
    model = Model("double", bodies, joints, gravity=P(0, -G),
                  initial_q={"J1": -0.4, "J2": 0.9}, initial_qd={"J1": 1.5, "J2": -2.0})
    t = np.linspace(0.0, 1.5, 31)
    sol = simulate(model, t, rtol=1e-10, atol=1e-12)

    def rhs(t, y):
        # Lagrange's equations in absolute angles (th1, th2) of the two bars
        th1, th2, w1, w2 = y
        a11, a22 = i1 + m1 * c1**2 + m2 * l1**2, i2 + m2 * c2**2
        a12 = m2 * l1 * c2 * math.cos(th1 - th2)
        f1 = -m2 * l1 * c2 * math.sin(th1 - th2) * w2**2 - (m1 * c1 + m2 * l1) * G * math.cos(th1)
        f2 = m2 * l1 * c2 * math.sin(th1 - th2) * w1**2 - m2 * c2 * G * math.cos(th2)
        acc = np.linalg.solve([[a11, a12], [a12, a22]], [f1, f2])
        return [w1, w2, *acc]
    ref = reference(rhs, [-0.4, 0.5, 1.5, -0.5], t)
    assert np.max(np.abs(sol.phi("a") - ref[0])) < 1e-8
    assert np.max(np.abs(sol.phi("b") - ref[1])) < 1e-8
    assert np.max(np.abs(sol.omega("b") - ref[3])) < 1e-7


def test_closed_loop_conserves_energy_and_stays_closed():
    model = linkdyn.model_from_dict(fourbar_dict())
    t = np.linspace(0.0, 0.5, 26)
    sol = simulate(model, t, rtol=1e-9, atol=1e-11)
    assert np.ptp(sol.columns["q_J1"]) > 1.0                 # a large swing
    assert sol.energy_drift < 1e-7                           # to the integrator's tolerance
    assert np.all(sol.valid)
    # the loop closes at every output sample: the rocker pin on both sides of the cut
    gap = sol.point("rocker", "O4") - np.array([0.0895, 0.0])
    assert np.max(np.abs(gap)) <= 1e-12 * 0.23
    assert sol.stats["closure_residual"] <= 1e-12
    # the free joint needs no effort at the simulated accelerations
    assert sol.stats["free_effort_residual"] < 1e-10
    # the columns of analyze, plus the potential energy and the work
    for col in ("Fx_J4", "qdd_J3", "alpha_rocker", "kinetic_energy", "potential_energy", "work"):
        assert col in sol.columns
    # power balance at the samples: dE/dt = 0 (no non-conservative loads)
    assert np.max(np.abs(sol.work)) == 0.0


def test_energy_kept_at_the_tolerance_shrinks_with_it():
    model = linkdyn.model_from_dict(fourbar_dict())
    t = np.linspace(0.0, 0.3, 4)
    loose = simulate(model, t, rtol=1e-5, atol=1e-7).energy_drift
    tight = simulate(model, t, rtol=1e-10, atol=1e-12).energy_drift
    assert tight < 1e-8 and tight < loose / 100


# ---------------------------------------------------------------------------- [initial] and errors

def test_initial_errors_name_the_field():
    with pytest.raises(ModelError, match=r"initial\.q.*unknown joint 'J9'"):
        linkdyn.model_from_dict(fourbar_dict(q={"J9": 1.0}))
    d = tomllib.loads(linkdyn.example_path("hoeken").read_text())
    d["initial"] = {"q": {"J1": 1.0}}
    with pytest.raises(ModelError, match=r"initial\.q\.J1: joint 'J1' is driven"):
        linkdyn.model_from_dict(d)
    two = linkdyn.model_from_dict(fourbar_dict(q={"J1": 10.0, "J2": 5.0}))
    with pytest.raises(ModelError, match=r"initial\.q: .*names 2 joint.*1 free degree"):
        simulate(two, np.linspace(0, 0.1, 3))
    driven = linkdyn.load(linkdyn.example_path("hoeken"))
    with pytest.raises(ModelError, match="no free degree of freedom.*linkdyn analyze"):
        simulate(driven, np.linspace(0, 0.1, 3))


def test_initial_q_may_come_from_the_assembly():
    d = fourbar_dict(qd={"J1": 0.0})
    m = linkdyn.model_from_dict(d)
    sol = simulate(m, np.linspace(0.0, 0.05, 3))
    # the assembly's crank angle (0) and at rest
    assert sol.columns["q_J1"][0] == 0.0 and sol.columns["qd_J1"][0] == 0.0
    assert sol.free == ("J1",)


def pushed_rocker(**initial):
    """Hoeken's four-bar without gravity, a constant torque on the rocker: from rest it turns
    the crank ever faster while the rocker swings between its two limits."""
    d = fourbar_dict(**initial)
    d["mechanism"]["gravity"] = [0.0, 0.0]
    d["loads"] = [{"kind": "torque", "body": "rocker", "value": 2.0}]
    return linkdyn.model_from_dict(d)


def test_a_dead_point_of_the_free_coordinate_is_passed_by_switching_coordinates():
    """[initial] names the rocker, which cannot describe the motion at its limits (crank and
    coupler in line: the crank's rate per unit rocker rate is unbounded). The simulation
    switches to a better-conditioned coordinate there and goes on; it matches the same
    mechanism integrated in the crank's angle throughout (another tree: J4 cut instead of J3),
    keeps its energy balance and closes its loop at every sample."""
    t = np.linspace(0.0, 0.5, 11)
    ref = simulate(pushed_rocker(q={"J1": 0.0}), t, rtol=1e-9, atol=1e-11)
    assert ref.stats["switches"] == []
    start = float(np.degrees(ref.columns["q_J4"][0]))
    sol = simulate(pushed_rocker(q={"J4": start}), t, rtol=1e-9, atol=1e-11)
    assert sol.free == ("J4",) and len(sol.stats["switches"]) >= 1
    assert sol.stats["switches"][0][1] != ["J4"]
    # summary.json lists the switches
    from linkdyn.cli import simulation_summary
    listed = json.loads(json.dumps(simulation_summary(sol, {})))["simulation"]
    assert listed["coordinate_switches"][0]["t_s"] == sol.stats["switches"][0][0]
    # the rocker passes a limit (its rate changes sign) while the crank races on
    qd4, qd1 = ref.columns["qd_J4"], ref.columns["qd_J1"]
    assert np.any(np.diff(np.sign(qd4[1:])) != 0) and np.min(np.abs(qd1[1:])) > 1.0
    for col in ("q_J1", "q_J4", "qd_J1", "qd_J4", "qdd_J3", "Fx_J2", "Fy_J4", "work",
                "kinetic_energy"):
        scale = np.max(np.abs(ref.columns[col]))
        assert np.max(np.abs(sol.columns[col] - ref.columns[col])) < 1e-6 * scale, col
    assert sol.energy_drift < 1e-7 and np.all(sol.valid)
    gap = sol.point("rocker", "O4") - np.array([0.0895, 0.0])
    assert np.max(np.abs(gap)) <= 1e-12 * 0.23
    assert sol.stats["free_effort_residual"] < 1e-10


def test_a_singular_position_of_the_mechanism_exits_3_naming_the_time_and_values():
    """A driver turning the rocker past its limit: no choice of coordinates can follow (the
    loop cannot close beyond it) and the run stops with the time and the coordinates there.
    A pendulum on the ground is the free freedom."""
    d = fourbar_dict(q={"J5": -90.0})
    d["bodies"].append({"name": "bob", "points": {"O": [0.0, 0.0]}, "mass": 1.0,
                        "com": [50.0, 0.0], "inertia": 1000.0})
    d["joints"].append({"name": "J5", "type": "revolute", "connect": ["ground.O1", "bob.O"]})
    d["drivers"] = [{"joint": "J4", "motion": {"kind": "constant_speed", "rpm": 30.0,
                                               "start": -77.12}}]
    d["assembly"]["phi"]["bob"] = -90.0
    d.pop("topology")
    m = linkdyn.model_from_dict(d)
    # the coordinates in the file's unit (deg): -0.7x rad and -1.x rad before issue 23
    with pytest.raises(AssemblyError, match=r"at t = 0\.1[0-9]+ s \(q_J4 = -4[0-5]\.[0-9]+ deg, "
                                            r"q_J5 = -(?:[5-9][0-9]|1[01][0-9])(?:\.[0-9]+)? deg\)"
                                            r".*cannot pass") as err:
        simulate(m, np.linspace(0.0, 0.5, 3), rtol=1e-4, atol=1e-6)
    assert err.value.exit_code == 3


def test_cli_simulate_writes_results_and_summary(tmp_path):
    path = tmp_path / "fourbar.json"
    path.write_text(json.dumps(fourbar_dict()))
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["simulate", str(path), "-o", str(out), "--duration", "0.2",
                                  "--samples", "11", "--rtol", "1e-8", "--report"])
    assert r.exit_code == 0, r.output
    assert "energy balance drift" in r.output
    header = (out / "results.csv").read_text().splitlines()[0].split(",")
    assert {"q_J1", "Fx_J4", "potential_energy", "work"} <= set(header)
    assert (out / "report.html").stat().st_size > 1000
    summary = json.loads((out / "summary.json").read_text())
    assert summary["simulation"]["free_joints"] == ["J1"]
    assert summary["simulation"]["coordinate_switches"] == []
    assert summary["simulation"]["energy_balance_drift_rel"] < 1e-6


def test_cli_simulate_errors(tmp_path):
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["simulate", str(linkdyn.example_path("hoeken")), "-o",
                                  str(out), "--duration", "0.1"])
    assert r.exit_code == 2 and "linkdyn analyze" in r.output
    assert not out.exists() or not any(out.iterdir())


# ---------------------------------------------------------------------------- loads of the state

def test_state_loads_and_joint_torques_in_analyze():
    """A torsion spring written as a joint_torque in q_J2 (deg) equals the same torque written
    as two torque loads of time; the joint's reaction excludes it, its power is counted."""
    d = tomllib.loads(linkdyn.example_path("hoeken").read_text())
    d["loads"] = [{"kind": "joint_torque", "joint": "J2", "value": "-0.02*(q_J2 - 30) + 0.001*qd_J2"}]
    m = linkdyn.model_from_dict(d)
    t = np.linspace(0.0, 1.0, 9)
    sol = linkdyn.analyze(m, t)
    q2, qd2 = np.degrees(sol.columns["q_J2"]), np.degrees(sol.columns["qd_J2"])
    torque = -0.02 * (q2 - 30) + 0.001 * qd2
    # the same torque on the coupler and its reaction on the crank, as loads of time
    d2 = dict(d, loads=[{"kind": "torque", "body": "coupler", "value": 0.0},
                        {"kind": "torque", "body": "crank", "value": 0.0}])
    m2 = linkdyn.model_from_dict(d2)
    spline = lambda k: (lambda tt: np.interp(tt, t, k * torque))  # noqa: E731
    m2 = replace(m2, loads=(replace(m2.loads[0], value=spline(1.0)),
                            replace(m2.loads[1], value=spline(-1.0))))
    ref = linkdyn.analyze(m2, t)
    assert np.allclose(sol.effort("J1"), ref.effort("J1"), rtol=1e-12, atol=1e-12)
    assert np.allclose(sol.reactions.force, ref.reactions.force, rtol=1e-12, atol=1e-12)
    assert np.allclose(sol.loads.power, ref.loads.power, rtol=1e-12, atol=1e-12)
    # a joint_force needs a prismatic joint, and a formula names only known variables
    d["loads"] = [{"kind": "joint_force", "joint": "J2", "value": 1.0}]
    with pytest.raises(ModelError, match=r"loads\[0\]\.kind: joint 'J2' is revolute"):
        linkdyn.model_from_dict(d)
    d["loads"] = [{"kind": "joint_torque", "joint": "J2", "value": "q_J7"}]
    with pytest.raises(ModelError, match=r"loads\[0\]\.value"):
        linkdyn.model_from_dict(d)


def test_joint_loads_are_per_design_in_a_batch():
    """A batch of designs differing in their joint_torque formulas and their joint_force's
    value and axis (the slider's, varied with the joint) equals each design solved alone."""
    t = np.linspace(0.0, 0.2, 7)

    def slider(value, axis, torque):
        d = tomllib.loads(linkdyn.example_path("slider_crank").read_text())
        d["joints"][3]["axis"] = axis
        d["loads"] = [{"kind": "joint_force", "joint": "J4", "value": value},
                      {"kind": "joint_torque", "joint": "J2", "value": torque}]
        return linkdyn.model_from_dict(d)
    models = [slider("-2000*q_J4", [1.0, 0.0], "0.1*qd_J2"),
              slider("100 + 0.5*qd_J4", [1.0, 0.1], "-0.3"),
              slider("30.0", [1.0, -0.2], "0.02*(q_J2 - 10)")]
    batch = linkdyn.analyze(models, t)
    for k, m in enumerate(models):
        one, b = linkdyn.analyze(m, t), batch.design(k)
        for x, y in ((b.effort("J1"), one.effort("J1")), (b.loads.power, one.loads.power),
                     (b.reactions.force, one.reactions.force)):
            assert np.allclose(x, y, rtol=0, atol=1e-12 * np.max(np.abs(y))), k
    # the designs' joint loads differ: the batch did not give all of them design 0's
    assert not np.allclose(batch.design(1).effort("J1"), batch.design(0).effort("J1"))


def test_round_trip_efforts_of_analyze_reproduce_the_motion():
    """analyze's driver torque for a prescribed motion, applied as a joint_torque in simulate
    (no driver), reproduces that motion."""
    from scipy.interpolate import CubicSpline
    from linkdyn.motion import ExpressionMotion
    d = fourbar_dict()
    d.pop("initial")
    driven = linkdyn.model_from_dict(d)
    motion = ExpressionMotion("0.3 + 6.0*t + 0.4*sin(5*t)")
    driven = replace(driven, drivers=(linkdyn.Driver("J1", motion),))
    tf = np.linspace(0.0, 0.4, 801)
    tau = linkdyn.analyze(driven, tf).effort("J1")
    spline = CubicSpline(tf, tau)
    free = replace(driven, drivers=(), initial_q={"J1": 0.3}, initial_qd={"J1": 8.0},
                   loads=(Load("joint_torque", "crank", "O1", lambda tt: spline(tt), "ground",
                               "O1", joint="J1"),))
    t = np.linspace(0.0, 0.4, 9)
    sol = simulate(free, t, rtol=1e-10, atol=1e-12)
    q, qd, _ = motion.evaluate(t)
    assert np.max(np.abs(sol.columns["q_J1"] - q)) < 1e-7
    assert np.max(np.abs(sol.columns["qd_J1"] - qd)) < 1e-6
    # the work of the joint torque is the driver's work of analyze
    ref = linkdyn.analyze(driven, t)
    assert np.allclose(sol.kinetic_energy, ref.kinetic_energy, rtol=1e-6)


# ---------------------------------------------------------------------------- through singular positions

def ladder(n, phi0=math.pi / 4):
    """n parallelogram windows in a row (:func:`builders.parallelogram_chain`), cut where the
    topology chooses."""
    return parallelogram_chain(n, phi0, name="ladder", g=G)


def test_parallelogram_chain_falls_flat_and_through():
    n = 10
    t = np.linspace(0.0, 1.2, 13)
    sol = simulate(ladder(n), t, rtol=1e-8, atol=1e-10)
    # one coordinate: every vertical bar turns by phi, the horizontal ones translate:
    # A phi'' = -g B cos(phi), A = (n + 1) m L^2 / 3 + n m L^2, B = (n + 1) m L / 2 + n m L
    a, b = (n + 1) / 3 + n, (n + 1) / 2 + n
    ref = reference(lambda t, y: [y[1], -G * b * math.cos(y[0]) / a], [math.pi / 4, 0.0], t)
    phi = sol.columns["q_G0"]
    assert phi.min() < -math.pi          # through flat (0) and flat again (-pi)
    # 1e-6 where a step's dense output does not span a flat position; 1e-4 where it does: the
    # right-hand side 4.5e-5 rad from flat is 1.5e-2 off the closed form (its dependent
    # coordinates are ill-determined there) and a stage landing there bends the interpolant
    # between the step's accurate ends (measured 4e-5 with OpenBLAS's AVX-512 kernels, 1e-8 with
    # its AVX2 ones, the same steps)
    s = np.sign(np.sin(ref[0]))
    crossed = np.flatnonzero(s[1:] != s[:-1])     # flat between samples i and i + 1
    near_flat = np.isin(np.arange(len(t)), np.concatenate((crossed, crossed + 1)))
    assert near_flat.sum() == 4
    assert np.max(np.abs(phi - ref[0])[~near_flat]) < 1e-6
    assert np.max(np.abs(phi - ref[0])) < 1e-4
    # every window stays a parallelogram (the branch its velocity leads to)
    for k in range(n + 1):
        assert np.max(np.abs(sol.columns[f"q_G{k}"] - phi)) < 1e-9
    assert sol.stats["closure_residual"] <= 1e-12
    assert np.all(sol.valid)


# ---------------------------------------------------------------------------- MuJoCo

def test_released_four_bar_matches_mujoco():
    """Hoeken's four-bar released from rest under gravity, against MuJoCo simulating the same
    open tree closed by a stiff ``connect`` (RK4, small steps) over a short horizon."""
    mujoco = pytest.importorskip("mujoco", reason="the MuJoCo check needs mujoco (the mujoco extra)")
    import xml.etree.ElementTree as ET
    from linkdyn.io.mjcf import mjcf
    from test_mujoco import hoeken

    model = replace(hoeken((0.0, -G)), drivers=(), initial_q={"J1": 0.5})
    t = np.linspace(0.0, 0.25, 6)
    sol = simulate(model, t, rtol=1e-10, atol=1e-12)
    root = ET.fromstring(mjcf(model, sol=sol, at=0.0).text)   # placed at the start, at rest
    root.find("option").set("timestep", "2e-5")
    root.find("option").set("integrator", "RK4")
    for c in root.iter("connect"):
        c.set("solref", "4e-5 1")
        c.set("solimp", "0.9999 0.9999 0.001")
    m = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    crank = []
    steps = int(round(t[-1] / 2e-5 / (len(t) - 1)))
    for k in range(len(t)):
        crank.append(d.qpos[m.joint("J1").qposadr[0]])
        for _ in range(steps):
            mujoco.mj_step(m, d)
    swing = np.ptp(sol.columns["q_J1"])
    assert swing > 0.1
    # MuJoCo's constraint made stiff and its steps small: both agree to the tolerances
    err = np.max(np.abs(np.array(crank) - sol.columns["q_J1"]))
    assert err < 1e-8 * swing            # measured 4.5e-11 * swing


# ---------------------------------------------------------------------------- bundled examples

def test_motor_and_flywheel_keep_the_speed_fluctuation_analyze_estimates():
    """hoeken_motor carries the flywheel `analyze hoeken` sizes for C_s = 0.02 at 45 rpm; near
    its no-load speed the simulated fluctuation over a crank turn is that C_s (the estimate
    neglects the linkage's varying inertia and the motor's slope: within 15 %)."""
    from linkdyn import design
    analysed = design.summary(linkdyn.analyze(linkdyn.load(linkdyn.example_path("hoeken")),
                                              np.linspace(0.0, 4 / 3, 361)))
    fly = analysed["driver_energy"]["J1"]["flywheel"]
    m = linkdyn.load(linkdyn.example_path("hoeken_motor"))
    crank = m.body("crank")
    assert math.isclose(crank.inertia + crank.mass * float(crank.com @ crank.com),
                        fly["inertia_kg_m2"] + 725.80e-6, rel_tol=1e-4)
    m = replace(m, initial_qd={"J1": 45 * 2 * math.pi / 60})
    period = 4 / 3
    t = np.linspace(0.0, 2 * period, 241)
    sol = simulate(m, t, rtol=1e-7, atol=1e-9)
    w = sol.columns["qd_J1"][t >= period]
    c_s = (w.max() - w.min()) / w.mean()
    assert abs(c_s - fly["speed_fluctuation"]) < 0.15 * fly["speed_fluctuation"]


def test_bundled_simulation_examples_run():
    """Each model of examples/simulate runs (briefly) and keeps its energy balance."""
    from linkdyn.cli import simulation_example_names
    names = simulation_example_names()
    assert {"hoeken_motor", "fourbar_release", "toggle_spring"} <= set(names)
    for name, method in (("fourbar_release", "DOP853"), ("toggle_spring", "Radau")):
        m = linkdyn.load(linkdyn.example_path(name))
        sol = simulate(m, np.linspace(0.0, 0.2, 5), rtol=1e-7, atol=1e-9, method=method)
        assert sol.energy_drift < 1e-4, name
        assert np.all(sol.valid)


def test_stiff_toggle_implicit_methods_agree():
    """The stiff toggle by Radau and by BDF: the same motion, the damper's work balanced.
    (Over 0.3 s Radau takes 83 steps and 660 evaluations, RK45 319 and 1964:
    benchmarks/bench_simulate.py.)"""
    m = linkdyn.load(linkdyn.example_path("toggle_spring"))
    t = np.linspace(0.0, 0.1, 3)
    radau = simulate(m, t, rtol=1e-7, atol=1e-9, method="Radau")
    bdf = simulate(m, t, rtol=1e-7, atol=1e-9, method="BDF")
    assert np.allclose(radau.columns["q_J1"], bdf.columns["q_J1"], atol=1e-5)
    assert radau.energy_drift < 1e-5 and np.all(radau.work[1:] < 0)  # the damper takes energy


def _toggle(stiffness):
    """The bundled toggle with its spring's stiffness changed (N/m)."""
    m = linkdyn.load(linkdyn.example_path("toggle_spring"))
    return replace(m, loads=tuple(replace(x, stiffness=stiffness) if x.kind == "spring" else x
                                  for x in m.loads))


def test_a_stiff_springs_free_acceleration_keeps_its_digits():
    """The free acceleration is affine in the spring's stiffness k (H does not hold k, h is
    affine in it): extrapolated from k = 0 and 2 N/mm, where it is a few hundred rad/s^2, it
    predicts that of k = 20,000 and 2,000,000 N/mm (about 1e7 and 1e9 rad/s^2) to the
    extrapolation's own error (~1e-13), where a unit free acceleration of 1 rad/s^2 in F5 would
    lose the digits of 1e7 in H (~5e-10)."""
    def qdd(k):
        sol = simulate(_toggle(k), np.array([0.0, 1e-9]), backend="numpy")
        return sol.columns["qdd_J1"][0]
    a0, a1 = qdd(0.0), qdd(2e3)
    for k in (2e7, 2e9):
        predicted = a0 + k / 2e3 * (a1 - a0)
        assert abs(predicted) > 1e6
        assert abs(qdd(k) / predicted - 1) < 1e-11, k


def test_a_thousand_times_stiffer_toggle_by_radau_agrees_with_dop853():
    """The toggle's spring at 20,000 N/mm (the crank snaps at ~1e7 rad/s^2): Radau completes
    and gives DOP853's motion, and both keep the energy balance."""
    m = _toggle(2e7)
    t = np.linspace(0.0, 2e-4, 3)
    radau = simulate(m, t, rtol=1e-6, atol=1e-8, method="Radau", backend="numpy")
    dop = simulate(m, t, rtol=1e-6, atol=1e-8, method="DOP853", backend="numpy")
    q = radau.columns["q_J1"]
    assert abs(q[-1] - q[0]) > 0.1                                    # it did snap
    assert np.allclose(q, dop.columns["q_J1"], rtol=0, atol=1e-6)
    w = np.abs(dop.columns["qd_J1"]).max()
    assert np.allclose(radau.columns["qd_J1"], dop.columns["qd_J1"], rtol=0, atol=1e-4 * w)
    assert radau.energy_drift < 1e-5 and dop.energy_drift < 1e-5


@pytest.mark.parametrize("method", ["Radau", "BDF"])
def test_a_stiff_toggle_at_rest_stays_there_in_few_implicit_steps(method):
    """The 20,000 N/mm toggle started at its static equilibrium (linkdyn.modal, Newton's method
    on the efforts) stays there. Its right-hand side resolves the free rate to ~1e-12 rad/s
    (its accelerations step by ~2e-8 rad/s^2 per last digit of the slider's position), so with
    the rate's atol at 1e-10 Radau's Newton iterations met noise and the steps collapsed (more
    than 200 steps before 0.05 s); with the rate's atol raised to its resolution (F14) a few
    steps reach 1 s."""
    from linkdyn import modal
    m = _toggle(2e7)
    rest = modal.equilibrium(m).q[0]
    m = replace(m, initial_q={"J1": rest})
    sol = simulate(m, np.linspace(0.0, 1.0, 3), rtol=1e-8, atol=1e-10, method=method,
                   max_steps=200, backend="numpy")
    assert 1e-10 < sol.stats["atol_rates"] < 1e-6      # measured 1.3e-8 rad/s
    assert np.allclose(sol.columns["q_J1"], rest, rtol=0, atol=1e-12)
    assert np.all(np.abs(sol.columns["qd_J1"]) < sol.stats["atol_rates"])


def test_simulation_models_round_trip_through_save(tmp_path):
    from linkdyn.cli import simulation_example_names
    for name in simulation_example_names():
        m = linkdyn.load(linkdyn.example_path(name))
        back = linkdyn.load(linkdyn.save(m, tmp_path / f"{name}.toml"))
        for a, b in ((m.initial_q, back.initial_q), (m.initial_qd, back.initial_qd)):
            assert a.keys() == b.keys()
            assert all(math.isclose(a[k], b[k], rel_tol=1e-12, abs_tol=1e-15) for k in a)
        assert [(x.kind, x.joint, x.body) for x in m.loads] == \
            [(x.kind, x.joint, x.body) for x in back.loads]
        for x, y in zip(m.loads, back.loads):
            if x.value is not None:
                assert [str(c) for c in x.value.components] == \
                    [str(c) for c in y.value.components]


def test_unknown_backend_names_the_field(monkeypatch):
    m = pendulum(initial_q={"J1": 0.3})
    with pytest.raises(ModelError, match="backend"):
        simulate(m, np.linspace(0.0, 0.1, 3), backend="fortran")
    monkeypatch.setenv("LINKDYN_BACKEND", "gpu")
    with pytest.raises(ModelError) as err:
        simulate(m, np.linspace(0.0, 0.1, 3))
    assert err.value.field == "LINKDYN_BACKEND"


# ---------------------------------------------------------------------------- a solver's state moved

def _steps(method, fun, y0, t_end, rtol, atol, between=None):
    """Steps of scipy's ``method`` on ``fun`` from ``y0``; ``between(solver)`` after each one
    but the last. Returns the solver and the number of steps."""
    import scipy.integrate as si
    solver = getattr(si, method)(fun, 0.0, np.array(y0, float), t_end, rtol=rtol, atol=atol)
    n = 0
    while solver.status == "running":
        solver.step()
        n += 1
        if between is not None and solver.status == "running":
            between(solver)
    assert solver.status == "finished", (method, solver.status)
    return solver, n


@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK23", "Radau", "BDF"])
def test_whole_turns_moved_out_of_a_solver_leave_its_steps_as_they_are(method):
    """(F12) A pendulum whirling over the top, its angle's whole turns moved out after every
    step by ``forward.restate``. Where the tolerance does not depend on ``|y|`` (atol only),
    the right-hand side is periodic in the angle, so each method must take the very same steps
    and give the same motion as without (Radau's stage prediction and BDF's difference table
    moved consistently; moved otherwise, both take other steps)."""
    from linkdyn.forward import restate

    def whirl(t, y):
        return np.array([y[1], -np.sin(y[0])])
    turns = []

    def unwind(solver):
        k = 2 * np.pi * np.round(solver.y[0] / (2 * np.pi))
        if k:
            y = solver.y - [k, 0.0]
            restate(solver, y, whirl(solver.t, y))
            turns.append(k)
    kw = dict(t_end=30.0, rtol=1e-13, atol=1e-6)
    plain, n_plain = _steps(method, whirl, [0.0, 2.5], **kw)
    moved, n_moved = _steps(method, whirl, [0.0, 2.5], between=unwind, **kw)
    assert sum(turns) > 5 * 2 * np.pi                       # several turns were moved out
    assert n_moved == n_plain
    # measured: 2e-10 (DOP853) to 3e-8 (Radau), rounding carried by the motion over 30 s
    assert np.max(np.abs(moved.y + [sum(turns), 0.0] - plain.y)) < 1e-6


@pytest.mark.parametrize("method", ["DOP853", "RK45", "RK23", "Radau"])
def test_energy_projection_in_a_solver_keeps_an_oscillator_on_its_energy(method):
    """(F11) A harmonic oscillator over 20 periods, its rate scaled back onto the energy after
    every step (within 1e-3, as ``forward.PROJECT_MAX``) and moved into the solver by
    ``forward.restate``, for each method ``simulate`` projects: at every step end, before the
    projection, the energy is within a few rtol of the start, the motion no farther from
    cos t than without, and the steps about as many as without."""
    from linkdyn.forward import restate

    def spring(t, y):
        return np.array([y[1], -y[0]])

    def energy(y):
        return 0.5 * (y[0] ** 2 + y[1] ** 2)
    worst = [0.0]

    def project(solver):
        y = solver.y.copy()
        worst[0] = max(worst[0], abs(energy(y) - 0.5))
        a = np.sqrt(max(1.0 - y[0] ** 2, 0.0)) / abs(y[1]) if y[1] else np.inf   # E = 1/2
        if abs(a - 1.0) <= 1e-3:
            y[1] *= a
            restate(solver, y, spring(solver.t, y))
    rtol, t_end = 1e-6, 20 * 2 * np.pi
    kw = dict(t_end=t_end, rtol=rtol, atol=1e-9)
    plain, n_plain = _steps(method, spring, [1.0, 0.0], **kw)
    drift = abs(energy(plain.y) - 0.5)
    projected, n = _steps(method, spring, [1.0, 0.0], between=project, **kw)
    exact = np.array([np.cos(t_end), -np.sin(t_end)])
    assert worst[0] < 5 * rtol and worst[0] < drift
    # measured: the energy at the step ends 1e-10 (Radau) to 5e-8, against 2e-7 (Radau) to
    # 1e-4 (RK23) unprojected; the motion at the end closer to cos t than unprojected
    assert np.max(np.abs(projected.y - exact)) < max(np.max(np.abs(plain.y - exact)), 10 * rtol)
    assert n <= 1.2 * n_plain


def test_a_load_reading_a_joint_coordinate_keeps_the_whole_turns():
    """(F12) A bar spun about a pin against a torsion spring written as a formula in q_J1:
    it turns several times before the spring returns it. Its angle must not be unwound (the
    spring's torque would change by 2 pi k): q_J1 follows the closed form of I q'' = -k q."""
    d = {"mechanism": {"name": "spun bar"}, "units": {"length": "m", "angle": "rad"},
         "bodies": [{"name": "ground", "points": {"O": [0.0, 0.0]}},
                    {"name": "bar", "points": {"O": [0.0, 0.0], "T": [1.0, 0.0]},
                     "mass": 1.0, "com": [0.5, 0.0], "inertia": 0.1}],
         "joints": [{"name": "J1", "type": "revolute", "connect": ["ground.O", "bar.O"]}],
         "loads": [{"kind": "joint_torque", "joint": "J1", "value": "-0.01*q_J1"}],
         "initial": {"q": {"J1": 0.0}, "qd": {"J1": 2.0}}}
    m = linkdyn.model_from_dict(d)
    inertia, k, w0 = 0.1 + 1.0 * 0.5**2, 0.01, 2.0            # about the pin
    t = np.linspace(0.0, 10.0, 11)
    omega = np.sqrt(k / inertia)
    exact = w0 / omega * np.sin(omega * t)                    # amplitude 11.8 rad
    for method in ("DOP853", "Radau"):
        sol = simulate(m, t, rtol=1e-9, atol=1e-11, method=method, backend="numpy")
        assert np.max(sol.columns["q_J1"]) > 3 * np.pi
        assert np.max(np.abs(sol.columns["q_J1"] - exact)) < 1e-6 * np.max(exact), method


@pytest.mark.parametrize("method,backend", [("Radau", "compiled")])
def test_radau_keeps_the_energy_over_many_turns(method, backend):
    """(F11) Hoeken with the flywheel of hoeken_motor spinning freely (a conservative closed
    loop), 20 crank turns at rtol 1e-4 by Radau: without the projection the balance drifts
    turn after turn (measured: to 6.4e-4); projected after every step it stays below a rtol
    (3.1e-5), and the motion is closer to a tight run's. (The compiled right-hand side, for
    speed: this runs on the compiled worker.)"""
    pytest.importorskip("numba", reason="the compiled right-hand side needs numba")
    driven = linkdyn.load(linkdyn.example_path("hoeken"))
    fly = linkdyn.load(linkdyn.example_path("hoeken_motor"))
    model = replace(driven, bodies=fly.bodies, drivers=(), loads=(), gravity=np.zeros(2),
                    initial_q={"J1": 0.0}, initial_qd={"J1": 1.5 * math.pi})
    t = np.linspace(0.0, 20 * 60 / 45, 21)                  # about a turn per sample
    rtol = 1e-4
    free, projected = (simulate(model, t, rtol=rtol, atol=rtol * 1e-2, method=method,
                                backend=backend, project=p) for p in (False, True))
    drift = [np.abs(s.energy - s.energy[0]) / np.max(s.kinetic_energy)
             for s in (free, projected)]
    assert free.stats["energy_projections"] == 0
    assert projected.stats["energy_projections"] >= projected.stats["steps"] // 2
    assert np.max(drift[1]) < 5 * rtol
    assert drift[0][-1] > 5 * np.max(drift[1])
    assert np.max(drift[0][15:]) > 2 * np.max(drift[0][:6])   # the integrator alone drifts on
    # the motion: as close to a tight run's as the integrator's alone (the phase error left)
    ref = simulate(model, t, rtol=1e-9, atol=1e-11, backend=backend).columns["q_J1"]
    err = [np.max(np.abs(s.columns["q_J1"] - ref)) for s in (free, projected)]
    assert ref[-1] > 20 * 2 * np.pi * 0.9                    # it turns
    assert err[1] < err[0] / 5                               # measured: 60 times less


def test_the_energy_balance_sees_between_the_samples():
    """The summary's energy balance (F9) holds the step ends too: the toggle by LSODA (not
    projected) with only its two end samples reports at least the largest |KE + PE - E(0) - W|
    that 601 samples of the same run show, computed here from the columns (the steps do not
    depend on the samples asked for; the end samples alone show 8 % less)."""
    m = linkdyn.load(linkdyn.example_path("toggle_spring"))

    def drift_at_samples(s):
        e = s.energy - s.energy[0] - s.work
        scale = max(np.max(np.abs(s.kinetic_energy)), np.ptp(s.potential_energy),
                    np.max(np.abs(s.work)))
        return np.max(np.abs(e)) / scale

    run = dict(method="LSODA", rtol=1e-6, atol=1e-8, backend="numpy")
    ends = simulate(m, np.array([0.0, 0.3]), **run)
    dense = simulate(m, np.linspace(0.0, 0.3, 601), **run)
    assert ends.stats["steps"] == dense.stats["steps"] > 100
    assert ends.energy_drift >= 0.999 * drift_at_samples(dense) > 1e-7
    assert drift_at_samples(ends) < 0.95 * drift_at_samples(dense)   # what the samples miss
    assert dense.energy_drift == pytest.approx(drift_at_samples(dense), rel=1e-3)
