"""``linkdyn import FILE``: Pyslvs's expressions and YAML projects as linkdyn models.

The references are Pyslvs's own numbers and Pyslvs's own method, written here:

- Pyslvs's test suite solves its Jansen example at input angles 0 and 45 degrees and asserts
  the foot (joint 7) at (-43.170055, -91.753226) and (-24.406394, -91.789596), to 6 decimals:
  the imported model, analysed at those crank angles, puts it there;
- Pyslvs places every joint by triangles (its PLA and PLLP formulas): the driven joint at the
  input angle from the base, each other joint from two placed joints of its links at their saved
  distances, on the side of their line where the saved pose has it. That construction, written
  here, shares no code with linkdyn's assembly (Newton's method and continuation on the loop
  closures); every revolute, one-input example of Pyslvs's example list
  (``tests/data/pyslvs/examples.json``, see its README) stands where it puts it, to 1e-12 of
  the mechanism's size, over a crank turn (or the part of it the mechanism can move through);
- a mechanism with sliders, which no triangle places, stands at its saved pose, every link rigid
  and every slider on its slot link's line (Pyslvs's constraints), over a turn;
- the examples linkdyn cannot represent (two inputs, a slider driven) are refused by name.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main
from linkdyn.io.pyslvs import from_pyslvs, import_pyslvs, parse_expression

EXAMPLES = json.loads((Path(__file__).parent / "data" / "pyslvs" / "examples.json").read_text())
IMPORTED = [n for n, e in EXAMPLES.items()
            if len(e["input"]) == 1 and len(set(e["input"][0])) == 2]


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def triangles(expression: str, pair, angle: float) -> np.ndarray:
    """Pyslvs's construction of the joints (n, 2) at input ``angle`` (rad), NaN rows where a
    triangle does not close (or is flat), None if no triangles place them all: the driven joint
    by PLA from the base, every other moving joint by PLLP from two placed joints sharing a link
    with it, on its saved side."""
    joints = parse_expression(expression)
    saved = np.array([j["position"] for j in joints])
    links = [set(j["links"]) for j in joints]
    base, drive = pair
    pos = {i: saved[i] for i, lk in enumerate(links) if "ground" in lk}
    pos[drive] = saved[base] + np.hypot(*(saved[drive] - saved[base])) * np.array(
        [math.cos(angle), math.sin(angle)])
    while len(pos) < len(joints):
        for j in (j for j in range(len(joints)) if j not in pos):
            near = [k for k in pos if links[k] & links[j]]      # on one link with j
            pairs = [(a, b) for a in near for b in near
                     if a < b and np.hypot(*(saved[b] - saved[a])) > 1e-9]
            if pairs:
                break
        else:
            return None                  # a loop no triangle solves (Pyslvs: its numeric solver)
        a, b = pairs[0]
        # PLLP: |p - p_a| = r_a, |p - p_b| = r_b, on the saved side of the line a -> b
        ra, rb = (np.hypot(*(saved[j] - saved[k])) for k in (a, b))
        d = pos[b] - pos[a]
        L = np.hypot(*d)
        u = d / L
        along = (ra ** 2 - rb ** 2 + L ** 2) / (2 * L)
        h2 = ra ** 2 - along ** 2
        s0 = saved[b] - saved[a]
        side = np.sign(s0[0] * (saved[j] - saved[a])[1] - s0[1] * (saved[j] - saved[a])[0])
        h = math.sqrt(h2) if h2 > (1e-6 * L) ** 2 else math.nan    # flat: a toggle, no side
        pos[j] = pos[a] + along * u + side * h * np.array([-u[1], u[0]])
    return np.array([pos[i] for i in range(len(joints))])


@pytest.mark.parametrize("name, joint, expected", [
    ("Jansen's linkage (Single)", "P7", {0.0: (-43.170055, -91.753226),
                                         45.0: (-24.406394, -91.789596)}),
    ("Crank slider (RP joint)", "P5", {0.0: (103.801126, 78.393173)}),
])
def test_the_points_pyslvs_test_suite_asserts(name, joint, expected):
    e = EXAMPLES[name]
    imp = from_pyslvs(e["mechanism"], e["input"], length_unit="mm")
    p0, p1 = (np.array(parse_expression(e["mechanism"])[k]["position"]) for k in e["input"][0])
    saved = math.atan2(*(p1 - p0)[::-1])
    at = [((math.radians(a) - saved) % math.tau) / math.tau for a in expected]
    t = np.unique(np.concatenate([np.linspace(0.0, 1.0, 73), at]))
    point = linkdyn.analyze(imp.model, t).point(*imp.points[joint]) * 1e3
    for ti, ref in zip(at, expected.values()):
        got = point[np.searchsorted(t, ti)]
        assert np.abs(got - ref).max() < 5e-7, (got, ref)   # Pyslvs's 6 decimals


@pytest.mark.parametrize("name", IMPORTED)
def test_the_examples_stand_where_pyslvs_triangles_put_them(name):
    e = EXAMPLES[name]
    imp = from_pyslvs(e["mechanism"], e["input"])
    joints = parse_expression(e["mechanism"])
    saved = np.array([j["position"] for j in joints])
    base, drive = e["input"][0]
    start = math.atan2(*(saved[drive] - saved[base])[::-1])
    sliders = [i for i, j in enumerate(joints) if j["type"] != "R"]
    if sliders or triangles(e["mechanism"], (base, drive), start) is None:
        # a loop no triangle solves (Stephenson II, III), or a slider: the saved pose, every
        # link rigid, every slider on its slot link's line, over a turn
        sol = linkdyn.analyze(imp.model, np.linspace(0.0, 1.0, 73))
        got = np.stack([sol.point(*imp.points[f"P{i}"]) for i in range(len(joints))], axis=1)
        size = np.abs(saved).max()
        assert np.abs(got[0] - saved).max() < 1e-12 * size
        # the links each joint is fixed in (a slider's pin moves along its slot link); a
        # slider's base, the slot link's point where the pin was saved (the line's point in the
        # model), a joint more of the slot link
        fixed = [set(j["links"][1:] if i in sliders else j["links"]) for i, j in enumerate(joints)]
        lines = {d["name"]: d["connect"][0].split(".") for d in imp.data["joints"]
                 if d["type"] in ("slot", "prismatic")}
        for i in sliders:
            got = np.concatenate([got, sol.point(*lines[f"P{i}"])[:, None]], axis=1)
            saved = np.concatenate([saved, saved[i][None]])
            fixed.append({joints[i]["links"][0]})
        for a, b in ((a, b) for a in range(len(fixed)) for b in range(a) if fixed[a] & fixed[b]):
            assert np.abs(np.hypot(*(got[:, a] - got[:, b]).T)
                          - np.hypot(*(saved[a] - saved[b]))).max() < 1e-12 * size
        for k, i in enumerate(sliders):
            base = len(joints) + k
            # the slot link's turn since the saved pose, from its base and another of its points
            other = next((b for b in range(len(fixed)) if b != base and fixed[b] & fixed[base]
                          and np.hypot(*(saved[b] - saved[base])) > 1e-9 * size), None)
            if other is None:           # the ground: its line does not turn
                turn = np.zeros(len(got))
            else:
                d, d0 = got[:, other] - got[:, base], saved[other] - saved[base]
                turn = np.arctan2(d[:, 1], d[:, 0]) - math.atan2(d0[1], d0[0])
            # (p - p_base) x (cos(A + turn), sin(A + turn)) = 0
            u = np.radians(joints[i]["angle"]) + turn
            off = got[:, i] - got[:, base]
            assert np.abs(off[:, 0] * np.sin(u) - off[:, 1] * np.cos(u)).max() < 1e-12 * size
            if joints[i]["type"] == "P":    # its links turn with the slot link only
                c, s = np.cos(turn), np.sin(turn)
                for b in (b for b in range(len(joints)) if b != i and fixed[b] & fixed[i]):
                    d0 = saved[b] - saved[i]
                    assert np.abs(got[:, b] - got[:, i] - np.stack(
                        [c * d0[0] - s * d0[1], s * d0[0] + c * d0[1]], axis=1)).max() \
                        < 1e-12 * size
        return
    # the way the crank can turn from the saved pose (a toggle press only one way)
    sense = 1.0 if np.isfinite(triangles(e["mechanism"], (base, drive),
                                         start + math.radians(5.0))).all() else -1.0
    t = np.linspace(0.0, 1.0, 73)                      # one turn, 5 degrees a sample
    ref = np.stack([triangles(e["mechanism"], (base, drive), start + sense * math.tau * ti)
                    for ti in t])
    # the part of the turn the triangles close on, from the saved pose on
    reach = np.isfinite(ref).all(axis=(1, 2))
    n = len(t) if reach.all() else int(np.argmin(reach))
    assert n >= 5, f"{name}: the crank turns less than 20 degrees"
    data = json.loads(json.dumps(imp.data))
    data["drivers"][0]["motion"]["speed"] *= sense
    sol = linkdyn.analyze(linkdyn.model_from_dict(data), t[:n])
    got = np.stack([sol.point(*imp.points[f"P{i}"]) for i in range(len(joints))], axis=1)
    err = np.abs(got - ref[:n]).max() / np.abs(ref[:n]).max()
    # 1e-11: the ball lifters' coupler tips, near a toggle at 300 degrees, differ by 3.5e-12 of
    # the size while both keep every link's length to 2e-16 of it (the toggle's conditioning)
    assert err < 1e-11, f"{name}: positions differ from Pyslvs's triangles by {err:.1e}"


def test_both_backends_follow_stephenson_ii_where_newtons_first_step_is_long():
    """Pyslvs's Stephenson II (loops Newton's method closes, no triangles): at the node after
    t = 0.206 s the predictor is 0.09 rad from the closed pose but Newton's first step is
    1.7 rad long (J_dep nearly singular along it); the numpy continuation takes it and closes
    the node, and so must the compiled one (it once refused a step over a radian there and
    stopped the branch: "the loops stop closing" at t = 0.319 s): both run the whole turn and
    agree to rounding."""
    e = EXAMPLES["Stephenson II"]
    imp = from_pyslvs(e["mechanism"], e["input"])
    t = np.linspace(0.0, 1.0, 73)
    ref = linkdyn.analyze(imp.model, t, backend="numpy")
    got = linkdyn.analyze(imp.model, t, backend="compiled")
    family = {}   # each kind of column's largest (vx, tau, F, ...): a column of rounding alone
    for key, col in ref.columns.items():
        kind = key.split("_")[0]
        family[kind] = max(family.get(kind, 0.0), float(np.max(np.abs(col))))
    for key, col in ref.columns.items():
        scale = max(float(np.max(np.abs(col))), 1e-3 * family[key.split("_")[0]], 1e-300)
        assert np.all(np.isfinite(got.columns[key])), key
        assert np.max(np.abs(got.columns[key] - col)) <= 1e-9 * scale, key


@pytest.mark.parametrize("name, words", [
    ("Slider lifter", ["input pair (0, 0)"]),
    ("Arm", ["one input pair", "[[0, 1], [0, 2]]"]),
])
def test_what_linkdyn_cannot_represent_is_refused_by_name(name, words, tmp_path):
    yaml = pytest.importorskip("yaml", reason="Pyslvs projects need PyYAML (the pyslvs extra)")
    file = tmp_path / "m.pyslvs"
    file.write_text(yaml.safe_dump(EXAMPLES[name]))               # its expression and inputs
    res = run("import", file, "-o", tmp_path / "m.toml")
    assert res.exit_code == 2 and "Traceback" not in res.output, res.output
    for w in words + ["m.pyslvs"]:
        assert w in res.output, res.output
    assert not (tmp_path / "m.toml").exists()


def test_a_yaml_project_and_an_expression_import_alike(tmp_path):
    yaml = pytest.importorskip("yaml", reason="Pyslvs projects need PyYAML (the pyslvs extra)")
    e = EXAMPLES["Crank rocker"]
    project = tmp_path / "rocker.pyslvs"
    project.write_text(yaml.safe_dump({"pyslvs_ver": "22.07.0", "mechanism": e["mechanism"],
                                       "links": {"ground": "White"}, "input": e["input"]}))
    expr = tmp_path / "rocker.txt"
    expr.write_text(e["mechanism"])
    out = tmp_path / "rocker.toml"
    res = run("import", project, "-o", out, "--length-unit", "mm")
    assert res.exit_code == 0, res.output
    assert "Pyslvs has no time" in res.output and f"wrote {out}" in res.output
    assert out.read_text().startswith("# Imported from Pyslvs by linkdyn import.")
    a = import_pyslvs(project, length_unit="mm")
    assert a.data == import_pyslvs(expr, inputs=[(0, 1)], length_unit="mm").data
    # the written file is the model: at t = 0 every joint at the project's saved position
    sol = linkdyn.analyze(linkdyn.load(out), np.array([0.0]))
    for i, j in enumerate(parse_expression(e["mechanism"])):
        assert np.abs(sol.point(*a.points[f"P{i}"])[0] * 1e3 - j["position"]).max() < 1e-12
    res = run("import", expr, "-o", tmp_path / "x.toml")          # an expression names no input
    assert res.exit_code == 2 and "--input" in res.output, res.output


def test_bad_expressions_name_the_joint(tmp_path):
    file = tmp_path / "bad.txt"
    file.write_text("M[J[R, P[0, 0], L[ground, L1]], J[R, P[1, oops], L[L1]]]")
    res = run("import", file, "--input", "0,1")
    assert res.exit_code == 2 and "joint 1" in res.output and "bad.txt" in res.output, res.output
    res = run("import", file, "--input", "zero")
    assert res.exit_code == 2 and "--input" in res.output, res.output
    # a slider that joins its slot link to nothing
    file.write_text("M[J[R, P[0, 0], L[ground, L1]], J[R, P[1, 0], L[L1, L2]], "
                    "J[RP, A[0], P[2, 0], L[L2]]]")
    res = run("import", file, "--input", "0,1")
    assert res.exit_code == 2 and "joint 2 is of type RP on link 'L2'" in res.output \
        and "Traceback" not in res.output, res.output


def test_the_documented_pyslvs_commands_run(tmp_path, monkeypatch):
    """docs/cli.md's Pyslvs commands, on the Jansen expression and a Crank rocker project."""
    pytest.importorskip("yaml", reason="Pyslvs projects need PyYAML (the pyslvs extra)")
    import yaml

    doc = (Path(__file__).resolve().parents[1] / "docs" / "cli.md").read_text("utf-8")
    block = doc[doc.index("### Pyslvs"):]
    block = block[block.index("```sh") + 5:]
    lines = [x.split() for x in block[:block.index("```")].splitlines() if x.strip()]
    assert len(lines) == 2 and all(x[:2] == ["linkdyn", "import"] for x in lines)
    monkeypatch.chdir(tmp_path)
    Path("jansen.txt").write_text(EXAMPLES["Jansen's linkage (Single)"]["mechanism"])
    Path("project.pyslvs").write_text(yaml.safe_dump(EXAMPLES["Crank rocker"]))
    for x in lines:
        res = run(*x[1:])
        assert res.exit_code == 0, (x, res.output)
    for out in ("jansen.toml", "project.toml"):
        assert linkdyn.load(out).bodies
