"""Free bodies (``free = "P"`` on a body joined to nothing but loads): a tumbling plate flies
as the closed form says, and a bar hanging from two springs (Exudyn's floating frame, without
its light carriages) sags and vibrates at its closed-form equilibrium and frequencies.

Closed forms: a free body under gravity alone turns at a constant rate and its mass centre
follows the parabola ``c(t) = c0 + v0 t + g t^2 / 2``. A bar of mass m and inertia I (about
its middle) hanging by two vertical springs (k, free length l0) at +-a from its middle, under
gravity: each spring carries ``T = m g / 2`` at the length ``L = l0 + T / k``; about that
equilibrium the three small motions decouple (the springs' lengths change to first order
only with the vertical and pitch motions, their tension resists the sideways one as a pendulum
of length L): ``w_x^2 = g / L``, ``w_y^2 = 2 k / m``, ``w_phi^2 = 2 k a^2 / I``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main
from linkdyn.io.writer import model_to_dict
from linkdyn.modal import equilibrium, modes

G = 9.81


def plate(extra: str = "", free: str = '"C"') -> str:
    """A 2 kg plate, free at its point C, its mass centre off C, thrown and spinning."""
    return f"""
[mechanism]
name = "free plate"
gravity = [0.0, {-G}]
[[bodies]]
name = "ground"
points = {{ O = [0.0, 0.0] }}
[[bodies]]
name = "plate"
points = {{ C = [0.0, 0.0], A = [0.3, 0.1] }}
mass = 2.0
com = [0.1, 0.05]
inertia = 0.05
free = {free}
{extra}
[initial]
q = {{ plate_x = 0.1, plate_y = 0.2, plate_phi = 0.3 }}
qd = {{ plate_x = 1.0, plate_y = 2.0, plate_phi = 3.0 }}
"""


def test_a_free_plate_flies_and_spins_as_the_closed_form_says():
    model = linkdyn.model_from_dict(__import__("tomllib").loads(plate()))
    t = np.linspace(0.0, 0.5, 6)
    cols = linkdyn.simulate(model, t, rtol=1e-11, atol=1e-12).columns
    phi0, w, c = 0.3, 3.0, np.array([0.1, 0.05])

    def rot(a):
        return np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])

    # the mass centre's start and velocity from C's, v_c = v_C + w k x (R c)
    rc0 = rot(phi0) @ c
    c0 = np.array([0.1, 0.2]) + rc0
    v0 = np.array([1.0, 2.0]) + w * np.array([-rc0[1], rc0[0]])
    phi = phi0 + w * t
    centre = c0[:, None] + v0[:, None] * t + 0.5 * np.array([0.0, -G])[:, None] * t ** 2
    C = centre - np.einsum("ijk,j->ik", rot(phi), c)            # C = c - R(phi) c_local
    assert np.abs(cols["q_plate_phi"] - phi).max() < 1e-8
    assert np.abs(cols["q_plate_x"] - C[0]).max() < 1e-8
    assert np.abs(cols["q_plate_y"] - C[1]).max() < 1e-8


M, I, A, K, L0, H = 3.0, 0.4, 0.25, 600.0, 0.5, 1.2


def hanging_bar() -> linkdyn.Model:
    """The bar, free at its middle M, hanging from ground points (+-a, H) by two springs."""
    return linkdyn.model_from_dict(__import__("tomllib").loads(f"""
[mechanism]
name = "bar on two springs"
gravity = [0.0, {-G}]
[[bodies]]
name = "ground"
points = {{ L = [{-A}, {H}], R = [{A}, {H}] }}
[[bodies]]
name = "bar"
points = {{ M = [0.0, 0.0], L = [{-A}, 0.0], R = [{A}, 0.0] }}
mass = {M}
inertia = {I}
free = "M"
[[loads]]
kind = "spring"
name = "left"
body = "ground"
point = "L"
body2 = "bar"
point2 = "L"
stiffness = {K}
free_length = {L0}
[[loads]]
kind = "spring"
name = "right"
body = "ground"
point = "R"
body2 = "bar"
point2 = "R"
stiffness = {K}
free_length = {L0}
[initial]
q = {{ bar_x = 0.02, bar_y = {H - L0 - 0.1}, bar_phi = 0.05 }}
"""))


def test_a_bar_on_two_springs_hangs_and_vibrates_as_the_closed_form_says():
    eq = equilibrium(hanging_bar())
    assert eq.free == ("bar_x", "bar_y", "bar_phi")
    length = L0 + M * G / (2 * K)                           # k (L - l0) = m g / 2
    assert eq.q == pytest.approx([0.0, H - length, 0.0], abs=1e-12)
    assert eq.mass == pytest.approx(np.diag([M, M, I]), abs=1e-12)
    md = modes(eq)
    assert md.stable
    w = np.sqrt([G / length, 2 * K / M, 2 * K * A ** 2 / I])
    assert np.sort(md.frequencies) == pytest.approx(np.sort(w) / (2 * math.pi), rel=1e-9)


def test_the_written_model_holds_the_carriages_and_reads_back_the_same():
    model = hanging_bar()
    again = linkdyn.model_from_dict(model_to_dict(model))
    assert [b.name for b in again.bodies] == [b.name for b in model.bodies]
    assert equilibrium(again).q == pytest.approx(equilibrium(model).q, abs=1e-14)


@pytest.mark.parametrize("free, extra, words", [
    ('"Z"', "", ["bodies.plate.free", "'Z'"]),
    ("1", "", ["bodies.plate.free", "point"]),
    ('"C"', '[[bodies]]\nname = "plate_x"\npoints = { O = [0, 0] }\nmass = 1\ninertia = 1',
     ["bodies.plate.free", "plate_x"]),
])
def test_a_bad_free_is_refused_naming_the_field(free, extra, words, tmp_path):
    file = tmp_path / "m.toml"
    file.write_text(plate(extra, free))
    res = CliRunner().invoke(main, ["check", str(file)])
    assert res.exit_code == 2 and "Traceback" not in res.output, res.output
    for w in words + ["m.toml"]:
        assert w in res.output, res.output


# ------------------------------------------------------------------ spatial free bodies

def spatial_m_a(model, csv, body, k):
    """m a_G (3,) of a spatial ``body`` at sample k from results.csv's columns alone (no
    reaction read): a named point P's acceleration, the body's quaternion, omega and alpha,
    and the model's mass centre c and P (body frame): ``a_G = a_P + alpha x d + omega x
    (omega x d)``, ``d = R (c - p)``."""
    b = model.body(body)
    pname = next(iter(b.points))
    w, x, y, z = (csv[f"quat_{c}_{body}"][k] for c in "wxyz")
    R = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                  [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                  [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
    d = R @ (np.asarray(b.com, float) - np.asarray(b.points[pname], float))
    om = np.array([csv[f"omega_{c}_{body}"][k] for c in "xyz"])
    al = np.array([csv[f"alpha_{c}_{body}"][k] for c in "xyz"])
    a = np.array([csv[f"a{c}_{body}.{pname}"][k] for c in "xyz"])
    return b.mass * (a + np.cross(al, d) + np.cross(om, np.cross(om, d)))


@pytest.mark.parametrize("example", ["spatial_slider_crank", "rsur", "stewart"])
def test_a_spatial_links_forces_are_results_csv_and_balance_its_inertia_force(example):
    # design.free_body of a spatial solution: each joint's force is results.csv's reaction,
    # signed (+ on the joint's second body, - on its first), the weight m g; and the forces
    # with the inertia force -m a_G, a_G from the csv's kinematics (quaternion, omega, alpha,
    # a point's acceleration), sum to zero: Newton's law, which nothing in the solution's
    # reactions is made to satisfy by this test
    from linkdyn import design
    from linkdyn.sampling import times
    model = linkdyn.load(linkdyn.example_path(example))
    sol = linkdyn.analyze(model, times(model, None, None, None))
    csv = {c: np.asarray(v, float) for c, v in sol.columns().items()}
    checked = 0
    for b in model.moving_bodies:
        forces, m_a = design.free_body(sol, b.name)
        by = {f.label: f for f in forces}
        scale = max(np.max(np.abs(f.force)) for f in forces)
        assert by["weight"].force[0] == pytest.approx(b.mass * np.asarray(model.gravity),
                                                      abs=1e-12 * scale)
        for j in model.joints:
            if b.name in (j.body_a, j.body_b) and j.name in by:
                sign = 1.0 if j.body_b == b.name else -1.0
                want = sign * np.stack([csv[f"F{c}_{j.name}"] for c in "xyz"], 1)
                np.testing.assert_allclose(by[j.name].force, want, rtol=0, atol=1e-12 * scale)
                checked += 1
        for k in range(0, len(sol.t), 5):
            inertia = -spatial_m_a(model, csv, b.name, k)
            np.testing.assert_allclose(sum(f.force[k] for f in forces) + inertia, 0.0, rtol=0,
                                       atol=1e-9 * scale, err_msg=f"{b.name} {k}")
            np.testing.assert_allclose(m_a[k], -inertia, rtol=0, atol=1e-9 * scale)
    assert checked >= 2 * len(model.joints) - sum(
        1 for j in model.joints if "ground" in (j.body_a, j.body_b))
