"""``linkdyn modes MODEL --report``: each mode that swings, animated over one period
(``modal.mode_motion``: the free joints driven along the mode, shown as ``analyze --report``
shows a run).

The check is the inverse dynamics (``analyze``, the recursive DeNOC efforts) along that motion:
moving a mechanism in one of its modes at the mode's frequency needs no effort in the free joints
to first order in the swing (the linearized equations' ``(K - w^2 H) v = 0``), while the same
shape at a frequency 10 % off needs an effort of the order of the swing's stiffness force.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main
from linkdyn.modal import mode_motion, modes
from linkdyn.motion import ExpressionMotion
from test_equilibrium import G, double_pendulum
from test_free_body import A, I, K, L0, M, hanging_bar


def retimed(model, factor):
    """The model with every expression driver's time scaled by ``factor``."""
    return replace(model, drivers=tuple(
        replace(d, motion=ExpressionMotion(d.motion.text.replace("*t)", f"*{factor!r}*t)")))
        if isinstance(d.motion, ExpressionMotion) else d for d in model.drivers))


@pytest.mark.parametrize("k", [0, 1])
def test_moving_in_a_mode_at_its_frequency_needs_no_effort(k):
    md = modes(double_pendulum())
    eq, v, f = md.equilibrium, md.shapes[:, k], md.frequencies[k]
    swing = 1e-3
    moving = mode_motion(md, k, swing=swing)
    assert moving.duration == pytest.approx(1 / f) and f"mode {k + 1} at" in moving.name
    t = np.linspace(0.0, moving.duration, 41)
    cols = linkdyn.analyze(moving, t).columns
    # the page's motion: q_j = q_eq_j + a v_j sin(w t), a the swing of the largest component
    for j, q, x in zip(eq.free, eq.q, v):
        assert np.abs(cols[f"q_{j}"] - q - swing * x * np.sin(2 * np.pi * f * t)).max() < 1e-12
    scale = (1.0 + 0.6) * G * 0.8 * swing                  # the weights' moment of the swing
    effort = max(np.abs(cols[f"tau_{j}"]).max() for j in eq.free)
    assert effort < 1e-5 * scale                           # measured 1.5e-7, 2.0e-7
    off = linkdyn.analyze(retimed(moving, 1.1), t).columns
    assert max(np.abs(off[f"tau_{j}"]).max() for j in eq.free) > 1e-3 * scale   # 0.18, 0.02


def test_the_command_writes_a_page_per_mode_of_the_hanging_bar(tmp_path):
    file = tmp_path / "bar.toml"
    file.write_text(_bar_text())
    out = tmp_path / "pages"
    res = CliRunner().invoke(main, ["modes", str(file), "--report", "-o", str(out)])
    assert res.exit_code == 0, res.output
    length = L0 + M * G / (2 * K)
    hz = np.sort(np.sqrt([G / length, 2 * K / M, 2 * K * A ** 2 / I])) / (2 * math.pi)
    assert sorted(p.name for p in out.iterdir()) == ["mode1.html", "mode2.html", "mode3.html"]
    for k, f in enumerate(hz, 1):
        page = (out / f"mode{k}.html").read_text("utf-8")
        assert f"mode {k} at {f:.6g} Hz" in page
    assert f"wrote {out / 'mode1.html'}" in res.output


def test_a_mechanism_with_no_swinging_mode_writes_no_page(tmp_path):
    file = tmp_path / "toggle.toml"
    file.write_text(linkdyn.example_path("toggle_spring").read_text("utf-8"), "utf-8")
    out = tmp_path / "pages"
    res = CliRunner().invoke(main, ["modes", str(file), "--report", "-o", str(out)])
    assert res.exit_code == 2 and "--report" in res.output and "overdamped" in res.output
    assert not out.exists()


def _bar_text() -> str:
    """test_free_body's hanging bar as a model file."""
    from linkdyn.io.writer import dumps_toml, model_to_dict
    return dumps_toml(model_to_dict(hanging_bar()))
