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


def test_a_position_it_cannot_pass_exits_3_naming_the_time():
    # the rocker as the free coordinate: pushed to its limit (crank and coupler in line) the
    # crank would have to move at an unbounded rate, and the run stops there
    d = fourbar_dict(q={"J4": -77.12})
    d["mechanism"]["gravity"] = [0.0, 0.0]
    d["loads"] = [{"kind": "torque", "body": "rocker", "value": 2.0}]
    m = linkdyn.model_from_dict(d)
    with pytest.raises(AssemblyError, match=r"at t = [0-9.e-]+ s.*cannot pass"):
        simulate(m, np.linspace(0.0, 1.0, 3), rtol=1e-6, atol=1e-8)


def test_cli_simulate_writes_results_and_summary(tmp_path):
    path = tmp_path / "fourbar.json"
    path.write_text(json.dumps(fourbar_dict()))
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["simulate", str(path), "-o", str(out), "--duration", "0.2",
                                  "--samples", "11", "--rtol", "1e-8"])
    assert r.exit_code == 0, r.output
    assert "energy balance drift" in r.output
    header = (out / "results.csv").read_text().splitlines()[0].split(",")
    assert {"q_J1", "Fx_J4", "potential_energy", "work"} <= set(header)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["simulation"]["free_joints"] == ["J1"]
    assert summary["simulation"]["energy_balance_drift_rel"] < 1e-6


def test_cli_simulate_errors(tmp_path):
    out = tmp_path / "out"
    r = CliRunner().invoke(main, ["simulate", str(linkdyn.example_path("hoeken")), "-o",
                                  str(out), "--duration", "0.1"])
    assert r.exit_code == 2 and "linkdyn analyze" in r.output
    assert not out.exists() or not any(out.iterdir())
