"""Issue 23, items 1 and 8: what a person reads is in the model file's own units, with the unit
named (``linkdyn.units``), and the set-up the README promises works.

Each test reproduces a finding of the issue (a deg/mm file answered in rad/m, ``--path-range
110:250`` read as radians by a sweep, ``rpm`` lost by ``save``, a 32,853-character ``repr``, a
traceback for a sweep without pandas) and checks the fixed behaviour against an independent
figure: the SI value the library computes (``summary.json``, ``results.csv``, ``analyze``'s own
straightness) converted by hand (``math.degrees``, x 1e3, x 1e6).
"""

from __future__ import annotations

import dataclasses
import json
import math
import re
import subprocess
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import example_text, main
from linkdyn.errors import ModelError
from linkdyn.units import Units

ROOT = Path(__file__).resolve().parents[1]
HOEKEN = example_text("hoeken")                    # mm and deg
RANGE = (math.radians(110), math.radians(250))     # the file's [analysis] path_range, rad


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture
def hoeken(tmp_path):
    path = tmp_path / "hoeken.toml"
    path.write_text(HOEKEN)
    return path


@pytest.fixture
def hoeken_si(tmp_path):
    """The same mechanism written in m and rad."""
    m = linkdyn.load(linkdyn.example_path("hoeken"))
    return linkdyn.save(dataclasses.replace(m, length_unit="m", angle_unit="rad"),
                        tmp_path / "si.toml")


# ------------------------------------------------------------------------- the formatter

def test_units_show_an_si_value_in_the_files_unit_with_its_name():
    u = Units("mm", "deg")
    assert u.show(0.0381, "length") == "38.1 mm"
    assert u.show(math.pi, "angle") == "180 deg"
    assert u.show(math.pi / 2, "angular_rate") == "90 deg/s"
    assert u.show(0.5, "velocity") == "500 mm/s"
    assert u.show(1.5e-4, "inertia") == "150 kg mm^2"
    assert u.show(2.0, "torque") == "2 N m" and u.show(3.0, "force") == "3 N"
    assert u.show(float("nan"), "length") == "n/a" and u.show(None, "angle") == "n/a"
    assert u.span(*RANGE, "angle") == "110 .. 250 deg"
    assert Units().show(0.0381, "length") == "0.0381 m"   # an SI file stays SI


def test_a_bare_number_is_in_the_files_unit_and_a_unit_may_be_given():
    u = Units("mm", "deg")
    assert u.parse("0.1", "length") == pytest.approx(1e-4)
    assert u.parse("0.1mm", "length") == pytest.approx(1e-4)
    assert u.parse("2 cm", "length") == pytest.approx(0.02)
    assert u.parse("30", "angle") == pytest.approx(math.radians(30))
    assert Units().parse("30deg", "angle") == pytest.approx(math.radians(30))
    assert Units().parse("45 rpm", "angular_rate") == pytest.approx(45 * 2 * math.pi / 60)
    assert u.parse("1 kg m^2", "inertia") == 1.0 and u.parse("1", "inertia") == 1e-6
    with pytest.raises(ModelError, match="not a unit of length") as err:
        u.parse("3deg", "length", "--path-range")
    assert err.value.field == "--path-range" and "mm" in err.value.fix
    with pytest.raises(ModelError, match="cannot read"):
        u.parse("abc", "angle", "--path-range")


# ------------------------------------------------------------------------- analyze, check

def test_the_summary_of_a_deg_file_says_deg_and_mm(hoeken, tmp_path):
    """Was ``driver range 1.92..4.363 rad`` and a flywheel in kg m^2 for a mm/deg file."""
    res = run("analyze", hoeken, "-o", tmp_path / "out")
    assert res.exit_code == 0, res.output
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert s["units"] == {"length": "mm", "angle": "deg"}
    ps = s["path_straightness"]
    lo, hi = (math.degrees(x) for x in ps["range"])          # SI kept in the SI fields
    assert ps["range_unit"] == "rad" and ps["range_shown"] == f"{lo:.6g} .. {hi:.6g} deg"
    assert f"(driver range {lo:.4g} .. {hi:.4g} deg)" in res.output
    assert f"max {ps['max_deviation_m'] * 1e3:.4g} mm" in res.output
    fly = s["driver_energy"]["J1"]["flywheel"]["inertia_kg_m2"]
    assert f"flywheel {fly * 1e6:.4g} kg mm^2" in res.output
    assert " rad" not in res.output and "kg m^2" not in res.output
    assert s["drivers"]["J1"]["motion"] == "constant speed 45 rpm from 0"
    ta = s["four_bars"][0]["transmission_angle_deg"]
    assert f"transmission angle {ta['min']:.4g} .. {ta['max']:.4g} deg" in res.output


def test_the_summary_of_an_si_file_says_rad_and_m(hoeken_si, tmp_path):
    res = run("analyze", hoeken_si, "-o", tmp_path / "out")
    assert res.exit_code == 0, res.output
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    ps, ta = s["path_straightness"], s["four_bars"][0]["transmission_angle_deg"]
    assert f"(driver range {ps['range'][0]:.4g} .. {ps['range'][1]:.4g} rad)" in res.output
    assert f"max {ps['max_deviation_m']:.4g} m," in res.output
    lo, hi = math.radians(ta["min"]), math.radians(ta["max"])
    assert f"transmission angle {lo:.4g} .. {hi:.4g} rad" in res.output
    assert " deg" not in res.output and " mm" not in res.output


def test_check_prints_inertias_and_lengths_in_the_files_units(hoeken, hoeken_si):
    m = linkdyn.load(hoeken)
    res = run("check", hoeken)
    assert res.exit_code == 0, res.output
    crank = m.body("crank")
    assert f"mass 1.5 kg, I_c {crank.inertia * 1e6:.6g} kg mm^2" in res.output
    assert "ground 89.5 mm, input 38.1 mm" in res.output
    assert "J1: constant speed 45 rpm from 0" in res.output
    res = run("check", hoeken_si)
    assert f"I_c {crank.inertia:.6g} kg m^2" in res.output
    assert "ground 0.0895 m, input 0.0381 m" in res.output
    mu = re.search(r"transmission angle ([0-9.]+) \.\. ([0-9.]+) rad", res.output)
    assert mu and float(mu.group(1)) == pytest.approx(math.radians(25.78), abs=1e-3)


def test_an_exit_3_message_gives_the_driver_value_in_the_files_unit(hoeken_si, tmp_path):
    """Was ``q_J1 = 2.42601`` for a deg model; the same failure in an SI file says rad."""
    text = HOEKEN.replace("O4 = [89.5, 0.0] }", "O4 = [250.0, 0.0] }")
    (tmp_path / "far.toml").write_text(text)
    res = run("analyze", tmp_path / "far.toml", "-o", tmp_path / "out")
    assert res.exit_code == 3
    m = re.search(r"at t = ([0-9.e-]+) s \(q_J1 = ([0-9.e-]+) deg\)", res.output)
    assert m, res.output
    assert float(m.group(2)) == pytest.approx(math.degrees(45 * 2 * math.pi / 60
                                                           * float(m.group(1))), rel=1e-5)
    si = tomllib.loads(Path(hoeken_si).read_text())
    si["bodies"][0]["points"]["O4"] = [0.25, 0.0]
    with pytest.raises(linkdyn.AssemblyError, match=r"\(q_J1 = [0-9.]+ rad\)"):
        linkdyn.analyze(linkdyn.model_from_dict(si, source="si.toml"), np.linspace(0, 4 / 3, 361))


def test_results_csv_in_the_model_units_names_each_unit(hoeken, tmp_path):
    assert run("analyze", hoeken, "-o", tmp_path / "si", "--samples", 19).exit_code == 0
    res = run("analyze", hoeken, "-o", tmp_path / "mm", "--samples", 19, "--units", "model")
    assert res.exit_code == 0, res.output
    with open(tmp_path / "si" / "results.csv") as f:
        names = f.readline().strip().split(",")
    data = np.loadtxt(tmp_path / "si" / "results.csv", delimiter=",", skiprows=1)
    si = {n: data[:, k] for k, n in enumerate(names)}
    with open(tmp_path / "mm" / "results.csv") as f:
        header = f.readline().strip().split(",")
    mm = np.loadtxt(tmp_path / "mm" / "results.csv", delimiter=",", skiprows=1)
    assert all(re.fullmatch(r"\S+ \[[^\]]+\]", h) for h in header), header
    col = {h.split(" [")[0]: mm[:, k] for k, h in enumerate(header)}
    assert "q_J1 [deg]" in header and "x_coupler.P [mm]" in header and "tau_J1 [N m]" in header
    assert "vx_coupler.P [mm/s]" in header and "alpha_crank [deg/s^2]" in header
    np.testing.assert_allclose(col["q_J1"], np.degrees(si["q_J1"]), rtol=1e-14, atol=1e-12)
    np.testing.assert_allclose(col["x_coupler.P"], si["x_coupler.P"] * 1e3, rtol=1e-14)
    np.testing.assert_allclose(col["tau_J1"], si["tau_J1"], rtol=0, atol=0)
    assert len(header) == len(names) and list(col) == names


# ------------------------------------------------------------------------- sweep, optimize

def test_a_sweeps_path_range_is_in_the_files_unit(hoeken, tmp_path):
    """``--path-range 110:250`` on a sweep was taken as radians (deviation 0.026 m against the
    3.7e-5 m of analyze): now it is the file's degrees, as for analyze."""
    pd = pytest.importorskip("pandas", reason="the sweep's table needs pandas (the parquet extra)")
    res = run("analyze", hoeken, "-o", tmp_path / "a", "--path-range", "110:250")
    want = json.loads((tmp_path / "a" / "summary.json").read_text())["path_straightness"]
    assert want["range"] == pytest.approx(RANGE, rel=1e-15)
    vary = "bodies.ground.points.O4[0]=89.5:89.5:1"   # the base design alone
    for k, given in enumerate(["110:250", "110deg:250deg", f"{RANGE[0]!r}rad:{RANGE[1]!r}rad"]):
        res = run("sweep", hoeken, "--vary", vary, "--path-range", given, "-o", tmp_path / f"s{k}")
        assert res.exit_code == 0, res.output
        got = pd.read_parquet(tmp_path / f"s{k}" / "designs.parquet")["path_deviation"][0]
        assert got == pytest.approx(want["max_deviation_m"], rel=1e-9), given
        assert f"path_deviation           {got * 1e3:.6g} .. {got * 1e3:.6g} mm" in res.output
    res = run("sweep", hoeken, "--vary", vary, "--path-range", "110mm:250", "-o", tmp_path / "x")
    assert res.exit_code == 2 and "--path-range" in res.output and "not a unit of angle" in res.output


def test_vary_bounds_may_carry_a_unit(hoeken, tmp_path):
    pd = pytest.importorskip("pandas", reason="the sweep's table needs pandas (the parquet extra)")
    tables = []
    for k, vary in enumerate(["bodies.ground.points.O4[0]=80:100:3", "bodies.ground.points.O4[0]=8cm:0.1m:3"]):
        res = run("sweep", hoeken, "--vary", vary, "-o", tmp_path / f"v{k}")
        assert res.exit_code == 0, res.output
        tables.append(pd.read_parquet(tmp_path / f"v{k}" / "designs.parquet"))
    assert list(tables[1]["bodies.ground.points.O4[0]"]) == pytest.approx([80, 90, 100], rel=1e-14)
    pd.testing.assert_frame_equal(tables[0], tables[1], rtol=1e-12)
    res = run("sweep", hoeken, "--vary", "bodies.ground.points.O4[0]=8deg:100:3", "-o", tmp_path / "x")
    assert res.exit_code == 2 and "not a unit of length" in res.output
    assert not (tmp_path / "x").exists()


def test_optimize_prints_and_bounds_in_the_files_units(hoeken, tmp_path):
    """``min_transmission_angle = 0.476449`` (rad) and ``path_deviation = 9.99994e-05`` (m) for a
    deg/mm file; a bare constraint bound is now in the file's unit (0.1 = 0.1 mm)."""
    res = run("optimize", hoeken, "--vary", "bodies.ground.points.O4[0]=85:95", "--minimize",
              "peak_tau_J1", "--constraint", "path_deviation<=0.1", "--constraint",
              "min_transmission_angle>=20", "--samples", 73, "--popsize", 4, "--maxiter", 3,
              "-o", tmp_path / "o")
    assert res.exit_code == 0, res.output
    info = json.loads((tmp_path / "o" / "optimize.json").read_text())
    assert info["constraints"] == ["path_deviation <= 0.1 mm", "min_transmission_angle >= 20 deg"]
    dev, mu = info["metrics"]["path_deviation"], info["metrics"]["min_transmission_angle"]
    assert dev <= 1e-4 * (1 + 1e-12) and mu >= math.radians(20)
    assert f"path_deviation = {dev * 1e3:.6g} mm" in res.output
    assert f"min_transmission_angle = {math.degrees(mu):.6g} deg" in res.output
    x = info["parameters"]["bodies.ground.points.O4[0]"]
    assert f"bodies.ground.points.O4[0] = {x:.6g} mm" in res.output


# ------------------------------------------------------------------------- set-up (item 8)

def test_save_keeps_the_files_speed_unit(tmp_path):
    src = tmp_path / "m.toml"
    src.write_text(HOEKEN.replace("rpm = 45.0", "rpm = 120"))
    data = tomllib.loads(linkdyn.save(linkdyn.load(src), tmp_path / "c.toml").read_text())
    assert data["drivers"][0]["motion"]["rpm"] == 120 and "speed" not in data["drivers"][0]["motion"]


def test_every_result_object_has_a_short_repr(tmp_path):
    """``repr(Simulation)`` was 32,853 characters (147,017 at 101 samples here)."""
    from linkdyn.studies.optimize import optimize
    (tmp_path / "motor.toml").write_text(example_text("hoeken_motor"))
    sim = linkdyn.simulate(linkdyn.load(tmp_path / "motor.toml"), np.linspace(0.0, 1.0, 201))
    sol = linkdyn.analyze(linkdyn.load(linkdyn.example_path("hoeken")), np.linspace(0, 4 / 3, 361))
    res = optimize(linkdyn.example_path("hoeken"), {"bodies.ground.points.O4[0]": (85, 95)},
                   np.linspace(0, 4 / 3, 37), "peak_tau_J1", popsize=3, maxiter=1, polish=False)
    objects = {"Simulation": sim, "Solution": sol, "optimize Result": res}
    for name, s in (("simulation", sim), ("analysis", sol)):
        objects.update({f"{name} {a}": getattr(s, a) for a in
                        ("kin", "dyn", "reactions", "loads", "topology")})
        objects[f"{name} layout"] = s.kin.layout
    long = {k: len(repr(v)) for k, v in objects.items() if len(repr(v)) > 600}
    assert not long, long
    assert repr(sim).startswith("<linkdyn.Simulation ") and "array(" in repr(sim.kin)


BLOCK = """
import sys
class Block:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in ("pandas", "pyarrow"):
            raise ImportError("blocked: " + name)
sys.meta_path.insert(0, Block())
from linkdyn.cli import main
sys.exit(main())
"""


def test_a_sweep_without_pandas_says_how_to_install_it(hoeken, tmp_path):
    """After ``make demo`` (no extras, before this fix) ``linkdyn sweep`` crashed with a
    traceback: it now exits 2 with one line naming the extra, and writes nothing."""
    for args in (["sweep", str(hoeken), "--vary", "bodies.ground.points.O4[0]=80:100:3",
                  "-o", str(tmp_path / "s")],
                 ["compare", str(hoeken), "--sweep", str(tmp_path), "--by", "peak_tau_J1",
                  "-o", str(tmp_path / "c")]):
        proc = subprocess.run([sys.executable, "-c", BLOCK, *args], capture_output=True,
                              text=True, timeout=300)
        assert proc.returncode == 2, proc.stderr
        assert "Traceback" not in proc.stderr and proc.stderr.count("\n") == 1, proc.stderr
        assert "pandas and pyarrow" in proc.stderr
        assert "pip install 'linkdyn[parquet]'" in proc.stderr
        assert not (tmp_path / "s").exists() and not (tmp_path / "c").exists()


def _readme_commands() -> list[str]:
    text = (ROOT / "README.md").read_text()
    block = text[text.index("## Command line"):]
    block = block[block.index("```sh") + 5:block.index("```", block.index("```sh") + 5)]
    lines, cur = [], ""
    for line in block.splitlines():
        cur += line.split("  #")[0].rstrip().removesuffix("\\") + " "
        if not line.rstrip().endswith("\\"):
            lines.append(" ".join(cur.split()))
            cur = ""
    return [ln for ln in lines if ln]


def test_the_readme_makes_variant_toml_before_comparing_it(tmp_path, monkeypatch):
    lines = _readme_commands()
    make = next(k for k, ln in enumerate(lines) if ln.endswith("> variant.toml"))
    use = next(k for k, ln in enumerate(lines) if "variant.toml" in ln and k != make)
    assert make < use
    m = re.fullmatch(r"sed 's/(.*?)/(.*?)/' hoeken.toml > variant.toml", lines[make])
    old, new = (g.replace("\\[", "[").replace("\\]", "]") for g in m.groups())
    assert HOEKEN.count(old) == 1   # the edit applies to the bundled file
    monkeypatch.chdir(tmp_path)
    Path("hoeken.toml").write_text(HOEKEN)
    Path("variant.toml").write_text(HOEKEN.replace(old, new))
    res = run(*lines[use].split()[1:])
    assert res.exit_code == 0, res.output
    assert Path("out/cmp/compare.html").is_file()


def test_every_readme_command_line_parses():
    """Each ``linkdyn ...`` line of the README's command block names a command and options
    that exist (parsed by click, not run)."""
    import shlex
    for line in _readme_commands():
        if not line.startswith("linkdyn "):
            continue
        args = shlex.split(line.split(" > ")[0])[1:]
        cmd = main.get_command(None, args[0])
        assert cmd is not None, line
        cmd.make_context(args[0], args[1:])   # raises on an unknown option or a bad value


def test_the_readme_says_how_to_run_linkdyn_and_make_demo_installs_the_sweep_extra():
    readme = (ROOT / "README.md").read_text()
    assert ". .venv/bin/activate" in readme and ".venv/bin/linkdyn" in readme
    make = (ROOT / "Makefile").read_text()
    demo = re.search(r"^demo: (\S+)", make, re.M).group(1)
    recipe = re.search(rf"^{re.escape(demo)}:.*\n((?:\t.*\n)+)", make, re.M).group(1)
    assert '".[parquet]"' in recipe
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]["parquet"]
    assert {e.split(">")[0] for e in extras} >= {"pandas", "pyarrow"}
