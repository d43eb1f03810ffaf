"""The distance constraint (a massless rod between two points): Hoeken with its rocker a rod
moves, drives and loads exactly as Hoeken with a massless rocker body on two pins (a different
joint kind, a different loop and cut), its rod force is that rocker's pin force, and both
backends agree. (The dense reference, the simultaneous Newton-Euler solve, power balance and
the body balances run on it in ``tests/test_dynamics.py``: ``hoeken-rod``.)"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main

from test_dynamics import hoeken, hoeken_rod, massless, times


def test_a_rod_is_a_massless_rocker_on_two_pins():
    rod = hoeken_rod()
    pins = massless(hoeken(True), ("rocker",))
    # the rocker's own load goes with its inertia: the rod has neither
    pins = dataclasses.replace(pins, loads=tuple(x for x in pins.loads if x.body != "rocker"))
    t = times(rod, 37)
    a, b = linkdyn.analyze(rod, t), linkdyn.analyze(pins, t)
    scale = np.max(np.abs(b.effort("J1")))
    assert np.max(np.abs(a.effort("J1") - b.effort("J1"))) <= 1e-9 * scale
    assert a.phi("coupler") == pytest.approx(b.phi("coupler"), abs=1e-12)
    # the rod's force on the coupler through O3 is minus the coupler's on the rocker at J3
    f_rod = np.stack([a.columns["Fx_R"], a.columns["Fy_R"]])
    f_j3 = np.stack([b.columns["Fx_J3"], b.columns["Fy_J3"]])
    assert np.max(np.abs(f_rod + f_j3)) <= 1e-9 * np.max(np.abs(f_j3))
    # its coordinate is the rod's length, held
    assert np.max(np.abs(a.columns["q_R"] - 0.1152)) <= 1e-12


def test_both_backends_run_the_rod():
    pytest.importorskip("numba", reason="the compiled backend needs numba (the fast extra)")
    rod = hoeken_rod()
    t = times(rod, 19)
    a = linkdyn.analyze(rod, t, backend="numpy")
    b = linkdyn.analyze(rod, t, backend="compiled")
    for name in ("tau_J1", "Fx_R", "Fy_R", "Fx_J2", "phi_coupler"):
        x, y = np.asarray(a.columns[name]), np.asarray(b.columns[name])
        assert np.max(np.abs(x - y)) <= 1e-12 * max(np.max(np.abs(x)), 1.0), name


def test_a_rod_without_a_length_is_refused(tmp_path):
    text = linkdyn.example_path("hoeken").read_text("utf-8")
    start = text.index('name = "J4"')
    block = text[start:text.index("[[", start)]
    text = text.replace(block, 'name = "J4"\ntype = "distance"\nconnect = ["rocker.O4", '
                               '"ground.O4"]\n\n')
    path = tmp_path / "rod.toml"
    path.write_text(text, "utf-8")
    res = CliRunner().invoke(main, ["check", str(path)])
    assert res.exit_code == 2 and "length > 0" in res.output and "joints.J4" in res.output
