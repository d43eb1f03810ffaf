"""Static equilibrium and small vibrations of spatial models (``linkdyn equilibrium`` and
``linkdyn modes`` on ``space = "spatial"``, issues 24 and 27) against references that share no
code with the solver:

- a pendulum on a universal joint: a point mass (``sqrt(g / L)``) and a rigid body
  (``w^2 = m g d / I_O`` about each axis), closed forms;
- planar examples written as spatial models (all axes +z): the planar equilibrium and
  frequencies;
- finite differences of ``simulate``'s free accelerations from small perturbations of the
  equilibrium: ``d qdd_f / d q_f = -H^-1 K``, whose eigenvalues are the modes' ``s^2`` (an
  off-centre body on a universal joint, two coupled modes; the released RSUR four-bar, a
  closed spatial loop);
- the command line: the file's units, JSON, exit 2 and 3.
"""

from __future__ import annotations

import json
import math
import tomllib
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main
from linkdyn.io import model_from_dict
from linkdyn.modal import equilibrium, modes
from test_spatial import spatial_of_planar

G = 9.81


def pendulum(mass=2.0, com=(0.0, 0.0, -0.4), inertia="[0.01, 0.03, 0.02]", gravity=-G,
             start=(0.3, -0.2)) -> linkdyn.Model:
    """A body hung from the ground's origin by a universal joint (axes x, then y), its frame
    the ground's at the design pose."""
    return model_from_dict(tomllib.loads(f"""
[mechanism]
name = "universal pendulum"
space = "spatial"
gravity = [0.0, 0.0, {gravity}]
[[bodies]]
name = "ground"
points = {{ O = [0.0, 0.0, 0.0] }}
[[bodies]]
name = "bob"
points = {{ O = [0.0, 0.0, 0.0] }}
mass = {mass}
com = [{com[0]}, {com[1]}, {com[2]}]
inertia = {inertia}
[[joints]]
name = "J1"
type = "universal"
connect = ["ground.O", "bob.O"]
axis = [1.0, 0.0, 0.0]
axis2 = [0.0, 1.0, 0.0]
[initial]
q = {{ "J1.1" = {start[0]}, "J1.2" = {start[1]} }}
"""))


def test_a_point_mass_on_a_universal_joint_swings_at_sqrt_g_over_l():
    L = 0.5
    eq = equilibrium(pendulum(com=(0.0, 0.0, -L), inertia="[0.0, 0.0, 0.0]"))
    assert eq.free == ("J1.1", "J1.2") and eq.iterations > 0
    assert np.max(np.abs(eq.q)) < 1e-12
    md = modes(eq)
    assert md.stable
    f = math.sqrt(G / L) / (2 * math.pi)
    assert md.frequencies == pytest.approx([f, f], rel=1e-10)
    assert np.all(md.damping_ratios == 0.0)


def test_a_rigid_body_on_a_universal_joint_has_m_g_d_over_i_about_each_axis():
    m, d, Ixx, Iyy = 2.0, 0.4, 0.01, 0.03
    eq = equilibrium(pendulum(mass=m, com=(0.0, 0.0, -d), inertia=f"[{Ixx}, {Iyy}, 0.02]"))
    assert np.max(np.abs(eq.q)) < 1e-12
    # H = diag(I_O) about the two axes, K = m g d on each
    assert eq.mass == pytest.approx(np.diag([Ixx + m * d * d, Iyy + m * d * d]), abs=1e-12)
    assert eq.stiffness == pytest.approx(np.diag([m * G * d] * 2), rel=1e-10, abs=1e-9)
    md = modes(eq)
    w = sorted(math.sqrt(m * G * d / (I + m * d * d)) for I in (Ixx, Iyy))
    assert md.frequencies == pytest.approx(np.array(w) / (2 * math.pi), rel=1e-10)
    # the slower mode swings about y (J1.2) alone, the faster about x (J1.1)
    assert md.shapes[:, 0] == pytest.approx([0.0, 1.0], abs=1e-9)
    assert md.shapes[:, 1] == pytest.approx([1.0, 0.0], abs=1e-9)


def test_upside_down_it_is_unstable_and_without_gravity_nothing_holds_it():
    eq = equilibrium(pendulum(gravity=G, start=(0.2, 0.1)))
    assert np.max(np.abs(eq.q)) < 1e-12 and not eq.stable
    with pytest.raises(linkdyn.errors.AssemblyError, match="singular"):
        equilibrium(pendulum(gravity=0.0))


def free_accelerations(model, names, q):
    """``simulate``'s free accelerations (nf,) at rest at the free coordinates ``q``."""
    sol = linkdyn.simulate(replace(model, initial_q=dict(zip(names, map(float, q))),
                                   initial_qd={}), np.zeros(1), backend="numpy")
    cols = sol.columns()
    return np.array([cols[f"qdd_{c}"][0] for c in names])


def simulated_stiffness(model, eq, e=1e-5):
    """``d qdd_f / d q_f`` (nf, nf) about the equilibrium by central differences of
    ``simulate``'s free accelerations (fourth order)."""
    nf = len(eq.q)
    out = np.empty((nf, nf))
    for j in range(nf):
        a = [free_accelerations(model, eq.free, eq.q + s * e * np.eye(nf)[j])
             for s in (1, -1, 2, -2)]
        out[:, j] = (8 * (a[0] - a[1]) - (a[2] - a[3])) / (12 * e)
    return out


def test_coupled_modes_are_those_of_simulate_perturbed_about_the_equilibrium():
    # an off-centre body with products of inertia: the equilibrium is tilted, the modes mix
    # both axes
    model = pendulum(com=(0.08, -0.05, -0.4),
                     inertia="[[0.02, 0.002, -0.001], [0.002, 0.03, 0.001], [-0.001, 0.001, 0.015]]")
    eq = equilibrium(model)
    assert np.max(np.abs(eq.q)) > 0.1            # hangs tilted
    assert np.max(np.abs(eq.residual)) < 1e-12
    md = modes(eq)
    A = simulated_stiffness(model, eq)            # -H^-1 K, from simulate alone
    assert A == pytest.approx(-np.linalg.solve(eq.mass, eq.stiffness), rel=1e-7, abs=1e-7)
    w2 = np.sort(-np.linalg.eigvals(A).real)
    assert (2 * math.pi * md.frequencies) ** 2 == pytest.approx(w2, rel=1e-7)
    # each shape is an eigenvector of simulate's -H^-1 K: A v = -w^2 v
    for k in range(2):
        v, w = md.shapes[:, k], 2 * math.pi * md.frequencies[k]
        assert A @ v == pytest.approx(-w * w * v, rel=1e-6, abs=1e-6 * w * w)
    assert np.max(np.abs(md.shapes[:, 0] * md.shapes[:, 1])) > 0.05   # they do mix


def test_the_released_rsur_four_bar_has_simulates_growth_rate():
    # a closed spatial loop: gravity holds the RSUR four-bar at an unstable equilibrium
    model = linkdyn.load(linkdyn.example_path("rsur_release"))
    eq = equilibrium(model)
    assert eq.free == ("J1",) and np.max(np.abs(eq.residual)) < 1e-12
    md = modes(eq)
    assert not md.stable
    s = float(np.max(np.real(md.eigenvalues)))
    assert s > 0
    assert simulated_stiffness(model, eq)[0, 0] == pytest.approx(s * s, rel=1e-7)
    # and it is in equilibrium: released there at rest, it does not accelerate
    a0 = free_accelerations(model, eq.free, eq.q)
    assert abs(a0[0]) < 1e-9 * s * s


@pytest.mark.parametrize("damper", [True, False])
def test_a_planar_example_written_as_spatial_gives_the_planar_modes(damper):
    planar = linkdyn.load(linkdyn.example_path("toggle_spring"))
    if not damper:
        planar = replace(planar, loads=tuple(ld for ld in planar.loads if ld.name != "damper"))
    start = linkdyn.simulate(planar, np.zeros(1), backend="numpy").columns
    data, _ = spatial_of_planar("simulate/toggle_spring", start)
    data["initial"] = {"q": {"J1": 0.0}}          # rotations count from the design pose
    if not damper:
        data["loads"] = [ld for ld in data["loads"] if ld["name"] != "damper"]
    flat, space = modes(equilibrium(planar)), modes(equilibrium(model_from_dict(data)))
    q0 = float(start["q_J1"][0])
    assert space.equilibrium.q[0] + q0 == pytest.approx(flat.equilibrium.q[0], abs=1e-10)
    assert space.frequencies == pytest.approx(flat.frequencies, rel=1e-10)
    assert space.damping_ratios == pytest.approx(flat.damping_ratios, abs=1e-10)
    assert space.equilibrium.tree_joints == flat.equilibrium.tree_joints
    assert space.joint_shapes == pytest.approx(flat.joint_shapes, rel=1e-8, abs=1e-10)
    assert space.stable == flat.stable
    if not damper:
        assert list(space.oscillating) == [0] and space.damping_ratios[0] == 0.0


# --- the command line ----------------------------------------------------------------------

def test_the_commands_take_a_spatial_model(tmp_path):
    path = tmp_path / "rsur.toml"
    path.write_text(linkdyn.example_path("rsur_release").read_text("utf-8"), "utf-8")
    eq = equilibrium(linkdyn.load(path))
    md = modes(eq)
    res = CliRunner().invoke(main, ["modes", str(path)])
    assert res.exit_code == 0, res.output
    # the file's units: the crank in degrees, the universal joint's two angles too
    assert f"J1 = {math.degrees(eq.q[0]):.6g} deg  (free)" in res.output
    assert f"J3.1 = {math.degrees(eq.joint_q['J3.1']):.6g} deg" in res.output
    assert "UNSTABLE" in res.output and f"{md.frequencies[0]:.6g} Hz" in res.output
    js = CliRunner().invoke(main, ["equilibrium", str(path), "--json"])
    assert js.exit_code == 0, js.output
    data = json.loads(js.output)
    assert data["q"]["J1"] == pytest.approx(eq.q[0], abs=1e-12)
    assert set(data["joint_q"]) == {"J1", "J4", "J3.1", "J3.2"}


def toggle_in_space(damper: bool = False) -> tuple[dict, float]:
    """The bundled toggle written as a spatial model (its design pose the planar start) and
    the planar crank angle there (rad)."""
    planar = linkdyn.load(linkdyn.example_path("toggle_spring"))
    start = linkdyn.simulate(planar, np.zeros(1), backend="numpy").columns
    data, _ = spatial_of_planar("simulate/toggle_spring", start)
    data["initial"] = {"q": {"J1": 0.0}}
    if not damper:
        data["loads"] = [ld for ld in data["loads"] if ld["name"] != "damper"]
    return data, float(start["q_J1"][0])


def test_moving_a_spatial_model_in_its_mode_needs_no_effort_to_first_order(tmp_path):
    from linkdyn.io.writer import dumps_toml
    from linkdyn.modal import mode_motion
    data, _ = toggle_in_space()
    eq = equilibrium(model_from_dict(data))
    md = modes(eq)
    K = float(eq.stiffness[0, 0])

    def relative_effort(m, swing):
        """The free joint's peak effort along the motion, per the swing's stiffness effort."""
        moving = mode_motion(m, 0, swing=swing)
        sol = linkdyn.analyze(moving, np.linspace(0.0, moving.duration, 61))
        assert np.ptp(sol.columns()["q_J1"]) == pytest.approx(2 * swing, rel=1e-3)
        return float(np.max(np.abs(sol.columns()["tau_J1"]))) / (K * swing)
    # in the mode: the effort is second order in the swing (halving it halves the ratio)
    big, small = relative_effort(md, 0.02), relative_effort(md, 0.01)
    assert small < 0.6 * big and small < 0.02
    # the same shape 10 % too fast needs the stiffness effort's order, whatever the swing
    off = replace(md, frequencies=md.frequencies * 1.1)
    assert relative_effort(off, 0.01) > 0.1
    # the command writes the mode's spatial page
    path = tmp_path / "toggle.toml"
    path.write_text(dumps_toml(data), "utf-8")
    res = CliRunner().invoke(main, ["modes", str(path), "--report", "-o", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    page = (tmp_path / "o" / "mode1.html").read_text("utf-8")
    assert '"dim":3' in page and "mode 1 at" in page


def test_a_mode_of_a_universal_joints_coordinates_moves_as_its_closed_form(tmp_path):
    """``modes --report`` where the free coordinates are a universal joint's two rotations
    (``J1.1``, ``J1.2``): each mode's motion drives those coordinates by name. The body hung
    by the joint swings about one axis at a time, a compound pendulum: the coordinate follows
    ``a sin(w t)`` and the effort that moves it so is the closed form
    ``I_O theta'' + m g d sin(theta) = m g d (sin(theta) - theta)`` (``w^2 = m g d / I_O``),
    third order in the swing; the other coordinate stays at 0 and needs no effort."""
    from linkdyn.modal import MODE_SWING, mode_motion

    m, d, Ixx, Iyy = 2.0, 0.4, 0.01, 0.03
    model = pendulum(mass=m, com=(0.0, 0.0, -d), inertia=f"[{Ixx}, {Iyy}, 0.02]")
    md = modes(equilibrium(model))
    for k, (coord, other, I) in enumerate((("J1.2", "J1.1", Iyy), ("J1.1", "J1.2", Ixx))):
        w = 2 * math.pi * float(md.frequencies[k])
        assert w == pytest.approx(math.sqrt(m * G * d / (I + m * d * d)), rel=1e-10)
        moving = mode_motion(md, k)
        t = np.linspace(0.0, moving.duration, 61)
        cols = linkdyn.analyze(moving, t).columns()
        theta = MODE_SWING * np.sin(w * t)
        np.testing.assert_allclose(cols[f"q_{coord}"], theta, rtol=0, atol=1e-13)
        np.testing.assert_allclose(cols[f"q_{other}"], 0.0, rtol=0, atol=1e-13)
        tau = m * G * d * (np.sin(theta) - theta)
        np.testing.assert_allclose(cols[f"tau_{coord}"], tau, rtol=0,
                                   atol=1e-9 * np.max(np.abs(tau)))
        np.testing.assert_allclose(cols[f"tau_{other}"], 0.0, rtol=0,
                                   atol=1e-9 * np.max(np.abs(tau)))
    # the command writes both modes' pages
    path = tmp_path / "pendulum.toml"
    linkdyn.save(model, path)
    res = CliRunner().invoke(main, ["modes", str(path), "--report", "-o", str(tmp_path / "o")])
    assert res.exit_code == 0, res.output
    for k in (1, 2):
        page = (tmp_path / "o" / f"mode{k}.html").read_text("utf-8")
        assert '"dim":3' in page and f"mode {k} at" in page
    # a driver naming no joint coordinate: exit 2 naming the field
    from linkdyn.model import Driver
    from linkdyn.motion import ExpressionMotion
    with pytest.raises(linkdyn.errors.ModelError, match="J1.3"):
        linkdyn.analyze(replace(model, drivers=(Driver("J1.3", ExpressionMotion("0.1")),)),
                        np.zeros(1))


def test_what_the_commands_refuse_on_a_spatial_model(tmp_path):
    path = tmp_path / "pendulum.toml"
    linkdyn.save(pendulum(), path)
    assert linkdyn.load(path).initial_q == pytest.approx({"J1.1": 0.3, "J1.2": -0.2})
    # a fully driven spatial mechanism has no free coordinate
    rsur = tmp_path / "rsur.toml"
    rsur.write_text(linkdyn.example_path("rsur").read_text("utf-8"), "utf-8")
    res = CliRunner().invoke(main, ["equilibrium", str(rsur)])
    assert res.exit_code == 2 and "no free degree of freedom" in res.output
    # nothing holds it without gravity: exit 3, no traceback
    weightless = tmp_path / "weightless.toml"
    linkdyn.save(pendulum(gravity=0.0), weightless)
    res = CliRunner().invoke(main, ["equilibrium", str(weightless)])
    assert res.exit_code == 3 and "Traceback" not in res.output and "singular" in res.output


def test_the_spatial_example_in_the_docs_is_what_the_command_prints(tmp_path):
    from pathlib import Path
    doc = (Path(__file__).resolve().parents[1] / "docs" / "cli.md").read_text("utf-8")
    block = doc.split("$ linkdyn modes rsur.toml\n", 1)[1].split("```", 1)[0].strip()
    path = tmp_path / "rsur.toml"
    path.write_text(CliRunner().invoke(main, ["example", "rsur_release"]).output, "utf-8")
    out = CliRunner().invoke(main, ["modes", str(path)])
    assert out.exit_code == 0, out.output

    def steady(text):   # the residual is rounding: its digits are not the docs' to hold
        return [ln for ln in text.strip().splitlines() if "residual" not in ln]
    assert steady(out.output) == steady(block)


def test_a_spring_sweep_of_a_spatial_model_on_one_set_up():
    from linkdyn.modal import Linearization
    planar = linkdyn.load(linkdyn.example_path("toggle_spring"))
    start = linkdyn.simulate(planar, np.zeros(1), backend="numpy").columns
    data, _ = spatial_of_planar("simulate/toggle_spring", start)
    data["initial"] = {"q": {"J1": 0.0}}
    base = model_from_dict(data)
    lin = Linearization(base)
    for k in (16e3, 20e3, 26e3):            # N/m
        space = replace(base, loads=tuple(replace(ld, stiffness=k) if ld.kind == "spring"
                                          else ld for ld in base.loads))
        flat = replace(planar, loads=tuple(replace(ld, stiffness=k) if ld.kind == "spring"
                                           else ld for ld in planar.loads))
        once, own = lin.modes(space), modes(equilibrium(flat))
        assert once.equilibrium.q[0] + float(start["q_J1"][0]) == pytest.approx(
            own.equilibrium.q[0], abs=1e-10)
        assert once.frequencies == pytest.approx(own.frequencies, rel=1e-9)
