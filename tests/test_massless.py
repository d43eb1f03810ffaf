"""Massless links and point masses: a massless rod between two pins is a two-force member, a
point mass on a massless arm swings at the simple pendulum's frequency, and forward dynamics
refuses free coordinates that move no mass, naming the bodies. (The dense reference, the
simultaneous Newton-Euler solve, power balance and virtual work run on massless models in
``tests/test_dynamics.py``: ``hoeken-massless-coupler``, ``slider-crank-point-masses``.)"""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main
from linkdyn.modal import modes

from test_dynamics import hoeken, massless, times


def test_a_massless_coupler_is_a_two_force_member():
    model = massless(hoeken(), ("coupler",))
    t = times(model, 37)
    sol = linkdyn.analyze(model, t)
    # the pins' forces on the coupler lie along the line O2 -> O3 and are equal and opposite
    o2 = np.stack([sol.columns["x_coupler.O2"], sol.columns["y_coupler.O2"]])
    o3 = np.stack([sol.columns["x_coupler.O3"], sol.columns["y_coupler.O3"]])
    line = (o3 - o2) / np.linalg.norm(o3 - o2, axis=0)
    f2 = np.stack([sol.columns["Fx_J2"], sol.columns["Fy_J2"]])   # crank on coupler at O2
    f3 = np.stack([sol.columns["Fx_J3"], sol.columns["Fy_J3"]])   # coupler on rocker at O3
    scale = np.max(np.abs(f2))
    assert scale > 1.0          # it carries a real force
    assert np.max(np.abs(line[0] * f2[1] - line[1] * f2[0])) <= 1e-9 * scale
    assert np.max(np.abs(f2 - f3)) <= 1e-9 * scale


POINT_MASS = """
[mechanism]
name = "point mass on a massless arm"
gravity = [0.0, -9.81]
[[bodies]]
name = "ground"
points = {{ O = [0.0, 0.0] }}
[[bodies]]
name = "arm"
points = {{ O = [0.0, 0.0], B = [0.6, 0.0] }}
mass = 0
inertia = 0
[[bodies]]
name = "bob"
points = {{ B = [0.0, 0.0] }}
mass = {bob}
inertia = {inertia}
inertia_about = "B"
[[joints]]
name = "J1"
type = "revolute"
connect = ["ground.O", "arm.O"]
[[joints]]
name = "J2"
type = "revolute"
connect = ["arm.B", "bob.B"]
[[drivers]]
joint = "J2"
motion = {{ kind = "constant_speed", speed = 0.0 }}
[initial]
q = {{ J1 = -1.0 }}
"""


def test_a_point_mass_on_a_massless_arm_swings_as_a_simple_pendulum(tmp_path):
    path = tmp_path / "bob.toml"
    path.write_text(POINT_MASS.format(bob=0.8, inertia=0.0), "utf-8")
    md = modes(linkdyn.load(path))
    # w^2 = g / L: nothing but the point mass at 0.6 m
    assert md.frequencies[0] == pytest.approx(math.sqrt(9.81 / 0.6) / (2 * math.pi), rel=1e-10)
    res = CliRunner().invoke(main, ["simulate", str(path), "--duration", "0.5",
                                    "--samples", "11", "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output


def test_free_coordinates_that_move_no_mass_are_refused_naming_the_bodies(tmp_path):
    path = tmp_path / "nothing.toml"
    path.write_text(POINT_MASS.format(bob=0.0, inertia=0.0), "utf-8")
    for command in (["simulate", str(path), "-o", str(tmp_path / "out"), "--duration", "1"],
                    ["modes", str(path)]):
        res = CliRunner().invoke(main, command)
        assert res.exit_code == 2 and "Traceback" not in res.output, res.output
        assert "move no mass" in res.output and "arm, bob" in res.output
    assert not (tmp_path / "out").exists()
