"""``analyze --plots``, ``analyze --report`` outputs, ``reproduce hoeken`` and the progress bar."""

from __future__ import annotations

import io
import json
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import Progress, main

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _hoeken_file(tmp_path):
    path = tmp_path / "hoeken.toml"
    path.write_text(linkdyn.example_path("hoeken").read_text("utf-8"), "utf-8")
    return path


def _png_size(path):
    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC, path
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def _read_csv(path):
    names = path.read_text("utf-8").splitlines()[0].split(",")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return {n: data[:, k] for k, n in enumerate(names)}


# ---------------------------------------------------------------------------- analyze

def test_plots_flag_writes_png_and_svg(tmp_path):
    out = tmp_path / "out"
    res = _run("analyze", _hoeken_file(tmp_path), "-o", out, "--plots")
    assert res.exit_code == 0, res.output
    files = set(os.listdir(out))
    names = ("joints", "efforts", "reactions", "multipliers", "paths")
    assert files == {"results.csv", "summary.json"} | {
        f"plot_{n}.{ext}" for n in names for ext in ("png", "svg")}
    for n in names:
        w, h = _png_size(out / f"plot_{n}.png")
        assert w > 500 and h > 300
        root = ET.parse(out / f"plot_{n}.svg").getroot()
        assert root.tag.endswith("svg")
        assert len(list(root.iter())) > 50  # drawn, not empty
    assert not any(f.startswith(".linkdyn-") for f in files)  # no temporary folder left


def test_plots_without_a_cut_joint_skip_the_multipliers():
    from linkdyn import plots
    m = linkdyn.load(linkdyn.example_path("hoeken"))
    sol = linkdyn.analyze(m, np.linspace(0.0, 4 / 3, 50))
    assert "multipliers" in plots.figure_builders(sol)
    figs = plots.figures(sol)
    assert set(figs) == {"joints", "efforts", "reactions", "multipliers", "paths"}
    # every panel of the joint figure has a labelled y axis and a legend
    for ax in figs["joints"].axes:
        assert ax.get_ylabel() and ax.get_legend() is not None


def _curves(ax):
    """The curves of ``ax`` (not its zero line)."""
    return [ln for ln in ax.get_lines() if len(ln.get_xdata()) > 2]


def _grey(fig):
    from PIL import Image
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=fig.dpi)
    return np.asarray(Image.open(buf).convert("L"), float)


def test_a_long_run_is_drawn_at_the_pixel_resolution_with_its_peaks():
    """A run of more samples than the axes has pixel columns is drawn by fewer points, a
    subsequence of the samples that keeps every peak and both ends, and its image is the image
    of the curve through every sample, but for anti-aliasing's shades."""
    from linkdyn import plots
    m = linkdyn.load(linkdyn.example_path("hoeken"))
    t = np.linspace(0.0, 4.0, 40001)
    sol = linkdyn.analyze(m, t)
    fig = plots.fig_efforts(sol)
    curve, = _curves(fig.axes[0])
    x, y = curve.get_data()
    tau = sol.dyn.tau[:, 0]
    width = fig.get_figwidth() * fig.dpi          # pixel columns of the whole figure
    assert 3 * 4 < len(x) <= 5 * width < len(t) / 8
    k = np.searchsorted(t, x)
    assert np.array_equal(t[k], x) and np.all(np.diff(k) > 0)   # samples, in their order
    assert np.array_equal(y, tau[k])
    assert (y.max(), y.min()) == (tau.max(), tau.min()) and (k[0], k[-1]) == (0, len(t) - 1)
    drawn = _grey(fig)
    curve.set_data(t, tau)   # the same curve through every sample
    full = _grey(fig)
    assert drawn.shape == full.shape
    # anti-aliasing shades a pixel a little differently; no pixel turns from curve to paper
    # (a change of about 200 of 255 grey levels) or back
    assert np.abs(drawn - full).max() <= 40


def test_a_gap_in_a_long_run_stays_a_gap_in_its_figure():
    """Samples of no value (NaN: a singular position kept by --allow-singular) break the
    curve: no drawn segment joins the samples on either side of them."""
    from types import SimpleNamespace

    from linkdyn import plots
    m = linkdyn.load(linkdyn.example_path("hoeken"))
    t = np.linspace(0.0, 4.0, 40001)
    tau = np.sin(7.0 * t) + 0.1 * np.cos(300.0 * t)
    tau[20000:20003] = np.nan
    fig = plots.fig_efforts(SimpleNamespace(model=m, t=t, dyn=SimpleNamespace(tau=tau[:, None])))
    x, y = _curves(fig.axes[0])[0].get_data()
    assert len(x) < len(t) / 4 and np.isnan(y).any()
    before, after = t[19999], t[20003]
    finite = np.flatnonzero(np.isfinite(y))
    runs = np.split(finite, np.flatnonzero(np.diff(finite) > 1) + 1)   # the drawn pieces
    assert all(x[r[-1]] <= before or x[r[0]] >= after for r in runs)
    assert np.nanmax(y) == np.nanmax(tau) and np.nanmin(y) == np.nanmin(tau)


def test_report_flag_adds_the_plots_and_exactly_one_html_file(hoeken_report_run):
    out = hoeken_report_run   # analyze hoeken.toml -o out --report (tests/conftest.py)
    files = set(os.listdir(out))
    assert {"results.csv", "summary.json", "report.html"} <= files
    assert [f for f in files if f.endswith(".html")] == ["report.html"]
    assert {f for f in files - {"results.csv", "summary.json", "report.html"}} == {
        f"plot_{name}.{ext}" for name in ("joints", "efforts", "reactions", "paths", "multipliers")
        for ext in ("png", "svg")}
    text = (out / "report.html").read_text("utf-8")
    assert text.startswith("<!DOCTYPE html>") and text.rstrip().endswith("</html>")


# ---------------------------------------------------------------------------- reproduce

@pytest.fixture(scope="module")
def reproduced(tmp_path_factory):
    out = tmp_path_factory.mktemp("repro") / "hoeken"
    res = _run("reproduce", "hoeken", "-o", out)
    assert res.exit_code == 0, res.output
    return out


def test_reproduce_hoeken_writes_the_paper_figures(reproduced):
    files = set(os.listdir(reproduced))
    for f in ("fig5_kinematics.png", "fig6_multipliers_torque.png", "fig7_reactions.png",
              "fig4_mechanism.png", "results.csv", "README.txt", "reproduce.json",
              "fig5.csv", "fig6.csv", "fig7.csv"):
        assert f in files
    for f in files:
        if f.endswith(".png"):
            w, h = _png_size(reproduced / f)
            assert w > 600 and h > 400
    meta = json.loads((reproduced / "reproduce.json").read_text("utf-8"))
    assert meta["cut_joints"] == ["J4"] and meta["samples"] == 361
    assert meta["crank_speed_rpm"] == 45.0
    assert {k: v["mirrors"] for k, v in meta["figures"].items()} == {
        "fig5": "Fig. 5 of the seed paper", "fig6": "Fig. 6 of the seed paper",
        "fig7": "Fig. 7 of the seed paper"}
    cols = [[s["column"] for s in p["series"]] for p in meta["figures"]["fig6"]["panels"]]
    assert cols == [["Fx_J4", "Fy_J4"], ["tau_J1"]]
    fig7 = {s["column"] for p in meta["figures"]["fig7"]["panels"] for s in p["series"]}
    assert fig7 == {f"F{c}_J{i}" for c in "xy" for i in (1, 2, 3)}
    readme = (reproduced / "README.txt").read_text("utf-8")
    for words in ("Fig. 5", "Fig. 6", "Fig. 7", "Sign conventions", "BY the ground ON the rocker",
                  "-q_J4"):
        assert words in readme


def test_reproduce_fig6_is_the_analyze_run(reproduced, tmp_path):
    """The plotted multipliers and torque are exactly lam and tau of an independent run."""
    m = linkdyn.load(linkdyn.example_path("hoeken"))
    sol = linkdyn.analyze(m, np.linspace(0.0, 60.0 / 45.0, 361))
    fig6 = _read_csv(reproduced / "fig6.csv")
    np.testing.assert_allclose(fig6["Fx_J4_N"], sol.dyn.lam[:, 0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(fig6["Fy_J4_N"], sol.dyn.lam[:, 1], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(fig6["tau_J1_Nm"], sol.dyn.tau[:, 0], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(fig6["crank_angle_deg"], np.arange(361.0), atol=1e-9)
    # and results.csv is what `linkdyn analyze` writes for the bundled model
    out = tmp_path / "an"
    res = _run("analyze", _hoeken_file(tmp_path), "-o", out)
    assert res.exit_code == 0, res.output
    a, r = _read_csv(out / "results.csv"), _read_csv(reproduced / "results.csv")
    assert list(a) == list(r)
    for name in a:
        np.testing.assert_allclose(r[name], a[name], rtol=1e-9, atol=1e-9, err_msg=name)
    fig5, fig7 = _read_csv(reproduced / "fig5.csv"), _read_csv(reproduced / "fig7.csv")
    np.testing.assert_allclose(fig5["q_J2_deg"], np.degrees(r["q_J2"]), rtol=1e-12)
    np.testing.assert_allclose(fig7["Fy_J3_N"], r["Fy_J3"], rtol=1e-12)


def test_reproduce_unknown_name_is_a_usage_error(tmp_path):
    out = tmp_path / "x"
    res = _run("reproduce", "watt", "-o", out)
    assert res.exit_code == 2
    assert "no reproduction named 'watt'" in res.output and "hoeken" in res.output
    assert "Traceback" not in res.output
    assert not out.exists() or not os.listdir(out)


# ---------------------------------------------------------------------------- progress

def test_progress_is_silent_when_not_a_terminal(tmp_path):
    res = _run("analyze", _hoeken_file(tmp_path), "-o", tmp_path / "o", "--samples", "2001")
    assert res.exit_code == 0
    assert "[#" not in res.output and "\r" not in res.output


class _Tty(io.StringIO):
    def isatty(self):
        return True


def test_progress_bar_on_a_terminal_for_a_big_run():
    stream = _Tty()
    with Progress(3, big=True, stream=stream) as p:
        p.step("solving")
        import time
        time.sleep(0.3)
        p.step("writing results.csv")
    text = stream.getvalue()
    assert "\r  [" in text and "solving" in text and "3/3" in text and "done" in text
    assert text.endswith("\n")


def test_progress_waits_before_showing_a_short_run():
    stream = _Tty()
    with Progress(2, delay=5.0, stream=stream) as p:
        p.step("solving")
    assert stream.getvalue() == ""
