"""``compare.csv``: the comparison's table exported at full precision, each design's key result
its own run's number (from its own results.csv), the differences and the best design by hand."""

from __future__ import annotations

import csv

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main

HOEKEN = linkdyn.example_path("hoeken")


def cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_compare_writes_its_table_as_csv(tmp_path):
    slow, fast = tmp_path / "slow.toml", tmp_path / "fast.toml"
    text = HOEKEN.read_text()
    slow.write_text(text)
    fast.write_text(text.replace("rpm = 45.0", "rpm = 60.0"))
    r = cli("compare", slow, fast, "--samples", 25, "--backend", "numpy", "-o", tmp_path / "c")
    assert r.exit_code == 0, r.output
    assert "compare.csv" in r.output
    rows = list(csv.DictReader((tmp_path / "c" / "compare.csv").open(encoding="utf-8")))
    key = {row["name"]: row for row in rows if row["kind"] == "key result"}
    # each design's own run: its torque column from its own results.csv
    for name, path in (("slow", slow), ("fast", fast)):
        assert cli("analyze", path, "--samples", 25, "--backend", "numpy",
                   "-o", tmp_path / name).exit_code == 0
        data = np.genfromtxt(tmp_path / name / "results.csv", delimiter=",", names=True)
        assert float(key["max torque J1"][name]) == pytest.approx(data["tau_J1"].max(),
                                                                  rel=1e-15)
        f = np.hypot(data["Fx_J3"], data["Fy_J3"])
        assert float(key["peak |F| J3"][name]) == pytest.approx(f.max(), rel=1e-12)
    # differences by hand; at 60 rpm instead of 45 the inertia torque is (60/45)^2 times
    row = key["RMS torque J1"]
    a, b = float(row["slow"]), float(row["fast"])
    assert float(row["diff fast"]) == pytest.approx(b - a, rel=1e-12)
    assert float(row["pct fast"]) == pytest.approx(100 * (b - a) / abs(a), rel=1e-12)
    assert b / a == pytest.approx((60 / 45) ** 2, rel=1e-9)
    assert row["sense"] == "min" and row["best"] == "slow"
    # a result both designs share (the path does not depend on the speed): no best
    assert float(key["straightness of coupler.P"]["slow"]) == pytest.approx(
        float(key["straightness of coupler.P"]["fast"]), rel=1e-9)
    assert key["straightness of coupler.P"]["best"] == ""
    assert key["max mechanical advantage coupler/rocker"]["slow"] == "inf"
    fields = {row["name"]: row for row in rows if row["kind"] == "model field"}
    assert set(fields) == {"drivers[0].motion.rpm"}
    assert (float(fields["drivers[0].motion.rpm"]["slow"]),
            float(fields["drivers[0].motion.rpm"]["fast"])) == (45.0, 60.0)
