"""Command-line options on spatial models that once exited with "not yet for spatial models"
(issue 24): ``--units model`` of ``analyze`` and ``simulate``, checked against the SI table
of the same run written by the same command; ``export --to svg|dxf``, the projection on a
named plane, read back by the SVG and DXF readers of test_export and checked against
``analyze``'s results.csv."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main
from test_export import read_dxf, read_svg
from test_report import page_blob


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


# ------------------------------------------------------------------ export --to svg|dxf

AXES = {"xy": (0, 1), "xz": (0, 2), "zy": (2, 1)}


@pytest.mark.parametrize("plane", [None, "xz", "zy"])
def test_a_spatial_drawing_is_its_projection_on_the_plane(plane, tmp_path):
    path = linkdyn.example_path("spatial_slider_crank")         # mm; a guide on the ground
    model = linkdyn.load(path)
    at = 0.01
    res = CliRunner().invoke(main, ["analyze", str(path), "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    runs = table(tmp_path / "out" / "results.csv")
    pose = linkdyn.analyze(model, np.array([at])).columns()
    a, b = (c for c in AXES[plane or "xy"])
    name = plane or "xy"

    def xy(body, point, cols):    # the point in the plane, mm
        return np.array([cols[f"{'xyz'[k]}_{body}.{point}"] for k in (a, b)]) / 1e-3

    def ground(point):
        return np.asarray(model.body("ground").points[point])[[a, b]] / 1e-3
    for fmt in ("svg", "dxf"):
        out = tmp_path / f"d.{fmt}"
        res = CliRunner().invoke(main, ["export", str(path), "--to", fmt, "--at", str(at),
                                        "-o", str(out)] + (["--plane", plane] if plane else []))
        assert res.exit_code == 0, res.output
        assert f"projected on the {name} plane" in res.output
        text = out.read_text()
        # the file says which projection it holds
        assert f"the projection of a spatial model on its {name} plane ({name[0]} right, " \
               f"{name[1]} up)" in text
        if fmt == "svg":
            joints, paths, lines, _ = read_svg(out)
            guides = lines["ground"]
        else:
            header, ents = read_dxf(out)
            assert header["$INSUNITS"] == "4"
            joints = [(float(e[10]), float(e[20])) for e in ents
                      if e[0] == "CIRCLE" and e[8] == "JOINTS"]
            joints = {j.name: min(joints, key=lambda c: np.hypot(*(
                np.array(c) - (xy(j.body_b, j.point_b, pose)[:, 0] if j.body_b != "ground"
                               else ground(j.point_b))))) for j in model.joints}
            guides = [tuple(float(e[c]) for c in (10, 20, 11, 21)) for e in ents
                      if e[0] == "LINE" and e[8] == "GROUND"]
        # every joint at its second body's point at --at, projected
        for j in model.joints:
            want = (xy(j.body_b, j.point_b, pose)[:, 0] if j.body_b != "ground"
                    else ground(j.point_b))
            np.testing.assert_allclose(joints[j.name], want, rtol=0, atol=1e-9)
        # the slider's fixed guide J4 (prismatic on the ground): a line through the travel of
        # slider.C over the run, projected
        travel = xy("slider", "C", runs).T
        lo, hi = travel[np.argmin(travel @ (travel[-1] - travel[0]))], travel[np.argmax(
            travel @ (travel[-1] - travel[0]))]
        e = hi - lo

        def on(p):    # p on the line through the travel, between beyond both ends
            v = np.array(p) - lo
            return abs(e[0] * v[1] - e[1] * v[0]) <= 1e-9 * (e @ e)
        assert any(on(g[:2]) and on(g[2:]) and
                   min((np.array(g[:2]) - lo) @ e, (np.array(g[2:]) - lo) @ e) < 0 and
                   max((np.array(g[:2]) - lo) @ e, (np.array(g[2:]) - lo) @ e) > e @ e
                   for g in guides)


def test_the_drawing_of_a_spatial_model_traces_its_points(tmp_path):
    path = linkdyn.example_path("stewart")
    res = CliRunner().invoke(main, ["analyze", str(path), "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    runs = table(tmp_path / "out" / "results.csv")
    out = tmp_path / "s.svg"
    res = CliRunner().invoke(main, ["export", str(path), "--to", "svg", "--plane", "zx",
                                    "-o", str(out)])
    assert res.exit_code == 0, res.output
    _, paths, _, _ = read_svg(out)
    assert "platform.T" in paths
    unit = linkdyn.load(path).length_unit
    size = {"mm": 1e-3, "m": 1.0}[unit]
    np.testing.assert_allclose(paths["platform.T"][:, 0], runs["z_platform.T"] / size,
                               rtol=1e-15, atol=1e-12)
    np.testing.assert_allclose(paths["platform.T"][:, 1], runs["x_platform.T"] / size,
                               rtol=1e-15, atol=1e-12)


def test_plane_refusals(tmp_path):
    run = CliRunner().invoke
    hoeken = str(linkdyn.example_path("hoeken"))
    res = run(main, ["export", hoeken, "--to", "svg", "--plane", "xz", "-o",
                     str(tmp_path / "h.svg")])
    assert res.exit_code == 2 and "--plane" in res.output and "planar" in res.output
    assert not (tmp_path / "h.svg").exists()
    res = run(main, ["export", str(linkdyn.example_path("rsur")), "--to", "mjcf", "--plane",
                     "xy", "-o", str(tmp_path / "r.xml")])
    assert res.exit_code == 2 and "--plane" in res.output
    res = run(main, ["export", hoeken, "--to", "svg", "--plane", "ab"])
    assert res.exit_code == 2 and "--plane" in res.output
    # a planar model's drawing in its own plane is as before: --plane xy changes nothing
    plain, xy = tmp_path / "a.svg", tmp_path / "b.svg"
    assert run(main, ["export", hoeken, "--to", "svg", "-o", str(plain)]).exit_code == 0
    assert run(main, ["export", hoeken, "--to", "svg", "--plane", "xy", "-o",
                      str(xy)]).exit_code == 0
    assert plain.read_text() == xy.read_text() and "projection" not in plain.read_text()


# ------------------------------------------------------------------ simulate --report

def test_simulate_report_of_a_spatial_model_draws_the_simulated_motion(tmp_path):
    path = linkdyn.example_path("rsur_release")
    res = CliRunner().invoke(main, ["simulate", str(path), "-o", str(tmp_path), "--samples",
                                    "21", "--duration", "0.2", "--report"])
    assert res.exit_code == 0, res.output
    assert "report.html" in res.output
    assert not list(tmp_path.glob("plot_*"))           # a spatial page's figures: --plots
    text = (tmp_path / "report.html").read_text("utf-8")
    assert "http://" not in text and "https://" not in text
    D = page_blob(text)   # the drawn points float32, as the page carries them
    cols = table(tmp_path / "results.csv")
    assert D["geom"]["dim"] == 3
    np.testing.assert_array_equal(D["t"], cols["t"])
    # the drawn points are the simulated ones, at every frame
    moving = [pid for pid, p in D["geom"]["points"].items() if not p.get("static")]
    assert "coupler.C" in moving
    for pid in moving:
        for c in "xyz":
            np.testing.assert_allclose(D["geom"]["points"][pid][c], cols[f"{c}_{pid}"],
                                       rtol=1e-5, atol=1e-9)
    # the summary shows the integration's figures
    assert "<h3>Simulation</h3>" in text and "energy balance drift (relative)" in text
    import json
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert "report.html" in summary["files"]


def test_the_design_summary_of_a_spatial_run_is_analyzes():
    """``linkdyn.design.summary`` of a spatial solution: the summary ``linkdyn analyze`` writes
    (not an AttributeError), its peak efforts the largest |effort| of the run's own table."""
    import numpy as np

    import linkdyn
    from linkdyn import design

    m = linkdyn.load(linkdyn.example_path("rsur"))
    sol = linkdyn.analyze(m, np.linspace(0.0, 1.0, 41))
    s = design.summary(sol)
    assert s["space"] == "spatial" and s["mobility"] == 1
    cols = sol.columns()
    for name, peak in s["peak_effort"].items():
        assert peak == np.max(np.abs(cols[name]))
    assert s["peak_effort"]


def test_a_spatial_run_writes_the_parquet_table_asked_for(tmp_path):
    """``analyze --format parquet`` of a spatial model writes results.parquet (it wrote
    results.csv before), the same columns and numbers as the csv table."""
    import numpy as np
    import pandas as pd
    import pytest
    from click.testing import CliRunner

    import linkdyn
    from linkdyn.cli import main

    pytest.importorskip("pyarrow", reason="--format parquet needs the parquet extra")
    model = tmp_path / "rsur.toml"
    model.write_text(linkdyn.example_path("rsur").read_text("utf-8"), "utf-8")
    for fmt in ("csv", "parquet"):
        res = CliRunner().invoke(main, ["analyze", str(model), "--samples", "31", "--format",
                                        fmt, "-o", str(tmp_path / fmt)])
        assert res.exit_code == 0, res.output
    csv = pd.read_csv(tmp_path / "csv" / "results.csv")
    assert not (tmp_path / "parquet" / "results.csv").exists()
    table = pd.read_parquet(tmp_path / "parquet" / "results.parquet")
    assert list(table.columns) == list(csv.columns)
    assert np.array_equal(table.to_numpy(), csv.to_numpy())


# a parallelogram four-bar in space (every axis +z), its crank turned at pi rad/s from 90 deg:
# at t = 0.5 s (crank at 180 deg) every link lies on the ground's line, a change point where
# the dependent joints' Jacobian loses rank
CHANGE_POINT = {
    "mechanism": {"space": "spatial", "gravity": [0.0, -9.81, 0.0]},
    "units": {"length": "m", "angle": "rad"},
    "bodies": [
        {"name": "ground", "points": {"O": [0, 0, 0], "D": [2, 0, 0]}},
        {"name": "crank", "points": {"O": [0, 0, 0], "A": [0, 1, 0]}, "mass": 1.0,
         "com": [0, 0.5, 0], "inertia": [0.1, 0.1, 0.1]},
        {"name": "coupler", "points": {"A": [0, 1, 0], "B": [2, 1, 0]}, "mass": 2.0,
         "com": [1, 1, 0], "inertia": [0.1, 0.7, 0.7]},
        {"name": "rocker", "points": {"D": [2, 0, 0], "B": [2, 1, 0]}, "mass": 1.0,
         "com": [2, 0.5, 0], "inertia": [0.1, 0.1, 0.1]}],
    "joints": [
        {"name": "J1", "type": "revolute", "connect": ["ground.O", "crank.O"], "axis": [0, 0, 1]},
        {"name": "J2", "type": "revolute", "connect": ["crank.A", "coupler.A"], "axis": [0, 0, 1]},
        {"name": "J3", "type": "revolute", "connect": ["coupler.B", "rocker.B"], "axis": [0, 0, 1]},
        {"name": "J4", "type": "revolute", "connect": ["ground.D", "rocker.D"], "axis": [0, 0, 1]}],
    "drivers": [{"joint": "J1", "motion": {"kind": "expression", "q": "pi*t"}}],
    "analysis": {"duration": 1.0, "samples": 21}}


def test_allow_singular_keeps_a_spatial_run_through_a_singular_position(tmp_path):
    """``analyze --allow-singular`` on a spatial model: the samples at the change point are NaN
    rows named in the summary, every other row the run without them (and the closed form of the
    parallelogram: the coupler translates, the kinetic energy is constant, so the driving torque
    is the rate of the potential energy over the crank speed, ``tau = -3 g sin(pi t)``); without
    the flag, exit 3 naming the time and driver value."""
    from linkdyn.io.writer import dumps_toml

    path = tmp_path / "change_point.toml"
    path.write_text(dumps_toml(CHANGE_POINT))
    res = CliRunner().invoke(main, ["analyze", str(path), "-o", str(tmp_path / "refused")])
    assert res.exit_code == 3, res.output
    assert "singular position" in res.output and "at t = 0.5 s (q_J1 = 1.5708 rad)" in res.output
    assert "Traceback" not in res.output and not (tmp_path / "refused").exists()

    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["analyze", str(path), "-o", str(out), "--allow-singular"])
    assert res.exit_code == 0, res.output
    assert ("1 samples that do not close or sit at a singular position are written as NaN rows "
            "(t = 0.5 s)") in res.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["invalid_samples"] == 1 and summary["invalid_times_s"] == [0.5]
    rows = table(out / "results.csv")
    t = np.linspace(0.0, 1.0, 21)
    np.testing.assert_array_equal(rows["t"], t)
    bad = t == 0.5
    assert all(np.all(np.isnan(v[bad])) for k, v in rows.items() if k != "t")
    assert all(np.all(np.isfinite(v[~bad])) for v in rows.values())
    # the other rows: the run without the singular sample, column by column
    alone = linkdyn.analyze(linkdyn.load(path), t[~bad]).columns()
    assert list(alone) == list(rows)
    for name, v in alone.items():
        scale = max(float(np.max(np.abs(v))), 1.0)
        np.testing.assert_allclose(rows[name][~bad], v, rtol=0, atol=1e-9 * scale, err_msg=name)
    np.testing.assert_allclose(rows["tau_J1"][~bad], -3 * 9.81 * np.sin(np.pi * t[~bad]),
                               rtol=0, atol=1e-9 * 3 * 9.81)
    # the peaks of the summary are those of the rows solved
    assert summary["peak_effort"]["tau_J1"] == pytest.approx(np.max(np.abs(alone["tau_J1"])))
    # the report of a run with gaps: not yet (exit 2, nothing written)
    res = CliRunner().invoke(main, ["analyze", str(path), "-o", str(tmp_path / "page"),
                                    "--allow-singular", "--report"])
    assert res.exit_code == 2 and "not yet for spatial models" in res.output, res.output
    assert not (tmp_path / "page").exists()
    # the API: valid flags the gap, the arrays are NaN there
    sol = linkdyn.analyze(linkdyn.load(path), t, allow_singular=True)
    np.testing.assert_array_equal(sol.valid, ~bad)
    assert np.all(np.isnan(sol.reaction("J2")[bad])) and np.all(np.isnan(sol.point("coupler", "B")[bad]))
