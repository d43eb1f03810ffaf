"""``linkdyn export MODEL --to mjcf|svg|dxf``: the files read back independently.

The SVG is read with ``xml.etree`` and the DXF with a group-code reader written here (pairs
of lines: code, value), not with the exporter's code. The joints must sit where linkdyn puts
them at ``--at`` (to 1e-9 of the model's length unit), and each traced path must be the
``x_``/``y_`` columns of ``results.csv`` of ``linkdyn analyze`` (the same run). The MJCF
written by the command is checked by MuJoCo's dynamics (``tests/test_mujoco.py``).
"""

from __future__ import annotations

import csv
import os
import subprocess
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.analysis import analyze
from linkdyn.cli import main

MM = {"mm": 1e-3, "cm": 1e-2, "m": 1.0, "in": 0.0254}      # metres per unit (SPEC units)


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def results(outdir: Path) -> dict[str, np.ndarray]:
    with open(outdir / "results.csv", newline="") as f:
        rows = list(csv.reader(f))
    data = np.array(rows[1:], float)
    return {name: data[:, k] for k, name in enumerate(rows[0])}


# ------------------------------------------------------------------------------- readers

def read_svg(path: Path):
    """(joints {name: (x, y)}, paths {BODY.POINT: (T, 2)}, lines {layer: [(x1, y1, x2, y2)]},
    the document's width in mm) in the file's coordinates (inside the scale(1 -1) group)."""
    ns = {"s": "http://www.w3.org/2000/svg"}
    root = ET.parse(path).getroot()
    flip = root.find("s:g", ns)
    assert flip.get("transform") == "scale(1 -1)"
    joints = {c.get("id").removeprefix("joint-"): (float(c.get("cx")), float(c.get("cy")))
              for c in flip.iter("{http://www.w3.org/2000/svg}circle")}
    paths = {p.get("id").removeprefix("path-"):
             np.array([[float(v) for v in xy.split(",")] for xy in p.get("points").split()])
             for p in flip.iter("{http://www.w3.org/2000/svg}polyline")}
    lines = {g.get("id").removeprefix("layer-"):
             [tuple(float(ln.get(k)) for k in ("x1", "y1", "x2", "y2"))
              for ln in g.findall("s:line", ns)] for g in flip.findall("s:g", ns)}
    width = float(root.get("width").removesuffix("mm"))
    return joints, paths, lines, width


def read_dxf(path: Path):
    """The DXF's header variables and entities: each entity a dict code -> value (VERTEX
    lists gathered under their POLYLINE as ``"vertices"``)."""
    text = path.read_text(encoding="ascii").splitlines()
    assert len(text) % 2 == 0
    pairs = [(int(text[k]), text[k + 1].strip()) for k in range(0, len(text), 2)]
    header, entities, section, var = {}, [], None, None
    for k, (code, value) in enumerate(pairs):
        if code == 0 and value == "SECTION":
            section = pairs[k + 1][1]
            continue
        if section == "HEADER":
            if code == 9:
                var = value
            elif code != 0 and var:
                header[var] = value
        elif section == "ENTITIES":
            if code == 0 and value not in ("ENDSEC", "EOF"):
                if value == "VERTEX":
                    entities[-1].setdefault("vertices", []).append({})
                elif value != "SEQEND":
                    entities.append({0: value})
            elif code != 0 and entities:
                target = entities[-1]["vertices"][-1] if (
                    "vertices" in entities[-1] and entities[-1][0] == "POLYLINE"
                    and pairs[k - 1][1] != "SEQEND") else entities[-1]
                target.setdefault(code, value)
    assert pairs[-1] == (0, "EOF")
    return header, entities


# ------------------------------------------------------------------------------- the drawing

# (example, --at, the points the report traces: coupler points no joint uses, and the
# five-bar's tool point, a joint between two bodies not pivoted on the ground)
CASES = [("hoeken", 0.3, ["coupler.P"]), ("slider_crank", 0.013, ["slider.F"]),
         ("fivebar", 0.21, ["link3.P"]), ("watt2", 0.5, ["output.T"]),
         ("inverted_slider_crank", 0.07, ["lever.T"])]


@pytest.mark.parametrize("name,at,traced", CASES)
def test_svg_and_dxf_joints_and_paths_are_linkdyns(name, at, traced, tmp_path):
    path = linkdyn.example_path(name)
    model = linkdyn.load(path)
    unit = MM[model.length_unit]
    assert run("analyze", path, "-o", tmp_path / "out").exit_code == 0
    table = results(tmp_path / "out")
    sol = analyze(model, np.array([at]))
    for fmt in ("svg", "dxf"):
        out = tmp_path / f"drawing.{fmt}"
        res = run("export", path, "--to", fmt, "--at", at, "-o", out)
        assert res.exit_code == 0, res.output
        if fmt == "svg":
            joints, paths, lines, width = read_svg(out)
            assert width > 0
        else:
            header, ents = read_dxf(out)
            assert header["$INSUNITS"] == {"mm": "4", "cm": "5", "m": "6", "in": "1"}[
                model.length_unit]
            circles = [e for e in ents if e[0] == "CIRCLE" and e[8] == "JOINTS"]
            joints = {}
            for j in model.joints:    # R12 entities carry no names: match each joint's circle
                want = sol.point(j.body_b, j.point_b)[0] / unit if j.body_b != "ground" else \
                    np.asarray(model.body("ground").points[j.point_b]) / unit
                near = min(circles, key=lambda e: np.hypot(float(e[10]) - want[0],
                                                           float(e[20]) - want[1]))
                joints[j.name] = (float(near[10]), float(near[20]))
            assert len(circles) == len(model.joints)
            paths = {e[8]: np.array([[float(v[10]), float(v[20])] for v in e["vertices"]])
                     for e in ents if e[0] == "POLYLINE"}
            lines = {}
            for e in ents:
                if e[0] == "LINE":
                    lines.setdefault(e[8].lower(), []).append(
                        tuple(float(e[c]) for c in (10, 20, 11, 21)))
        # every joint at its second body's point at --at, in the model's unit, to 1e-9 of it
        for j in model.joints:
            want = (sol.point(j.body_b, j.point_b)[0] if j.body_b != "ground"
                    else np.asarray(model.body("ground").points[j.point_b])) / unit
            np.testing.assert_allclose(joints[j.name], want, rtol=0, atol=1e-9)
        # every body's lines join its points where linkdyn puts them
        for b in model.moving_bodies:
            ends = np.array(lines.get(b.name.lower(), [])).reshape(-1, 2)
            if len(b.points) < 2:        # a block on one point: its joint's circle
                assert len(ends) == 0
                continue
            pts = np.array([sol.point(b.name, p)[0] for p in b.points]) / unit
            dist = np.linalg.norm(ends[:, None] - pts[None], axis=-1)
            assert np.max(np.min(dist, axis=1)) <= 1e-9     # every end is a point of the body
            assert np.max(np.min(dist, axis=0)) <= 1e-9     # every point is an end
        # a fixed guide: a ground line through the guide's point along its axis, spanning the
        # sliding point's travel in results.csv
        for j in model.joints:
            if j.body_a == "ground" and j.kind in ("prismatic", "slot"):
                o = np.asarray(model.body("ground").points[j.point_a]) / unit
                e = np.asarray(j.axis, float) / np.linalg.norm(j.axis)
                travel = ((np.stack([table[f"x_{j.body_b}.{j.point_b}"],
                                     table[f"y_{j.body_b}.{j.point_b}"]], axis=1) / unit - o) @ e)
                def off(x):  # distance of the point x from the guide's line
                    v = np.array(x) - o
                    return abs(e[0] * v[1] - e[1] * v[0])
                on = [ln for ln in lines["ground"] if off(ln[:2]) <= 1e-9 and off(ln[2:]) <= 1e-9]
                spans = [sorted(((np.array(ln[k:k + 2]) - o) @ e) for k in (0, 2)) for ln in on]
                assert any(a < travel.min() and b > travel.max() for a, b in spans), j.name
        # every traced path is results.csv's columns, in the model's unit
        keys = ({p: p for p in paths} if fmt == "svg" else
                {p: next(t for t in traced if f"PATH-{t.replace('.', '-').upper()}" == p)
                 for p in paths})
        assert sorted(keys.values()) == sorted(traced)
        for key, pid in keys.items():
            np.testing.assert_allclose(paths[key][:, 0], table[f"x_{pid}"] / unit, rtol=1e-15,
                                       atol=1e-12)
            np.testing.assert_allclose(paths[key][:, 1], table[f"y_{pid}"] / unit, rtol=1e-15,
                                       atol=1e-12)


def test_the_mjcf_written_by_the_command_reproduces_linkdyn_in_mujoco(tmp_path):
    pytest.importorskip("mujoco", reason="the MuJoCo check needs mujoco (the mujoco extra)")
    from test_mujoco import check_against_mujoco

    path = linkdyn.example_path("slider_crank")
    out = tmp_path / "sc.xml"
    res = run("export", path, "--to", "mjcf", "-o", out, "--at", 0.01)
    assert res.exit_code == 0, res.output
    assert "force 'slider'" in res.output          # the gas load MJCF cannot hold is named
    model = linkdyn.load(path)
    sol = analyze(model, np.linspace(0.0, 0.2, 9))
    assert check_against_mujoco(model, sol, out.read_text(), "slider_crank") <= 1e-12


def test_the_mjcf_export_needs_no_mujoco(tmp_path):
    out = tmp_path / "h.xml"
    code = ("import sys; sys.modules['mujoco'] = None\n"
            "from linkdyn.cli import main\n"
            f"main(['export', {str(linkdyn.example_path('hoeken'))!r}, '--to', 'mjcf', "
            f"'-o', {str(out)!r}])")
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         timeout=300)
    assert res.returncode == 0, res.stderr
    root = ET.parse(out).getroot()
    assert root.tag == "mujoco" and root.find("equality/connect").get("name") == "J4"


def test_the_default_file_is_named_after_the_model(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert run("export", linkdyn.example_path("hoeken"), "--to", "dxf").exit_code == 0
    assert (tmp_path / "hoeken.dxf").is_file()


# ------------------------------------------------------------------------------- bad input

def _one_error(res, code, *words):
    assert res.exit_code == code, res.output
    lines = [ln for ln in res.output.splitlines() if ln.strip()]
    assert "Traceback" not in res.output
    assert any(all(w in ln for w in words) for ln in lines), res.output


def test_an_unknown_format_exits_2(tmp_path):
    out = tmp_path / "x.step"
    res = run("export", linkdyn.example_path("hoeken"), "--to", "step", "-o", out)
    _one_error(res, 2, "--to", "step")
    assert not out.exists()


@pytest.mark.parametrize("where", ["folder", "under-a-file", "read-only"])
def test_an_unwritable_output_exits_2_and_writes_nothing(where, tmp_path):
    if where == "folder":
        out = tmp_path
    elif where == "under-a-file":
        (tmp_path / "f").write_text("")
        out = tmp_path / "f" / "x.svg"
    elif os.geteuid() != 0:
        ro = tmp_path / "ro"
        ro.mkdir()
        ro.chmod(0o500)
        out = ro / "x.svg"
    else:  # root writes into read-only folders; nobody creates files in /proc
        if not Path("/proc/self").exists():
            pytest.skip("root writes into read-only folders and this machine has no /proc")
        out = Path("/proc/self/linkdyn-x.svg")
    before = sorted(p.name for p in tmp_path.rglob("*"))
    res = run("export", linkdyn.example_path("hoeken"), "--to", "svg", "-o", out)
    _one_error(res, 2, "-o")
    assert sorted(p.name for p in tmp_path.rglob("*")) == before


NG = """
[mechanism]
name = "non-Grashof"
[units]
length = "mm"
angle = "deg"
[[bodies]]
name = "ground"
points = { O1 = [0, 0], O4 = [180, 0] }
[[bodies]]
name = "crank"
points = { O1 = [0, 0], O2 = [60, 0] }
mass = 1.5
com = [30, 0]
inertia = 400
[[bodies]]
name = "coupler"
points = { O2 = [0, 0], O3 = [115.2, 0] }
mass = 3
com = [57.6, 0]
inertia = 3000
[[bodies]]
name = "rocker"
points = { O3 = [0, 0], O4 = [115.2, 0] }
mass = 3
com = [57.6, 0]
inertia = 3000
[[joints]]
name = "J1"
type = "revolute"
connect = ["ground.O1", "crank.O1"]
[[joints]]
name = "J2"
type = "revolute"
connect = ["crank.O2", "coupler.O2"]
[[joints]]
name = "J3"
type = "revolute"
connect = ["coupler.O3", "rocker.O3"]
[[joints]]
name = "J4"
type = "revolute"
connect = ["ground.O4", "rocker.O4"]
[[drivers]]
joint = "J1"
motion = { kind = "constant_speed", speed = 270.0 }
[assembly]
phi = { crank = 0.0, coupler = 60.0, rocker = -60.0 }
"""


@pytest.mark.parametrize("fmt", ["mjcf", "svg", "dxf"])
def test_a_model_that_cannot_assemble_at_the_time_exits_3(fmt, tmp_path):
    """Ground 180 mm, crank 60 mm, coupler and rocker 115.2 mm: the crank cannot pass about
    142 deg, which it reaches at about 0.53 s; at 0.75 s (202 deg) there is no position."""
    path = tmp_path / "ng.toml"
    path.write_text(NG, encoding="utf-8")
    out = tmp_path / f"ng.{fmt}"
    res = run("export", path, "--to", fmt, "--at", 0.75, "-o", out)
    _one_error(res, 3, "error")
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["ng.toml"]


def test_a_slot_joint_is_refused_for_mjcf_naming_it(tmp_path):
    out = tmp_path / "y.xml"
    res = run("export", linkdyn.example_path("scotch_yoke"), "--to", "mjcf", "-o", out)
    _one_error(res, 2, "J3", "slot")
    assert not out.exists()
    # the drawing of the same model is fine
    assert run("export", linkdyn.example_path("scotch_yoke"), "--to", "svg",
               "-o", tmp_path / "y.svg").exit_code == 0


def test_a_failed_export_keeps_the_earlier_file(tmp_path):
    out = tmp_path / "h.svg"
    out.write_text("earlier", encoding="utf-8")
    res = run("export", linkdyn.example_path("hoeken"), "--to", "svg", "--at", "nan", "-o", out)
    _one_error(res, 2, "--at")
    assert out.read_text(encoding="utf-8") == "earlier"


def test_the_documented_export_commands_run(tmp_path, monkeypatch):
    """The commands of docs/cli.md's export section, on the bundled models they name (Hoeken's
    four-bar, the spatial RSUR)."""
    text = (Path(__file__).resolve().parents[1] / "docs" / "cli.md").read_text("utf-8")
    section = text[text.index("## `linkdyn export`"):]
    block = section[section.index("```sh") + 5:]
    block = block[:block.index("```")]
    commands = [ln.split() for ln in block.strip().splitlines()]
    assert commands and all(c[:2] == ["linkdyn", "export"] for c in commands)
    monkeypatch.chdir(tmp_path)
    for name in {c[2] for c in commands}:
        (tmp_path / name).write_text(linkdyn.example_path(Path(name).stem).read_text("utf-8"))
    for c in commands:
        res = run(*c[1:])
        assert res.exit_code == 0, (c, res.output)
        assert (tmp_path / c[c.index("-o") + 1]).stat().st_size > 0
