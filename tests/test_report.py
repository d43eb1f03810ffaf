"""report.html: one self-contained offline file, checked in a real browser.

The browser is Debian's headless Chromium driven by Playwright through ``executable_path``
(Playwright's own browser download is not used). Locally the browser tests skip when Chromium or
Playwright is missing; with ``CI=true`` they fail instead, so CI cannot pass without them.
"""

from __future__ import annotations

import base64
import io
import json
import os
import re
import shutil

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn import design, report
from linkdyn.cli import main

CHROMIUM_ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                 "--disable-background-networking", "--disable-component-update",
                 "--disable-sync"]
IN_CI = os.environ.get("CI", "").strip().lower() in ("true", "1", "yes")


def _chromium() -> str | None:
    for path in ("/usr/bin/chromium", "/usr/bin/chromium-browser"):
        if os.path.exists(path):
            return path
    return shutil.which("chromium") or shutil.which("chromium-browser")


def _unavailable(why: str):
    if IN_CI:
        pytest.fail(f"{why} (CI=true: the browser tests must run; .ci/run installs chromium)")
    pytest.skip(why)


def _analyze(tmp_path, example: str, *extra: str):
    tmp_path.mkdir(parents=True, exist_ok=True)
    model = tmp_path / f"{example}.toml"
    model.write_text(linkdyn.example_path(example).read_text("utf-8"), "utf-8")
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["analyze", str(model), "-o", str(out), *extra])
    assert res.exit_code == 0, res.output
    return out


@pytest.fixture(scope="module")
def hoeken_report(hoeken_report_run):
    return hoeken_report_run / "report.html"


@pytest.fixture(scope="module")
def browser():
    exe = _chromium()
    if exe is None:
        _unavailable("Chromium is not installed (apt-get install chromium)")
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        _unavailable("playwright is not installed (pip install playwright)")
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=exe, args=CHROMIUM_ARGS)
        yield b
        b.close()


class Page:
    """A page with every console error and uncaught exception recorded (an uncaught exception
    arrives as ``pageerror``, not as a console message)."""

    def __init__(self, browser, path, width=1400, height=1000):
        self.page = browser.new_page(viewport={"width": width, "height": height})
        self.errors: list[str] = []
        self.requests: list[str] = []
        self.page.on("console", lambda m: m.type == "error" and self.errors.append(m.text))
        self.page.on("pageerror", lambda e: self.errors.append(f"pageerror: {e}"))
        self.page.on("request", lambda r: self.requests.append(r.url))
        self.page.goto(path.resolve().as_uri())
        self.page.wait_for_function("window.__linkdynFrame === 0")

    def frame(self) -> int:
        return self.page.evaluate("window.__linkdynFrame")

    def close(self):
        self.page.close()


@pytest.fixture
def page(browser, hoeken_report):
    pg = Page(browser, hoeken_report)
    yield pg
    pg.close()


# ---------------------------------------------------------------------------- the file

def test_report_is_one_self_contained_file(tmp_path, hoeken_report_run):
    base = set(os.listdir(_analyze(tmp_path / "a", "hoeken")))
    with_report = set(os.listdir(hoeken_report_run))   # the same run with --report
    # SPEC: --report adds the plots and one self-contained report.html
    added = with_report - base
    assert "report.html" in added and not any(f.endswith(".html") for f in added - {"report.html"})
    assert {f for f in added if f.startswith("plot_")} == added - {"report.html"}
    assert {"plot_joints.png", "plot_joints.svg", "plot_efforts.png"} <= added
    text = (hoeken_report_run / "report.html").read_text("utf-8")
    assert "http://" not in text and "https://" not in text
    assert not re.search(r"<script[^>]*\bsrc\s*=", text, re.I)
    assert not re.search(r"<link[^>]*\bhref\s*=", text, re.I)
    assert not re.search(r"<(img|iframe|object|embed)\b", text, re.I)
    assert not re.search(r"@import|url\(\s*['\"]?(https?:|//)", text, re.I)
    assert "fetch(" not in text and "XMLHttpRequest" not in text
    # the data, the script and the styles are inline
    assert '<script id="linkdyn-data" type="application/json">' in text
    for elem_id in ("play", "scrubber", "speed", "time", "anim"):
        assert f'id="{elem_id}"' in text
    assert len(text) < 400_000


def test_long_runs_are_downsampled_for_the_page():
    m = linkdyn.load(linkdyn.example_path("hoeken"))
    sol = linkdyn.analyze(m, np.linspace(0.0, 8 / 3, 5001))
    data = report.page_data(sol)
    assert len(data["t"]) == report.MAX_FRAMES
    assert data["total_samples"] == 5001
    assert data["t"][0] == 0.0 and data["t"][-1] == pytest.approx(8 / 3)
    assert all(len(v) == report.MAX_FRAMES for v in data["series"].values())
    html = report.render(sol, design.summary(sol))
    assert "the page shows 2000 of them" in html
    assert len(html) < 1_350_000   # 1.32 MB: the drawn-only tracks as float32 (1.48 before)
    # what the page prints keeps every digit; what it only draws is float32 of the solution
    D = page_blob(html)
    assert D["series"] == report.page_data(sol)["series"] | {
        k: v for k, v in D["series"].items() if k.startswith("ic:")}
    idx = np.searchsorted(sol.t, D["t"])
    assert np.array_equal(sol.t[idx], D["t"])
    xy = np.asarray(sol.point("coupler", "P"))
    np.testing.assert_array_equal(D["geom"]["points"]["coupler.P"]["x"],
                                  xy[idx, 0].astype(np.float32))
    ic = np.asarray(sol.instant_centre("coupler"))[idx]
    np.testing.assert_array_equal(np.array(D["series"]["ic:coupler:x"], float),
                                  np.where(np.isfinite(ic[:, 0]), ic[:, 0], np.nan).astype(np.float32))


def test_page_data_matches_the_solution():
    m = linkdyn.load(linkdyn.example_path("hoeken"))
    sol = linkdyn.analyze(m, np.linspace(0.0, 4 / 3, 361))
    d = report.page_data(sol)
    # driver torque, reaction magnitudes, multipliers: the solution's numbers to 5 digits
    np.testing.assert_allclose(d["series"]["tau:J1"], sol.dyn.tau[:, 0], rtol=1e-4, atol=1e-9)
    np.testing.assert_allclose(d["series"]["F:J2"],
                               np.linalg.norm(sol.reactions.force[:, 1], axis=-1), rtol=1e-4)
    # the cut joint's multipliers are its reaction: one panel, no duplicate λ panel
    np.testing.assert_allclose(d["series"]["Fx:J4"], sol.dyn.lam[:, 0], rtol=1e-4,
                               atol=1e-9 * np.max(np.abs(sol.dyn.lam)))
    titles = [p["title"] for p in d["plots"]]
    assert "Reaction at J4 (ground on rocker), where the loop is cut" in titles
    assert not any(t.startswith("λ") for t in titles) and len(set(titles)) == len(titles)
    np.testing.assert_allclose(d["series"]["q:J3"], np.degrees(sol.kin.q[:, 2]), rtol=1e-4)
    xy = sol.point("coupler", "P")
    np.testing.assert_allclose(d["geom"]["points"]["coupler.P"]["x"], xy[:, 0], rtol=1e-5)
    assert d["geom"]["traces"] == ["coupler.P"]
    shapes = {b["name"]: b["shape"] for b in d["geom"]["bodies"]}
    assert shapes == {"crank": "bar", "coupler": "line", "rocker": "bar"}
    assert titles[:3] == ["Joint angles", "Joint angular rates", "Joint angular accelerations"]
    assert {s["label"] for p in d["plots"] for s in p["series"]} >= {"Fx", "Fy"}
    # the coupler point's speed along its path is plotted: |v| from the vx_, vy_ columns
    np.testing.assert_allclose(d["series"]["v:coupler.P"],
                               np.hypot(*sol.point_velocity("coupler", "P").T), rtol=1e-4)
    # the link-frame forces, one polar diagram per pin, output versus input, instant centres
    fl = sol.reaction_local("J2")
    np.testing.assert_allclose(d["series"]["Fa:J2"], fl[:, 0], rtol=1e-4, atol=1e-9)
    np.testing.assert_allclose(d["series"]["Fc:J2"], fl[:, 1], rtol=1e-4, atol=1e-9)
    polar = [p for p in d["plots"] if p.get("kind") == "polar"]
    assert [p["x"]["key"] for p in polar] == ["Fa:J1", "Fa:J2", "Fa:J3", "Fa:J4"]
    oi = next(p for p in d["plots"] if p["title"].startswith("Output versus input"))
    assert oi["x"]["key"] == "q:J1" and [s["label"] for s in oi["series"]] == ["coupler", "rocker"]
    ics = {c["body"]: c for c in d["geom"]["ics"]}
    assert set(ics) == {"crank", "coupler", "rocker"}
    np.testing.assert_allclose(d["series"][ics["coupler"]["x"]],
                               sol.instant_centre("coupler")[:, 0], rtol=1e-5)


def test_summary_tables_render_known_and_unknown_keys():
    s = {"model": "m", "samples": 3, "drivers": {"J1": {"effort": "torque", "unit": "N m",
                                                        "peak": 1.5, "peak_time_s": 0.1,
                                                        "rms": 0.7, "motion": "constant"}},
         "reactions": {"J1": {"peak_force_N": 12.0, "peak_time_s": 0.2}},
         "new_metric_Nm": 3.25, "nested": {"a_N": 1.0, "b": [1, 2]}, "health": {"x": None}}
    html = report.summary_html(s)
    assert "1.500 N m" in html and "12.00 N" in html
    assert "New metric (N m)" in html and "3.250" in html
    assert "a (N)" in html and "1, 2" in html
    assert report.pretty_key("peak_force_N") == "peak force (N)"
    assert report.fmt(0.000123) == "1.230e-04" and report.fmt(1234.56) == "1235"
    assert report.fmt(0.5) == "0.5000"


# ---------------------------------------------------------------------------- in a notebook

def _solution(example, t):
    return linkdyn.analyze(linkdyn.load(linkdyn.example_path(example)), t, backend="numpy")


@pytest.mark.parametrize("example", ["hoeken", "slider_crank", "fivebar", "stephenson"])
def test_point_velocity_and_acceleration_columns_match_finite_differences(example):
    # at three times t0: central differences of the positions (h = 1e-5 s for the velocity,
    # 1e-4 s for the acceleration) against the vx_/vy_/ax_/ay_ columns, relative to each
    # point's peak speed or acceleration over the run
    m = linkdyn.load(linkdyn.example_path(example))
    period = m.drivers[0].period or 1.0
    run = linkdyn.analyze(m, np.linspace(0.0, period, 73), backend="numpy").columns
    t0 = np.array([0.13, 0.41, 0.77]) * period
    hv, ha = 1e-5 * period, 1e-4 * period
    t = np.concatenate([t0, t0 - hv, t0 + hv, t0 - ha, t0 + ha])
    cols = linkdyn.analyze(m, t, backend="numpy").columns
    names = [c[2:] for c in cols if c.startswith("x_")]
    assert names and all(f"ay_{n}" in cols for n in names)
    order = list(cols)  # after SPEC's columns, which end with kinetic_energy
    assert order.index(f"vx_{names[0]}") > order.index("kinetic_energy")
    # scales: the point's own peak, at least a thousandth of the fastest point's (a pivot's
    # velocity is zero)
    vmax = max(np.max(np.hypot(run[f"vx_{n}"], run[f"vy_{n}"])) for n in names)
    amax = max(np.max(np.hypot(run[f"ax_{n}"], run[f"ay_{n}"])) for n in names)
    assert vmax > 0 and amax > 0
    for n in names:
        vscale = max(np.max(np.hypot(run[f"vx_{n}"], run[f"vy_{n}"])), 1e-3 * vmax)
        ascale = max(np.max(np.hypot(run[f"ax_{n}"], run[f"ay_{n}"])), 1e-3 * amax)
        for c in "xy":
            x = cols[f"{c}_{n}"]
            v_fd = (x[6:9] - x[3:6]) / (2 * hv)
            a_fd = (x[12:15] - 2 * x[0:3] + x[9:12]) / ha ** 2
            np.testing.assert_allclose(cols[f"v{c}_{n}"][:3], v_fd, rtol=0, atol=1e-7 * vscale,
                                       err_msg=f"v{c}_{n}")
            np.testing.assert_allclose(cols[f"a{c}_{n}"][:3], a_fd, rtol=0, atol=1e-5 * ascale,
                                       err_msg=f"a{c}_{n}")


def test_reaction_carries_the_prismatic_moment_and_units_follow_the_columns():
    sol = _solution("inverted_slider_crank", np.linspace(0.0, 0.2, 21))
    cols, units = sol.columns, sol.units
    prism = [j.name for j in sol.model.joints if j.kind == "prismatic"]
    assert prism
    for j in sol.model.joints:
        r = sol.reaction(j.name)
        want = [f"Fx_{j.name}", f"Fy_{j.name}"] + ([f"M_{j.name}"] if j.name in prism else [])
        assert r.shape == (21, len(want))
        np.testing.assert_array_equal(r, np.stack([cols[c] for c in want], axis=-1))
    # this guide carries a moment well above rounding noise
    m = sol.reaction(prism[0])[:, 2]
    assert np.max(np.abs(m)) > 1e-9 * np.max(np.abs(sol.reaction(prism[0])[:, :2]))
    assert list(units) == list(cols)
    j_rev = next(j.name for j in sol.model.joints if j.kind == "revolute")
    assert (units[f"q_{j_rev}"], units[f"qd_{prism[0]}"], units[f"M_{prism[0]}"]) == (
        "rad", "m/s", "N m")
    assert units["kinetic_energy"] == "J" and units["tau_J1"] == "N m"
    assert all(units[c] == "m/s^2" for c in cols if c.startswith(("ax_", "ay_")))


def test_notebook_display_is_short_and_dataframe_is_indexed_by_time():
    pd = pytest.importorskip("pandas", reason="the sweep's table needs pandas (the parquet extra)")
    sol = _solution("hoeken", np.linspace(0.0, 4 / 3, 361))
    text = repr(sol)
    assert len(text) < 600 and "Hoeken" in text and "361 samples" in text
    tau = sol.columns["tau_J1"]
    k = int(np.argmax(np.abs(tau)))
    assert f"{tau[k]:+.4g} N m at t = {sol.t[k]:.4g} s" in text  # the peak keeps its sign
    page = sol._repr_html_()
    assert len(page) < 3000 and "<table>" in page and f"{tau[k]:+.4g}" in page
    df = sol.to_dataframe()
    assert isinstance(df, pd.DataFrame) and df.index.name == "t"
    np.testing.assert_array_equal(df.index.to_numpy(), sol.t)
    assert list(df.columns) == list(sol.columns)[1:]
    assert df.attrs["units"] == sol.units and df.attrs["units"]["phi_crank"] == "rad"
    # a batch of designs displays too, without any per-sample dump
    m = sol.model
    batch = linkdyn.analyze([m, m], np.linspace(0.0, 1.0, 50), backend="numpy")
    assert "2 designs x 50 samples" in repr(batch) and len(repr(batch)) < 300


# ---------------------------------------------------------------------------- in the browser

def test_page_loads_without_errors(page):
    n_plots = page.page.locator("#plots .panel").count()
    assert n_plots >= 8
    assert page.page.locator(".cursor").count() == n_plots
    assert page.page.locator("#anim line, #anim polygon, #anim circle").count() > 10
    assert page.page.inner_text("#time").startswith("t = 0")
    assert "J1" in page.page.inner_text("#drivers")
    assert "most loaded joint" in page.page.inner_text("#loaded")
    assert page.errors == []
    assert all(u.startswith("file:") for u in page.requests), page.requests


def test_play_advances_the_frame_and_pause_stops_it(page):
    assert page.frame() == 0
    page.page.click("#play")
    page.page.wait_for_function("window.__linkdynFrame > 5", timeout=5000)
    page.page.click("#play")  # pause
    f1 = page.frame()
    page.page.wait_for_timeout(250)
    assert page.frame() == f1
    assert "Play" in page.page.inner_text("#play")
    assert page.errors == []


def test_every_panel_shows_the_frame_after_a_pause(page, hoeken_report):
    # while playing only the panels on the screen follow the frames (a smooth cursor at 2000
    # frames); a panel scrolled into view catches up, and a pause brings every panel, on the
    # screen or not, to the frame shown: each cursor of a time axis at that frame's time
    p = page.page
    p.evaluate("window.scrollTo(0, 0)")
    p.click("#play")
    p.wait_for_function("window.__linkdynFrame > 20", timeout=5000)
    last = p.locator("#plots .panel").last
    last.scroll_into_view_if_needed()
    p.wait_for_timeout(200)
    p.click("#play")
    k = page.frame()
    D = _page_data(hoeken_report)
    t = D["t"]
    got = p.evaluate("""() => [...document.querySelectorAll('#plots .panel')].map(panel => {
        const c = panel.querySelector('.cursor'), box = panel.querySelector('svg.plot');
        return [+c.getAttribute('x1'), box.viewBox.baseVal.width];
    })""")
    timed = [n for n, s in enumerate(D["plots"]) if "x" not in s]
    assert len(timed) >= 10
    ml, mr = 50, 16   # the plots' margins (report.js: ML, MR)
    for n in timed:
        x, w = got[n]
        assert x == pytest.approx(ml + (t[k] - t[0]) / (t[-1] - t[0]) * (w - ml - mr), abs=0.06), n
    assert page.errors == []


def test_speed_control_offers_quarter_to_four_times(page):
    values = page.page.eval_on_selector_all("#speed option", "os => os.map(o => +o.value)")
    assert min(values) == 0.25 and max(values) == 4 and 1 in values
    # simulated seconds per wall-clock second over about a second (Hoeken: 1x is real time),
    # both read at animation frames (the time played and the frame time it belongs to), so a
    # busy machine that drops or delays frames does not bias it; +-20 % band
    measure = """async () => {
        const p0 = window.__linkdynPlayed, t0 = window.__linkdynTick;
        await new Promise(r => setTimeout(r, 1000));
        const p1 = window.__linkdynPlayed, t1 = window.__linkdynTick;
        return (p1 - p0) / ((t1 - t0) / 1000);
    }"""
    ratios = {}
    for speed in ("4", "0.25"):
        page.page.select_option("#speed", speed)
        page.page.click("#play")
        page.page.wait_for_function("window.__linkdynPlayed > 0.005", timeout=5000)
        ratios[speed] = page.page.evaluate(measure)
        page.page.click("#play")
        page.page.evaluate("window.__linkdynPlayed = 0")
    assert 3.2 < ratios["4"] < 4.8, ratios
    assert 0.2 < ratios["0.25"] < 0.3, ratios
    assert page.errors == []


def test_scrubber_moves_the_plot_cursors_and_the_time(page):
    cursor = page.page.locator(".cursor").first
    x0 = float(cursor.get_attribute("x1"))
    t0 = page.page.inner_text("#time")
    page.page.focus("#scrubber")
    page.page.keyboard.press("End")
    n = page.page.evaluate("window.__linkdynFrame")
    assert n == 360
    x1 = float(cursor.get_attribute("x1"))
    assert x1 > x0 + 100  # the cursor crossed the panel
    assert page.page.inner_text("#time") != t0
    # half-way, set as a user's drag would (input event)
    page.page.eval_on_selector(
        "#scrubber", "s => { s.value = '180'; s.dispatchEvent(new Event('input')); }")
    assert page.frame() == 180
    xs = page.page.eval_on_selector_all(".cursor", "cs => cs.map(c => +c.getAttribute('x1'))")
    assert all(x0 < x < x1 for x in xs)
    # clicking a plot moves the cursor there too
    svg = page.page.locator("#plots .panel svg").first
    box = svg.bounding_box()
    svg.click(position={"x": box["width"] * 0.3, "y": box["height"] * 0.5})
    assert 0 < page.frame() < 180
    assert page.errors == []


def test_screenshot_is_not_blank(page):
    page.page.click("#play")
    page.page.wait_for_timeout(300)
    page.page.click("#play")
    png = page.page.screenshot()
    try:
        from PIL import Image
        img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), float)
    except ImportError:  # pragma: no cover - matplotlib reads PNG itself
        import matplotlib.image as mpimg
        img = mpimg.imread(io.BytesIO(png), format="png")[..., :3] * 255.0
    assert img.shape[0] > 500 and img.shape[1] > 1000
    assert img.std() > 15.0
    q = img.reshape(-1, 3).astype(int) // 8
    colours = np.unique(q[:, 0] * 1024 + q[:, 1] * 32 + q[:, 2])
    assert len(colours) > 60
    # the animation itself is drawn, not only the page's text
    box = page.page.locator("#anim").bounding_box()
    y0, x0 = int(box["y"]), int(box["x"])
    anim = img[y0:y0 + int(box["height"]), x0:x0 + int(box["width"])]
    assert (np.abs(anim - anim.mean(axis=(0, 1))).sum(-1) > 60).mean() > 0.01
    assert page.errors == []


@pytest.mark.parametrize("example", ["slider_crank", "inverted_slider_crank", "stephenson",
                                     "fivebar", "scotch_yoke"])
def test_other_mechanisms_render_and_play(browser, example_runs, example):
    path, _ = example_runs(example)   # the page `analyze --report` writes, shared per worker
    pg = Page(browser, path, width=1200, height=900)
    try:
        pg.page.click("#play")
        pg.page.wait_for_function("window.__linkdynFrame > 3", timeout=5000)
        pg.page.click("#play")
        if example in ("slider_crank", "inverted_slider_crank"):  # a slider block is drawn
            assert pg.page.locator("#anim rect[rx]").count() == 1
        if example == "scotch_yoke":  # the yoke's slider block and its slot around the pin
            assert pg.page.locator("#anim rect[rx]").count() == 2
        if example == "stephenson":  # the ternary coupler is a filled plate
            assert pg.page.locator("#anim polygon[fill-opacity]").count() == 1
        if example == "fivebar":  # two drivers
            assert pg.page.locator("#drivers .drv").count() == 2
        pg.page.check("#show-forces")
        pg.page.select_option("#xaxis", index=1)
        assert pg.page.locator(".cursor").count() == pg.page.locator("#plots .panel").count()
        assert pg.errors == []
    finally:
        pg.close()


def _triple_rocker():
    """A non-Grashof four-bar driven a full turn: the loop cannot close for part of it."""
    a, b, c, d = 0.07, 0.08, 0.07, 0.09

    def bar(L, m):
        return {"mass": m, "com": [L / 2, 0.0], "inertia": m * L * L / 12}

    return linkdyn.model_from_dict({
        "mechanism": {"name": "triple rocker past its limits"},
        "bodies": [
            {"name": "ground", "points": {"O1": [0.0, 0.0], "O4": [d, 0.0]}},
            {"name": "crank", "points": {"O1": [0.0, 0.0], "A": [a, 0.0]}, **bar(a, 0.2)},
            {"name": "coupler", "points": {"A": [0.0, 0.0], "B": [b, 0.0], "P": [0.04, 0.03]},
             **bar(b, 0.5)},
            {"name": "rocker", "points": {"O4": [0.0, 0.0], "B": [c, 0.0]}, **bar(c, 0.3)}],
        "joints": [{"name": "J1", "type": "revolute", "connect": ["ground.O1", "crank.O1"]},
                   {"name": "J2", "type": "revolute", "connect": ["crank.A", "coupler.A"]},
                   {"name": "J3", "type": "revolute", "connect": ["coupler.B", "rocker.B"]},
                   {"name": "J4", "type": "revolute", "connect": ["ground.O4", "rocker.O4"]}],
        "drivers": [{"joint": "J1", "motion": {"kind": "constant_speed", "speed": 6.283}}],
        "assembly": {"phi": {"crank": 1.5, "coupler": 0.0, "rocker": 2.0}}})


def test_singular_samples_are_gaps_not_errors(browser, tmp_path):
    sol = linkdyn.analyze(_triple_rocker(), np.linspace(0.0, 1.0, 200), allow_singular=True)
    assert 0 < np.sum(~sol.valid) < 200
    data = report.page_data(sol)
    assert None in data["series"]["tau:J1"] and not all(data["valid"])
    path = tmp_path / "report.html"
    report.outputs(sol, design.summary(sol))["report.html"](path)
    pg = Page(browser, path)
    try:
        bad = int(np.argmin(sol.valid))
        pg.page.eval_on_selector(
            "#scrubber", f"s => {{ s.value = '{bad}'; s.dispatchEvent(new Event('input')); }}")
        assert "singular" in pg.page.inner_text("#frameinfo")
        pg.page.click("#play")
        pg.page.wait_for_timeout(400)
        pg.page.click("#play")
        assert pg.errors == []
    finally:
        pg.close()


# ---------------------------------------------------------------------------- acceptance, every example

EXAMPLES = sorted(p.stem for p in linkdyn.example_path("hoeken").parent.glob("*.toml"))
SIZES = [(1440, 900), (390, 844)]
# in the browser, the examples that span what the page's layout depends on: one driver and
# four bodies (hoeken), two drivers (fivebar), the most bodies and joints (stephenson), a slot
# (scotch_yoke) and higher pairs (geared_fivebar), at both sizes; a cam and a slider
# (cam_follower) at desktop size. The other examples' pages draw nothing these do not (four
# revolute joints, a six-bar of revolutes, a slider: test_other_mechanisms_render_and_play
# plays those in the browser), and every example's page data is checked against its
# results.csv without a browser (test_report_data_of_every_example_is_its_results_csv)
PHONE = ("fivebar", "geared_fivebar", "hoeken", "scotch_yoke", "stephenson")
DESKTOP = PHONE + ("cam_follower",)
CASES = [(e, s) for e in EXAMPLES for s in SIZES if e in (DESKTOP if s[0] >= 500 else PHONE)]


@pytest.fixture(scope="module")
def example_runs(tmp_path_factory):
    """Each bundled example analyzed once with --report: (report.html, results.csv columns)."""
    cache = {}

    from linkdyn.cli import write_csv
    from linkdyn.sampling import times as sample_times

    def get(example):
        if example not in cache:  # what `analyze --report` writes, without the static figures
            out = tmp_path_factory.mktemp(example)
            mech = linkdyn.load(linkdyn.example_path(example))
            sol = linkdyn.analyze(mech, sample_times(mech, None, None, None))
            report.outputs(sol, design.summary(sol))["report.html"](out / "report.html")
            write_csv(sol, out / "results.csv")
            names = (out / "results.csv").read_text().splitlines()[0].split(",")
            data = np.loadtxt(out / "results.csv", delimiter=",", skiprows=1, ndmin=2)
            cache[example] = out / "report.html", dict(zip(names, data.T))
        return cache[example]
    return get


# page series key -> (results.csv column, factor to the page's unit)
def _column_of(key: str) -> tuple[str, float] | None:
    kind, _, name = key.partition(":")
    table = {"tau": ("tau_", "force_"), "Fx": ("Fx_",), "Fy": ("Fy_",), "M": ("M_",),
             "q": ("q_",), "qd": ("qd_",), "qdd": ("qdd_",), "ke": None}
    if key == "ke":
        return "kinetic_energy", 1.0
    if kind not in table or table[kind] is None:
        return None
    return next(((p + name, 1.0) for p in table[kind]), None)


def page_blob(text: str) -> dict:
    """The data block a page carries (what its script reads), parsed by Python: each packed
    series (the base64 text of its little-endian float64 values) unpacked here to a list of
    floats, None for NaN, as the page's JSON had them before they were packed."""
    blob = text.split('<script id="linkdyn-data" type="application/json">', 1)[1]
    D = json.loads(blob.split("</script>", 1)[0])

    def unpack(v):
        if not isinstance(v, str):
            return v
        f4 = v.startswith("f4:")   # drawn only: float32 (report.data.packed)
        a = np.frombuffer(base64.b64decode(v[3:] if f4 else v), dtype="<f4" if f4 else "<f8")
        return [None if np.isnan(x) else float(x) for x in a]
    for d in [D] + list(D.get("designs", [])):
        if isinstance(d.get("series"), dict):
            d["series"] = {k: unpack(v) for k, v in d["series"].items()}
        if "t" in d:
            d["t"] = unpack(d["t"])
        geom = d.get("geom", {})
        for p in geom.get("points", {}).values():
            p.update({c: unpack(p[c]) for c in "xyz" if c in p})
        for b in geom.get("freebody", []):
            if b.get("com"):
                b["com"] = {c: unpack(v) for c, v in b["com"].items()}
    return D


def _page_data(path) -> dict:
    """The data block report.html carries, parsed by Python (:func:`page_blob`)."""
    return page_blob(path.read_text("utf-8"))


@pytest.mark.parametrize("example", EXAMPLES)
def test_report_data_of_every_example_is_its_results_csv(example_runs, example):
    # every example's page, without a browser: each plotted series, each peak the page jumps
    # to, the link-frame forces, the link angles and the instant centres are results.csv's
    # numbers (recomputed from its columns here) at every frame
    path, csv = example_runs(example)
    D = _page_data(path)
    n = len(D["t"])
    assert n == len(csv["t"])  # the default runs are short: one frame per sample
    np.testing.assert_allclose(D["t"], csv["t"], rtol=1e-6, atol=1e-9 * csv["t"][-1])
    fscale = max(np.max(np.abs(v)) for c, v in csv.items() if c.startswith(("Fx_", "Fy_")))
    checked = 0
    for spec in D["plots"]:
        factor = np.degrees(1) if spec["unit"] == "deg" else 1.0
        for s in spec["series"]:
            col = _column_of(s["key"])
            if not col or spec.get("kind") == "polar":
                continue
            want = csv[col[0]] * factor
            if col[0].startswith(("Fx_", "Fy_")):  # no series of pure rounding noise is drawn
                assert np.max(np.abs(want)) > 1e-12 * fscale, s["key"]
            got = np.array(D["series"][s["key"]], float)
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-4 * np.max(np.abs(want)) + 1e-12,
                                       err_msg=s["key"])
            checked += 1
    assert checked >= 6
    # each driver's max and min effort: the frame where results.csv has it, and its value
    peaks = 0
    for item in D["key"]:
        words = item["label"].split()
        if item["frame"] is None or words[0] not in ("max", "min") or words[1] not in (
                "torque", "force"):
            continue
        col = ("tau_" if words[1] == "torque" else "force_") + words[-1]
        pick = np.argmax if words[0] == "max" else np.argmin
        k = item["frame"]
        assert csv[col][k] == csv[col][pick(csv[col])], (item, k)
        assert item["value"] == pytest.approx(csv[col][k], rel=1e-12)
        peaks += 1
    assert peaks == 2 * len([c for c in csv if c.startswith(("tau_", "force_"))])
    # the link-frame forces: results.csv's joint force turned by -phi of the second body
    joints = {j["name"]: j for j in D["geom"]["joints"]}
    for j, e in joints.items():
        phi = csv[f"phi_{e['second']}"] if f"phi_{e['second']}" in csv else 0.0
        fx, fy = csv[f"Fx_{j}"], csv[f"Fy_{j}"]
        for c, want in (("a", np.cos(phi) * fx + np.sin(phi) * fy),
                        ("c", -np.sin(phi) * fx + np.cos(phi) * fy)):
            np.testing.assert_allclose(np.array(D["series"][f"F{c}:{j}"], float), want, rtol=0,
                                       atol=1e-4 * fscale, err_msg=f"F{c}:{j}")
    # output versus input: each link's angle in degrees is its phi_ column (to whole turns)
    for spec in [s for s in D["plots"] if s["title"].startswith("Output versus input")]:
        for s in spec["series"]:
            d = np.array(D["series"][s["key"]], float) - np.degrees(csv[f"phi_{s['label']}"])
            np.testing.assert_allclose((d + 180) % 360 - 180, 0, atol=0.05, err_msg=s["key"])
    # instant centres: r_P + perp(v_P)/omega of any point P of the body, where it turns
    B = D["geom"]["bounds"]
    size = max(B[2] - B[0], B[3] - B[1])
    for ic in D["geom"]["ics"]:
        body = ic["body"]
        pt = next(c.split(".", 1)[1] for c in csv if c.startswith(f"vx_{body}."))
        w = csv[f"omega_{body}"]
        turns = np.abs(w) > 1e-3 * np.max(np.abs(w))
        assert turns.any(), body
        x = csv[f"x_{body}.{pt}"][turns] - csv[f"vy_{body}.{pt}"][turns] / w[turns]
        y = csv[f"y_{body}.{pt}"][turns] + csv[f"vx_{body}.{pt}"][turns] / w[turns]
        for got, want in ((ic["x"], x), (ic["y"], y)):
            got = np.array(D["series"][got], float)[turns]
            np.testing.assert_allclose(got, want, rtol=1e-5, atol=1e-6 * size, err_msg=body)


@pytest.mark.parametrize("example, size", CASES, ids=[f"{e}-{s[0]}x{s[1]}" for e, s in CASES])
def test_report_acceptance(browser, example_runs, example, size):
    path, csv = example_runs(example)
    pg = Page(browser, path, width=size[0], height=size[1])
    p = pg.page
    try:
        # first, on the page as it opens: its force labels sit clear of every body (what
        # test_force_labels_sit_clear_of_every_body checks on the pages this test does not
        # load), then forces off again
        _check_force_labels_clear_of_bodies(p)
        p.uncheck("#show-forces")
        D = _page_data(path)
        n = len(D["t"])
        assert n == len(csv["t"])  # the default runs are short: one frame per sample
        # no horizontal overflow
        assert p.evaluate("document.documentElement.scrollWidth") <= size[0]
        # every control can be clicked: the element itself is what a click at its centre hits
        blocked = p.evaluate("""() => {
            const out = [];
            const all = [...document.querySelectorAll('.controls button, .controls select, ' +
                '.controls input, .plotbar select, .keyitem, #plots .panel:first-of-type button')];
            for (const e of all) {
                if (!e.offsetParent) continue;
                e.scrollIntoView({block: 'center'});
                const r = e.getBoundingClientRect();
                const hit = document.elementFromPoint(r.left + r.width / 2, r.top + r.height / 2);
                if (!(hit === e || e.contains(hit) || (hit && hit.control === e)))
                    out.push((e.id || e.className || e.tagName) + ' under ' +
                             (hit ? hit.tagName + '.' + hit.className : 'nothing'));
            }
            return out;
        }""")
        assert blocked == []
        if size[0] < 500:  # phone: touch targets of 44 px
            small = p.evaluate("""() => [...document.querySelectorAll('.controls button, .keyitem')]
                .filter(e => e.offsetParent && e.getBoundingClientRect().height < 44)
                .map(e => e.id || e.textContent.slice(0, 20))""")
            assert small == []
            assert p.locator("#anim").bounding_box()["height"] >= 250
        # no series of pure rounding noise is drawn
        scale = {"N": max(np.max(np.abs(v)) for k, v in csv.items() if k.startswith(("Fx_", "Fy_")))}
        for spec in D["plots"]:
            for s in spec["series"]:
                col = _column_of(s["key"])
                if col and col[0].startswith(("Fx_", "Fy_")):
                    assert np.max(np.abs(csv[col[0]])) > 1e-12 * scale["N"], s["key"]
        # the jump to each peak lands on the peak's frame, and the address keeps it
        for item in D["key"]:
            if item["frame"] is None or not item["label"].startswith(("max ", "min ")):
                continue
            if not item["label"].split()[1] in ("torque", "force"):
                continue
            col = ("tau_" if "torque" in item["label"] else "force_") + item["label"].split()[-1]
            btn = p.locator(f".keyitem[data-frame='{item['frame']}']").first
            btn.click()
            k = pg.frame()
            assert k == item["frame"]
            pick = np.argmax if item["label"].startswith("max") else np.argmin
            assert csv[col][k] == csv[col][pick(csv[col])], (item, k)
            assert item["value"] == pytest.approx(csv[col][k], rel=1e-12)
            p.wait_for_function(f"location.hash === '#frame={k}'", timeout=3000)
        # hover readouts equal results.csv at the hovered frame, on the first panels
        panels = p.locator("#plots .panel")
        checked = 0
        efforts = [n for n, s in enumerate(D["plots"]) if s["title"].startswith("Driver")]
        for at in sorted({0, 2, *efforts, len(D["plots"]) - 1}):
            spec = D["plots"][at]
            cols = [(s["key"], _column_of(s["key"])) for s in spec["series"]]
            svg = panels.nth(at).locator("svg.plot")
            svg.scroll_into_view_if_needed()
            box = svg.bounding_box()
            p.mouse.move(box["x"] + 0.57 * box["width"], box["y"] + 0.5 * box["height"])
            tip = panels.nth(at).locator(".tooltip")
            k = int(tip.get_attribute("data-frame"))
            for key, col in cols:
                if not col:
                    continue
                text = tip.locator(f"b[data-key='{key}']").inner_text().split()[0]
                want = csv[col[0]][k] * (np.degrees(1) if spec["unit"] == "deg" else 1.0)
                peak = np.max(np.abs(csv[col[0]])) * (np.degrees(1) if spec["unit"] == "deg" else 1)
                assert float(text) == pytest.approx(want, abs=1e-3 * peak + 1e-12), (key, k)
                checked += 1
        assert checked >= 2
        # forces drawn: each arrow's length over the legend's scale is the joint force of
        # results.csv at three frames; no two labels' boxes overlap (forces on and off)
        overlap = """() => {
            const b = [...document.querySelectorAll('#anim .labels text')]
                .filter(e => e.style.display !== 'none' && e.getClientRects().length &&
                             getComputedStyle(e.parentNode).display !== 'none')
                .map(e => [e.textContent, e.getBoundingClientRect()]);
            const out = [];
            for (let i = 0; i < b.length; i++) for (let j = i + 1; j < b.length; j++) {
                const [p, q] = [b[i][1], b[j][1]];
                if (p.left < q.right - 0.5 && q.left < p.right - 0.5 &&
                    p.top < q.bottom - 0.5 && q.top < p.bottom - 0.5) out.push(b[i][0] + ' / ' + b[j][0]);
            }
            return out;
        }"""
        p.locator("#anim").scroll_into_view_if_needed()
        assert p.evaluate(overlap) == []
        p.check("#show-forces")
        legend = p.locator("#force-legend")
        scale = float(legend.get_attribute("data-length")) / float(legend.get_attribute("data-force"))
        for k in (n // 5, n // 2, 4 * n // 5):
            p.eval_on_selector("#scrubber", f"s => {{ s.value = '{k}'; s.dispatchEvent(new Event('input')); }}")
            arrows = p.eval_on_selector_all(".farrow[data-joint]", """as => as.map(a => [
                a.getAttribute('data-joint'), a.style.display !== 'none',
                Math.hypot(a.getAttribute('x2') - a.getAttribute('x1'),
                           a.getAttribute('y2') - a.getAttribute('y1'))])""")
            assert len(arrows) == len([c for c in csv if c.startswith("Fx_")])
            for joint, shown, length in arrows:
                f = np.hypot(csv[f"Fx_{joint}"][k], csv[f"Fy_{joint}"][k])
                if shown:
                    assert length / scale == pytest.approx(f, rel=2e-3, abs=0.02 / scale), (joint, k)
                else:  # left out only when shorter than 2 units of the drawing
                    assert f * scale <= 2.0 + 1e-9, (joint, k)
            assert p.evaluate(overlap) == [], k
        _check_link_frame_panels_and_instant_centres(p, D, csv, overlap)
        assert pg.errors == []
    finally:
        pg.close()


@pytest.mark.parametrize("example, size", [("stephenson", (390, 844)), ("fivebar", (390, 844))],
                         ids=["stephenson-phone", "fivebar-phone"])
def test_force_labels_never_drop_out(browser, example_runs, example, size):
    # forces on, at every fifth frame: each joint force drawn has its label, inside the view
    # and clear of every other label, saying results.csv's |F|; a label with no room by its
    # arrow's tip sits at the view's edge, its leader line ending on that tip
    path, csv = example_runs(example)
    pg = Page(browser, path, width=size[0], height=size[1])
    p = pg.page
    try:
        p.locator("#anim").scroll_into_view_if_needed()
        assert not p.locator("#forcekey").is_visible()
        p.check("#show-forces")
        # the force key, shown with the forces: each kind drawn, in its arrows' colour
        key = dict(p.eval_on_selector_all("#forcekey .fk", """es => es.map(e =>
            [e.dataset.kind, getComputedStyle(e.querySelector('i')).backgroundColor])"""))
        drawn = p.eval_on_selector(".farrow[data-joint]", "a => (a.style.color = a.getAttribute("
                                   "'stroke'), getComputedStyle(a).color)")
        assert set(key) == {"joint", "driver", "shaking"} and key["joint"] == drawn
        n = len(csv["t"])
        peak = max(np.max(np.hypot(csv[c], csv["Fy_" + c[3:]])) for c in csv if c.startswith("Fx_"))
        leaders = 0
        for k in range(0, n, 5):
            p.evaluate("k => { const s = document.getElementById('scrubber'); s.value = String(k);"
                       " s.dispatchEvent(new Event('input')); }", k)
            shown = p.evaluate("""() => {
                const view = document.getElementById('anim').getBoundingClientRect();
                const boxes = [...document.querySelectorAll('#anim .labels text')]
                    .filter(e => e.style.display !== 'none' && e.getClientRects().length)
                    .map(e => [e, e.getBoundingClientRect()]);
                return [...document.querySelectorAll('#anim .farrow[data-joint]')]
                    .filter(a => a.style.display !== 'none').map(a => {
                    const name = a.dataset.joint;
                    const hit = boxes.filter(([e]) => e.textContent.startsWith(name + ' '));
                    if (hit.length !== 1) return [name, null];
                    const [e, r] = hit[0];
                    const inside = r.left >= view.left - 0.5 && r.right <= view.right + 0.5 &&
                                   r.top >= view.top - 0.5 && r.bottom <= view.bottom + 0.5;
                    const clear = boxes.every(([o, q]) => o === e || !(r.left < q.right - 0.5 &&
                        q.left < r.right - 0.5 && r.top < q.bottom - 0.5 && q.top < r.bottom - 0.5));
                    const led = [...document.querySelectorAll('#anim line.leader')]
                        .filter(l => l.style.display !== 'none' &&
                                Math.abs(l.getAttribute('x2') - a.getAttribute('x2')) < 0.11 &&
                                Math.abs(l.getAttribute('y2') - a.getAttribute('y2')) < 0.11).length;
                    return [name, [e.textContent, inside, clear, led]];
                });
            }""")
            assert shown, k
            for name, label in shown:
                assert label is not None, (name, k)
                text, inside, clear, led = label
                assert led <= 1, (name, k)
                assert inside and clear, (name, k, text)
                f = np.hypot(csv[f"Fx_{name}"][k], csv[f"Fy_{name}"][k])
                assert float(text.split()[1]) == pytest.approx(f, abs=1e-3 * peak), (name, k)
            leaders += p.evaluate("[...document.querySelectorAll('#anim line.leader')]"
                                  ".filter(l => l.style.display !== 'none').length")
        assert leaders > 0   # these two crowd their views: some labels go to the edge
        assert pg.errors == []
    finally:
        pg.close()


def _segment_box_distance(a, b, box, step=0.25):
    """Distance (px) from the segment a-b to the box (x0, y0, x1, y1), the segment sampled
    every ``step`` px (so within step / 2 of the exact distance)."""
    n = max(2, int(np.ceil(np.hypot(*(np.subtract(b, a))) / step)) + 1)
    s = np.linspace(0.0, 1.0, n)[:, None]
    p = np.asarray(a, float) + s * (np.asarray(b, float) - np.asarray(a, float))
    dx = np.maximum.reduce([box[0] - p[:, 0], np.zeros(n), p[:, 0] - box[2]])
    dy = np.maximum.reduce([box[1] - p[:, 1], np.zeros(n), p[:, 1] - box[3]])
    return float(np.min(np.hypot(dx, dy)))


def _box_on_shape(box, shape) -> bool:
    """Whether a label's box (client px) touches a body as drawn: its outline's segments with
    half the stroke's width (``r``), and the inside of a closed outline (a plate, a block)."""
    from matplotlib.path import Path as MplPath
    pts, r, closed = shape["pts"], shape["r"], shape["closed"]
    segs = list(zip(pts, pts[1:] + pts[:1] if closed else pts[1:])) or [(pts[0], pts[0])]
    if any(_segment_box_distance(a, b, box) < r for a, b in segs):
        return True
    if closed and len(pts) > 2:
        corners = [(box[0], box[1]), (box[2], box[1]), (box[2], box[3]), (box[0], box[3]),
                   ((box[0] + box[2]) / 2, (box[1] + box[3]) / 2)]
        return bool(MplPath(pts).contains_points(corners).any())
    return False


_DRAWN_BODIES = r"""() => {
    // each body as drawn (#anim .body, .slider), in client px: its points through the
    // element's screen matrix, half its stroke scaled the same way
    const out = [];
    const at = (e, x, y) => { const m = e.getScreenCTM(), p = new DOMPoint(+x, +y).matrixTransform(m);
                              return [p.x, p.y]; };
    const half = e => 0.5 * (+e.getAttribute('stroke-width') || 0) * Math.hypot(
        e.getScreenCTM().a, e.getScreenCTM().b);
    for (const e of document.querySelectorAll('#anim .body')) {
        if (e.style.display === 'none') continue;
        if (e.tagName === 'polygon')
            out.push({pts: e.getAttribute('points').trim().split(/\s+/).map(
                s => at(e, ...s.split(','))), r: half(e), closed: true});
        else if (e.tagName === 'polyline')   // the 3-D view's bars: their points joined
            out.push({pts: e.getAttribute('points').trim().split(/\s+/).map(
                s => at(e, ...s.split(','))), r: half(e), closed: false});
        else if (e.tagName === 'line')
            out.push({pts: [at(e, e.getAttribute('x1'), e.getAttribute('y1')),
                            at(e, e.getAttribute('x2'), e.getAttribute('y2'))], r: half(e), closed: false});
        else
            out.push({pts: [at(e, e.getAttribute('cx'), e.getAttribute('cy'))],
                      r: +e.getAttribute('r') * Math.hypot(e.getScreenCTM().a, e.getScreenCTM().b),
                      closed: false});
    }
    for (const e of document.querySelectorAll('#anim .joint .block')) {   // 3-D: a prismatic
        // joint's block, a cylindrical one's sleeve, on its second body
        if (e.closest('.joint').style.display === 'none' || !e.hasAttribute('x1')) continue;
        out.push({pts: [at(e, e.getAttribute('x1'), e.getAttribute('y1')),
                        at(e, e.getAttribute('x2'), e.getAttribute('y2'))], r: half(e), closed: false});
    }
    for (const g of document.querySelectorAll('#anim .slider')) {
        if (g.style.display === 'none') continue;
        const r = g.querySelector('rect'), x = +r.getAttribute('x'), y = +r.getAttribute('y'),
              w = +r.getAttribute('width'), h = +r.getAttribute('height');
        out.push({pts: [[x, y], [x + w, y], [x + w, y + h], [x, y + h]].map(q => at(r, ...q)),
                  r: half(r), closed: true});
    }
    return out;
}"""


def _labels_on_bodies(labels, shapes) -> list:
    """Each ``(label text, body index)`` where a label's box touches a drawn body's shape."""
    return [(text, n) for text, box in labels for n, sh in enumerate(shapes)
            if _box_on_shape(box, sh)]


def _force_labels_at_the_first_frame(p):
    """Forces on, the first frame shown: each force label drawn, ``[text, [left, top, right,
    bottom]]`` in client px (its text as the browser lays it out)."""
    p.locator("#anim").scroll_into_view_if_needed()
    p.check("#show-forces")
    p.evaluate("() => { const s = document.getElementById('scrubber'); s.value = '0';"
               " s.dispatchEvent(new Event('input')); }")
    return p.evaluate("""() => [...document.querySelectorAll('#anim .flabels text')]
        .filter(e => e.style.display !== 'none' && e.getClientRects().length)
        .map(e => { const r = e.getBoundingClientRect();
                    return [e.textContent, [r.left, r.top, r.right, r.bottom]]; })""")


def _check_force_labels_clear_of_bodies(p):
    """Forces on, at the first frame: no force label's box (its text as the browser lays it
    out) touches any body as drawn (a bar's thick line, a plate and its border, a dot, a
    slider's block), computed here from the drawn elements, not from the page's placer."""
    labels = _force_labels_at_the_first_frame(p)
    shapes = p.evaluate(_DRAWN_BODIES)
    assert labels and shapes
    on = _labels_on_bodies(labels, shapes)
    assert on == [], on


# every example at both sizes; the pages test_report_acceptance loads are checked there, on
# the same fresh page (one load serves both)
LABEL_CASES = [(e, s) for e in EXAMPLES for s in SIZES if (e, s) not in CASES]


@pytest.mark.parametrize("example, size", LABEL_CASES,
                         ids=[f"{e}-{s[0]}x{s[1]}" for e, s in LABEL_CASES])
def test_force_labels_sit_clear_of_every_body(browser, example_runs, example, size):
    path, _ = example_runs(example)
    pg = Page(browser, path, width=size[0], height=size[1])
    try:
        _check_force_labels_clear_of_bodies(pg.page)
        assert pg.errors == []
    finally:
        pg.close()


SPATIAL = sorted(p.stem for p in linkdyn.example_path("rsur").parent.glob("*.toml"))


@pytest.fixture(scope="module")
def spatial_pages(tmp_path_factory):
    """Each bundled spatial example's report.html: ``analyze --report``, or for a model with
    free coordinates (no driver for each freedom) ``simulate --report``, run once."""
    cache = {}

    def get(example):
        if example not in cache:
            folder = tmp_path_factory.mktemp(example)
            model = folder / f"{example}.toml"
            model.write_text(linkdyn.example_path(example).read_text("utf-8"), "utf-8")
            out = folder / "out"
            res = CliRunner().invoke(main, ["analyze", str(model), "-o", str(out), "--report"])
            if res.exit_code == 2 and "mobility" in res.output:
                res = CliRunner().invoke(main, ["simulate", str(model), "-o", str(out), "--report"])
            assert res.exit_code == 0, res.output
            cache[example] = out / "report.html"
        return cache[example]
    return get


@pytest.mark.parametrize("example, size", [(e, s) for e in SPATIAL for s in SIZES],
                         ids=[f"{e}-{s[0]}x{s[1]}" for e in SPATIAL for s in SIZES])
def test_spatial_force_labels_sit_clear_of_every_body(browser, spatial_pages, example, size):
    # the 3-D view as the planar one above: forces on, at the first frame, every force drawn
    # has its label (none drops out), and no label's box touches a body as drawn (a bar's
    # thick polyline, a plate, a dot, a prismatic block or a cylindrical sleeve), computed
    # from the drawn elements in client px
    pg = Page(browser, spatial_pages(example), width=size[0], height=size[1])
    p = pg.page
    try:
        labels = _force_labels_at_the_first_frame(p)
        arrows = p.evaluate("[...document.querySelectorAll('#anim .farrow')]"
                            ".filter(a => a.style.display !== 'none').length")
        shapes = p.evaluate(_DRAWN_BODIES)
        assert shapes and len(labels) == arrows > 0, (len(labels), arrows)
        view = p.evaluate("(() => { const r = document.getElementById('anim')"
                          ".getBoundingClientRect(); return [r.left, r.top, r.right, r.bottom]; })()")
        for text, box in labels:   # inside the view
            assert box[0] >= view[0] - 0.5 and box[2] <= view[2] + 0.5, text
            assert box[1] >= view[1] - 0.5 and box[3] <= view[3] + 0.5, text
        on = _labels_on_bodies(labels, shapes)
        assert on == [], on
        assert pg.errors == []
    finally:
        pg.close()


def test_a_cams_contact_stress_is_a_key_result(example_runs):
    # the summary's contact.<joint>.stress (a roller's Hertz line contact) on the report page:
    # its peak pressure, in the file's N/mm^2, at the frame of its time, equal to
    # sqrt(F E* / (pi L R)) with F the joint's |F| from results.csv at that frame, E* and L the
    # model file's numbers and R the contact's effective radius the summary reports there
    path, csv = example_runs("cam_follower")
    D = _page_data(path)
    model = linkdyn.load(linkdyn.example_path("cam_follower"))
    sol = linkdyn.analyze(model, csv["t"])
    h = design.summary(sol)["contact"]["K"]["stress"]
    key = {it["label"]: it for it in D["key"]}["contact stress K"]
    assert key["unit"] == "N/mm^2"
    k = key["frame"]
    assert D["t"][k] == pytest.approx(h["max_time_s"], abs=1e-12)
    F = np.hypot(csv["Fx_K"], csv["Fy_K"])[int(np.argmin(np.abs(csv["t"] - D["t"][k])))]
    e_star = 206000.0 / (2 * (1 - 0.3 ** 2))            # N/mm^2, steel on steel
    R, L = h["effective_radius_m"] * 1e3, 8.0           # mm
    assert key["value"] == pytest.approx(np.sqrt(F * e_star / (np.pi * L * R)), rel=1e-4)


def _hover(p, at, fx=0.57, fy=0.5):
    """Hover panel ``at`` at a fraction of its plot; the tooltip's frame and locator."""
    panel = p.locator("#plots .panel").nth(at)
    svg = panel.locator("svg.plot")
    svg.scroll_into_view_if_needed()
    box = svg.bounding_box()
    p.mouse.move(box["x"] + fx * box["width"], box["y"] + fy * box["height"])
    tip = panel.locator(".tooltip")
    return int(tip.get_attribute("data-frame")), tip


def _check_link_frame_panels_and_instant_centres(p, D, csv, overlap):
    """The link-frame force panels and polar diagrams read results.csv's reactions turned by
    -phi of the second body; the output-versus-input panel reads its phi_ columns; each
    instant-centre marker sits at r_P + perp(v_P)/omega from results.csv."""
    n = len(D["t"])
    joints = {j["name"]: j for j in D["geom"]["joints"]}
    fscale = max(np.max(np.abs(v)) for c, v in csv.items() if c.startswith(("Fx_", "Fy_")))

    def local(joint, k):  # independent: the csv's global force turned by -phi_b
        b = joints[joint]["second"]
        phi = csv[f"phi_{b}"][k] if f"phi_{b}" in csv else 0.0
        fx, fy = csv[f"Fx_{joint}"][k], csv[f"Fy_{joint}"][k]
        return (np.cos(phi) * fx + np.sin(phi) * fy, -np.sin(phi) * fx + np.cos(phi) * fy)

    titles = [s["title"] for s in D["plots"]]
    assert any(t.startswith("Reaction along") for t in titles) or all(
        np.max(np.abs(csv[c])) <= 1e-12 * fscale for c in csv if c.startswith(("Fx_", "Fy_")))
    polar = [i for i, s in enumerate(D["plots"]) if s.get("kind") == "polar"]
    pins = [j for j, e in joints.items() if e["kind"] == "revolute"
            and np.max(np.hypot(csv[f"Fx_{j}"], csv[f"Fy_{j}"])) > 1e-12 * fscale]
    assert len(polar) == len(pins)  # one polar diagram per loaded pin
    for k in (n // 7, 3 * n // 5):
        for j in joints:
            want = local(j, k)
            for c, w in zip("ac", want):
                assert D["series"][f"F{c}:{j}"][k] == pytest.approx(w, abs=1e-4 * fscale), (j, k)
    if polar:  # hover the first: the readout is the turned force at the hovered frame
        at = polar[0]
        joint = D["plots"][at]["x"]["key"].split(":", 1)[1]
        k, tip = _hover(p, at, 0.3, 0.4)
        across = float(tip.locator(f"b[data-key='Fc:{joint}']").inner_text().split()[0])
        assert across == pytest.approx(local(joint, k)[1], abs=1e-3 * fscale), k
    oi = [i for i, s in enumerate(D["plots"]) if s["title"].startswith("Output versus input")]
    drv = [c.split("_", 1)[1] for c in csv if c.startswith(("tau_", "force_"))]
    if len(drv) == 1:  # shown when some link turns, and not just with the driver
        q = csv[f"q_{drv[0]}"]
        turning = [c for c in csv if c.startswith("phi_") and np.ptp(np.unwrap(csv[c])) > 1e-6
                   and np.ptp(np.unwrap(csv[c]) - q) > 1e-6]
        assert bool(oi) == bool(turning), turning
    if oi:  # the hovered frame's link angles, in degrees, equal phi_ of results.csv
        k, tip = _hover(p, oi[0])
        for s in D["plots"][oi[0]]["series"]:
            got = float(tip.locator(f"b[data-key='{s['key']}']").inner_text().split()[0])
            want = np.degrees(csv[f"phi_{s['label']}"][k])
            assert (got - want + 180) % 360 - 180 == pytest.approx(0, abs=0.05), (s, k)
    # instant centres: hidden until toggled, then at r_P + perp(v_P)/omega
    B = D["geom"]["bounds"]
    sc = min(640 / (B[2] - B[0]), 520 / (B[3] - B[1]))
    p.locator("#anim").scroll_into_view_if_needed()
    assert p.eval_on_selector("#anim g.ics", "g => getComputedStyle(g).display") == "none"
    p.check("#show-ics")
    seen = noted = 0

    def centre(body, k):   # r_P + perp(v_P) / omega from results.csv, in view units
        pt = next(c.split(".", 1)[1] for c in csv if c.startswith(f"vx_{body}."))
        w = csv[f"omega_{body}"][k]
        with np.errstate(divide="ignore", invalid="ignore"):  # w = 0: no centre
            x = csv[f"x_{body}.{pt}"][k] - csv[f"vy_{body}.{pt}"][k] / w
            y = csv[f"y_{body}.{pt}"][k] + csv[f"vx_{body}.{pt}"][k] / w
        return w, (x - B[0]) * sc, (B[3] - y) * sc

    def off(k):
        return any(abs(w) > 1e-6 and not (-1 < X < (B[2] - B[0]) * sc + 1
                                          and -1 < Y < (B[3] - B[1]) * sc + 1)
                   for w, X, Y in (centre(c["body"], k) for c in D["geom"]["ics"]))
    away = next((k for k in range(0, n, max(1, n // 60)) if off(k)), None)
    for k in (n // 4, 2 * n // 3) + (() if away is None else (away,)):
        p.eval_on_selector("#scrubber", f"s => {{ s.value = '{k}'; s.dispatchEvent(new Event('input')); }}")
        marks = p.eval_on_selector_all(".icmark", """ms => ms.map(m => [m.getAttribute('data-body'),
            m.style.display !== 'none', m.getAttribute('transform')])""")
        assert len(marks) == len(D["geom"]["ics"])
        labels = dict(p.eval_on_selector_all(".iclabel", """ls => ls.map(l =>
            [l.textContent.split(' ')[1], [l.style.display !== 'none', l.textContent]])"""))
        for body, shown, tr in marks:
            w, X, Y = centre(body, k)
            inside = 1 < X < (B[2] - B[0]) * sc - 1 and 1 < Y < (B[3] - B[1]) * sc - 1
            outside = not (-1 < X < (B[2] - B[0]) * sc + 1 and -1 < Y < (B[3] - B[1]) * sc + 1)
            if shown:
                got = [float(v) for v in re.match(r"translate\(([^,]+),([^)]+)\)", tr).groups()]
                assert got == pytest.approx([X, Y], abs=0.2), (body, k)
                seen += 1
            else:
                assert not inside or abs(w) < 1e-6, (body, k)
            if abs(w) > 1e-6 and outside:   # off the view: its label says so, not nothing
                assert labels[body][0] and " off view " in labels[body][1], (body, k, labels)
                noted += 1
        assert p.evaluate(overlap) == [], k
    assert seen > 0 or not D["geom"]["ics"]
    assert (noted > 0) == (away is not None)
    p.uncheck("#show-ics")


def test_summary_tables_show_rounding_noise_as_zero_and_angles_in_degrees():
    sol = _solution("slider_crank", np.linspace(0.0, 0.2, 61))
    s = design.summary(sol)
    assert 0 < abs(s["driver_energy"]["J1"]["work_J"]) < 1e-9  # a whole cycle: noise
    assert 0 < s["reactions"]["J4"]["peak_moment_Nm"] < 1e-9
    page = report.summary_html(s, report.keys.scales(sol))
    body = page[:page.index("Numerical health")]  # residuals are meant to be tiny there
    assert "e-1" not in body  # no 1e-15-sized number printed as data
    assert "<th>J1</th><td>0</td><td>20.19</td>" in body  # the cycle's net work
    assert "mean speed (rad/s)" in page and "rad (s)" not in page
    assert "<td>deg</td><td>0</td><td>360.0</td>" in page  # joint travel in degrees


# ---------------------------------------------------------------------------- compare

def test_compare_shows_each_designs_own_numbers(browser, tmp_path):
    import json
    text = linkdyn.example_path("hoeken").read_text("utf-8")
    a, b = tmp_path / "hoeken.toml", tmp_path / "heavy.toml"
    a.write_text(text, "utf-8")
    # the variant: a coupler twice as heavy (mass and inertia), so its loads differ
    heavy = text.replace("mass = 5.0", "mass = 10.0", 1).replace("inertia = 88473.60",
                                                                 "inertia = 176947.20", 1)
    assert heavy != text
    b.write_text(heavy, "utf-8")
    runner = CliRunner()
    res = runner.invoke(main, ["compare", str(a), str(b), "-o", str(tmp_path / "cmp")])
    assert res.exit_code == 0, res.output
    assert sorted(p.name for p in (tmp_path / "cmp").iterdir()) == [
        "compare.csv", "compare.html", "compare.json"]
    page = (tmp_path / "cmp" / "compare.html").read_text("utf-8")
    data = page_blob(page)
    assert [d["name"] for d in data["designs"]] == ["hoeken", "heavy"]
    own = {}
    for path in (a, b):
        out = tmp_path / f"own-{path.stem}"
        assert runner.invoke(main, ["analyze", str(path), "-o", str(out)]).exit_code == 0
        own[path.stem] = json.loads((out / "summary.json").read_text())
    peaks = []
    for d in data["designs"]:
        s, key = own[d["name"]], {it["label"]: it for it in d["key"]}
        # the driver's peak |torque| of its own run is its max or min on the page, signed
        top = max(key["max torque J1"]["value"], -key["min torque J1"]["value"])
        assert top == pytest.approx(s["drivers"]["J1"]["peak"], rel=1e-12)
        for j, r in s["reactions"].items():
            assert key[f"peak |F| {j}"]["value"] == pytest.approx(r["peak_force_N"], rel=1e-12)
            assert key[f"peak |F| {j}"]["t"] == pytest.approx(r["peak_time_s"], rel=1e-12)
        assert key["peak shaking force"]["value"] == pytest.approx(
            s["shaking"]["force_N"]["peak"], rel=1e-12)
        # and the table beside the curves shows that number
        assert f"<b>{report.tables.key_value(key['max torque J1'])}</b>" in page
        peaks.append(top)
    assert peaks[0] != pytest.approx(peaks[1], rel=1e-3)  # the designs do differ
    saved = json.loads((tmp_path / "cmp" / "compare.json").read_text())
    assert saved["heavy"]["summary"]["drivers"] == own["heavy"]["drivers"]
    # differences from the first design, absolute and %, and the better value by its sense
    rows = {r["label"]: r for r in data["rows"]}
    top = rows["RMS torque J1"]
    a0, a1 = top["values"]
    assert top["diff"] == [None, pytest.approx(a1 - a0, rel=1e-12)]
    assert top["pct"][1] == pytest.approx(100 * (a1 - a0) / a0, rel=1e-12)
    assert top["sense"] == "min" and top["best"] == [int(np.argmin([a0, a1]))]
    mu = rows["min transmission angle coupler/rocker"]
    assert mu["sense"] == "max" and mu["best"] == []   # the same geometry: no better one
    tmin = rows["min torque J1"]   # signed: the smaller magnitude is the better
    assert tmin["best"] == [int(np.argmin(np.abs(tmin["values"])))]
    # the parameters that differ: the coupler's mass and inertia, in the file's units as
    # linkdyn save writes them (the inertia about the mass centre, 115.2 mm from O2)
    assert data["differs"] == [{"path": "bodies.coupler.mass", "values": [5, 10]},
                               {"path": "bodies.coupler.inertia", "values": [
                                   pytest.approx(88473.6 - 5 * 115.2 ** 2, rel=1e-12),
                                   pytest.approx(176947.2 - 10 * 115.2 ** 2, rel=1e-12)]}]
    assert "bodies.coupler.mass" in page and "Δ " in page
    # the traced paths overlaid: coupler.P of each design, in mm, equal to its results.csv
    assert data["length_unit"] == "mm" and list(data["paths"]) == ["coupler.P"]
    for n, d in enumerate(data["designs"]):
        cols = _csv_columns(tmp_path / f"own-{d['name']}" / "results.csv")
        k = np.abs(cols["t"][:, None] - np.array(d["series"]["t"])[None]).argmin(0)
        for c, xy in zip("xy", data["paths"]["coupler.P"][n]):
            np.testing.assert_allclose(xy, cols[f"{c}_coupler.P"][k] * 1e3, rtol=2e-5,
                                       atol=1e-9)
    # the page: curves of both designs in every panel, a hover readout per design
    pg = Page.__new__(Page)
    pg.page = browser.new_page(viewport={"width": 1440, "height": 900})
    errors = []
    pg.page.on("pageerror", lambda e: errors.append(str(e)))
    pg.page.goto((tmp_path / "cmp" / "compare.html").as_uri())
    pg.page.wait_for_function("window.__linkdynCompare === true")
    n = len(data["panels"])
    assert n >= 5 and pg.page.locator("#plots path.series").count() == 2 * n
    svg = pg.page.locator("#plots .panel svg").first
    svg.scroll_into_view_if_needed()
    box = svg.bounding_box()
    pg.page.mouse.move(box["x"] + 0.5 * box["width"], box["y"] + 0.5 * box["height"])
    assert pg.page.locator("#plots .tooltip b[data-design]").count() == 2
    # the path overlay: one path per design, each of many points; the better values marked
    paths = pg.page.eval_on_selector_all("#pathbox path.ppath", "es => es.map(e => "
                                         "[+e.dataset.design, e.getAttribute('d').length])")
    assert [n for n, _ in paths] == [0, 1] and all(n > 200 for _, n in paths)
    assert pg.page.locator("table.cmp td.best").count() >= 3
    # on a phone nothing is wider than the screen (the tables scroll in their box)
    pg.page.set_viewport_size({"width": 390, "height": 844})
    assert pg.page.evaluate("document.documentElement.scrollWidth") <= 390
    assert pg.page.locator("#pathbox svg").bounding_box()["width"] <= 390
    assert errors == []
    pg.page.close()


def test_compare_needs_two_models(tmp_path):
    res = CliRunner().invoke(main, ["compare", str(linkdyn.example_path("hoeken")),
                                    "-o", str(tmp_path / "c")])
    assert res.exit_code == 2 and "at least two" in res.output
    assert not (tmp_path / "c").exists()


def test_printed_summary_shows_rounding_noise_as_zero(tmp_path):
    res = CliRunner().invoke(main, ["analyze", str(linkdyn.example_path("slider_crank")),
                                    "-o", str(tmp_path / "o"), "--samples", 73])
    assert res.exit_code == 0, res.output
    summary = json.loads((tmp_path / "o" / "summary.json").read_text())
    assert 0 < abs(summary["driver_energy"]["J1"]["work_J"]) < 1e-9  # the file keeps it
    assert "driver J1: work 0 J (+" in res.output
    assert re.search(r"J4 +\S+ N at t = \S+ s, moment 0 N m", res.output)


def test_slider_dyad_transmission_angle_is_the_closed_form():
    # offset slider-crank (crank r = 50 mm, rod L = 180 mm, slide 20 mm above the crank axis):
    # the rod's angle to the slide is asin((r sin q - e) / L); the transmission angle is its
    # complement (the rod against the slide's normal)
    sol = _solution("slider_crank", np.linspace(0.0, 0.2, 121))
    items = {it["label"]: it for it in report.key_results(sol)}
    item = items["min transmission angle rod/slider"]
    q = sol.columns["q_J1"]
    mu = 90.0 - np.degrees(np.abs(np.arcsin((0.05 * np.sin(q) - 0.02) / 0.18)))
    assert item["value"] == pytest.approx(np.min(mu), rel=1e-9)
    assert item["k"] == int(np.argmin(mu))
    d = report.page_data(sol)
    np.testing.assert_allclose(d["series"]["mu_s:0"], mu, rtol=1e-4)


def test_a_panel_exports_its_series_as_csv_svg_and_png(page, hoeken_report_run):
    p = page.page
    spec = p.evaluate("JSON.parse(document.getElementById('linkdyn-data').textContent).plots[0]")
    with p.expect_download() as dl:
        p.locator("#plots .panel").first.locator(".pexport button", has_text="CSV").click()
    text = open(dl.value.path(), encoding="utf-8").read().splitlines()
    assert dl.value.suggested_filename == "joint_angles.csv"
    assert text[0].startswith('"t_s","J1 (deg)"') and len(text) == 1 + 361
    # every digit: each exported value is results.csv's (angles turned to degrees), to the
    # last bit but the one rounding of that turn (5 significant digits failed this)
    csv = _csv_columns(hoeken_report_run / "results.csv")
    got = np.array([[float(v) for v in line.split(",")] for line in text[1:]])
    np.testing.assert_array_equal(got[:, 0], csv["t"])
    for n, s in enumerate(spec["series"]):
        want = csv[_column_of(s["key"])[0]] * (np.degrees(1) if spec["unit"] == "deg" else 1)
        np.testing.assert_allclose(got[:, 1 + n], want, rtol=3e-16,
                                   atol=3e-16 * np.max(np.abs(want)), err_msg=s["key"])
    svg = p.evaluate("window.__linkdynExport.svg(0)")
    assert svg.startswith("<svg") and "Joint angles" in svg and "<path" in svg
    # the figure has its legend (each series' label beside a line of its colour) and none of
    # the page's state (the time cursor, its dots, the hover line)
    import xml.etree.ElementTree as ET
    root = ET.fromstring(svg)
    ns = "{http://www.w3.org/2000/svg}"
    classes = [e.get("class", "") for e in root.iter()]
    assert not any(c.split() and set(c.split()) & {"cursor", "dot", "hoverline"} for c in classes)
    legend = [e for e in root.iter(ns + "text") if "legendtext" in e.get("class", "")]
    assert [e.text for e in legend] == [s["label"] for s in spec["series"]]
    swatches = [e.get("stroke") for e in root.iter(ns + "line") if e.get("stroke-width") == "3"]
    assert swatches == [s["color"] for s in spec["series"]]
    height = float(root.get("height"))
    assert all(float(e.get("y")) < height for e in legend)
    with p.expect_download() as dl:
        p.locator("#plots .panel").first.locator(".pexport button", has_text="PNG").click()
    png = open(dl.value.path(), "rb").read()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    # IHDR: the image is the figure at twice its size, legend included
    assert int.from_bytes(png[20:24], "big") == 2 * round(height)
    assert page.errors == []


def test_every_readout_is_results_csv_correctly_rounded(page, hoeken_report_run):
    # each panel's readout under its legend, at frames across the run: results.csv's value
    # (turned to degrees for an angle) rounded once to the decimals shown. The page's data
    # keep every digit; at 5 significant digits stored and 4 shown, about 3 % of these were
    # one unit off (a value rounded twice)
    csv = _csv_columns(hoeken_report_run / "results.csv")
    D = _page_data(hoeken_report_run / "report.html")
    unit = {s["key"]: p["unit"] for p in D["plots"] for s in p["series"]}
    p = page.page
    checked = 0
    for k in range(3, 361, 9):
        p.evaluate("k => { const s = document.getElementById('scrubber'); s.value = String(k);"
                   " s.dispatchEvent(new Event('input')); }", k)
        shown = p.eval_on_selector_all("#plots .legend b[data-key]",
                                       "bs => bs.map(b => [b.dataset.key, b.textContent])")
        for key, text in shown:
            col = _column_of(key)
            if col is None or col[0] not in csv:
                continue
            want = csv[col[0]][k] * (np.degrees(1) if unit[key] == "deg" else 1.0)
            if "e" in text:   # a series of peak below 1e-3 or from 1e6: 4 significant digits
                assert float(text) == float(f"{want:.3e}"), (key, k, text, want)
            else:
                digits = len(text.split(".")[1]) if "." in text else 0
                expect = f"{want:.{digits}f}"
                if float(expect) == 0:
                    expect = expect.lstrip("-")
                assert text == expect, (key, k, text, want)
            checked += 1
    assert checked > 800
    assert page.errors == []


def test_the_arrow_keys_step_the_frame_after_a_click_on_a_key_result(page):
    p = page.page
    btn = p.locator(".keyitem[data-frame]").nth(1)
    k = int(btn.get_attribute("data-frame"))
    btn.click()
    assert page.frame() == k
    assert p.evaluate("document.activeElement.classList.contains('keyitem')")
    p.keyboard.press("ArrowRight")
    p.wait_for_function(f"window.__linkdynFrame === {k + 1}", timeout=3000)
    p.keyboard.press("ArrowLeft")
    p.keyboard.press("ArrowLeft")
    p.wait_for_function(f"window.__linkdynFrame === {k - 1}", timeout=3000)
    assert page.errors == []


def test_a_tap_on_a_phone_shows_the_readout_of_the_frame_it_picks(browser, hoeken_report_run):
    # a phone has no hover: the tap picks the frame and shows that frame's readout
    csv = _csv_columns(hoeken_report_run / "results.csv")
    p = browser.new_page(viewport={"width": 390, "height": 844}, has_touch=True, is_mobile=True)
    errors: list[str] = []
    p.on("pageerror", lambda e: errors.append(str(e)))
    try:
        p.goto((hoeken_report_run / "report.html").resolve().as_uri())
        p.wait_for_function("window.__linkdynFrame === 0")
        D = p.evaluate("JSON.parse(document.getElementById('linkdyn-data').textContent)")
        at = next(n for n, s in enumerate(D["plots"]) if s["title"].startswith("Driver"))
        panel = p.locator("#plots .panel").nth(at)
        panel.scroll_into_view_if_needed()
        box = panel.locator("svg.plot").bounding_box()
        p.touchscreen.tap(box["x"] + 0.6 * box["width"], box["y"] + 0.5 * box["height"])
        tip = panel.locator(".tooltip")
        p.wait_for_function("() => [...document.querySelectorAll('.tooltip')]"
                            ".some(t => t.style.display === 'block')", timeout=3000)
        k = int(tip.get_attribute("data-frame"))
        assert p.evaluate("window.__linkdynFrame") == k > 0
        text = tip.locator("b").first.inner_text().split()[0]
        assert float(text) == pytest.approx(csv["tau_J1"][k], abs=1e-3 * abs(csv["tau_J1"]).max())
        assert errors == []
    finally:
        p.close()


def test_each_joints_bar_is_its_force_now_against_its_own_run_peak(page, hoeken_report_run):
    # each joint's bar: |F| at the frame over that joint's peak |F| over the run, from
    # results.csv (not the largest joint's peak, which made the lighter joints' bars short)
    csv = _csv_columns(hoeken_report_run / "results.csv")
    p = page.page
    k = 200
    p.evaluate("k => { const s = document.getElementById('scrubber'); s.value = String(k);"
               " s.dispatchEvent(new Event('input')); }", k)
    p.wait_for_function(f"window.__linkdynFrame === {k}")
    rows = p.locator("#jointforces tbody tr")
    for n in range(rows.count()):
        name = rows.nth(n).locator("th").inner_text()
        f = np.hypot(csv[f"Fx_{name}"], csv[f"Fy_{name}"])
        width = rows.nth(n).locator(".fbar").evaluate("e => parseFloat(e.style.width)")
        assert width == pytest.approx(100.0 * f[k] / f.max(), abs=0.06), name
    assert page.errors == []


# ------------------------------------------------ link-frame forces and instant centres

def test_reaction_local_is_the_global_reaction_turned_into_the_second_body():
    from linkdyn.planar import rotate
    for example in ("hoeken", "inverted_slider_crank"):
        sol = _solution(example, np.linspace(0.0, 0.5, 13))
        for j in sol.model.joints:
            f = sol.reaction(j.name)[:, :2]
            phi = 0.0 * sol.t if j.body_b == "ground" else sol.phi(j.body_b)
            want = rotate(-phi, f.T).T  # R(-phi_b) f, through planar.rotate
            scale = np.max(np.abs(f))
            np.testing.assert_allclose(sol.reaction_local(j.name), want, rtol=0,
                                       atol=1e-12 * scale, err_msg=j.name)


def test_reaction_local_of_a_spun_bar_is_its_centripetal_pull():
    # a uniform 0.4 m bar of 2 kg turned at a constant 120 rpm about one end, no gravity: the
    # pivot pulls the centre of mass (0.2 m out) inward, -m w^2 d along the bar, 0 across it
    data = {"mechanism": {"name": "spun bar", "gravity": [0.0, 0.0]},
            "bodies": [{"name": "ground", "points": {"O": [0.0, 0.0]}},
                       {"name": "bar", "points": {"O": [0.0, 0.0], "A": [0.4, 0.0]},
                        "mass": 2.0, "com": [0.2, 0.0], "inertia": 2.0 * 0.4 ** 2 / 12}],
            "joints": [{"name": "J1", "type": "revolute", "connect": ["ground.O", "bar.O"]}],
            "drivers": [{"joint": "J1", "motion": {"kind": "constant_speed", "rpm": 120.0}}]}
    m = linkdyn.io.model_from_dict(data)
    sol = linkdyn.analyze(m, np.linspace(0.0, 0.5, 7), backend="numpy")
    w = 120.0 * 2 * np.pi / 60
    want = np.tile([-2.0 * w ** 2 * 0.2, 0.0], (7, 1))
    np.testing.assert_allclose(sol.reaction_local("J1"), want, rtol=0, atol=1e-9 * 2 * w ** 2 * 0.2)
    # the global force turns with the bar while its local components stay put
    assert np.ptp(sol.reaction("J1")[:, 0]) > 1.0


def _line_intersection(p1, p2, p3, p4):
    """(T, 2) intersection of the lines p1p2 and p3p4 (each (T, 2))."""
    d1, d2 = p2 - p1, p4 - p3
    den = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    s = ((p3 - p1)[:, 0] * d2[:, 1] - (p3 - p1)[:, 1] * d2[:, 0]) / den
    return p1 + s[:, None] * d1


def test_instant_centres_are_the_closed_forms_on_hoeken():
    sol = _solution("hoeken", np.linspace(0.0, 4 / 3, 37)[:-1])
    size = 0.2304  # the coupler's length, m
    # the crank and the rocker turn about their ground pivots
    for body, pivot in (("crank", [0.0, 0.0]), ("rocker", [0.0895, 0.0])):
        ic = sol.instant_centre(body)
        np.testing.assert_allclose(ic, np.tile(pivot, (36, 1)), rtol=0, atol=1e-9 * size)
    # the coupler's: where the crank line O1-O2 meets the rocker line O4-O3 (Kennedy)
    want = _line_intersection(sol.point("crank", "O1"), sol.point("crank", "O2"),
                              sol.point("rocker", "O4"), sol.point("rocker", "O3"))
    ic = sol.instant_centre("coupler")
    far = np.hypot(*want.T)
    err = np.hypot(*(ic - want).T) / np.maximum(size, far)
    assert np.all(err < 1e-9), err.max()
    # the coupler really is at rest there: v = v_O2 + omega z x (ic - O2) = 0
    r = ic - sol.point("coupler", "O2")
    v = sol.point_velocity("coupler", "O2") + sol.omega("coupler")[:, None] * np.stack(
        [-r[:, 1], r[:, 0]], axis=-1)
    assert np.max(np.abs(v)) < 1e-9 * np.max(np.abs(sol.point_velocity("coupler", "P")))


def test_a_translating_body_has_no_instant_centre():
    sol = _solution("slider_crank", np.linspace(0.0, 0.2, 9))
    slider = next(j.body_b for j in sol.model.joints if j.kind == "prismatic")
    assert np.all(np.isnan(sol.instant_centre(slider)))


def test_compare_takes_a_sweeps_best_designs(tmp_path, monkeypatch):
    pd = pytest.importorskip("pandas", reason="the sweep's table needs pandas (the parquet extra)")
    monkeypatch.chdir(tmp_path)  # the sweep names its model file relative to where it ran
    (tmp_path / "hoeken.toml").write_text(linkdyn.example_path("hoeken").read_text("utf-8"))
    runner = CliRunner()
    res = runner.invoke(main, ["sweep", "hoeken.toml", "--vary", "bodies.coupler.mass=3:5:3",
                               "--vary", "bodies.ground.points.O4[0]=85:95:2", "--samples", "19",
                               "-o", "sw"])
    assert res.exit_code == 0, res.output
    df = pd.read_parquet(tmp_path / "sw" / "designs.parquet")
    # a missing or unknown ranking metric: exit 2 naming --by and the metrics, nothing written
    for extra in ([], ["--by", "nope"]):
        bad = runner.invoke(main, ["compare", "--sweep", "sw", *extra, "-o", "bad"])
        assert bad.exit_code == 2 and "--by" in bad.output and "peak_tau_J1" in bad.output
        assert not (tmp_path / "bad").exists()
    res = runner.invoke(main, ["compare", "hoeken.toml", "--sweep", "sw", "--by", "peak_tau_J1",
                               "--best", "2", "--samples", "19", "-o", "cmp"])
    assert res.exit_code == 0, res.output
    saved = json.loads((tmp_path / "cmp" / "compare.json").read_text())
    best = df[df["valid"]].sort_values("peak_tau_J1").head(2)
    assert list(saved) == ["hoeken"] + [f"hoeken #{d}" for d in best["design"]]
    for (_, row), name in zip(best.iterrows(), list(saved)[1:]):
        entry = saved[name]
        assert entry["sweep"]["parameters"] == {
            p: row[p] for p in ("bodies.coupler.mass", "bodies.ground.points.O4[0]")}
        # the design solved again on its own has the sweep's batch-computed metric
        assert entry["summary"]["drivers"]["J1"]["peak"] == pytest.approx(
            row["peak_tau_J1"], rel=1e-9)
    peaks = [saved[n]["summary"]["drivers"]["J1"]["peak"] for n in saved]
    assert peaks[1] <= peaks[2] and peaks[1] != pytest.approx(peaks[0], rel=1e-6)


def test_sweep_page_draws_each_valid_design_and_highlights_the_pareto_set(browser, tmp_path):
    pd = pytest.importorskip("pandas", reason="the sweep's table needs pandas (the parquet extra)")
    from linkdyn.report.sweep import pareto_front
    model = tmp_path / "hoeken.toml"
    model.write_text(linkdyn.example_path("hoeken").read_text("utf-8"), "utf-8")
    res = CliRunner().invoke(main, [
        "sweep", str(model), "--vary", "bodies.ground.points.O4[0]=40:200:5",
        "--vary", "bodies.coupler.points.O3[0]=60:140:4", "--samples", "41", "--metric",
        "peak_tau_J1", "--metric", "path_deviation", "--backend", "numpy", "--report",
        "-o", str(tmp_path / "s")])
    assert res.exit_code == 0, res.output
    df = pd.read_parquet(tmp_path / "s" / "designs.parquet")
    pg = browser.new_page(viewport={"width": 1200, "height": 900})
    errors = []
    pg.on("pageerror", lambda e: errors.append(str(e)))
    pg.on("console", lambda m: m.type == "error" and errors.append(m.text))
    pg.goto((tmp_path / "s" / "sweep.html").resolve().as_uri())
    pg.wait_for_function("window.__linkdynSweep === true")
    rows = lambda sel: sorted(pg.eval_on_selector_all(  # noqa: E731
        sel, "es => es.map(e => +e.getAttribute('data-row'))"))
    # default axes are the two metrics: one point per valid design (invalid ones have none)
    valid = np.flatnonzero(df.valid.to_numpy()).tolist()
    assert rows("#scatter circle.pt") == valid
    v = df.valid.to_numpy()
    front = pareto_front(np.where(v, df.peak_tau_J1, np.nan), np.where(v, df.path_deviation,
                                                                        np.nan)).tolist()
    assert rows("#scatter circle.front") == front
    assert pg.locator("#scatter path.frontline").count() == 1
    # log axes keep every (positive) point and the front
    pg.check("#logx")
    pg.check("#logy")
    assert rows("#scatter circle.pt") == valid and rows("#scatter circle.front") == front
    pg.uncheck("#logx")
    pg.uncheck("#logy")
    # parameters on both axes: every design, invalid ones grey, hidden by the checkbox
    pg.select_option("#sx", "bodies.ground.points.O4[0]")
    pg.select_option("#sy", "bodies.coupler.points.O3[0]")
    assert rows("#scatter circle.pt") == list(range(len(df)))
    assert rows("#scatter circle.invalid") == np.flatnonzero(~v).tolist()
    pg.check("#hideinvalid")
    assert rows("#scatter circle.pt") == valid
    # hover reads the design's row; the best designs are the lowest valid ones
    box = pg.locator("#scatter circle.pt").first.bounding_box()
    pg.mouse.move(box["x"] + box["width"] / 2, box["y"] + box["height"] / 2)
    first = int(pg.locator("#scatter circle.pt").first.get_attribute("data-row"))
    tip = pg.inner_text("#scatter .tooltip")
    assert f"design {df.design[first]}" in tip
    shown = re.search(r"bodies\.ground\.points\.O4\[0\] \(mm\) = (\S+)", tip).group(1)
    assert float(shown) == pytest.approx(df["bodies.ground.points.O4[0]"][first], rel=1e-3)
    best = df[df.valid].sort_values(["peak_tau_J1", "design"]).index[:3].tolist()
    assert pg.eval_on_selector_all("#best tbody tr", "es => es.map(e => +e.dataset.row)") == best
    assert "linkdyn compare --sweep" in pg.inner_text("#cmpcmd")
    assert "--by peak_tau_J1" in pg.inner_text("#cmpcmd")
    # each best design's own report page, shown below the table with its animation drawn:
    # the first at once, another on a click
    assert pg.get_attribute("#preview", "src") == f"design-{df.design[best[0]]}.html"
    assert pg.locator("#best tbody tr.shown").get_attribute("data-row") == str(best[0])
    second = f"design-{df.design[best[1]]}.html"
    with pg.expect_event("framenavigated", lambda f: f.url.endswith(second)) as nav:
        pg.locator("#best tbody tr").nth(1).click(position={"x": 5, "y": 5})
    assert pg.get_attribute("#preview", "src") == second
    inner = nav.value
    inner.wait_for_load_state()
    inner.wait_for_function("document.querySelectorAll('#anim *').length > 10")
    assert errors == []
    pg.close()


# ---------------------------------------------------------------------------- spatial models

def _csv_columns(path) -> dict[str, np.ndarray]:
    head = path.read_text("utf-8").splitlines()[0].split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {name: data[:, n] for n, name in enumerate(head)}


def _camera_projection(cam: dict, p: np.ndarray) -> np.ndarray:
    """Independent of the page: the orthographic view of points p (..., 3) by the camera the
    page reports (azimuth, elevation about +z; docs/spatial.md "The report"), viewBox units."""
    az, el = cam["az"], cam["el"]
    right = np.array([-np.sin(az), np.cos(az), 0.0])
    up = np.array([-np.sin(el) * np.cos(az), -np.sin(el) * np.sin(az), np.cos(el)])
    q = np.asarray(p, float) - np.asarray(cam["centre"], float)
    s = cam["fit"] * cam["zoom"]
    return np.stack([cam["cx"] + s * q @ right, cam["cy"] - s * q @ up], axis=-1)


def test_spatial_report_is_one_self_contained_file(rsur_report_run):
    text = (rsur_report_run / "report.html").read_text("utf-8")
    assert "http://" not in text and "https://" not in text
    assert not re.search(r"<script[^>]*\bsrc\s*=|<link[^>]*\bhref\s*=|<(img|iframe)\b", text, re.I)
    assert "fetch(" not in text and "XMLHttpRequest" not in text
    D = page_blob(text)
    assert D["geom"]["dim"] == 3
    # the drawn points are results.csv's, at every frame (all 121 samples are frames)
    cols = _csv_columns(rsur_report_run / "results.csv")
    assert len(D["t"]) == len(cols["t"])
    for pid, p in D["geom"]["points"].items():
        if p.get("static"):
            continue
        for c in "xyz":
            np.testing.assert_allclose(p[c], cols[f"{c}_{pid}"], rtol=1e-5, atol=1e-9)
    # each joint's reaction force at the frame is the csv's, the driver torque too
    for j in D["geom"]["joints"]:
        for c in ("Fx", "Fy", "Fz"):
            np.testing.assert_allclose(D["series"][f"{c}:{j['name']}"], cols[f"{c}_{j['name']}"],
                                       rtol=1e-4, atol=1e-9 * max(1.0, D["geom"]["fmax"]))
    np.testing.assert_allclose(D["series"]["tau:J1"], cols["tau_J1"], rtol=1e-4, atol=1e-9)
    # a revolute joint's axis at each frame: the ground's J1 stays +z; J4's axis (fixed in
    # the ground) stays put while the rocker turns about it
    ax = np.array([D["series"][k] for k in next(j for j in D["geom"]["joints"] if j["name"] == "J1")["axis"]])
    np.testing.assert_allclose(ax.T, np.tile([0.0, 0.0, 1.0], (len(D["t"]), 1)), atol=1e-12)
    key = {it["label"]: it for it in D["key"]}
    assert key["max torque J1"]["value"] == pytest.approx(cols["tau_J1"].max(), rel=1e-9)
    assert key["max torque J1"]["frame"] == int(np.argmax(cols["tau_J1"]))


@pytest.mark.parametrize("size", [(1400, 1000), (390, 844)], ids=["desktop", "phone"])
def test_spatial_report_draws_turns_and_zooms(browser, rsur_report_run, size):
    pg = Page(browser, rsur_report_run / "report.html", width=size[0], height=size[1])
    p = pg.page
    try:
        cols = _csv_columns(rsur_report_run / "results.csv")
        D = json.loads(p.inner_text("#linkdyn-data"))
        ends = {j["name"]: j["b"] for j in D["geom"]["joints"]}

        def drawn_match_csv():
            """Each joint's drawn point (circle.jc, viewBox units) is results.csv's point
            column at the page's frame, projected by the page's own camera."""
            k, cam = pg.frame(), p.evaluate("window.__linkdynCamera")
            for name, pid in ends.items():
                c = p.locator(f"#anim g.joint[data-joint='{name}'] circle.jc")
                drawn = [float(c.get_attribute("cx")), float(c.get_attribute("cy"))]
                xyz = np.array([cols[f"{a}_{pid}"][k] for a in "xyz"])
                np.testing.assert_allclose(drawn, _camera_projection(cam, xyz), atol=0.02)
            return cam

        cam0 = drawn_match_csv()
        assert p.locator("#plots .panel").count() >= 8
        assert p.locator("#anim g.joint[data-kind='spherical']").count() == 1
        assert p.locator("#anim g.joint[data-kind='universal'] line").count() == 2
        # the animation advances, and the drawing follows it
        p.click("#play")
        p.wait_for_function("window.__linkdynFrame > 5", timeout=5000)
        p.click("#play")
        drawn_match_csv()
        # the forces: each joint's reaction arrow from its point along the csv's force, at the
        # page's one length per newton, projected by the camera
        p.check("#show-forces")
        assert p.locator("#anim line.farrow[data-joint]").count() == 4
        k, cam = pg.frame(), p.evaluate("window.__linkdynCamera")
        per_newton = p.evaluate("window.__linkdynForces.scale")
        assert per_newton > 0
        for name, pid in ends.items():
            a = p.locator(f"#anim line.farrow[data-joint='{name}']")
            drawn = [float(a.get_attribute(c)) for c in ("x1", "y1", "x2", "y2")]
            xyz = np.array([cols[f"{c}_{pid}"][k] for c in "xyz"])
            force = np.array([cols[f"F{c}_{name}"][k] for c in "xyz"])
            want = _camera_projection(cam, np.array([xyz, xyz + per_newton * force])).ravel()
            np.testing.assert_allclose(drawn, want, atol=0.05)
        # dragging turns the view: the camera and the pixels change, the drawing still matches
        box = p.locator("#anim").bounding_box()
        before = p.locator("#anim").screenshot()
        x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        p.mouse.move(x, y)
        p.mouse.down()
        p.mouse.move(x + 60, y + 25, steps=4)
        p.mouse.up()
        cam1 = drawn_match_csv()
        assert abs(cam1["az"] - cam0["az"]) > 0.1 and abs(cam1["el"] - cam0["el"]) > 0.02
        assert p.locator("#anim").screenshot() != before
        # the wheel zooms, the reset button returns to the starting view
        p.mouse.wheel(0, -300)
        p.wait_for_function(f"window.__linkdynCamera.zoom > 1.2")
        drawn_match_csv()
        p.click("#view-reset")
        cam2 = p.evaluate("window.__linkdynCamera")
        assert (cam2["az"], cam2["el"], cam2["zoom"]) == pytest.approx((cam0["az"], cam0["el"], 1.0))
        # the page fits the screen, with no request leaving it and no error
        assert p.evaluate("document.documentElement.scrollWidth") <= size[0] + 1
        assert all(u.startswith("file:") for u in pg.requests), pg.requests
        assert pg.errors == []
    finally:
        pg.close()


def test_spatial_plots_are_the_pages_panels(rsur_report_run, tmp_path):
    """``--plots`` on a spatial model: each section of the page's panels as one figure; here
    the energy section alone (the others are drawn alike), its curve the csv's energy."""
    from linkdyn.plots import panel_outputs
    text = (rsur_report_run / "report.html").read_text("utf-8")
    D = page_blob(text)
    names = set(panel_outputs(D))
    assert {"plot_joints.png", "plot_efforts.svg", "plot_energy.png"} <= names
    D["plots"] = [p for p in D["plots"] if p["section"] == "Energy"]
    cols = _csv_columns(rsur_report_run / "results.csv")
    ke = next(s for s in D["plots"][0]["series"] if s["label"] == "kinetic")
    np.testing.assert_allclose(D["series"][ke["key"]], cols["kinetic_energy"], rtol=1e-4)
    out = panel_outputs(D, formats=("png",))
    assert list(out) == ["plot_energy.png"]
    out["plot_energy.png"](tmp_path / "e.png")
    assert (tmp_path / "e.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_spatial_page_of_a_planar_mechanism_shows_the_planar_pages_numbers():
    """Hoeken's four-bar modelled in space: its page's joint rates, driver torque and
    reaction magnitudes are the planar page's (two solvers that share no kinematics or
    dynamics code), and its out-of-plane reactions are listed as zero, not plotted."""
    from linkdyn.report import spatial as sp
    t = np.linspace(0.0, 1.0, 13)
    planar = report.page_data(linkdyn.analyze(linkdyn.load(linkdyn.example_path("hoeken")), t))
    space = sp.page_data(linkdyn.analyze(linkdyn.load(linkdyn.example_path("hoeken_spatial")), t))
    assert space["geom"]["dim"] == 3 and "dim" not in planar["geom"]
    joints = [j["name"] for j in planar["geom"]["joints"]]
    assert joints == [j["name"] for j in space["geom"]["joints"]]
    fpeak = max(max(planar["series"][f"F:{j}"]) for j in joints)
    for j in joints:
        np.testing.assert_allclose(space["series"][f"F:{j}"], planar["series"][f"F:{j}"],
                                   rtol=1e-4, atol=1e-9 * fpeak)
        # rates (a spatial coordinate is 0 at the design pose, a planar one is not)
        np.testing.assert_allclose(space["series"][f"qd:{j}"], planar["series"][f"qd:{j}"],
                                   rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(space["series"]["tau:J1"], planar["series"]["tau:J1"],
                               rtol=1e-4, atol=1e-9 * fpeak)
    for j in joints:   # the plane's normal force and in-plane couples: zero to rounding
        assert any(z.endswith(f"Fz") and j in z for z in space["zero"]), (j, space["zero"])
    titles = {p["title"] for p in space["plots"]}
    assert not any(s["label"] == "Fz" for p in space["plots"] for s in p["series"])
    # the key results say that statics leaves 3 reaction sets open (a planar loop in space)
    open_sets = next(it for it in space["key"] if it["label"].startswith("reaction sets"))
    assert open_sets["value"] == 3 and "Fz_J1" in open_sets["note"]
    assert "Joint angles" in titles and "Driver torque" in titles


# ---------------------------------------------------------------------------- optimize, print

# A4 at 96 px per inch, less the print stylesheet's 12 mm margins: the width a page lays out in
A4_WIDTH = round((210 - 24) / 25.4 * 96)


def test_optimize_page_leads_with_objective_constraints_and_changes(browser, tmp_path):
    """The page optimize --report writes (its head from standing(), the rest the best design's
    report): the objective, each constraint with its status, each parameter's change, in view
    at 1440 x 900, within a phone's width, and first when printed."""
    from linkdyn.report.optimized import optimize_html
    from linkdyn.studies.optimize import optimize, standing
    from linkdyn.studies.params import space
    from linkdyn.units import Units
    hoeken = linkdyn.example_path("hoeken")
    t = np.linspace(0.0, 4.0 / 3.0, 41)
    box = {"bodies.ground.points.O4[0]": (85.0, 95.0)}
    res = optimize(hoeken, box, t, "peak_tau_J1", ["path_deviation<=0.2mm",
                                                   "min_transmission_angle>=10deg"],
                   popsize=4, maxiter=3, backend="numpy")
    st = standing(res, space(hoeken, list(box)), box, Units("mm", "deg"))
    sol = linkdyn.analyze(res.model, t, backend="numpy")
    page = report.render(sol, design.summary(sol), title="Hoeken: peak_tau_J1 minimized",
                         intro=optimize_html(st, evaluations=res.evaluations,
                                             seconds=res.seconds))
    path = tmp_path / "report.html"
    path.write_text(page, "utf-8")
    pg = Page(browser, path, 1440, 900)
    p = pg.page
    head = p.inner_text("#optimize h2")
    assert head == f"Optimized: peak_tau_J1 minimized to {res.metrics['peak_tau_J1']:.6g} N m"
    assert p.inner_text("h1") == "Hoeken: peak_tau_J1 minimized"
    dev = res.metrics["path_deviation"]
    rows = p.eval_on_selector_all("#opt-constraints tbody tr", "es => es.map(e => "
                                  "[e.dataset.metric, e.className, e.innerText])")
    assert [r[0] for r in rows] == ["path_deviation", "min_transmission_angle"]
    assert (rows[0][1] == "active") == (abs(dev - 2e-4) <= 2e-6)
    assert f"{dev * 1e3:.4g} mm" in rows[0][2] and rows[1][1] == ""
    x = res.values["bodies.ground.points.O4[0]"]
    change = p.inner_text("#opt-params tr[data-path='bodies.ground.points.O4[0]']")
    assert "89.50 mm" in change and report.tables.fmt(x) + " mm" in change
    for sel in ("#optimize h2", "#opt-params"):   # in view without scrolling
        b = p.locator(sel).bounding_box()
        assert b["y"] + b["height"] <= 900 and b["x"] + b["width"] <= 1440, sel
    p.set_viewport_size({"width": 390, "height": 844})
    assert p.evaluate("document.documentElement.scrollWidth") <= 390
    # printed: the optimize head first, then the key results
    p.set_viewport_size({"width": A4_WIDTH, "height": 1000})
    p.emulate_media(media="print")
    tops = [p.locator(s).bounding_box()["y"] for s in ("#optimize", "section.keys", "#summary")]
    assert tops == sorted(tops)
    assert pg.errors == []
    pg.close()


def test_printed_report_leads_with_key_results_and_clips_nothing(browser, hoeken_report):
    """The report under the print stylesheet at an A4 page's width: the key results, then the
    summary, then the animation; no value cut (every key value and summary cell fits its box
    and the page) and the flywheel printed whole. page.pdf() writes the A4 PDF."""
    pg = Page(browser, hoeken_report, A4_WIDTH, 1000)
    p = pg.page
    p.emulate_media(media="print")
    tops = [p.locator(s).bounding_box()["y"] for s in ("section.keys", "#summary",
                                                       "section.top", "#plotsec", "#model")]
    assert tops == sorted(tops)
    cut = p.evaluate("""w => Array.from(document.querySelectorAll(
        '.keyitem .kv, .keyitem .kl, #summary td, #summary th, #model td, #model th'))
        .filter(e => e.offsetParent !== null)
        .filter(e => e.scrollWidth > e.clientWidth + 1 || e.getBoundingClientRect().right > w + 0.5)
        .map(e => e.textContent)""", A4_WIDTH)
    assert cut == []
    assert p.evaluate("document.documentElement.scrollWidth") <= A4_WIDTH
    fly = p.locator(".keyitem", has_text="flywheel on J1")
    key = {it["label"]: it for it in json.loads(p.inner_text("#linkdyn-data"))["key"]}
    assert fly.locator(".kv").inner_text() == report.tables.key_value(key["flywheel on J1"])
    kv, item = fly.locator(".kv").bounding_box(), fly.bounding_box()
    assert kv["x"] >= item["x"] and kv["x"] + kv["width"] <= item["x"] + item["width"]
    pdf = p.pdf(format="A4")
    assert pdf.startswith(b"%PDF") and len(re.findall(rb"/Type\s*/Page[^s]", pdf)) >= 2
    assert pg.errors == []
    pg.close()


# ------------------------------------------------ the free-body view and its force polygon

@pytest.mark.parametrize("example, size", [("spatial_slider_crank", (1440, 900)),
                                           ("spatial_slider_crank", (390, 844)),
                                           ("stewart", (1440, 900))],
                         ids=["slider_crank-desktop", "slider_crank-phone", "stewart-desktop"])
def test_spatial_free_body_view_balances_each_links_inertia_force(browser, tmp_path, example,
                                                                    size):
    # the spatial page's free-body view of each link: its table's joint rows are results.csv's
    # reactions, signed, the weight m g; every row summed with the inertia force -m a_G (from
    # the csv's kinematics alone: Newton-Euler, independent of the reactions) is zero; the
    # polygon's sides are the forces as the 3-D view's camera sees them, head to tail, closed by
    # their sum; turning the view turns the drawing
    from test_free_body import spatial_m_a
    out = _analyze(tmp_path, example, "--report")
    csv = _csv_columns(out / "results.csv")
    model = linkdyn.load(linkdyn.example_path(example))
    pg = Page(browser, out / "report.html", width=size[0], height=size[1])
    p = pg.page
    try:
        p.locator("#freebody").scroll_into_view_if_needed()
        assert p.locator("#freebody").is_visible()
        bodies = p.eval_on_selector_all("#fbody option", "os => os.map(o => o.textContent)")
        assert bodies == [b.name for b in model.moving_bodies]
        n = len(csv["t"])

        def polygon_is_the_camera_view(rows):
            cam = p.evaluate("window.__linkdynCamera")
            az, el = cam["az"], cam["el"]
            right = np.array([-np.sin(az), np.cos(az), 0.0])
            up = np.array([-np.sin(el) * np.cos(az), -np.sin(el) * np.sin(az), np.cos(el)])
            sc = float(p.get_attribute("#fbpoly", "data-scale"))
            sides = p.eval_on_selector_all("#fbpoly line.fbside", """ls => ls.map(l =>
                [l.dataset.label, +l.getAttribute('x1'), +l.getAttribute('y1'),
                 +l.getAttribute('x2'), +l.getAttribute('y2')])""")
            force = {r[0]: np.array(r[1:]) for r in rows}
            assert [s[0] for s in sides] == [r[0] for r in rows[:-1]]
            for (name, x1, y1, x2, y2), nxt in zip(sides, sides[1:] + [None]):
                np.testing.assert_allclose([(x2 - x1) / sc, (y1 - y2) / sc],
                                           [force[name] @ right, force[name] @ up], rtol=0,
                                           atol=0.02 / sc)
                if nxt:
                    assert (nxt[1], nxt[2]) == pytest.approx((x2, y2), abs=0.011)
            x1, y1, x2, y2 = p.eval_on_selector("#fbpoly line.fbsum", """l =>
                ['x1', 'y1', 'x2', 'y2'].map(a => +l.getAttribute(a))""")
            total = force["sum = m a_G"]
            np.testing.assert_allclose([(x2 - x1) / sc, (y1 - y2) / sc],
                                       [total @ right, total @ up], rtol=0, atol=0.02 / sc)
            return cam

        for n_b, body in enumerate(bodies):
            p.select_option("#fbody", str(n_b))
            b = model.body(body)
            for k in (n // 6, n // 2, 5 * n // 6):
                p.evaluate("k => { const s = document.getElementById('scrubber');"
                           " s.value = String(k); s.dispatchEvent(new Event('input')); }", k)
                rows = p.eval_on_selector_all("#fbtable tbody tr", """rs => rs.map(r =>
                    [r.dataset.label, +r.dataset.fx, +r.dataset.fy, +r.dataset.fz])""")
                got = {r[0]: np.array(r[1:]) for r in rows}
                scale = max(np.max(np.abs(f)) for f in got.values())
                assert rows[-1][0] == "sum = m a_G" and "weight" in got, (body, k)
                np.testing.assert_allclose(got["weight"], b.mass * np.asarray(model.gravity),
                                           rtol=0, atol=1e-12 * scale)
                joints = 0
                for j in model.joints:
                    if body in (j.body_a, j.body_b) and j.name in got:
                        sign = 1.0 if j.body_b == body else -1.0
                        want = sign * np.array([csv[f"F{c}_{j.name}"][k] for c in "xyz"])
                        np.testing.assert_allclose(got[j.name], want, rtol=0, atol=1e-12 * scale)
                        joints += 1
                assert joints >= 1, (body, k)
                inertia = -spatial_m_a(model, csv, body, k)
                forces = [f for name, f in got.items() if name != "sum = m a_G"]
                np.testing.assert_allclose(sum(forces) + inertia, 0.0, rtol=0, atol=1e-9 * scale,
                                           err_msg=f"{body} {k}")
                np.testing.assert_allclose(got["sum = m a_G"], sum(forces), rtol=0,
                                           atol=1e-12 * scale)
                cam0 = polygon_is_the_camera_view(rows)
        # turning the 3-D view turns the free body's drawing with it
        p.locator("#anim").scroll_into_view_if_needed()
        box = p.locator("#anim").bounding_box()
        x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        p.mouse.move(x, y)
        p.mouse.down()
        p.mouse.move(x + 60, y + 25, steps=4)
        p.mouse.up()
        rows = p.eval_on_selector_all("#fbtable tbody tr", """rs => rs.map(r =>
            [r.dataset.label, +r.dataset.fx, +r.dataset.fy, +r.dataset.fz])""")
        cam1 = polygon_is_the_camera_view(rows)
        assert abs(cam1["az"] - cam0["az"]) > 0.1
        assert p.evaluate("document.documentElement.scrollWidth") <= size[0] + 1
        assert pg.errors == []
    finally:
        pg.close()


def _newton(model, csv, body, k):
    """m a_G of ``body`` at sample k from results.csv's columns alone: a named point P's
    acceleration, the body's omega, alpha and phi, and the model's mass centre c and P's
    coordinates p: ``a_G = a_P + alpha perp(d) - omega^2 d``, ``d = R(phi) (c - p)``."""
    b = model.body(body)
    pname = next(iter(b.points))
    c, s = np.cos(csv[f"phi_{body}"][k]), np.sin(csv[f"phi_{body}"][k])
    loc = np.asarray(b.com, float) - np.asarray(b.points[pname], float)
    d = np.array([c * loc[0] - s * loc[1], s * loc[0] + c * loc[1]])
    w, al = csv[f"omega_{body}"][k], csv[f"alpha_{body}"][k]
    a = np.array([csv[f"ax_{body}.{pname}"][k], csv[f"ay_{body}.{pname}"][k]])
    return b.mass * (a + al * np.array([-d[1], d[0]]) - w * w * d)


def _forces_from_csv(model, csv, body, k):
    """Each force on ``body`` at sample k from results.csv and the model file: each joint's
    reaction (by the first body on the second: + on the second, - on the first), the weight
    m g, a point force's value columns and a spring's or damper's tension along its line."""
    out = {}
    for j in model.joints:
        if body in (j.body_a, j.body_b):
            sign = 1.0 if j.body_b == body else -1.0
            out[j.name] = sign * np.array([csv[f"Fx_{j.name}"][k], csv[f"Fy_{j.name}"][k]])
    out["weight"] = model.body(body).mass * np.asarray(model.gravity, float)
    from linkdyn.loads import labels
    for ld, label in zip(model.loads, labels(model)):
        if ld.kind == "force" and ld.body == body:
            out[label] = np.array([csv[f"value_x_{label}"][k], csv[f"value_y_{label}"][k]])
        elif ld.kind in ("spring", "damper") and body in (ld.body, ld.body2):
            mine, other = ((ld.body, ld.point), (ld.body2, ld.point2))[:: 1 if ld.body == body else -1]
            r = [np.array([csv[f"x_{b}.{p}"][k], csv[f"y_{b}.{p}"][k]]) if b != "ground" else
                 np.asarray(model.body(b).points[p], float) for b, p in (mine, other)]
            u = (r[1] - r[0]) / np.linalg.norm(r[1] - r[0])   # tension pulls toward the other end
            out[label] = csv[f"value_{label}"][k] * u
    return {n: f for n, f in out.items() if np.any(f != 0)}


@pytest.mark.parametrize("example", ["slider_crank", "cam_follower", "geared_fivebar"])
def test_free_body_forces_are_results_csv_and_sum_to_m_a(example):
    # design.free_body: each force is results.csv's (signed reaction, weight, load), and by
    # Newton's law they sum to m a_G from the csv's kinematics, for every body at every sample
    from linkdyn.sampling import times
    model = linkdyn.load(linkdyn.example_path(example))
    sol = linkdyn.analyze(model, times(model, None, None, None))
    csv = {c: np.asarray(v, float) for c, v in sol.columns.items()}
    for b in model.moving_bodies:
        forces, m_a = design.free_body(sol, b.name)
        scale = max(np.max(np.abs(f.force)) for f in forces)
        for k in range(0, len(sol.t), 7):
            want = _forces_from_csv(model, csv, b.name, k)
            got = {f.label: f.force[k] for f in forces if f.kind in ("joint", "weight", "load")}
            assert set(want) <= set(got), (b.name, k)
            for name, f in want.items():
                np.testing.assert_allclose(got[name], f, rtol=0, atol=1e-12 * scale,
                                           err_msg=f"{b.name} {name} {k}")
            newton = _newton(model, csv, b.name, k)
            np.testing.assert_allclose(sum(f.force[k] for f in forces), newton, rtol=0,
                                       atol=1e-9 * scale, err_msg=f"{b.name} {k}")
            np.testing.assert_allclose(m_a[k], newton, rtol=0, atol=1e-9 * scale)


def test_free_body_of_a_block_pushed_up_an_incline_with_friction():
    # a slider driver's effort and the guide's friction are forces of the free body too: a
    # block of weight W pushed up a guide at angle a at constant speed, friction mu: the
    # driver's W (sin a + mu cos a) along the guide, the friction -mu W cos a, the guide's
    # normal W cos a, the weight; no acceleration, so they sum to zero
    import math
    import tomllib
    from linkdyn.io import model_from_dict
    a, mu, mass, G = 20 * math.pi / 180, 0.3, 2.0, 9.81
    model = model_from_dict(tomllib.loads(f"""
[mechanism]
name = "incline"
gravity = [0.0, {-G}]
[[bodies]]
name = "ground"
points = {{ O = [0.0, 0.0] }}
[[bodies]]
name = "block"
points = {{ B = [0.0, 0.0] }}
mass = {mass}
inertia = 0.01
[[joints]]
name = "J1"
type = "prismatic"
connect = ["ground.O", "block.B"]
axis = [{math.cos(a)}, {math.sin(a)}]
[[drivers]]
joint = "J1"
motion = {{ kind = "constant_speed", speed = 0.5, start = 0.1 }}
[[loads]]
kind = "friction"
joint = "J1"
coefficient = {mu}
transition_speed = 1e-9
"""))
    sol = linkdyn.analyze(model, np.linspace(0.0, 1.0, 5), backend="numpy")
    forces, m_a = design.free_body(sol, "block")
    got = {f.kind: f.force for f in forces}
    W, e, n = mass * G, np.array([math.cos(a), math.sin(a)]), np.array([-math.sin(a), math.cos(a)])
    want = {"driver": W * (math.sin(a) + mu * math.cos(a)) * e, "friction": -mu * W * math.cos(a) * e,
            "joint": W * math.cos(a) * n, "weight": np.array([0.0, -W])}
    assert set(got) == set(want)
    for kind, f in want.items():
        np.testing.assert_allclose(got[kind], np.broadcast_to(f, got[kind].shape), rtol=0,
                                   atol=1e-12 * W, err_msg=kind)
    np.testing.assert_allclose(m_a, 0.0, atol=1e-12 * W)


@pytest.mark.parametrize("size", [(1440, 900), (390, 844)], ids=["desktop", "phone"])
def test_free_body_view_shows_each_links_forces_closing_to_m_a(browser, example_runs, size):
    # the page's free-body view of each link of the slider-crank (joints, weight, the gas
    # load): its table is results.csv's forces, its sum row and the polygon's closing side
    # m a_G by Newton's law from the csv's kinematics; each side of the drawn polygon is its
    # force at the polygon's scale, head to tail from the origin
    path, csv = example_runs("slider_crank")
    model = linkdyn.load(linkdyn.example_path("slider_crank"))
    pg = Page(browser, path, width=size[0], height=size[1])
    p = pg.page
    try:
        p.locator("#freebody").scroll_into_view_if_needed()
        bodies = p.eval_on_selector_all("#fbody option", "os => os.map(o => o.textContent)")
        assert bodies == [b.name for b in model.moving_bodies]
        n = len(csv["t"])
        for n_b, body in enumerate(bodies):
            p.select_option("#fbody", str(n_b))
            for k in (n // 6, n // 2, 5 * n // 6):
                p.evaluate("k => { const s = document.getElementById('scrubber');"
                           " s.value = String(k); s.dispatchEvent(new Event('input')); }", k)
                rows = p.eval_on_selector_all("#fbtable tbody tr", """rs => rs.map(r =>
                    [r.dataset.label, +r.dataset.fx, +r.dataset.fy])""")
                want = _forces_from_csv(model, csv, body, k)
                newton = _newton(model, csv, body, k)
                scale = max(np.max(np.abs(f)) for f in want.values())
                got = {r[0]: np.array(r[1:]) for r in rows}
                assert set(got) == set(want) | {"sum = m a_G"}, (body, k, got)
                for name, f in want.items():
                    np.testing.assert_allclose(got[name], f, rtol=0, atol=1e-12 * scale)
                np.testing.assert_allclose(got["sum = m a_G"], newton, rtol=0, atol=1e-9 * scale)
                # the drawing: sides head to tail at the polygon's scale, closed by m a_G
                sc = float(p.get_attribute("#fbpoly", "data-scale"))
                sides = p.eval_on_selector_all("#fbpoly line.fbside", """ls => ls.map(l =>
                    [l.dataset.label, +l.getAttribute('x1'), +l.getAttribute('y1'),
                     +l.getAttribute('x2'), +l.getAttribute('y2')])""")
                assert [s[0] for s in sides] == [r[0] for r in rows[:-1]]
                for (name, x1, y1, x2, y2), (nxt) in zip(sides, sides[1:] + [None]):
                    np.testing.assert_allclose([(x2 - x1) / sc, (y1 - y2) / sc], want[name],
                                               rtol=0, atol=0.02 / sc)
                    if nxt:
                        assert (nxt[1], nxt[2]) == pytest.approx((x2, y2), abs=0.011)
                x1, y1, x2, y2 = p.eval_on_selector("#fbpoly line.fbsum", """l =>
                    ['x1', 'y1', 'x2', 'y2'].map(a => +l.getAttribute(a))""")
                assert (x1, y1) == pytest.approx((sides[0][1], sides[0][2]), abs=0.011)
                np.testing.assert_allclose([(x2 - x1) / sc, (y1 - y2) / sc], newton, rtol=0,
                                           atol=0.02 / sc)
        assert p.evaluate("document.documentElement.scrollWidth") <= size[0]
        assert pg.errors == []
    finally:
        pg.close()
