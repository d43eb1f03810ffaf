"""Coordinate couplings (``type = "coupling"``, ``q_J1 = ratio q_J2 + offset_angle``).

Each check is against a method that shares no code with the coupling kind: a gear pair on the
same shafts (another kind's rows), closed forms of two coupled discs, the Lagrange equation of
two coupled pendulums integrated by scipy, and the file round trip. The recursive solution's
dense, Newton–Euler and power-balance checks are in ``test_dynamics.py`` (``coupled-five-bar``,
``coupled-carrier``).
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import solve_ivp

import linkdyn
from linkdyn.cli import main
from linkdyn.io.writer import dumps_toml, model_to_dict
from linkdyn.joints.coupling import couple
from linkdyn.model import Body, Driver, Joint, Model
from linkdyn.motion import ExpressionMotion

G = 9.81


def geared(ra=30.0, rb=50.0, coupled=False):
    """The bundled geared five-bar with pitch radii ``ra``, ``rb`` (mm, centres 80 mm apart) and
    a pressure angle of 0, or with the gear pair replaced by the coupling of its two pivots that
    turns the gears alike: ``q_J1 = -(rb / ra) q_J2``."""
    data = tomllib.loads(linkdyn.example_path("geared_fivebar").read_text("utf-8"))
    g = next(j for j in data["joints"] if j["name"] == "G")
    if coupled:
        g.clear()
        g.update(name="G", type="coupling", joints=["J1", "J2"], ratio=-rb / ra)
    else:
        g.update(radius_a=ra, radius_b=rb, pressure_angle=0.0)
    return linkdyn.model_from_dict(data, source="geared.toml")


def test_a_coupling_is_the_gear_pair_on_the_same_shafts():
    t = np.linspace(0.0, 1.0, 13)
    gear = linkdyn.analyze(geared(), t, backend="numpy").columns
    cpl = linkdyn.analyze(geared(coupled=True), t, backend="numpy").columns
    # the speed ratio and the relation itself
    assert np.max(np.abs(cpl["qd_J2"] - (-30.0 / 50.0) * cpl["qd_J1"])) <= 1e-12 * 2 * math.pi
    assert np.max(np.abs(cpl["q_J1"] + 50.0 / 30.0 * cpl["q_J2"])) <= 1e-12
    # the same efforts and pin reactions; the coupling torque is the tooth force times r_a
    for name in ("tau_J1", "Fx_J1", "Fy_J2", "Fx_J3", "Fy_J5", "Fx_G", "Fy_G", "phi_link1"):
        peak = max(np.max(np.abs(gear[name])), 1e-300)
        assert np.max(np.abs(cpl[name] - gear[name])) <= 1e-11 * peak, name
    lam_gear = -np.hypot(gear["Fx_G"], gear["Fy_G"]) * np.sign(cpl["torque_G"])
    assert np.max(np.abs(cpl["torque_G"] + 0.030 * lam_gear)) <= 1e-11 * np.max(
        np.abs(cpl["torque_G"]))


def discs(ratio, offset, motion):
    """Two discs pivoted on the ground 0.1 m apart at their mass centres, J2 declared disc
    first (its q is -phi_B), coupled ``q_J1 = ratio q_J2 + offset``, J1 driven by ``motion``."""
    bodies = (Body("ground", {"O1": np.zeros(2), "O2": np.array([0.1, 0.0])}),
              Body("A", {"O": np.zeros(2)}, 2.0, np.zeros(2), 0.003),
              Body("B", {"O": np.zeros(2)}, 1.5, np.zeros(2), 0.005))
    j1 = Joint("J1", "revolute", "ground", "O1", "A", "O")
    j2 = Joint("J2", "revolute", "B", "O", "ground", "O2")
    k = couple("K", j1, j2, {b.name: b for b in bodies}, ratio, offset)
    return Model("discs", bodies, (j1, j2, k), (Driver("J1", motion),), (),
                 np.array([0.0, -G]), assembly_phi={"A": 0.0, "B": 0.0})


def test_two_coupled_discs_by_hand():
    """q_1 = r q_2 + c: disc B turns at alpha / r, so the driver's torque is
    ``(I_A + I_B / r^2) alpha`` and the coupling's ``-I_B alpha / r^2`` (B's equation
    ``I_B alpha / r = -r lam``, its torque in J2 being ``-r lam``)."""
    r, c, al = -2.5, 0.4, 0.6
    t = np.linspace(0.0, 1.0, 5)
    sol = linkdyn.analyze(discs(r, c, ExpressionMotion("0.3*t**2 + 0.5*t")), t,
                          backend="numpy")
    col = sol.columns
    ia, ib = 0.003, 0.005
    assert np.max(np.abs(col["q_J1"] - r * col["q_J2"] - c)) <= 1e-13
    assert np.max(np.abs(col["phi_B"] - (-(col["q_J1"] - c) / r))) <= 1e-13
    assert np.max(np.abs(col["tau_J1"] - (ia + ib / r ** 2) * al)) <= 1e-14
    assert np.max(np.abs(col["torque_K"] - (-ib * al / r ** 2))) <= 1e-14
    assert np.max(np.abs(col["q_K"] - col["q_J1"])) <= 1e-13


def pendulums(ratio, offset):
    """Two bars hanging from ground pivots 0.1 m apart, coupled and released (no driver)."""
    bar = dict(mass=0.4, com=np.array([0.15, 0.0]), inertia=0.4 * 0.3 ** 2 / 12)
    bodies = (Body("ground", {"O1": np.zeros(2), "O2": np.array([0.1, 0.0])}),
              Body("A", {"O": np.zeros(2), "T": np.array([0.3, 0.0])}, **bar),
              Body("B", {"O": np.zeros(2)}, 0.25, np.array([0.1, 0.02]), 0.001))
    j1 = Joint("J1", "revolute", "ground", "O1", "A", "O")
    j2 = Joint("J2", "revolute", "ground", "O2", "B", "O")
    k = couple("K", j1, j2, {b.name: b for b in bodies}, ratio, offset)
    q0 = -1.0
    return Model("pendulums", bodies, (j1, j2, k), (), (), np.array([0.0, -G]),
                 assembly_phi={"A": q0, "B": (q0 - offset) / ratio},
                 initial_q={"J1": q0}, initial_qd={"J1": 0.0}), q0


def test_coupled_pendulums_follow_their_lagrange_equation():
    """One freedom q_1 (q_2 = (q_1 - c) / r): ``(I_A + I_B / r^2) q_1'' = -dV/dq_1`` with
    ``V = m_A g y_A(q_1) + m_B g y_B(q_2)``, the inertias about the pivots."""
    r, c = -1.5, 0.2
    model, q0 = pendulums(r, c)
    ia = 0.4 * 0.3 ** 2 / 3
    ib = 0.001 + 0.25 * (0.1 ** 2 + 0.02 ** 2)

    def rhs(_, y):
        q1, w = y
        q2 = (q1 - c) / r
        # y_C = x_c sin(q) + y_c cos(q) for the mass centre (x_c, y_c) in the body
        dv = 0.4 * G * 0.15 * np.cos(q1) + 0.25 * G * (0.1 * np.cos(q2) - 0.02 * np.sin(q2)) / r
        return [w, -dv / (ia + ib / r ** 2)]

    t = np.linspace(0.0, 0.4, 9)
    ref = solve_ivp(rhs, (0.0, t[-1]), [q0, 0.0], t_eval=t, method="DOP853", rtol=1e-12,
                    atol=1e-12)
    sol = linkdyn.simulate(model, t, rtol=1e-9, atol=1e-11, backend="numpy")
    col = sol.columns
    assert np.ptp(col["q_J1"]) > 0.5                      # it swings
    assert np.max(np.abs(col["q_J1"] - ref.y[0])) <= 1e-7
    assert np.max(np.abs(col["q_J1"] - r * col["q_J2"] - c)) <= 1e-10


def test_the_file_round_trip_and_the_coupled_joints():
    model = geared(coupled=True)
    data = model_to_dict(model)
    entry = next(j for j in data["joints"] if j["name"] == "G")
    assert entry == {"name": "G", "type": "coupling", "joints": ["J1", "J2"],
                     "ratio": pytest.approx(-50 / 30), "offset_angle": 0.0}
    again = linkdyn.model_from_dict(data, source="again.toml")
    assert again.joint("G") == model.joint("G")
    assert model.joint("G").coupled == ("J1", "J2")


def refused(tmp_path, joints, **numbers):
    """``check`` of the geared five-bar with its gear a coupling of ``joints``."""
    data = tomllib.loads(linkdyn.example_path("geared_fivebar").read_text("utf-8"))
    data["bodies"][0]["points"]["O3"] = [0.0, 0.0]
    data["joints"].append({"name": "J6", "type": "prismatic",
                           "connect": ["link1.A", "link2.P"]})
    g = next(j for j in data["joints"] if j["name"] == "G")
    g.clear()
    g.update(name="G", type="coupling", joints=joints, **numbers)
    path = tmp_path / "bad.toml"
    path.write_text(dumps_toml(data), "utf-8")
    res = CliRunner().invoke(main, ["check", str(path)])
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output
    return res.output


@pytest.mark.parametrize("joints, says", [
    (["J1", "J6"], "'J6' is prismatic"),
    (["J1", "J5"], "share no body"),
    (["J1", "J9"], "unknown joint 'J9'"),
    (["J1", "J1"], "names joint 'J1' twice"),
    ("J1", "expected two joint names"),
])
def test_what_a_coupling_cannot_couple_is_refused(tmp_path, joints, says):
    out = refused(tmp_path, joints)
    assert says in out and "joints" in out


def test_coaxial_joints_are_refused(tmp_path):
    data = tomllib.loads(linkdyn.example_path("geared_fivebar").read_text("utf-8"))
    data["bodies"][0]["points"]["O2"] = [0.0, 0.0]      # both gears on one axis
    data["bodies"][0]["points"]["O1"] = [0.0, 0.0]
    g = next(j for j in data["joints"] if j["name"] == "G")
    g.clear()
    g.update(name="G", type="coupling", joints=["J1", "J2"])
    path = tmp_path / "coaxial.toml"
    path.write_text(dumps_toml(data), "utf-8")
    res = CliRunner().invoke(main, ["check", str(path)])
    assert res.exit_code == 2 and "at one point of body 'ground'" in res.output, res.output
    assert "joints.G" in res.output or "joints[2]" in res.output


def test_a_coupling_with_connect_is_refused(tmp_path):
    out = refused(tmp_path, ["J1", "J2"], connect=["gear1.O1", "gear2.O2"])
    assert "not connect" in out


def test_both_backends_run_a_coupling():
    """The coupling is a kind behind the cut protocol: the compiled kernels run it unchanged."""
    pytest.importorskip("numba", reason="the compiled backend needs numba (the fast extra)")
    from test_dynamics import coupled_carrier

    model = coupled_carrier()
    t = np.linspace(0.0, 1.3, 7)
    a = linkdyn.analyze(model, t, backend="numpy").columns
    b = linkdyn.analyze(model, t, backend="compiled").columns
    for name in ("tau_J0", "tau_J1", "torque_K", "Fx_K", "M_K", "Fy_J2", "q_K", "qdd_K"):
        assert np.max(np.abs(a[name] - b[name])) <= 1e-12 * max(np.max(np.abs(a[name])), 1.0), \
            name
    swing, _ = pendulums(-1.5, 0.2)
    ts = np.linspace(0.0, 0.2, 5)
    a = linkdyn.simulate(swing, ts, rtol=1e-10, atol=1e-12, backend="numpy").columns
    b = linkdyn.simulate(swing, ts, rtol=1e-10, atol=1e-12, backend="compiled").columns
    assert np.max(np.abs(a["q_J2"] - b["q_J2"])) <= 1e-8
