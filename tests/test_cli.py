"""Command line: examples, check, analyze outputs (SPEC columns and order), exit codes and
messages for bad input, no partial output, parquet, and the Python API's table.

Most runs go through click's CliRunner (fast, in process); a few run the installed ``linkdyn``
entry point in a subprocess to see the real exit status and stderr.
"""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import example_names, example_text, main
from linkdyn.io import model_from_dict
from linkdyn.model import PRISMATIC

EXAMPLES = example_names()
HOEKEN = example_text("hoeken")
HOEKEN_W = 45.0 * 2 * math.pi / 60          # rad/s
SUMMARY_KEYS = {"model", "file", "samples", "duration_s", "mobility", "loops", "cut_joints",
                "spanning_tree", "drivers", "reactions", "four_bars", "invalid_samples", "health"}
# (mobility, cut joints) of each bundled example
TOPOLOGY = {"hoeken": (1, ["J4"]), "drag_link": (1, ["J4"]), "slider_crank": (1, ["J4"]),
            "inverted_slider_crank": (1, ["J3"]), "fivebar": (2, ["J4"]),
            "stephenson": (1, ["J4", "J7"]), "watt2": (1, ["J4", "J7"]),
            "scotch_yoke": (1, ["J3"]), "geared_fivebar": (1, ["G", "J5"]),
            "cam_follower": (1, ["K"]), "cam_fourbar": (1, ["J5", "K"]),
            "cam_flat_rocker": (1, ["K"])}


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def entry_point() -> str:
    exe = Path(sys.executable).with_name("linkdyn")
    found = str(exe) if exe.exists() else shutil.which("linkdyn")
    assert found, "the linkdyn entry point is not installed"
    return found


def run_process(*args, cwd=None):
    return subprocess.run([entry_point(), *map(str, args)], capture_output=True, text=True,
                          cwd=cwd, timeout=120)


def edit(text: str, old: str, new: str) -> str:
    assert old in text, f"test setup: {old!r} not in the model text"
    return text.replace(old, new)


def write(tmp_path: Path, text: str, name: str = "model.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def period(mech) -> float:
    if mech.duration:
        return mech.duration
    return (mech.cycles or 1.0) * next(d.period for d in mech.drivers if d.period)


def spec_columns(mech) -> list[str]:
    """results.csv columns in SPEC order, derived from the model here, not by the library."""
    moving = [b for b in mech.bodies if b.name != "ground"]
    cols = ["t"]
    for j in mech.joints:
        cols += [f"q_{j.name}", f"qd_{j.name}", f"qdd_{j.name}"]
    for b in moving:
        cols += [f"phi_{b.name}", f"omega_{b.name}", f"alpha_{b.name}"]
    for d in mech.drivers:
        kind = next(j.kind for j in mech.joints if j.name == d.joint)
        cols.append(f"{'force' if kind == PRISMATIC else 'tau'}_{d.joint}")
    for j in mech.joints:
        # a moment for a prismatic joint, and for a flat face (its contact off the joint's point)
        moment = j.kind in (PRISMATIC, "flat_cam", "rocker_flat_cam")
        cols += [f"Fx_{j.name}", f"Fy_{j.name}"] + ([f"M_{j.name}"] if moment else [])
    for b in moving:
        for p in b.points:
            cols += [f"x_{b.name}.{p}", f"y_{b.name}.{p}"]
    return cols + ["kinetic_energy"]


def read_csv(path: Path) -> tuple[list[str], np.ndarray]:
    lines = path.read_text().splitlines()
    header = lines[0].split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return header, data


def assert_user_error(res, code: int, *fragments: str):
    """Exit status ``code``; exactly one message on stderr, containing every fragment; no
    traceback anywhere."""
    out = res.stdout + res.stderr
    assert "Traceback" not in out, out
    status = res.returncode if isinstance(res, subprocess.CompletedProcess) else res.exit_code
    assert status == code, out
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, res.stderr
    for f in fragments:
        assert f in lines[0], f"{f!r} not in {lines[0]!r}"
    return lines[0]


def assert_no_outputs(outdir: Path):
    """Nothing written: the folder is absent or empty (no results, no temporary folder)."""
    if outdir.exists():
        assert sorted(p.name for p in outdir.iterdir()) == []


# ------------------------------------------------------------------------------- example

def test_example_list_names_every_bundled_model():
    res = run("example", "--list")
    assert res.exit_code == 0
    names = [line.split()[0] for line in res.stdout.splitlines() if line.strip()]
    files = sorted(p.name[:-5] for p in (Path(linkdyn.__file__).parent / "examples").iterdir()
                   if p.name.endswith(".toml"))
    # then the models for `linkdyn simulate` (examples/simulate)
    from linkdyn.cli import simulation_example_names, spatial_example_names
    assert names == files + simulation_example_names() + spatial_example_names()
    assert files == EXAMPLES
    assert len(files) >= 7 and "hoeken" in names
    # each line carries the model's [mechanism] name
    assert "Hoeken straight-line linkage" in res.stdout


def test_example_hoeken_prints_toml_that_loads(tmp_path):
    res = run("example", "hoeken")
    assert res.exit_code == 0
    assert res.stdout == linkdyn.example_path("hoeken").read_text()
    mech = model_from_dict(tomllib.loads(res.stdout))
    assert [b.name for b in mech.bodies] == ["ground", "crank", "coupler", "rocker"]
    # and the printed file works with the other commands, as the docs suggest
    path = write(tmp_path, res.stdout, "hoeken.toml")
    assert run("check", path).exit_code == 0


def test_unknown_example_exits_2_with_a_suggestion():
    res = run("example", "hoekn")
    line = assert_user_error(res, 2, "no bundled example named 'hoekn'", "Did you mean 'hoeken'?")
    assert all(n in line for n in EXAMPLES)
    assert res.stdout == ""


# ------------------------------------------------------------------------------- check

@pytest.mark.parametrize("name", EXAMPLES)
def test_check_describes_every_example(name):
    path = linkdyn.example_path(name)
    res = run("check", path)
    assert res.exit_code == 0, res.output
    out = res.stdout
    mobility, cuts = TOPOLOGY[name]
    assert f"mobility (Grübler–Kutzbach): {mobility}; drivers: {mobility}" in out
    assert f"loops: {len(cuts)}; cut joints: {', '.join(cuts)}" in out
    assert "spanning tree" in out
    mech = linkdyn.load(path)
    # every moving body hangs from the tree by exactly one line "parent <- body via joint"
    tree = re.findall(r"^\s+(\S+) <- (\S+) via (\S+)$", out, flags=re.M)
    assert sorted(b for _, b, _ in tree) == sorted(b.name for b in mech.moving_bodies)
    assert not {j for _, _, j in tree} & set(cuts)
    for j in cuts:
        assert re.search(rf"^\s+{j}\s.*\[cut\]$", out, flags=re.M)
    assert out.rstrip().endswith("model OK")
    assert res.stderr == ""


@pytest.mark.parametrize("name,grashof", [("hoeken", "crank-rocker"),
                                          ("drag_link", "double-crank"),
                                          ("stephenson", "crank-rocker"),
                                          ("watt2", "crank-rocker")])
def test_check_prints_the_grashof_type(name, grashof):
    res = run("check", linkdyn.example_path(name))
    line = next(ln for ln in res.stdout.splitlines() if ln.startswith("four-bar"))
    assert grashof in line and "Grashof" in line and "non-Grashof" not in line


def test_check_hoeken_lengths_and_roles():
    out = run("check", linkdyn.example_path("hoeken")).stdout
    assert "ground 89.5 mm, input 38.1 mm, coupler 115.2 mm, output 115.2 mm" in out
    assert re.search(r"^\s+J1\s.*\[tree, driven\]$", out, flags=re.M)
    assert "ground <- crank via J1" in out and "coupler <- rocker via J3" in out


def test_check_flags_a_non_grashof_linkage(tmp_path):
    path = write(tmp_path, non_grashof_hoeken())
    res = run("check", path)
    assert res.exit_code == 3      # driven through a full turn, it locks (tests/test_check.py)
    assert "non-Grashof" in res.stdout and "model OK" not in res.stdout


# ------------------------------------------------------------------------------- analyze

@pytest.mark.parametrize("name", EXAMPLES)
def test_analyze_every_example_writes_spec_outputs(name, tmp_path):
    path = linkdyn.example_path(name)
    out = tmp_path / "out"
    res = run("analyze", path, "-o", out, "--samples", 37)
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in out.iterdir()) == ["results.csv", "summary.json"]
    mech = linkdyn.load(path)
    header, data = read_csv(out / "results.csv")
    expected = spec_columns(mech)
    assert header[:len(expected)] == expected
    assert len(set(header)) == len(header)
    extras = header[len(expected):]
    if np.any(mech.gravity != 0):
        assert "potential_energy" in extras
    assert data.shape == (37, len(header))
    assert np.all(np.isfinite(data))
    col = dict(zip(header, data.T))
    T = period(mech)
    np.testing.assert_array_equal(col["t"], np.linspace(0.0, T, 37))
    assert np.all(col["kinetic_energy"] >= 0) and np.max(col["kinetic_energy"]) > 0
    # the file holds exactly what the library computes (full precision round trip)
    sol = linkdyn.analyze(mech, np.linspace(0.0, T, 37))
    for k in expected:
        np.testing.assert_array_equal(col[k], sol.columns[k], err_msg=k)

    summary = json.loads((out / "summary.json").read_text())
    assert SUMMARY_KEYS <= set(summary)
    mobility, cuts = TOPOLOGY[name]
    assert summary["samples"] == 37
    assert summary["duration_s"] == pytest.approx(T, rel=1e-12)
    assert summary["mobility"] == mobility and summary["loops"] == len(cuts)
    assert summary["cut_joints"] == cuts
    assert set(summary["spanning_tree"]) == {b.name for b in mech.moving_bodies}
    assert list(summary["drivers"]) == [d.joint for d in mech.drivers]
    assert list(summary["reactions"]) == [j.name for j in mech.joints]
    assert summary["invalid_samples"] == 0
    for j, d in summary["drivers"].items():
        effort = col[("force_" if d["unit"] == "N" else "tau_") + j]
        assert d["peak"] == pytest.approx(np.max(np.abs(effort)), rel=1e-12)
    # the printed summary names the model and the peak effort
    assert mech.name in res.stdout and "driver J1: peak" in res.stdout


def test_hoeken_csv_values_make_sense(tmp_path):
    out = tmp_path / "out"
    assert run("analyze", linkdyn.example_path("hoeken"), "-o", out, "--samples", 37).exit_code == 0
    header, data = read_csv(out / "results.csv")
    col = dict(zip(header, data.T))
    # constant-speed crank: q = w t, qd = w, qdd = 0; ground pivots do not move
    np.testing.assert_allclose(col["q_J1"], HOEKEN_W * col["t"], rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(col["qd_J1"], HOEKEN_W, rtol=1e-14)
    np.testing.assert_array_equal(col["qdd_J1"], 0.0)
    np.testing.assert_allclose(col["x_rocker.O4"], 0.0895, rtol=1e-12)
    np.testing.assert_allclose(col["y_rocker.O4"], 0.0, atol=1e-12)
    # crank pin on its circle; angles are not wrapped (the crank ends at 2 pi)
    np.testing.assert_allclose(np.hypot(col["x_crank.O2"], col["y_crank.O2"]), 0.0381,
                               rtol=1e-12)
    assert col["phi_crank"][-1] == pytest.approx(2 * math.pi, rel=1e-14)
    # one full period: the kinetic energy repeats
    assert col["kinetic_energy"][-1] == pytest.approx(col["kinetic_energy"][0], rel=1e-9)


def test_duration_and_cycles(tmp_path):
    hoeken = linkdyn.example_path("hoeken")
    res = run("analyze", hoeken, "-o", tmp_path / "d", "--samples", 11, "--duration", 0.5)
    assert res.exit_code == 0, res.output
    header, data = read_csv(tmp_path / "d" / "results.csv")
    np.testing.assert_array_equal(data[:, 0], np.linspace(0.0, 0.5, 11))
    res = run("analyze", hoeken, "-o", tmp_path / "c", "--samples", 21, "--cycles", 2)
    assert res.exit_code == 0, res.output
    header, data = read_csv(tmp_path / "c" / "results.csv")
    np.testing.assert_array_equal(data[:, 0], np.linspace(0.0, 2 * 60 / 45, 21))
    col = dict(zip(header, data.T))
    assert col["phi_crank"][-1] == pytest.approx(4 * math.pi, rel=1e-13)
    summary = json.loads((tmp_path / "c" / "summary.json").read_text())
    assert summary["duration_s"] == pytest.approx(8 / 3, rel=1e-13)


def test_samples_default_from_the_model(tmp_path):
    # [analysis] of hoeken: cycles = 1, samples = 361
    res = run("analyze", linkdyn.example_path("hoeken"), "-o", tmp_path / "o")
    assert res.exit_code == 0, res.output
    _, data = read_csv(tmp_path / "o" / "results.csv")
    assert data.shape[0] == 361
    assert data[-1, 0] == pytest.approx(4 / 3, rel=1e-14) and data[0, 0] == 0.0


def test_parquet_has_the_same_columns_and_values(tmp_path):
    import pandas as pd  # the test extras install pandas and pyarrow: this must run in CI
    hoeken = linkdyn.example_path("slider_crank")
    assert run("analyze", hoeken, "-o", tmp_path / "p", "--samples", 9,
               "--format", "parquet").exit_code == 0
    assert sorted(p.name for p in (tmp_path / "p").iterdir()) == ["results.parquet",
                                                                   "summary.json"]
    assert run("analyze", hoeken, "-o", tmp_path / "c", "--samples", 9).exit_code == 0
    df = pd.read_parquet(tmp_path / "p" / "results.parquet")
    header, data = read_csv(tmp_path / "c" / "results.csv")
    assert list(df.columns) == header
    assert len(df) == 9
    np.testing.assert_array_equal(df.to_numpy(), data)


def test_python_api_table_equals_the_csv(tmp_path):
    path = linkdyn.example_path("watt2")
    assert run("analyze", path, "-o", tmp_path, "--samples", 13).exit_code == 0
    header, data = read_csv(tmp_path / "results.csv")
    mech = linkdyn.load(path)
    t = np.linspace(0.0, period(mech), 13)
    df = linkdyn.analyze(mech, t).to_dataframe()
    assert df.index.name == "t" and df.attrs["units"]["t"] == "s"
    df = df.reset_index()
    assert list(df.columns) == header
    assert df.shape == data.shape
    np.testing.assert_array_equal(df.to_numpy(), data)
    assert list(df.columns[:len(spec_columns(mech))]) == spec_columns(mech)


def test_successful_run_in_a_subprocess(tmp_path):
    res = run_process("analyze", linkdyn.example_path("hoeken"), "-o", "out", "--samples", 5,
                      cwd=tmp_path)
    assert res.returncode == 0, res.stderr
    assert res.stderr == "" and "Traceback" not in res.stdout
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["results.csv",
                                                                      "summary.json"]
    header, data = read_csv(tmp_path / "out" / "results.csv")
    assert data.shape == (5, len(header))


# ------------------------------------------------------------------------------- bad input

DRIVER_J1 = 'joint = "J1"\nmotion = { kind = "constant_speed", rpm = 45.0, start = 0.0 }\n'
LONELY = '\n[[bodies]]\nname = "lonely"\npoints = { A = [0.0, 0.0] }\nmass = 1.0\ninertia = 1.0\n'
EXPR = 'motion = { kind = "expression", q = "%s" }'
CONST = 'motion = { kind = "constant_speed", rpm = 45.0, start = 0.0 }'


# a pendulum hung from the coupler point: one more freedom, still one driver
PENDULUM = ('\n[[bodies]]\nname = "pendulum"\npoints = { A = [0.0, 0.0] }\nmass = 1.0\n'
            'inertia = 1.0\n\n[[joints]]\nname = "J5"\ntype = "revolute"\n'
            'connect = ["coupler.P", "pendulum.A"]\n')


# name: (edit of the Hoeken text, field, fragments of the message)
BAD_MODELS = {
    "unknown body in connect": (
        lambda s: edit(s, 'connect = ["crank.O2", "coupler.O2"]',
                       'connect = ["crank.O2", "copler.O2"]'),
        "joints.J2.connect[1]", ["unknown body 'copler'", "Did you mean 'coupler'?"]),
    "unknown point in connect": (
        lambda s: edit(s, 'connect = ["crank.O2", "coupler.O2"]',
                       'connect = ["crank.O2", "coupler.Q2"]'),
        "joints.J2.connect[1]", ["body 'coupler' has no point 'Q2'", "Did you mean 'O2'?"]),
    "misspelt key": (
        lambda s: edit(s, "mass = 5.0", "mas = 5.0"),
        "bodies.coupler", ["unknown key 'mas'", "Did you mean 'mass'?"]),
    "negative mass": (
        lambda s: edit(s, "mass = 5.0", "mass = -5.0"),
        "bodies.coupler.mass", ["must not be negative", "-5 kg"]),
    "negative inertia": (
        lambda s: edit(s, "inertia = 88473.60", "inertia = -88473.60"),
        "bodies.coupler.inertia", ["must not be negative", "-88473.6"]),
    "dangling body": (
        lambda s: s + LONELY,
        "bodies.lonely", ["body 'lonely' is not connected to the ground"]),
    "under-driven": (
        lambda s: s + PENDULUM,
        "drivers", ["mobility 2", "1 driver(s)", "Add 1 driver(s)"]),
    "over-driven": (
        lambda s: edit(s, "[assembly]", "[[drivers]]\n" + DRIVER_J1.replace('"J1"', '"J3"')
                       + "\n[assembly]"),
        "drivers", ["mobility 1", "2 driver(s)", "Remove 1 driver(s)"]),
    "joint joining a body to itself": (
        lambda s: edit(s, 'connect = ["crank.O2", "coupler.O2"]',
                       'connect = ["crank.O2", "crank.O1"]'),
        "joints.J2.connect", ["connects body 'crank' to itself"]),
    "unknown name in an expression": (
        lambda s: edit(s, CONST, EXPR % "4.7*t + x"),
        "drivers[0].motion.q", ["unknown name 'x'"]),
    "unknown function in an expression": (
        lambda s: edit(s, CONST, EXPR % "4.7*t + foo(t)"),
        "drivers[0].motion.q", ["unknown function 'foo'"]),
    "missing table file": (
        lambda s: edit(s, CONST, 'motion = { kind = "table", file = "no-such-profile.csv" }'),
        "drivers[0].motion.file", ["not found", "no-such-profile.csv"]),
    "bad TOML syntax": (
        lambda s: edit(s, "mass = 5.0", "mass = = 5.0"),
        "line ", ["invalid TOML", "mass = = 5.0"]),
    "cutting a driven joint": (
        lambda s: edit(s, 'cut = ["J4"]', 'cut = ["J1"]'),
        "topology.cut[0]", ["'J1'", "driven"]),
    "cut that disconnects": (
        lambda s: edit(s, 'cut = ["J4"]', 'cut = ["J3", "J4"]'),
        "topology.cut", ["without a path to the ground"]),
    "unknown unit": (
        lambda s: edit(s, 'length = "mm"', 'length = "mmm"'),
        "units.length", ["unknown length unit 'mmm'", "Did you mean 'mm'?"]),
}


@pytest.mark.parametrize("case", sorted(BAD_MODELS))
def test_bad_model_exits_2_with_one_message(case, tmp_path):
    change, field, fragments = BAD_MODELS[case]
    path = write(tmp_path, change(HOEKEN), "bad-model.toml")
    out = tmp_path / "out"
    res = run("analyze", path, "-o", out, "--samples", 9)
    line = assert_user_error(res, 2, str(path), *fragments)
    assert line.startswith(f"error: {path}: {field}"), line
    assert res.stdout == ""
    assert_no_outputs(out)
    # check reports the same problem
    res = run("check", path)
    assert res.exit_code == 2 and res.stderr.strip() == line


def test_missing_model_file(tmp_path):
    path = tmp_path / "nowhere" / "model.toml"
    res = run("analyze", path, "-o", tmp_path / "out")
    assert_user_error(res, 2, str(path), "file not found")
    assert_no_outputs(tmp_path / "out")


def test_duration_and_cycles_together(tmp_path):
    res = run("analyze", linkdyn.example_path("hoeken"), "-o", tmp_path / "out",
              "--duration", 1.0, "--cycles", 1)
    assert_user_error(res, 2, "--duration", "not both")
    assert_no_outputs(tmp_path / "out")


@pytest.mark.parametrize("args,fragment", [(["--samples", 1], "--samples"),
                                           (["--duration", -1.0], "duration must be positive")])
def test_bad_arguments(args, fragment, tmp_path):
    res = run("analyze", linkdyn.example_path("hoeken"), "-o", tmp_path / "out", *args)
    assert_user_error(res, 2, fragment)
    assert_no_outputs(tmp_path / "out")


def test_bad_input_in_a_subprocess(tmp_path):
    path = write(tmp_path, BAD_MODELS["unknown body in connect"][0](HOEKEN), "bad.toml")
    res = run_process("analyze", path, "-o", tmp_path / "out")
    assert_user_error(res, 2, str(path), "joints.J2.connect[1]", "unknown body 'copler'")
    assert_no_outputs(tmp_path / "out")
    res = run_process("example", "hoekn")
    assert_user_error(res, 2, "Did you mean 'hoeken'?")
    res = run_process("check", tmp_path / "missing.toml")
    assert_user_error(res, 2, "file not found")


# ------------------------------------------------------------------------------- exit 3

def test_links_that_cannot_close_at_t0_exit_3(tmp_path):
    # ground pivots 400 mm apart: crank + coupler + rocker = 268.5 mm cannot span them
    text = edit(HOEKEN, "O4 = [89.5, 0.0] }", "O4 = [400.0, 0.0] }")
    path = write(tmp_path, text)
    res = run("analyze", path, "-o", tmp_path / "out", "--samples", 9)
    # the driver value in the file's unit, named (issue 23: a bare radian in a deg model)
    assert_user_error(res, 3, str(path), "at t = 0 s (q_J1 = 0 deg)", "cannot be assembled")
    assert_no_outputs(tmp_path / "out")
    proc = run_process("analyze", path, "-o", tmp_path / "out", "--samples", 9)
    assert_user_error(proc, 3, "cannot be assembled")
    assert_no_outputs(tmp_path / "out")


NG_GROUND, NG_CRANK, NG_LINK = 180.0, 60.0, 115.2      # mm


def non_grashof_hoeken() -> str:
    """Hoeken with ground 180 mm and crank 60 mm: s + l = 240 > p + q = 230.4 (non-Grashof);
    it assembles at t = 0 but the crank cannot pass the angle where coupler and rocker are
    stretched in line, |O4 - A| = 230.4 mm."""
    text = edit(HOEKEN, "O2 = [38.1, 0.0]", f"O2 = [{NG_CRANK}, 0.0]")
    return edit(text, "O4 = [89.5, 0.0] }", f"O4 = [{NG_GROUND}, 0.0] }}")


def non_grashof_limit() -> float:
    """Crank angle (rad) at which coupler and rocker are stretched in line."""
    L = 2 * NG_LINK
    return math.acos((NG_GROUND**2 + NG_CRANK**2 - L**2) / (2 * NG_GROUND * NG_CRANK))


def test_loop_that_stops_closing_during_the_run_exits_3_and_writes_nothing(tmp_path):
    path = write(tmp_path, non_grashof_hoeken())
    out = tmp_path / "out"
    out.mkdir()                         # an existing, empty output folder stays empty
    res = run("analyze", path, "-o", out, "--samples", 37)
    line = assert_user_error(res, 3, str(path))
    m = re.search(r"at t = ([-+0-9.e]+) s \(q_J1 = ([-+0-9.e]+) deg\)", line)
    assert m, line
    t_fail, q_fail = float(m.group(1)), math.radians(float(m.group(2)))
    assert "stop closing" in line or "singular" in line
    # the time is a sample time, and the driver value is the crank angle at that time
    samples = np.linspace(0.0, 60 / 45, 37)
    assert np.min(np.abs(samples - t_fail)) <= 1e-6 * t_fail
    assert q_fail == pytest.approx(HOEKEN_W * t_fail, rel=1e-5)   # 6 digits of deg
    # ... near the limit position (142.3 deg): within one continuation step (0.1 rad) and one
    # sample of it (see the strict test below for the exact sample)
    step = HOEKEN_W * (samples[1] - samples[0])
    assert non_grashof_limit() - 0.1 - step <= q_fail <= non_grashof_limit() + step
    assert res.stdout == ""
    assert sorted(p.name for p in out.iterdir()) == []


def test_the_reported_failure_is_the_first_sample_past_the_limit(tmp_path):
    path = write(tmp_path, non_grashof_hoeken())
    res = run("analyze", path, "-o", tmp_path / "out", "--samples", 37)
    samples = np.linspace(0.0, 60 / 45, 37)
    first = samples[np.argmax(HOEKEN_W * samples > non_grashof_limit())]
    assert f"at t = {first:.6g} s (q_J1 = {math.degrees(HOEKEN_W * first):.6g} deg)" in res.stderr


def test_stop_closing_in_a_subprocess_has_no_traceback(tmp_path):
    path = write(tmp_path, non_grashof_hoeken())
    res = run_process("analyze", path, "-o", tmp_path / "out", "--samples", 37)
    assert_user_error(res, 3, "at t = ", "(q_J1 = ")
    assert_no_outputs(tmp_path / "out")
    assert not list(tmp_path.glob("**/.linkdyn-*"))


def change_point_hoeken() -> str:
    """A parallelogram (crank = rocker = 50 mm, coupler = ground = 115.2 mm) started at a crank
    angle of 30 deg: at 180 deg all four links lie on one line, a change point where the loop
    still closes but J_dep is singular (the mechanism could continue as a parallelogram or an
    anti-parallelogram)."""
    text = edit(HOEKEN, "O2 = [38.1, 0.0]", "O2 = [50.0, 0.0]")
    text = edit(text, "O4 = [89.5, 0.0] }", "O4 = [115.2, 0.0] }")
    text = edit(text, "points = { O3 = [0.0, 0.0], O4 = [115.2, 0.0] }",
                "points = { O3 = [0.0, 0.0], O4 = [50.0, 0.0] }")
    text = edit(text, "com = [19.05, 0.0]", "com = [25.0, 0.0]")
    text = edit(text, "com = [57.6, 0.0]", "com = [25.0, 0.0]")
    text = edit(text, "inertia = 725.80", "inertia = 1250.0")
    text = edit(text, "inertia = 13271.76", "inertia = 2500.0")
    text = edit(text, "rpm = 45.0, start = 0.0", "rpm = 45.0, start = 30.0")
    return edit(text, "phi = { crank = 0.0, coupler = 77.12, rocker = -77.12 }",
                "phi = { crank = 30.0, coupler = 0.0, rocker = 210.0 }")


def test_a_singular_position_exits_3_naming_the_time_and_driver_value(tmp_path):
    path = write(tmp_path, change_point_hoeken())
    res = run("analyze", path, "-o", tmp_path / "out", "--samples", 37)
    line = assert_user_error(res, 3, "singular")
    # the crank reaches 180 deg at t = (150 deg) / (270 deg/s), a sample of linspace(0, 4/3, 37)
    t_toggle = (150 / 270)
    assert f"at t = {t_toggle:.6g} s (q_J1 = 180 deg)" in line
    assert_no_outputs(tmp_path / "out")


def test_allow_singular_keeps_the_other_samples_as_nan_rows(tmp_path):
    path = write(tmp_path, change_point_hoeken())
    out = tmp_path / "out"
    res = run("analyze", path, "-o", out, "--samples", 37, "--allow-singular")
    assert res.exit_code == 0, res.output
    summary = json.loads((out / "summary.json").read_text())
    assert summary["invalid_samples"] >= 1
    rows = np.genfromtxt(out / "results.csv", delimiter=",", names=True)
    bad = np.isnan(rows["tau_J1"])
    assert bad.sum() == summary["invalid_samples"]
    # the NaN rows are at the toggle; every other row is finite, t never NaN
    assert np.all(np.abs(rows["q_J1"][bad] - math.pi) < 1e-9) or np.all(np.isnan(rows["q_J1"][bad]))
    assert np.isfinite(rows["t"]).all()
    assert np.isfinite(rows["tau_J1"][~bad]).all() and (~bad).sum() >= 30


# ------------------------------------------------------------------------------- outputs

def snapshot(folder: Path) -> dict:
    """Every entry below ``folder``: relative path -> (bytes, mtime_ns) for files, None for
    folders."""
    return {str(p.relative_to(folder)): (p.read_bytes(), p.stat().st_mtime_ns) if p.is_file()
            else None for p in sorted(folder.rglob("*"))}


@pytest.fixture
def earlier_results(hoeken_report_run, tmp_path) -> Path:
    """A folder holding a successful run's outputs (csv, summary, report, plots: the suite's one
    ``analyze hoeken --report`` run, tests/conftest.py) and an unrelated file of the user's."""
    out = tmp_path / "runs" / "hoeken"
    shutil.copytree(hoeken_report_run, out)
    (out / "notes.txt").write_text("the user's own notes\n")
    assert {"results.csv", "summary.json", "report.html", "notes.txt"} <= {
        p.name for p in out.iterdir()}
    return out


@pytest.mark.parametrize("failure", ["cannot assemble", "bad model", "bad option"])
def test_a_failing_run_leaves_earlier_results_byte_for_byte_untouched(failure, tmp_path,
                                                                      earlier_results):
    out = earlier_results
    before, around = snapshot(out), snapshot(out.parent)
    if failure == "cannot assemble":   # ground pivots too far apart: exit 3
        model = write(tmp_path, edit(HOEKEN, "O4 = [89.5, 0.0] }", "O4 = [400.0, 0.0] }"))
        args, code = [], 3
    elif failure == "bad model":
        model = write(tmp_path, edit(HOEKEN, "mass = 5.0", "mass = -5.0"))
        args, code = [], 2
    else:
        model, args, code = linkdyn.example_path("hoeken"), ["--fluctuation", "-1"], 2
    # in a subprocess once (the real exit status and stderr), in process for the others
    runner = run_process if failure == "cannot assemble" else run
    res = runner("analyze", model, "-o", out, "--samples", 9, "--report", *args)
    assert_user_error(res, code)
    assert snapshot(out) == before
    assert snapshot(out.parent) == around      # no temporary folder left beside it either


def test_a_writer_that_fails_leaves_nothing(tmp_path, earlier_results):
    from linkdyn.outputs import write_outputs

    def broken(path):
        raise RuntimeError("disk on fire")

    files = {"summary.json": lambda p: p.write_text("{}"), "report.html": broken}
    fresh = tmp_path / "a" / "b" / "out"
    with pytest.raises(RuntimeError, match="disk on fire"):
        write_outputs(fresh, files)
    assert not (tmp_path / "a").exists()       # not even the parents created for it
    out = earlier_results
    before, around = snapshot(out), snapshot(out.parent)
    with pytest.raises(RuntimeError):
        write_outputs(out, files)
    assert snapshot(out) == before and snapshot(out.parent) == around


def test_a_new_run_replaces_only_what_linkdyn_wrote(tmp_path, earlier_results):
    out = earlier_results
    plots = {p.name for p in out.glob("plot_*")}
    assert plots
    (out / "plot_mine.txt").write_text("not a linkdyn output")
    res = run("analyze", linkdyn.example_path("hoeken"), "-o", out, "--samples", 9,
              "--format", "parquet")
    assert res.exit_code == 0, res.output
    # the earlier csv, report and plots would disagree with the new run: gone; the user's
    # files stay as they were
    assert sorted(p.name for p in out.iterdir()) == [
        "notes.txt", "plot_mine.txt", "results.parquet", "summary.json"]
    assert (out / "notes.txt").read_text() == "the user's own notes\n"
    res = run("analyze", linkdyn.example_path("hoeken"), "-o", out, "--samples", 9)
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in out.iterdir()) == [
        "notes.txt", "plot_mine.txt", "results.csv", "summary.json"]
    assert not list(tmp_path.glob("**/.linkdyn-*"))


def test_a_new_output_folder_gets_the_usual_permissions(tmp_path):
    out = tmp_path / "new"
    res = run("analyze", linkdyn.example_path("hoeken"), "-o", out, "--samples", 5)
    assert res.exit_code == 0, res.output
    probe = tmp_path / "probe"
    probe.mkdir()
    assert out.stat().st_mode == probe.stat().st_mode


@pytest.mark.parametrize("where", ["file", "into a file", "devnull", "proc"])
def test_output_folder_that_cannot_be_one_exits_2_naming_o(where, tmp_path):
    afile = write(tmp_path, "not a folder\n", "afile.txt")
    target = {"file": afile, "into a file": afile / "out", "devnull": Path(os.devnull),
              "proc": Path("/proc/linkdyn-no-such-folder")}[where]
    if where == "proc" and not Path("/proc/self").exists():
        pytest.skip("no /proc here")
    before = snapshot(tmp_path)
    runner = run_process if where == "devnull" else run
    res = runner("analyze", linkdyn.example_path("hoeken"), "-o", target, "--samples", 5)
    line = assert_user_error(res, 2, "-o", str(target))
    assert "cannot write the outputs" in line
    assert res.stdout == ""
    assert snapshot(tmp_path) == before


def test_unwritable_output_folder_exits_2_naming_o(tmp_path):
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o500)
    try:
        res = run("analyze", linkdyn.example_path("hoeken"), "-o", locked / "out",
                  "--samples", 5)
        if os.geteuid() == 0:            # root writes anywhere: only check that it worked
            assert res.exit_code == 0, res.output
        else:
            assert_user_error(res, 2, "-o", "not writable")
            assert list(locked.iterdir()) == []
    finally:
        locked.chmod(0o700)


def test_samples_further_apart_than_a_turn_finish_with_one_summary(tmp_path):
    # 10 samples over 20 crank turns, and 361 over a million seconds: the summary used to
    # crash after the files were written (exit 1, traceback)
    for args in (["--samples", 10, "--cycles", 20], ["--duration", "1e6"]):
        out = tmp_path / "out"
        res = run("analyze", linkdyn.example_path("hoeken"), "-o", out, *args)
        assert res.exit_code == 0 and "Traceback" not in res.output, res.output
        assert res.stdout.startswith("Hoeken straight-line linkage:")
        assert f"wrote {out / 'results.csv'}, {out / 'summary.json'}" in res.stdout
        summary = json.loads((out / "summary.json").read_text())
        assert summary["driver_energy"]["J1"]["energy_fluctuation_J"] is None
        assert "energy fluctuation n/a" in res.stdout
        # and the summary says its figures are those of the samples, not of the motion
        assert summary["sampling"]["coarse"] is True
        assert "NOTE: the samples are up to" in res.stdout
        shutil.rmtree(out)
    # 9 samples over a turn (45 deg apart) resolve it: no note
    res = run("analyze", linkdyn.example_path("hoeken"), "-o", tmp_path / "out", "--samples", 9)
    assert res.exit_code == 0 and "NOTE" not in res.stdout, res.output
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["sampling"] == {"driver_step": {"J1": pytest.approx(math.pi / 4)},
                                   "coarse": False}
