"""Metric senses: a metric that is better larger (``min_transmission_angle``, a slider's stroke) is
ranked largest first by everything that ranks designs (the sweep's summary and printout, its
best designs and Pareto fronts, ``compare --sweep --by``), ``optimize --maximize`` maximizes it,
and an optimize that meets no constraint exits 3 naming the one nearest to holding."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

import linkdyn
from linkdyn.studies import evaluate_metrics
from linkdyn.studies.metrics import sense
from test_report import browser  # noqa: F401  (the Chromium of the page tests)

HOEKEN = linkdyn.example_path("hoeken")
T = np.linspace(0.0, 4.0 / 3.0, 41)
GRID = ["--vary", "bodies.ground.points.O4[0]=40:200:6", "--vary",
        "bodies.coupler.points.O3[0]=60:140:4"]


def _cli(*args):
    from click.testing import CliRunner

    from linkdyn.cli import main
    return CliRunner().invoke(main, [str(a) for a in args])


@pytest.fixture(scope="module")
def swept(tmp_path_factory):
    """A 24-design grid of Hoeken with its report: (folder, table, printed output)."""
    import pandas as pd
    out = tmp_path_factory.mktemp("senses") / "s"
    r = _cli("sweep", HOEKEN, *GRID, "--samples", 41, "--metric", "peak_tau_J1",
             "--metric", "min_transmission_angle", "--backend", "numpy", "--report", "-o", out)
    assert r.exit_code == 0, r.output
    return out, pd.read_parquet(out / "designs.parquet"), r.output


def test_senses_are_those_a_designer_means():
    assert sense("min_transmission_angle") == "max" and sense("stroke_J4") == "max"
    for m in ("peak_tau_J1", "rms_force_J4", "peak_F_J2", "path_deviation",
              "peak_shaking_force", "flywheel_inertia"):
        assert sense(m) == "min"


def test_a_sweep_names_the_largest_transmission_angle_best(swept):
    out, df, printed = swept
    ok = df[df.valid]
    assert 3 < len(ok) < len(df)   # invalid designs take no part
    best_mu = int(ok.design[ok.min_transmission_angle.idxmax()])
    best_tau = int(ok.design[ok.peak_tau_J1.idxmin()])
    s = json.loads((out / "summary.json").read_text())["metrics"]
    assert s["min_transmission_angle"]["best_design"] == best_mu
    assert s["min_transmission_angle"]["sense"] == "max"
    assert s["min_transmission_angle"]["best"] == ok.min_transmission_angle.max()
    assert s["peak_tau_J1"]["best_design"] == best_tau and s["peak_tau_J1"]["unit"] == "N m"
    # printed in the model file's angle unit (deg), its range the table's (SI) in degrees
    mu = ok.min_transmission_angle
    assert (f"min_transmission_angle   {np.degrees(mu.min()):.6g} .. {np.degrees(mu.max()):.6g} "
            f"deg  (best: design {best_mu}, the largest)") in printed
    assert re.search(rf"peak_tau_J1 .* N m  \(best: design {best_tau}, the smallest\)", printed)
    # the best designs with their own report pages: the largest angles, not the smallest
    from linkdyn.studies.runner import best_designs
    rows = best_designs(df, ["min_transmission_angle"])
    assert list(df.min_transmission_angle[rows]) == sorted(ok.min_transmission_angle,
                                                           reverse=True)[:3]
    assert (out / f"design-{best_mu}.html").is_file()


def _front_min_max(a, b):
    """The Pareto front of ``a`` minimized and ``b`` maximized, by its definition, O(n^2)."""
    ok = np.isfinite(a) & np.isfinite(b)
    return [i for i in range(len(a)) if ok[i] and not any(
        ok[j] and a[j] <= a[i] and b[j] >= b[i] and (a[j] < a[i] or b[j] > b[i])
        for j in range(len(a)))]


def test_the_sweep_pages_front_maximizes_the_transmission_angle(swept):
    out, df, _ = swept
    text = (out / "sweep.html").read_text("utf-8")
    data = json.loads(re.search(r'<script id="linkdyn-data" type="application/json">(.*?)'
                                r'</script>', text, re.S).group(1))
    assert data["senses"] == {"peak_tau_J1": "min", "min_transmission_angle": "max"}
    v = df.valid.to_numpy()
    want = _front_min_max(np.where(v, df.peak_tau_J1, np.nan),
                          np.where(v, df.min_transmission_angle, np.nan))
    assert data["fronts"]["peak_tau_J1|min_transmission_angle"] == want
    # the design with the largest angle is on it, the one with the smallest is not
    ok = df[df.valid]
    assert ok.min_transmission_angle.idxmax() in want
    assert ok.min_transmission_angle.idxmin() not in want or \
        ok.peak_tau_J1.idxmin() == ok.min_transmission_angle.idxmin()


def test_compare_by_a_larger_is_better_metric_takes_the_largest(swept, tmp_path):
    out, df, _ = swept
    r = _cli("compare", "--sweep", out, "--by", "min_transmission_angle", "--best", 2,
             "--samples", 41, "-o", tmp_path / "c")
    assert r.exit_code == 0, r.output
    rows = [v["sweep"] for v in json.loads((tmp_path / "c" / "compare.json").read_text())
            .values() if "sweep" in v]
    ok = df[df.valid].sort_values("min_transmission_angle", ascending=False)
    assert [row["design"] for row in rows] == ok.design.tolist()[:2]


def test_optimize_maximize_finds_the_largest_transmission_angle(tmp_path):
    box = "bodies.ground.points.O4[0]=80:100"
    r = _cli("optimize", HOEKEN, "--vary", box, "--maximize", "min_transmission_angle",
             "--samples", 41, "--popsize", 5, "--maxiter", 6, "--backend", "numpy",
             "-o", tmp_path)
    assert r.exit_code == 0, r.output
    info = json.loads((tmp_path / "optimize.json").read_text())
    assert info["sense"] == "max" and info["maximize"] == "min_transmission_angle"
    # the written design analyzes to the reported angle, and no design of a fine grid of the
    # same range has a larger one
    got = evaluate_metrics(linkdyn.analyze(linkdyn.load(tmp_path / "best.toml"), T,
                                           backend="numpy"), ["min_transmission_angle"])
    mu = info["metrics"]["min_transmission_angle"]
    assert got["min_transmission_angle"] == pytest.approx(mu, rel=1e-12)
    grid = linkdyn.sweep(HOEKEN, {"bodies.ground.points.O4[0]": np.linspace(80, 100, 41)}, T,
                         metrics=["min_transmission_angle"], backend="numpy")
    assert mu >= grid.min_transmission_angle.max() - 1e-9
    assert "maximized" in (tmp_path / "best.toml").read_text().splitlines()[0]


def test_optimize_needs_exactly_one_objective(tmp_path):
    for args in ([], ["--minimize", "peak_tau_J1", "--maximize", "min_transmission_angle"]):
        r = _cli("optimize", HOEKEN, "--vary", "bodies.ground.points.O4[0]=85:95", *args,
                 "--samples", 11, "-o", tmp_path)
        assert r.exit_code == 2 and "--maximize METRIC" in r.output, r.output
        assert "Traceback" not in r.output


def test_an_infeasible_optimize_exits_3_naming_the_nearest_constraint(tmp_path):
    from linkdyn.studies.optimize import optimize
    box = {"bodies.ground.points.O4[0]": (85.0, 95.0)}
    cons = ["path_deviation<=0.001mm", "min_transmission_angle>=10deg"]
    res = optimize(HOEKEN, box, T, "peak_tau_J1", cons, popsize=5, maxiter=4,
                   backend="numpy")
    assert not res.feasible
    (c, miss), = res.misses()   # the angle holds; the straightness cannot
    assert c.metric == "path_deviation"
    dev = evaluate_metrics(linkdyn.analyze(res.model, T, backend="numpy"),
                           ["path_deviation"])["path_deviation"]
    assert miss == pytest.approx(dev - 1e-6, rel=1e-9)
    r = _cli("optimize", HOEKEN, "--vary", "bodies.ground.points.O4[0]=85:95",
             "--minimize", "peak_tau_J1", *[a for c in cons for a in ("--constraint", c)],
             "--samples", 41, "--popsize", 5, "--maxiter", 4, "--backend", "numpy",
             "-o", tmp_path / "o")
    assert r.exit_code == 3, r.output
    assert "Traceback" not in r.output
    m = re.search(r"nearest to holding is path_deviation <= 0\.001 mm, missed by ([0-9.e+-]+) "
                  r"mm \(path_deviation = ([0-9.e+-]+) mm\)", r.output)
    assert m, r.output
    assert float(m.group(1)) == pytest.approx(float(m.group(2)) - 0.001, abs=1e-3)
    assert float(m.group(2)) == pytest.approx(dev * 1e3, rel=1e-3)
    assert not (tmp_path / "o" / "best.toml").exists()


def test_stroke_of_a_slider_crank_is_the_closed_form_and_the_summarys_travel():
    """Offset slider-crank (crank r 50, rod l 180, offset e 20 mm): the slider's extreme
    positions are at the crank in line with the rod, x = sqrt((l +- r)^2 - e^2)."""
    path = linkdyn.example_path("slider_crank")
    r, l, e = 50.0, 180.0, 20.0
    want = (np.sqrt((l + r) ** 2 - e ** 2) - np.sqrt((l - r) ** 2 - e ** 2)) * 1e-3
    t = np.linspace(0.0, 0.2, 121)   # one turn at 300 rpm
    assert sense("stroke_J4") == "max"
    df = linkdyn.sweep(path, {"bodies.rod.points.B[0]": [180.0, 200.0]}, t,
                       metrics=["stroke_J4"], backend="numpy")
    assert df.stroke_J4[0] == pytest.approx(want, rel=1e-6)   # refined between samples
    l = 200.0
    assert df.stroke_J4[1] == pytest.approx(
        (np.sqrt((l + r) ** 2 - e ** 2) - np.sqrt((l - r) ** 2 - e ** 2)) * 1e-3, rel=1e-6)
    sol = linkdyn.analyze(linkdyn.load(path), t, backend="numpy")
    assert evaluate_metrics(sol, ["stroke_J4"])["stroke_J4"] == \
        linkdyn.design.summary(sol)["joint_travel"]["J4"]["range"]


@pytest.mark.parametrize("width, height", [(1440, 900), (390, 844)])
def test_the_sweep_pages_best_designs_follow_the_sense(browser, swept, width, height):
    out, df, _ = swept
    pg = browser.new_page(viewport={"width": width, "height": height})
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.goto((out / "sweep.html").resolve().as_uri())
    pg.wait_for_function("window.__linkdynSweep === true")
    pg.select_option("#bm", "min_transmission_angle")
    ok = df[df.valid]
    want = ok.sort_values("min_transmission_angle", ascending=False).index[:3].tolist()
    assert pg.eval_on_selector_all("#best tbody tr", "es => es.map(e => +e.dataset.row)") == want
    assert "(larger)" in pg.inner_text("#bm option[value='min_transmission_angle']")
    assert "(smaller)" in pg.inner_text("#bm option[value='peak_tau_J1']")
    assert pg.get_attribute("#preview", "src") == f"design-{df.design[want[0]]}.html"
    # the front of the two metrics, each in its sense, is the one drawn in red
    pg.select_option("#sx", "peak_tau_J1")
    pg.select_option("#sy", "min_transmission_angle")
    red = sorted(pg.eval_on_selector_all("#scatter circle.front",
                                         "es => es.map(e => +e.getAttribute('data-row'))"))
    v = df.valid.to_numpy()
    assert red == _front_min_max(np.where(v, df.peak_tau_J1, np.nan),
                                 np.where(v, df.min_transmission_angle, np.nan))
    assert errors == []
    pg.close()
