"""A spatial mechanism at a singular position is never answered with wrong numbers (issue 24,
item 3): a slider-crank driven by its slider into a dead centre, which Newton's method closes
to rounding a hair off the singular configuration (the dependent joints' Jacobian keeping a
smallest singular value of ~1e-8 of its largest), is flagged by the closure's resolution
(``kinematics.positions.singular``: exit 3 naming the time and the slider's value; with
``--allow-singular`` a gap), while a sample near the dead centre keeps its numbers, checked
against the slider-crank's statics by virtual work. The old rank test (1e-9 of the largest)
let the dead centre through with a slider force of ~1e13 N at exit 0. Planar ``analyze``
applies the same test (a geared five-bar stretched by its crank, closed by Newton's method);
and a spatial run whose loops stop closing writes gaps past the branch's end with
``--allow-singular``, as a planar one (issue 24, "Left")."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from scipy.optimize import brentq

import linkdyn
from linkdyn.cli import main
from linkdyn.io import model_from_dict
from linkdyn.kinematics.positions import singular

EXAMPLES = Path(linkdyn.__file__).with_name("examples") / "spatial"


def table(path):
    names = path.read_text().splitlines()[0].split(",")
    return dict(zip(names, np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2).T))


def same_as_alone(rows: dict, alone, kept, size: float) -> None:
    """The rows ``kept`` of a run with gaps equal the solution ``alone`` of those samples
    alone, column by column, to 1e-9 of the column's peak; a column of rounding alone (the
    out-of-plane reactions of a planar motion) to 1e-14 of its unit's largest (a moment's: of
    the largest force times the mechanism's ``size``, m): a few units of rounding, which
    Newton's solution of a sample leaves different from different guesses."""
    cols, units = alone.columns(), alone.units()
    assert list(cols) == list(rows)
    family = {}
    for k, v in cols.items():
        family[units[k]] = max(family.get(units[k], 0.0), float(np.max(np.abs(v))))
    family["N m"] = max(family.get("N m", 0.0), family.get("N", 0.0) * size)
    for name, v in cols.items():
        scale = max(float(np.max(np.abs(v))), 1e-5 * family[units[name]], 1e-300)
        np.testing.assert_allclose(rows[name][kept], v, rtol=0, atol=1e-9 * scale, err_msg=name)


# ------------------------------------------------ the bundled slider-crank driven by its slider
# its guide: S + s e (mm), its crank: radius 30 mm about +z at the origin, its rod B-C
S, E, CRANK = np.array([0.0, 40.0, 60.0]), np.array([0.8, 0.0, 0.6]), 30.0
ROD2 = 44.0 ** 2 + 40.0 ** 2 + 115.5 ** 2        # |C - B|^2 at the design pose, mm^2


def dead_centre() -> float:
    """The slider's coordinate s (mm from S) where crank and rod line up seen along the crank
    axis, the crank pointing away from the pin C: the farthest crank pin B is the rod's
    length from C, ``(|C_xy| + r)^2 + C_z^2 = L^2``; the crank angle then no longer follows
    from s (a dead centre of the slider as driver)."""
    def reach(s):
        c = S + s * E
        return (np.hypot(c[0], c[1]) + CRANK) ** 2 + c[2] ** 2 - ROD2
    return brentq(reach, 0.0, 92.5, xtol=1e-13)


def slider_driven(tmp_path, samples: int) -> tuple[Path, float]:
    """The bundled spatial slider-crank with its driver moved to the slider: from its design
    pose (s = 92.5 mm) down to the dead centre at t = pi/2 s and back over pi s."""
    text = (EXAMPLES / "spatial_slider_crank.toml").read_text()
    head, rest = text.split("[[drivers]]")
    rest = rest.split("[[loads]]", 1)[1]
    s0 = dead_centre()
    driver = (f'[[drivers]]\njoint = "J4"\nmotion = {{ kind = "expression", '
              f'q = "{s0!r} + {92.5 - s0!r}*(1 - sin(t))" }}\n\n[[loads]]')
    body = head + driver + rest
    body = body.replace("cycles = 1", "duration = 3.141592653589793")
    body = body.replace("samples = 121", f"samples = {samples}")
    path = tmp_path / "slider_driven.toml"
    path.write_text(body)
    return path, s0


@pytest.mark.parametrize("samples", [21, 121])
def test_a_dead_centre_reached_by_the_slider_exits_3(tmp_path, samples):
    """Exit 3 naming the time (pi/2 s) and the slider's value there (the dead centre, mm);
    ``check`` says the same; nothing written."""
    path, s0 = slider_driven(tmp_path, samples)
    for command in (["analyze", str(path), "-o", str(tmp_path / "out")], ["check", str(path)]):
        res = CliRunner().invoke(main, command)
        assert res.exit_code == 3, res.output
        assert "singular position" in res.output and "Traceback" not in res.output
        assert f"at t = 1.5708 s (q_J4 = {s0:.6g} mm)" in res.output, res.output
    assert not (tmp_path / "out").exists()


def test_allow_singular_makes_the_dead_centre_a_gap(tmp_path):
    """With ``--allow-singular`` the dead-centre row is NaN, named in the summary, and every
    other row is the run without that sample's, to 1e-9 of each column's peak."""
    path, _ = slider_driven(tmp_path, 21)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["analyze", str(path), "-o", str(out), "--allow-singular"])
    assert res.exit_code == 0, res.output
    t = np.linspace(0.0, np.pi, 21)
    bad = np.arange(21) == 10
    summary = json.loads((out / "summary.json").read_text())
    assert summary["invalid_samples"] == 1
    assert summary["invalid_times_s"] == pytest.approx([t[10]], abs=1e-12)
    rows = table(out / "results.csv")
    assert all(np.all(np.isnan(v[bad])) for k, v in rows.items() if k != "t")
    assert all(np.all(np.isfinite(v[~bad])) for v in rows.values())
    same_as_alone(rows, linkdyn.analyze(linkdyn.load(path), t[~bad]), ~bad, 0.12)
    # the slider's force stays that of a mechanism away from its dead centre: tens of newtons
    assert np.max(np.abs(rows["force_J4"][~bad])) < 100.0


# ------------------------------------------- a planar slider-crank in space, statics near the dead centre
R, L, TORQUE = 0.1, 0.3, 2.0          # crank, rod (m), the couple on the crank (N m, about +z)


def inline(delta: float) -> dict:
    """An in-line slider-crank in the plane z = 0 written as a spatial model (crank at 60 deg
    at the design pose), a couple on the crank, no gravity; the slider driven by ``s(t) = R +
    L - delta + delta (t - 1)^3``: at rest (s' = s'' = 0) at t = 1 s, ``delta`` short of the
    outer dead centre, and at the dead centre itself at t = 2 s."""
    c, s = np.cos(np.pi / 3), np.sin(np.pi / 3)
    a = [float(R * c), float(R * s), 0.0]
    x0 = float(R * c + np.sqrt(L * L - R * R * s * s))

    def body(name, points):
        return {"name": name, "points": points, "mass": 1.0, "inertia": [0.001, 0.002, 0.003]}

    def revolute(name, a_, b_):
        return {"name": name, "type": "revolute", "connect": [a_, b_], "axis": [0, 0, 1]}
    return {"mechanism": {"space": "spatial"},
            "bodies": [{"name": "ground", "points": {"O": [0, 0, 0]}},
                       body("crank", {"O": [0, 0, 0], "A": a}),
                       body("rod", {"A": a, "B": [x0, 0, 0]}), body("slider", {"B": [x0, 0, 0]})],
            "joints": [revolute("J1", "ground.O", "crank.O"), revolute("J2", "crank.A", "rod.A"),
                       revolute("J3", "rod.B", "slider.B"),
                       {"name": "J4", "type": "prismatic", "connect": ["ground.O", "slider.B"],
                        "axis": [1, 0, 0]}],
            "drivers": [{"joint": "J4", "motion": {
                "kind": "expression", "q": f"{R + L!r} - {delta!r} + {delta!r}*(t - 1)**3"}}],
            "loads": [{"kind": "torque", "body": "crank", "value": [0, 0, TORQUE]}]}


def static_force(s: float) -> float:
    """The slider's driving force (N, along +x) holding the couple on the crank at rest with
    the slider at s: virtual work, ``F ds + M dtheta = 0``, with ``s = R cos(theta) +
    sqrt(L^2 - R^2 sin^2(theta))`` on the branch theta > 0."""
    cos = (R * R + s * s - L * L) / (2 * R * s)
    th = np.arccos(cos)
    ds = -R * np.sin(th) * (1 + R * cos / np.sqrt(L * L - R * R * np.sin(th) ** 2))
    return -TORQUE / ds


@pytest.mark.parametrize("delta", [1e-5, 1e-7])
def test_a_sample_near_the_dead_centre_keeps_its_statics(delta):
    """``delta`` (m) short of the dead centre (its smallest singular value ~1e-3 and ~1e-4 of
    the largest) the sample is regular: its slider force is the closed form's to 1e-6
    (hundreds to thousands of newtons: a force of that size is the mechanism's, not a
    singularity's); the dead-centre sample of the same run is a gap, and without
    ``allow_singular`` the run stops there."""
    model = model_from_dict(inline(delta))
    t = np.linspace(0.0, 2.0, 21)
    sol = linkdyn.analyze(model, t, allow_singular=True)
    np.testing.assert_array_equal(sol.valid, np.arange(21) != 20)
    force = sol.columns()["force_J4"][10]
    expected = static_force(R + L - delta)
    assert expected > 300.0
    assert force == pytest.approx(expected, rel=1e-6)
    with pytest.raises(linkdyn.AssemblyError, match="singular position") as err:
        linkdyn.analyze(model, t)
    assert "at t = 2 s (q_J4 = 0.4 m)" in str(err.value), str(err.value)


def test_the_criterion_weighs_conditioning_against_the_residual():
    """``singular``: a conditioning well above the closure's resolution (the square root of
    its residual, or of rounding) is regular; at or below it, or not finite, singular."""
    assert not singular(1e-3, 0.0) and not singular(1e-3, 1e-12)
    assert singular(1e-8, 0.0) and singular(1e-8, 3e-15)       # a dead centre closed to rounding
    assert singular(1e-5, 1e-11)                               # closed only to 1e-11: too near
    assert singular(0.0, 0.0) and singular(np.nan, 1e-16) and singular(0.5, np.nan)


@pytest.mark.parametrize("name", ["hoeken_spatial", "rps3", "rsur", "spatial_slider_crank",
                                  "spherical_fourbar", "stewart"])
def test_the_bundled_spatial_examples_run_clean(name):
    """The bundled driven spatial examples: no sample flagged over their run."""
    from linkdyn.sampling import times
    model = linkdyn.load(EXAMPLES / f"{name}.toml")
    sol = linkdyn.analyze(model, times(model, None, None, None))
    assert np.all(sol.valid)


def test_allow_singular_writes_gaps_where_the_loops_stop_closing(tmp_path):
    """The slider pushed past the dead centre (s from R + L - 0.02 m at 0.041 m/s: out of reach
    from t ~ 0.49 s): exit 3 naming the first sample that does not close (t = 0.5 s, its
    slider value); with ``--allow-singular`` that sample and every later one are NaN rows, as
    a planar branch that ends, and the others are the run without them to 1e-9 of each
    column's peak."""
    from linkdyn.io.writer import dumps_toml

    data = inline(0.0)
    data["drivers"][0]["motion"]["q"] = f"{R + L - 0.02!r} + 0.041*t"
    data["analysis"] = {"duration": 1.0, "samples": 11}
    path = tmp_path / "past_dead_centre.toml"
    path.write_text(dumps_toml(data))
    res = CliRunner().invoke(main, ["analyze", str(path), "-o", str(tmp_path / "refused")])
    assert res.exit_code == 3 and "Traceback" not in res.output, res.output
    assert "the loops stop closing" in res.output
    assert "at t = 0.5 s (q_J4 = 0.4005 m)" in res.output, res.output
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["analyze", str(path), "-o", str(out), "--allow-singular"])
    assert res.exit_code == 0, res.output
    assert "6 samples that do not close or sit at a singular position" in res.output
    t = np.linspace(0.0, 1.0, 11)
    bad = t >= 0.5
    summary = json.loads((out / "summary.json").read_text())
    assert summary["invalid_samples"] == 6
    np.testing.assert_allclose(summary["invalid_times_s"], t[bad], atol=1e-12)
    rows = table(out / "results.csv")
    np.testing.assert_array_equal(rows["t"], t)
    assert all(np.all(np.isnan(v[bad])) for k, v in rows.items() if k != "t")
    assert all(np.all(np.isfinite(v[~bad])) for v in rows.values())
    same_as_alone(rows, linkdyn.analyze(linkdyn.load(path), t[~bad]), ~bad, R + L)


# ------------------------------------------------ the same test on planar models
def stretched_fivebar(tmp_path) -> Path:
    """The bundled geared five-bar with 45 mm links: its crank pins 80 to 94.3 mm apart, the
    two links stretch in line (a dead centre of the crank as driver) where they are 90 mm
    apart, at sin^2(theta) = 0.68; the crank driven there, theta* sin(t), at t = pi/2 of
    [0, pi]. Its loops are closed by Newton's method (a gear joint: no closed form), which
    leaves the relative pivot of J_dep at ~1e-7 (numpy) and ~1e-8 (compiled), above the old
    fixed threshold 1e-10: a driving torque of ~1e9 N m on one backend and ~1e11 on the other
    at exit 0."""
    src = (Path(linkdyn.__file__).with_name("examples") / "geared_fivebar.toml").read_text()
    th = float(np.degrees(np.arcsin(np.sqrt(0.68))))
    for old, new in [("A = [0.0, 0.0], P = [90.0, 0.0]", "A = [0.0, 0.0], P = [45.0, 0.0]"),
                     ("P = [0.0, 0.0], B = [90.0, 0.0]", "P = [0.0, 0.0], B = [45.0, 0.0]"),
                     ("com = [45.0, 0.0]", "com = [22.5, 0.0]"),
                     ("link1 = 63.6, link2 = -63.6", "link1 = 27.27, link2 = -27.27"),
                     ('{ kind = "constant_speed", rpm = 60.0, start = 0.0 }',
                      f'{{ kind = "expression", q = "{th!r}*sin(t)" }}'),
                     ("duration = 1.0 ", "duration = 3.141592653589793 "),
                     ("samples = 361", "samples = 21")]:
        assert old in src, old
        src = src.replace(old, new)
    path = tmp_path / "stretched.toml"
    path.write_text(src)
    return path


@pytest.mark.parametrize("backend", ["numpy", "compiled"])
def test_a_planar_dead_centre_closed_by_newton_is_flagged(tmp_path, backend):
    """Planar ``analyze`` applies the same test (its relative pivots against the closure
    residual): the stretched sample is singular, exit 3 naming its time and crank angle; with
    ``allow_singular`` it alone is invalid and its neighbours keep a torque of a few N m."""
    path = stretched_fivebar(tmp_path)
    model = linkdyn.load(path)
    t = np.linspace(0.0, np.pi, 21)
    with pytest.raises(linkdyn.AssemblyError, match="singular") as err:
        linkdyn.analyze(model, t, backend=backend)
    assert "at t = 1.5708 s (q_J1 = 55.5501 deg)" in str(err.value), str(err.value)
    sol = linkdyn.analyze(model, t, backend=backend, allow_singular=True)
    np.testing.assert_array_equal(sol.valid, np.arange(21) != 10)
    assert np.max(np.abs(sol.columns["tau_J1"][sol.valid])) < 20.0
