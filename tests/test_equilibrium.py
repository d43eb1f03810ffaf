"""Static equilibrium and small vibrations (``linkdyn.modal``: ``linkdyn equilibrium`` and
``linkdyn modes``) against references that share no code with the solver: closed forms (a
pendulum, an inverted one, a mass on a spring and damper, a double pendulum of two rods), an
explicit four-bar written here (closed-form positions, its potential and generalized inertia
along the one coordinate), and the period of a small motion integrated by ``simulate``."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main
from linkdyn.modal import equilibrium, modes

G = 9.81


def model(text: str) -> linkdyn.Model:
    import tomllib
    return linkdyn.io.model_from_dict(tomllib.loads(text))


def pendulum(start_deg: float, gravity=-G) -> linkdyn.Model:
    """A bar of 2 kg pivoted at O, its mass centre 0.3 m along it, 0.05 kg m^2 about it."""
    return model(f"""
[mechanism]
name = "pendulum"
gravity = [0.0, {gravity}]
[[bodies]]
name = "ground"
points = {{ O = [0.0, 0.0] }}
[[bodies]]
name = "bar"
points = {{ O = [0.0, 0.0] }}
mass = 2.0
com = [0.3, 0.0]
inertia = 0.05
[[joints]]
name = "J1"
type = "revolute"
connect = ["ground.O", "bar.O"]
[initial]
q = {{ J1 = {math.radians(start_deg)} }}
""")


def test_a_pendulum_hangs_straight_down_and_swings_at_its_closed_form_frequency():
    eq = equilibrium(pendulum(-60.0))
    assert eq.q[0] == pytest.approx(-math.pi / 2, abs=1e-12)
    md = modes(eq)
    # w^2 = m g d / (I_c + m d^2)
    w = math.sqrt(2.0 * G * 0.3 / (0.05 + 2.0 * 0.3 ** 2))
    assert md.stable and eq.stable
    assert md.frequencies[0] == pytest.approx(w / (2 * math.pi), rel=1e-10)
    assert md.damping_ratios[0] == 0.0
    assert eq.mass[0, 0] == pytest.approx(0.05 + 2.0 * 0.3 ** 2, rel=1e-12)
    assert eq.stiffness[0, 0] == pytest.approx(2.0 * G * 0.3, rel=1e-10)


def test_an_inverted_pendulum_is_an_unstable_equilibrium():
    eq = equilibrium(pendulum(80.0))
    assert eq.q[0] == pytest.approx(math.pi / 2, abs=1e-12)
    md = modes(eq)
    assert not md.stable and not eq.stable
    # the motion grows as exp(s t), s^2 = m g d / I_O
    s = math.sqrt(2.0 * G * 0.3 / (0.05 + 2.0 * 0.3 ** 2))
    assert np.max(np.real(md.eigenvalues)) == pytest.approx(s, rel=1e-10)


def slider(k=400.0, c=6.0, m=1.5, free_length=0.5, gravity=-G) -> linkdyn.Model:
    """A 1.5 kg slider on a vertical guide, on a spring and a damper to the ground's origin."""
    return model(f"""
[mechanism]
name = "slider on a spring"
gravity = [0.0, {gravity}]
[[bodies]]
name = "ground"
points = {{ O = [0.0, 0.0] }}
[[bodies]]
name = "slider"
points = {{ B = [0.0, 0.0] }}
mass = {m}
inertia = 0.01
[[joints]]
name = "J1"
type = "prismatic"
connect = ["ground.O", "slider.B"]
axis = [0.0, 1.0]
[[loads]]
kind = "spring"
name = "spring"
body = "ground"
point = "O"
body2 = "slider"
point2 = "B"
stiffness = {k}
free_length = {free_length}
[[loads]]
kind = "damper"
name = "damper"
body = "ground"
point = "O"
body2 = "slider"
point2 = "B"
damping = {c}
[initial]
q = {{ J1 = 0.45 }}
""")


def test_a_mass_on_a_spring_and_damper_sags_and_rings_as_the_closed_form_says():
    k, c, m = 400.0, 6.0, 1.5
    eq = equilibrium(slider(k, c, m))
    # k (y - l0) = -m g
    assert eq.q[0] == pytest.approx(0.5 - m * G / k, abs=1e-12)
    assert eq.stiffness[0, 0] == pytest.approx(k, rel=1e-10)
    assert eq.damping[0, 0] == pytest.approx(c, rel=1e-10)
    md = modes(eq)
    assert md.stable and len(md.frequencies) == 1
    assert md.frequencies[0] == pytest.approx(math.sqrt(k / m) / (2 * math.pi), rel=1e-10)
    assert md.damping_ratios[0] == pytest.approx(c / (2 * math.sqrt(k * m)), rel=1e-10)


def double_pendulum(m1=1.0, l1=0.8, m2=0.6, l2=0.5) -> linkdyn.Model:
    """Two uniform rods in a chain, pivoted at the ground's O."""
    return model(f"""
[mechanism]
name = "double pendulum"
gravity = [0.0, {-G}]
[[bodies]]
name = "ground"
points = {{ O = [0.0, 0.0] }}
[[bodies]]
name = "upper"
points = {{ O = [0.0, 0.0], A = [{l1}, 0.0] }}
mass = {m1}
com = [{l1 / 2}, 0.0]
inertia = {m1 * l1 ** 2 / 12}
[[bodies]]
name = "lower"
points = {{ A = [0.0, 0.0] }}
mass = {m2}
com = [{l2 / 2}, 0.0]
inertia = {m2 * l2 ** 2 / 12}
[[joints]]
name = "J1"
type = "revolute"
connect = ["ground.O", "upper.O"]
[[joints]]
name = "J2"
type = "revolute"
connect = ["upper.A", "lower.A"]
[initial]
q = {{ J1 = -1.2, J2 = -0.3 }}
""")


def test_a_double_pendulum_of_rods_has_the_closed_form_frequencies():
    m1, l1, m2, l2 = 1.0, 0.8, 0.6, 0.5
    eq = equilibrium(double_pendulum(m1, l1, m2, l2))
    assert eq.q == pytest.approx([-math.pi / 2, 0.0], abs=1e-12)
    # absolute angles from the vertical: M and K of the linearized rods (the frequencies do
    # not depend on the coordinates)
    M = np.array([[(m1 / 3 + m2) * l1 ** 2, m2 * l1 * l2 / 2], [m2 * l1 * l2 / 2, m2 * l2 ** 2 / 3]])
    K = np.diag([(m1 / 2 + m2) * G * l1, m2 * G * l2 / 2])
    w = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real))
    md = modes(eq)
    assert md.frequencies == pytest.approx(w / (2 * np.pi), rel=1e-9)
    # each shape solves K v = w^2 H v in linkdyn's own (relative) coordinates
    for k in range(2):
        v = md.shapes[:, k]
        r = eq.stiffness @ v - (2 * np.pi * md.frequencies[k]) ** 2 * eq.mass @ v
        assert np.max(np.abs(r)) <= 1e-9 * np.max(np.abs(eq.stiffness))



@pytest.mark.parametrize("k", [0, 1])
def test_a_double_pendulum_let_go_along_a_mode_shape_swings_in_that_shape(k):
    """simulate from rest at the equilibrium plus eps times mode k's shape: the motion is
    eps v_k cos(w_k t) (the other mode not excited), to O(eps) of eps (the nonlinear terms;
    measured 3e-5 and 5e-5 of eps, 1.4 with the other mode's shape)."""
    from dataclasses import replace
    m = double_pendulum()
    md = modes(equilibrium(m))
    eq, v, w = md.equilibrium, md.shapes[:, k], 2 * np.pi * md.frequencies[k]
    eps = 1e-5
    start = replace(m, initial_q=dict(zip(eq.free, (eq.q + eps * v).tolist())),
                    initial_qd={j: 0.0 for j in eq.free})
    t = np.linspace(0.0, 2 * np.pi / w, 41)                          # one period of mode k
    cols = linkdyn.simulate(start, t, rtol=1e-12, atol=1e-16, backend="numpy").columns
    dq = np.stack([np.asarray(cols[f"q_{j}"]) - q0 for j, q0 in zip(eq.free, eq.q)])
    assert np.max(np.abs(dq - eps * np.outer(v, np.cos(w * t)))) < 3e-4 * eps   # 3e-5, 5e-5


# --- a four-bar with a diagonal spring, against an explicit four-bar written here ----------

A, B, C, D = 0.3, 0.9, 0.7, 0.8          # ground, crank, coupler, rocker lengths, m
MASS = (1.0, 2.0, 1.5)                    # crank, coupler, rocker, at their mid-points
K_SPRING, L0 = 150.0, 0.6                 # from the ground pivot O1 to the rocker pin O3


def spring_fourbar(start: float) -> linkdyn.Model:
    """The four-bar, its free crank J1 at ``start`` (rad), assembled on the explicit branch."""
    o2, o3, o4 = pose(start)
    phi_c, phi_r = (math.atan2(*(y - x)[::-1]) for x, y in ((o2, o3), (o3, o4)))
    bars = (("crank", B, MASS[0]), ("coupler", C, MASS[1]), ("rocker", D, MASS[2]))
    bodies = "\n".join(f"""
[[bodies]]
name = "{n}"
points = {{ P = [0.0, 0.0], Q = [{l}, 0.0] }}
mass = {m}
com = [{l / 2}, 0.0]
inertia = {m * l ** 2 / 12}""" for n, l, m in bars)
    return model(f"""
[mechanism]
name = "four-bar with a diagonal spring"
gravity = [0.0, {-G}]
[[bodies]]
name = "ground"
points = {{ O1 = [0.0, 0.0], O4 = [{A}, 0.0] }}
{bodies}
[[joints]]
name = "J1"
type = "revolute"
connect = ["ground.O1", "crank.P"]
[[joints]]
name = "J2"
type = "revolute"
connect = ["crank.Q", "coupler.P"]
[[joints]]
name = "J3"
type = "revolute"
connect = ["coupler.Q", "rocker.P"]
[[joints]]
name = "J4"
type = "revolute"
connect = ["rocker.Q", "ground.O4"]
[[loads]]
kind = "spring"
name = "diagonal"
body = "ground"
point = "O1"
body2 = "rocker"
point2 = "P"
stiffness = {K_SPRING}
free_length = {L0}
[assembly]
phi = {{ coupler = {phi_c}, rocker = {phi_r} }}
[initial]
q = {{ J1 = {start} }}
""")


def pose(th):
    """Pins O2, O3, O4 of the explicit four-bar at crank angle ``th``: closed form (circle
    intersection), the coupler's far pin O3 on the left of O2 -> O4."""
    o2 = np.array([B * math.cos(th), B * math.sin(th)])
    o4 = np.array([A, 0.0])
    d = o4 - o2
    L = math.hypot(*d)
    # |O3 - O2| = C, |O3 - O4| = D
    a = (C ** 2 - D ** 2 + L ** 2) / (2 * L)
    h = math.sqrt(C ** 2 - a ** 2)
    u = d / L
    return o2, o2 + a * u + h * np.array([-u[1], u[0]]), o4


def explicit(theta: float):
    """The explicit four-bar at crank angle ``theta``: (potential energy, generalized inertia),
    from the closed-form positions and their derivative along theta."""
    def energy_and_points(th):
        o2, o3, o4 = pose(th)
        coms = (o2 / 2, (o2 + o3) / 2, (o3 + o4) / 2)
        phis = (th, math.atan2(*(o3 - o2)[::-1]), math.atan2(*(o4 - o3)[::-1]))
        v = sum(m * G * c[1] for m, c in zip(MASS, coms))
        v += 0.5 * K_SPRING * (math.hypot(*o3) - L0) ** 2
        return v, np.concatenate([np.concatenate(coms), phis])

    # derivatives along theta by a fourth-order central difference of the closed form
    e = 1e-4
    pts = [energy_and_points(theta + s * e)[1] for s in (-2, -1, 1, 2)]
    dx = (8 * (pts[2] - pts[1]) - (pts[3] - pts[0])) / (12 * e)
    inertia = (m * l ** 2 / 12 for m, l in zip(MASS, (B, C, D)))
    H = sum(m * (dx[2 * k] ** 2 + dx[2 * k + 1] ** 2) for k, m in enumerate(MASS))
    H += sum(i * dx[6 + k] ** 2 for k, i in enumerate(inertia))
    return energy_and_points(theta)[0], H


def test_a_four_bar_with_a_diagonal_spring_matches_the_explicit_four_bar():
    import scipy.optimize as so

    eq = equilibrium(spring_fourbar(-0.8))

    def dV(th, e=1e-4):
        v = [explicit(th + s * e)[0] for s in (-2, -1, 1, 2)]
        return (8 * (v[2] - v[1]) - (v[3] - v[0])) / (12 * e)
    th = so.brentq(dV, eq.q[0] - 0.2, eq.q[0] + 0.2, xtol=1e-14)
    assert eq.q[0] == pytest.approx(th, abs=1e-9)
    # w^2 = V'' / H at the equilibrium (V' = 0 there, so H' does not enter)
    e = 1e-3
    d2 = (-dV(th + 2 * e) + 8 * dV(th + e) - 8 * dV(th - e) + dV(th - 2 * e)) / (12 * e)
    H = explicit(th)[1]
    assert eq.mass[0, 0] == pytest.approx(H, rel=1e-8)
    md = modes(eq)
    assert md.stable
    assert md.frequencies[0] == pytest.approx(math.sqrt(d2 / H) / (2 * math.pi), rel=1e-7)


def test_a_small_motion_simulated_about_the_equilibrium_swings_at_the_mode_frequency():
    m = spring_fourbar(-0.8)
    eq = equilibrium(m)
    f = modes(eq).frequencies[0]
    from dataclasses import replace
    start = replace(m, initial_q={"J1": float(eq.q[0]) + 1e-3})
    period = 1.0 / f
    t = np.linspace(0.0, 4 * period, 4001)
    # the integrator at rtol 1e-9 moves the measured period by 1e-9 of it (7.62e-8 from the
    # mode's against 7.55e-8 at 1e-11, the motion's own nonlinearity), far inside the 2e-5
    # checked, at half the steps
    sol = linkdyn.simulate(start, t, rtol=1e-9, atol=1e-11, backend="numpy")
    x = np.asarray(sol.columns["q_J1"]) - eq.q[0]
    # upward zero crossings, interpolated: their spacing is the period of the motion
    k = np.nonzero((x[:-1] < 0) & (x[1:] >= 0))[0]
    tc = t[k] - x[k] * (t[k + 1] - t[k]) / (x[k + 1] - x[k])
    assert len(tc) >= 3
    assert np.mean(np.diff(tc)) == pytest.approx(period, rel=2e-5)


# --- the command line ----------------------------------------------------------------------

def test_the_commands_print_in_the_files_units(tmp_path):
    path = tmp_path / "toggle.toml"
    path.write_text(linkdyn.example_path("toggle_spring").read_text("utf-8"), "utf-8")
    res = CliRunner().invoke(main, ["modes", str(path)])
    assert res.exit_code == 0, res.output
    eq = equilibrium(linkdyn.load(path))
    md = modes(eq)
    # the free joint in degrees (the file's unit), each frequency in Hz
    assert f"J1 = {math.degrees(eq.q[0]):.6g} deg  (free)" in res.output
    for f in md.frequencies:
        assert f"{f:.6g} Hz" in res.output
    js = CliRunner().invoke(main, ["equilibrium", str(path), "--json"])
    assert js.exit_code == 0
    import json
    data = json.loads(js.output)
    assert data["q"]["J1"] == pytest.approx(eq.q[0], abs=1e-12)


def test_what_has_no_equilibrium_gets_one_clear_message(tmp_path):
    # nothing holds a pendulum without gravity (singular stiffness): exit 3, no traceback
    path = tmp_path / "weightless.toml"
    from linkdyn import save
    save(pendulum(-60.0, gravity=0.0), path)
    res = CliRunner().invoke(main, ["equilibrium", str(path)])
    assert res.exit_code == 3 and "Traceback" not in res.output
    assert "stiffness" in res.output and "singular" in res.output
    # a fully driven mechanism has no free coordinate: exit 2 naming the drivers
    hoeken = tmp_path / "hoeken.toml"
    hoeken.write_text(linkdyn.example_path("hoeken").read_text("utf-8"), "utf-8")
    res = CliRunner().invoke(main, ["modes", str(hoeken)])
    assert res.exit_code == 2 and "no free degree of freedom" in res.output


def test_the_example_in_the_docs_is_what_the_command_prints(tmp_path):
    from pathlib import Path
    doc = (Path(__file__).resolve().parents[1] / "docs" / "cli.md").read_text("utf-8")
    block = doc.split("$ linkdyn modes toggle.toml\n", 1)[1].split("```", 1)[0].strip()
    path = tmp_path / "toggle.toml"
    res = CliRunner().invoke(main, ["example", "toggle_spring"])
    path.write_text(res.output, "utf-8")
    out = CliRunner().invoke(main, ["modes", str(path)])
    assert out.exit_code == 0
    # the residual is rounding: its digits are not the docs' to hold
    def steady(text):
        return [ln for ln in text.strip().splitlines() if "residual" not in ln]
    assert steady(out.output) == steady(block)


# --- the set-up once: Linearization -------------------------------------------------------

def with_spring(m: linkdyn.Model, k: float) -> linkdyn.Model:
    from dataclasses import replace
    return replace(m, loads=tuple(replace(ld, stiffness=k) if ld.kind == "spring" else ld
                                  for ld in m.loads))


def test_a_spring_sweep_on_one_set_up_is_each_models_own_equilibrium():
    from linkdyn.modal import Linearization
    base = linkdyn.load(linkdyn.example_path("toggle_spring"))
    ks = [15e3, 18e3, 20e3, 24e3, 30e3]       # N/m
    lin = Linearization(base)
    steps_once, steps_fresh = 0, 0
    for k in ks:
        m = with_spring(base, k)
        once, fresh = lin.equilibrium(m), equilibrium(m)
        steps_once += once.iterations
        steps_fresh += fresh.iterations
        assert once.model is m and once.free == fresh.free
        assert once.q == pytest.approx(fresh.q, abs=1e-12)
        assert np.max(np.abs(once.residual)) < 1e-9
        for a, b in ((once.stiffness, fresh.stiffness), (once.mass, fresh.mass)):
            assert a == pytest.approx(b, rel=1e-8)
        assert modes(once).frequencies == pytest.approx(modes(fresh).frequencies, rel=1e-8)
    # each solve starts from the last equilibrium: a continuation along the sweep
    assert steps_once < steps_fresh
    # the set-up's own model again, and the linearization at its start (no Newton step)
    assert lin.equilibrium(base).q == pytest.approx(equilibrium(base).q, abs=1e-12)
    at = lin.equilibrium(search=False)
    assert at.iterations == 0 and np.max(np.abs(at.residual)) < 1e-9


def test_a_linearization_is_for_one_mechanism():
    from linkdyn.errors import ModelError
    from linkdyn.modal import Linearization
    lin = Linearization(pendulum(-60.0))
    assert lin.free == ("J1",)
    assert lin.modes().frequencies[0] == pytest.approx(
        math.sqrt(2.0 * G * 0.3 / (0.05 + 2.0 * 0.3 ** 2)) / (2 * math.pi), rel=1e-10)
    with pytest.raises(ModelError) as err:
        lin.equilibrium(linkdyn.load(linkdyn.example_path("toggle_spring")))
    assert err.value.field == "model"
