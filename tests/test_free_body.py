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
