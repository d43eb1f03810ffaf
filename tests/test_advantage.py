"""A four-bar's mechanical advantage |w_in / w_out| where a link stops: infinite at a rocker's
limit positions, zero where the input stops, said as such (summary, printout, report) rather
than the sampled extreme, which is only a number of the sampling. Located between samples and
checked against the closed forms of the limit positions (crank and coupler in line) and of a
swinging driver's reversals."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn import design, report
from linkdyn.cli import main

HOEKEN = linkdyn.example_path("hoeken")
A, B, C, D = 38.1, 115.2, 115.2, 89.5   # Hoeken's crank, coupler, rocker, frame (mm)


def limit_positions_deg() -> list[float]:
    """Crank angles (deg, from the frame line O1->O4, the rocker's assembly above it) where
    crank and coupler are in line: extended (O1 B = a + b) and folded (O1 B = b - a, the crank
    pointing away from B), by the cosine law in the triangle O1 B O4."""
    ext = math.degrees(math.acos((D * D + (A + B) ** 2 - C * C) / (2 * D * (A + B))))
    fold = math.degrees(math.acos((D * D + (B - A) ** 2 - C * C) / (2 * D * (B - A))))
    return [ext, 180.0 + fold]


@pytest.fixture(scope="module")
def turn():
    model = linkdyn.load(HOEKEN)
    sol = linkdyn.analyze(model, np.linspace(0.0, 4.0 / 3.0, 73), backend="numpy")  # 5 deg
    return sol, design.four_bars(model)[0]


def test_the_output_stops_at_the_closed_form_limit_positions(turn):
    sol, fb = turn
    at = design.stops(sol, fb, "output")
    got = sorted(math.degrees(s["q"]) % 360.0 for s in at)
    # linear interpolation of the rocker's speed over 5 deg samples: within 2 % of a step
    assert got == pytest.approx(limit_positions_deg(), abs=0.1)
    # the crank turns at 45 rpm from 0: the stops' times are their angles over its speed
    w = 45.0 * 360.0 / 60.0
    assert sorted(s["t"] for s in at) == pytest.approx([g / w for g in got], abs=1e-9)
    assert design.stops(sol, fb, "input") == []     # the crank never stops


def test_the_summary_says_infinite_where_the_output_stops_at_any_sampling(turn):
    sol, fb = turn
    fine = linkdyn.analyze(sol.model, np.linspace(0.0, 4.0 / 3.0, 361), backend="numpy")
    for s in (sol, fine):
        ma = design.summary(s)["four_bars"][0]["mechanical_advantage"]
        assert math.isnan(ma["max"])   # null in summary.json, not 1251 at 361 samples
        w = 45.0 * 360.0 / 60.0
        assert sorted(ma["infinite_at_s"]) == pytest.approx(
            [x / w for x in limit_positions_deg()], abs=0.1 / w)
        assert "zero_at_s" not in ma and 1.0 < ma["min"] < 2.0


def test_a_driver_that_reverses_stops_the_loop_whole_and_leaves_the_advantage_finite(
        turn, tmp_path):
    # the crank swings 120 +- 60 deg: crank and rocker stop together where dq/dt = 0 (t = 0.25,
    # 0.75 s), so |w_in / w_out| stays the ratio of the position, as in the turning run at the
    # same crank angle; the rocker's limit positions (48.3, 267.2 deg) are outside the swing
    text = HOEKEN.read_text().replace(
        'motion = { kind = "constant_speed", rpm = 45.0, start = 0.0 }',
        'motion = { kind = "expression", q = "120 + 60*sin(2*pi*t)" }').replace(
        "phi = { crank = 0.0,", "phi = { crank = 120.0,").replace("cycles = 1", "duration = 1.0")
    path = tmp_path / "swing.toml"
    path.write_text(text)
    model = linkdyn.load(path)
    sol = linkdyn.analyze(model, np.linspace(0.0, 1.0, 40), backend="numpy")   # 0.25 between
    fb = design.four_bars(model)[0]
    assert design.stops(sol, fb, "input") == design.stops(sol, fb, "output") == []
    ma = design.summary(sol)["four_bars"][0]["mechanical_advantage"]
    assert "zero_at_s" not in ma and "infinite_at_s" not in ma
    # the turning run (45 rpm from 0) solved at the swinging run's crank angles
    q = np.asarray(sol.columns["q_J1"])
    ref_sol, ref_fb = turn
    ref = linkdyn.analyze(ref_sol.model, q / (45.0 * 2.0 * np.pi / 60.0), backend="numpy")
    ma_ref = design.mechanical_advantage(ref, ref_fb)
    assert np.all(np.isfinite(ma_ref))
    assert design.mechanical_advantage(sol, fb) == pytest.approx(ma_ref, rel=1e-9)


def test_a_loop_whose_input_and_output_stop_together_keeps_a_finite_advantage():
    # Watt-II's second loop: its input (the first loop's rocker) and output swing together,
    # so both stop at once (0/0) and the ratio stays finite; the first loop's rocker stops
    model = linkdyn.load(linkdyn.example_path("watt2"))
    sol = linkdyn.analyze(model, np.linspace(0.0, 1.0, 61), backend="numpy")
    first, second = design.four_bars(model)[:2]
    assert design.stops(sol, first, "output") and not design.stops(sol, first, "input")
    assert design.stops(sol, second, "input") == design.stops(sol, second, "output") == []
    assert np.all(np.isfinite(design.mechanical_advantage(sol, second)))


def test_the_printout_and_the_page_say_infinite_where_the_rocker_stops(turn, tmp_path):
    r = CliRunner().invoke(main, ["analyze", str(HOEKEN), "--samples", "73", "-o",
                                  str(tmp_path), "--backend", "numpy"])
    assert r.exit_code == 0, r.output
    line = next(x for x in r.output.splitlines() if "mechanical advantage" in x)
    assert "..infinite (infinite where the output stops, t = " in line
    sol, fb = turn
    items = {it["label"]: it for it in report.page_data(sol)["key"]}
    top = items["max mechanical advantage coupler/rocker"]
    assert top["value"] is None and top["infinite"] is True
    assert report.tables.key_value(top) == "∞"
    where = top["note"].split("where the output stops: J1 = ")[1]
    assert where.endswith(" deg")
    got = [float(x) for x in where.removesuffix(" deg").split(", ")]
    assert got == pytest.approx(limit_positions_deg(), abs=0.1)
    assert math.isfinite(items["min mechanical advantage coupler/rocker"]["value"])

