"""The energy-balance health figure where every power is rounding: "not meaningful" instead of
rounding divided by rounding (a parallelogram turned at constant speed without loads printed
0.0148 "relative"); the same linkage under gravity, whose powers are real, is checked."""

from __future__ import annotations

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn import design
from linkdyn.cli import main
from test_design import four_bar_dict

PHI = {"crank": 0.3, "coupler": 0.0, "rocker": 0.3}


def parallelogram(gravity=(0.0, 0.0)):
    """Crank = rocker = 0.1 m (0.2, 0.3 kg bars), coupler = ground = 0.3 m (0.5 kg), 1 rad/s."""
    return linkdyn.model_from_dict(four_bar_dict(0.1, 0.3, 0.1, 0.3, start=0.3, speed=1.0,
                                                 phi=PHI, gravity=gravity))


def test_a_parallelogram_without_loads_has_no_power_to_balance(tmp_path):
    sol = linkdyn.analyze(parallelogram(), np.linspace(0.0, 2.5, 41), backend="numpy")
    # every power is zero: the kinetic energy is constant, by hand: crank and rocker turn at
    # 1 rad/s about their pivots (m a^2 / 3), the coupler translates at a * w
    ke = 0.5 * (0.2 * 0.1 ** 2 / 3 + 0.3 * 0.1 ** 2 / 3 + 0.5 * 0.1 ** 2)
    np.testing.assert_allclose(sol.columns["kinetic_energy"], ke, rtol=1e-12)
    h = design.health(sol)
    assert h["energy_balance_residual_rel"] is None
    assert h["energy_balance"] == "not meaningful (every power is rounding)"
    path = tmp_path / "p.toml"
    linkdyn.save(parallelogram(), path)
    r = CliRunner().invoke(main, ["analyze", str(path), "--duration", "2.5", "--samples", "41",
                                  "-o", str(tmp_path / "o"), "--backend", "numpy"])
    assert r.exit_code == 0, r.output
    assert "energy balance not meaningful (every power is rounding), worst" in r.output


def test_the_same_linkage_under_gravity_is_checked():
    # gravity does work on crank and rocker: the driver's power is real, and balances
    sol = linkdyn.analyze(parallelogram(gravity=(0.0, -9.81)), np.linspace(0.0, 2.5, 41),
                          backend="numpy")
    h = design.health(sol)
    assert h["energy_balance"] == "checked"
    assert h["energy_balance_residual_rel"] == pytest.approx(0.0, abs=1e-12)
    # the driver's power against gravity's, by hand: the torque lifts the mass centres
    # of crank and rocker (0.05 m from their pivots) and the coupler (at the crank pin)
    th = np.asarray(sol.columns["q_J1"])
    power = 9.81 * (0.2 * 0.05 + 0.3 * 0.05 + 0.5 * 0.1) * np.cos(th) * 1.0
    np.testing.assert_allclose(np.asarray(sol.columns["tau_J1"]) * 1.0, power, rtol=1e-9,
                               atol=1e-12 * np.max(np.abs(power)))
