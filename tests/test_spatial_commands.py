"""Command-line options on spatial models that once exited with "not yet for spatial models"
(issue 24): ``--units model`` of ``analyze`` and ``simulate``, checked against the SI table
of the same run written by the same command."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main


def table(path):
    names = path.read_text().splitlines()[0].split(",")
    return dict(zip(names, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2).T))


#: Each unit of a mm, deg file in SI, written out here
SIZE = {"s": 1.0, "1": 1.0, "N": 1.0, "N m": 1.0, "J": 1.0, "mm": 1e-3, "mm/s": 1e-3,
        "mm/s^2": 1e-3, "deg": math.pi / 180, "deg/s": math.pi / 180,
        "deg/s^2": math.pi / 180}


def both(tmp_path, args):
    """The SI table and the --units model table of one command."""
    out = {}
    for units in ("si", "model"):
        res = CliRunner().invoke(main, [*args, "-o", str(tmp_path / units), "--units", units])
        assert res.exit_code == 0, res.output
        out[units] = table(tmp_path / units / "results.csv")
    return out["si"], out["model"]


def check_scaled(si, model):
    """Every model-units column is its SI column over its unit's size, in the same order."""
    assert len(si) == len(model)
    for (name, v), (head, w) in zip(si.items(), model.items()):
        base, unit = head[:-1].split(" [")
        assert base == name
        np.testing.assert_allclose(w * SIZE[unit], v, rtol=1e-14, atol=0, err_msg=head)


def test_analyze_units_model_writes_the_files_units(tmp_path):
    path = linkdyn.example_path("spatial_slider_crank")         # a mm, deg file
    si, model = both(tmp_path, ["analyze", str(path), "--samples", "7"])
    check_scaled(si, model)
    # each quantity in its unit: angles deg, the slider's travel mm, forces N
    for head in ("q_J1 [deg]", "qd_J1 [deg/s]", "q_J3.1 [deg]", "q_J4 [mm]", "qd_J4 [mm/s]",
                 "omega_x_crank [deg/s]", "alpha_z_crank [deg/s^2]", "quat_w_crank [1]",
                 "x_crank.B [mm]", "vz_crank.B [mm/s]", "ax_crank.B [mm/s^2]", "tau_J1 [N m]",
                 "Fx_J2 [N]", "Mx_J1 [N m]", "kinetic_energy [J]", "t [s]"):
        assert head in model, head


def test_simulate_units_model_writes_the_files_units(tmp_path):
    path = linkdyn.example_path("rsur_release")
    si, model = both(tmp_path, ["simulate", str(path), "--samples", "3", "--duration", "0.02"])
    check_scaled(si, model)
    assert "work [J]" in model and "q_J1 [deg]" in model
    # the free crank starts at [initial] q = 20 deg
    assert model["q_J1 [deg]"][0] == pytest.approx(20.0, abs=1e-9)
