"""Mass that follows the geometry: a body's mass properties composed of uniform bars between
its points (``bars``), checked against the closed forms of a bar and of two bars by the
parallel-axis theorem written here, Hoeken's own table (its coupler is a uniform bar), the file
round trip, and a sweep that moves a point and with it the mass, against each design read alone."""

from __future__ import annotations

import math

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main

HOEKEN = linkdyn.example_path("hoeken")


def with_bars(text: str, body: str, bars: str) -> str:
    """Hoeken's file with ``body``'s mass, com, inertia and inertia_about replaced by ``bars``."""
    start = text.index(f'name = "{body}"')
    end = text.index("[[", start)
    block = text[start:end]
    kept = [ln for ln in block.splitlines()
            if not ln.startswith(("mass", "com", "inertia"))]
    return text[:start] + "\n".join(kept).rstrip() + f"\nbars = {bars}\n\n" + text[end:]


def load(tmp_path, text, name="m.toml"):
    path = tmp_path / name
    path.write_text(text, "utf-8")
    return linkdyn.load(path), path


def test_hoekens_coupler_is_a_uniform_bar(tmp_path):
    base = linkdyn.load(HOEKEN)
    text = with_bars(HOEKEN.read_text("utf-8"), "coupler", '[{ between = ["O2", "P"], mass = 5.0 }]')
    m, _ = load(tmp_path, text)
    a, b = base.body("coupler"), m.body("coupler")
    # m L^2 / 12 about the midpoint: the paper's table (88473.6 kg mm^2 about O2, less m d^2)
    assert b.mass == 5.0 and b.com == pytest.approx(a.com, abs=1e-15)
    assert b.inertia == pytest.approx(5.0 * 0.2304 ** 2 / 12, rel=1e-12)
    assert b.inertia == pytest.approx(a.inertia, rel=1e-12)
    t = np.linspace(0.0, 4 / 3, 73)
    assert linkdyn.analyze(m, t).effort("J1") == pytest.approx(
        linkdyn.analyze(base, t).effort("J1"), rel=1e-10, abs=1e-12)


def test_two_bars_compose_by_the_parallel_axis_theorem(tmp_path):
    # an L: 1.2 kg from O2 to O3 (115.2 mm along x), then 0.8 kg/m ... per mm from O3 up 60 mm
    text = HOEKEN.read_text("utf-8").replace(
        'points = { O2 = [0.0, 0.0], O3 = [115.2, 0.0], P = [230.4, 0.0] }',
        'points = { O2 = [0.0, 0.0], O3 = [115.2, 0.0], P = [230.4, 0.0], Q = [115.2, 60.0] }')
    assert "Q = [115.2, 60.0]" in text
    text = with_bars(text, "coupler", '[{ between = ["O2", "O3"], mass = 1.2 }, '
                                      '{ between = ["O3", "Q"], mass_per_length = 0.01 }]')
    m, _ = load(tmp_path, text)
    b = m.body("coupler")
    m1, l1, c1 = 1.2, 0.1152, np.array([0.0576, 0.0])
    m2, l2, c2 = 0.01 * 60.0, 0.060, np.array([0.1152, 0.030])
    c = (m1 * c1 + m2 * c2) / (m1 + m2)
    i = m1 * l1 ** 2 / 12 + m1 * np.sum((c1 - c) ** 2) + m2 * l2 ** 2 / 12 + m2 * np.sum((c2 - c) ** 2)
    assert b.mass == pytest.approx(m1 + m2, rel=1e-15)
    assert b.com == pytest.approx(c, abs=1e-15)
    assert b.inertia == pytest.approx(i, rel=1e-12)


def test_bars_are_written_back_as_bars(tmp_path):
    text = with_bars(HOEKEN.read_text("utf-8"), "coupler",
                     '[{ between = ["O2", "P"], mass_per_length = 0.0217 }]')
    m, _ = load(tmp_path, text)
    linkdyn.save(m, tmp_path / "again.toml")
    import tomllib
    again = tomllib.loads((tmp_path / "again.toml").read_text("utf-8"))
    coupler = next(b for b in again["bodies"] if b["name"] == "coupler")
    assert coupler["bars"] == [{"between": ["O2", "P"], "mass_per_length": 0.0217}]
    assert "mass" not in coupler
    m2 = linkdyn.load(tmp_path / "again.toml")
    assert m2.body("coupler").inertia == pytest.approx(m.body("coupler").inertia, rel=1e-12)


def test_a_sweep_moves_the_mass_with_the_points(tmp_path):
    pytest.importorskip("pandas", reason="the sweep's table needs pandas (the parquet extra)")
    text = with_bars(HOEKEN.read_text("utf-8"), "coupler",
                     '[{ between = ["O2", "P"], mass_per_length = 0.0217 }]')
    m, path = load(tmp_path, text)
    t = np.linspace(0.0, 4 / 3, 61)
    xs = [200.0, 230.4, 260.0]
    df = linkdyn.sweep(m, {"bodies.coupler.points.P[0]": xs}, t, metrics=["peak_tau_J1"],
                       backend="numpy")
    for x, got in zip(xs, df["peak_tau_J1"]):
        alone, _ = load(tmp_path, text.replace("P = [230.4, 0.0]", f"P = [{x}, 0.0]"), "d.toml")
        # the longer coupler is heavier and its inertia grows as L^3
        assert alone.body("coupler").mass == pytest.approx(0.0217 * x)
        want = float(np.max(np.abs(linkdyn.analyze(alone, t).effort("J1"))))
        assert got == pytest.approx(want, rel=1e-9)
    assert df["peak_tau_J1"].iloc[0] != pytest.approx(df["peak_tau_J1"].iloc[2], rel=1e-3)


@pytest.mark.parametrize("bars, field, words", [
    ('[{ between = ["O2", "Z"], mass = 1.0 }]', "bodies.coupler.bars[0].between[1]", "no point 'Z'"),
    ('[{ between = ["O2", "P"] }]', "bodies.coupler.bars[0]", "exactly one of mass"),
    ('[{ between = ["O2", "P"], mass = 1.0, mass_per_length = 0.1 }]', "bodies.coupler.bars[0]",
     "exactly one of mass"),
    ('[{ between = ["O2"], mass = 1.0 }]', "bodies.coupler.bars[0].between", "two point names"),
    ('[]', "bodies.coupler.bars", "no bars"),
])
def test_a_bad_bar_is_named_with_its_fix(tmp_path, bars, field, words):
    path = tmp_path / "bad.toml"
    path.write_text(with_bars(HOEKEN.read_text("utf-8"), "coupler", bars), "utf-8")
    res = CliRunner().invoke(main, ["check", str(path)])
    assert res.exit_code == 2 and "Traceback" not in res.output
    assert field in res.output and words in res.output, res.output


def test_bars_and_a_mass_together_are_refused(tmp_path):
    text = HOEKEN.read_text("utf-8").replace(
        "mass = 5.0", 'mass = 5.0\nbars = [{ between = ["O2", "P"], mass = 5.0 }]', 1)
    path = tmp_path / "both.toml"
    path.write_text(text, "utf-8")
    res = CliRunner().invoke(main, ["check", str(path)])
    assert res.exit_code == 2 and "takes its mass from them" in res.output
