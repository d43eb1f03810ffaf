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


def _page_data(out):
    text = (out / "sweep.html").read_text("utf-8")
    return json.loads(re.search(r'<script id="linkdyn-data" type="application/json">(.*?)'
                                r'</script>', text, re.S).group(1))


def test_the_sweep_page_shows_every_number_in_the_files_units(swept):
    """Hoeken's file is in mm and deg: the page's columns are the table's (SI) turned by hand
    (deg = rad * 180/pi, mm = m * 1000), each with its unit, and the summary names the units."""
    out, df, _ = swept
    data = _page_data(out)
    assert json.loads((out / "summary.json").read_text())["units"] == {"length": "mm",
                                                                       "angle": "deg"}
    col = lambda c: np.array([np.nan if v is None else v for v in data["cols"][c]])  # noqa
    np.testing.assert_allclose(col("min_transmission_angle"),
                               df.min_transmission_angle * 180 / np.pi, rtol=1e-13)
    np.testing.assert_allclose(col("peak_tau_J1"), df.peak_tau_J1, rtol=1e-15)
    np.testing.assert_array_equal(col("bodies.ground.points.O4[0]"), df["bodies.ground.points.O4[0]"])
    assert data["units"] == {"min_transmission_angle": "deg", "peak_tau_J1": "N m",
                             "bodies.ground.points.O4[0]": "mm",
                             "bodies.coupler.points.O3[0]": "mm"}
    # designs on a bound of a --vary range: the grid's first and last values
    assert data["ranges"] == {"bodies.ground.points.O4[0]": [40.0, 200.0],
                              "bodies.coupler.points.O3[0]": [60.0, 140.0]}
    for c, (lo, hi) in data["ranges"].items():
        want = np.where(df[c] == lo, -1, np.where(df[c] == hi, 1, 0))
        assert data["edges"][c] == want.tolist()
    assert data["pair"] == ["peak_tau_J1", "min_transmission_angle"]


def test_a_design_near_a_bound_is_at_it_and_one_inside_is_not():
    from linkdyn.report.sweep import at_bounds
    # range 40..200, width 160: within 1.6 of a bound is at it
    got = at_bounds([40.0, 41.5, 41.7, 120.0, 198.4, 198.3, 200.0, np.nan], 40.0, 200.0)
    assert got.tolist() == [-1, -1, 0, 0, 1, 0, 1, 0]


def test_the_default_axes_are_the_pair_of_metrics_that_trade_off_most():
    """Three metrics: a and b improve together, c worsens as they do (c maximized, so its cost
    -c rises with a). The pair with the most negative Spearman rho of their costs (here
    pandas' ranks and numpy's Pearson correlation of them) is the default."""
    pd = pytest.importorskip("pandas", reason="the sweep's table needs pandas (the parquet extra)")
    from linkdyn.report.sweep import trade_off
    rng = np.random.default_rng(3)
    x = rng.uniform(0, 1, 40)
    df = pd.DataFrame({"design": np.arange(40), "valid": x < 0.9,
                       "peak_tau_J1": x + 0.05 * rng.normal(size=40),
                       "path_deviation": x ** 2 + 0.3 * rng.normal(size=40),
                       "min_transmission_angle": x + 0.1 * rng.normal(size=40)})
    ok = df[df.valid]
    names = ["peak_tau_J1", "path_deviation", "min_transmission_angle"]
    cost = {"peak_tau_J1": ok.peak_tau_J1, "path_deviation": ok.path_deviation,
            "min_transmission_angle": -ok.min_transmission_angle}
    rho = {(a, b): np.corrcoef(cost[a].rank(), cost[b].rank())[0, 1]
           for i, a in enumerate(names) for b in names[i + 1:]}
    want = min(rho, key=rho.get)
    assert rho[want] < -0.5 and trade_off(df, names) == list(want)


def test_the_sweep_page_in_the_browser(browser, swept):
    """One page load at 1440x900 then 390x844: senses, units, the colour map, the filters,
    the marks on range bounds and what stays in view."""
    out, df, _ = swept
    pg = browser.new_page(viewport={"width": 1440, "height": 900})
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.goto((out / "sweep.html").resolve().as_uri())
    pg.wait_for_function("window.__linkdynSweep === true")
    rows = lambda sel: sorted(pg.eval_on_selector_all(  # noqa: E731
        sel, "es => es.map(e => +e.getAttribute('data-row'))"))
    ok = df[df.valid]
    deg = df.min_transmission_angle * 180 / np.pi
    # the default axes are the two metrics, each titled with its unit and its sense
    assert pg.input_value("#sx") == "peak_tau_J1"
    assert pg.input_value("#sy") == "min_transmission_angle"
    ticks = pg.eval_on_selector("#scatter svg", "e => e.textContent")
    assert "peak_tau_J1 (N m), smaller is better" in ticks
    assert "min_transmission_angle (deg), larger is better" in ticks
    # the front of the two metrics, each in its sense, is the one drawn in red
    v = df.valid.to_numpy()
    front = _front_min_max(np.where(v, df.peak_tau_J1, np.nan),
                           np.where(v, df.min_transmission_angle, np.nan))
    assert rows("#scatter circle.front") == front
    # best designs by the angle: the largest first, its column first, in degrees
    pg.select_option("#bm", "min_transmission_angle")
    want = ok.sort_values("min_transmission_angle", ascending=False).index[:3].tolist()
    assert pg.eval_on_selector_all("#best tbody tr", "es => es.map(e => +e.dataset.row)") == want
    assert "(larger)" in pg.inner_text("#bm option[value='min_transmission_angle']")
    assert "(smaller)" in pg.inner_text("#bm option[value='peak_tau_J1']")
    assert pg.get_attribute("#preview", "src") == f"design-{df.design[want[0]]}.html"
    heads = pg.eval_on_selector_all("#best thead th", "es => es.map(e => e.textContent)")
    assert heads[:2] == ["design", "min_transmission_angle (deg)"]
    first = pg.inner_text(f"#best tbody tr[data-row='{want[0]}'] td[data-col='min_transmission_angle']")
    assert float(first) == pytest.approx(deg[want[0]], rel=1e-3)
    # a cell on a bound of its range is marked, and so is the design's point
    edge = {c: (df[c] == lo) | (df[c] == hi) for c, (lo, hi) in
            _page_data(out)["ranges"].items()}
    any_edge = edge["bodies.ground.points.O4[0]"] | edge["bodies.coupler.points.O3[0]"]
    assert rows("#scatter circle.edge") == np.flatnonzero(any_edge & v).tolist()
    marked = pg.eval_on_selector_all("#best td.edge", "es => es.map(e => [+e.parentNode.dataset"
                                     ".row, e.dataset.col])")
    assert sorted(marked) == sorted([k, c] for k in want for c in edge if edge[c][k])
    # at 1440 x 900 the plot and the ranking metric's column are in view without scrolling
    for sel in ("#scatter svg", "#best th[data-col='min_transmission_angle']",
                f"#best td[data-col='min_transmission_angle']"):
        b = pg.locator(sel).first.bounding_box()
        assert b["x"] >= 0 and b["y"] >= 0 and b["x"] + b["width"] <= 1440 and \
            b["y"] + b["height"] <= 900, sel
    # colour by a parameter: its smallest value at the ramp's start, its largest at its end
    pg.select_option("#sc", "bodies.ground.points.O4[0]")
    fill = lambda k: pg.eval_on_selector(f"#scatter circle[data-row='{k}']",  # noqa: E731
                                         "e => e.style.fill")
    o4 = df["bodies.ground.points.O4[0]"][v]
    assert fill(o4.idxmin()) == "rgb(68, 1, 84)" and fill(o4.idxmax()) == "rgb(253, 231, 37)"
    assert "mm" in pg.inner_text("#colorbar")
    # a filter: the angle at least 30 deg keeps those designs only, in the plot and the table
    pg.fill("#filters tr[data-col='min_transmission_angle'] input[data-limit='min']", "30")
    keep = np.flatnonzero(v & (deg >= 30).to_numpy()).tolist()
    assert 0 < len(keep) < v.sum()
    assert rows("#scatter circle.pt") == keep
    assert set(rows("#best tbody tr")) <= set(keep)
    assert rows("#scatter circle.front") == [k for k in front if k in keep]
    assert f"{len(keep)} of {len(df)} designs meet the filters" in pg.inner_text("#filternote")
    # on a phone the ranking metric's column is still the first after the design's number
    pg.set_viewport_size({"width": 390, "height": 844})
    b = pg.locator("#best th[data-col='min_transmission_angle']").bounding_box()
    assert b["x"] >= 0 and b["x"] + b["width"] <= 390
    assert pg.evaluate("document.documentElement.scrollWidth") <= 390
    assert errors == []
    pg.close()
