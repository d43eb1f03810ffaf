"""Command-line options that choose how a run computes: ``--backend`` of ``analyze``,
``simulate`` and ``compare`` (it wins over ``LINKDYN_BACKEND``; the default defers to it) and
``simulate --no-project`` (no energy projection, F11). Each test would fail if the option were
ignored: an invalid ``LINKDYN_BACKEND`` stops the run unless the option replaces it, and the
projection's count and the energy drift differ with and without it."""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main

G = 9.81


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def released_fourbar(tmp_path):
    """Hoeken's four-bar released under gravity with a push (a model file for simulate)."""
    d = tomllib.loads(linkdyn.example_path("hoeken").read_text())
    d.pop("drivers")
    d.pop("analysis", None)
    d["mechanism"]["gravity"] = [0.0, -G]
    d["initial"] = {"q": {"J1": 30.0}, "qd": {"J1": 200.0}}
    path = tmp_path / "fourbar.json"
    path.write_text(json.dumps(d))
    return path


@pytest.mark.parametrize("command", ["analyze", "simulate", "compare"])
def test_backend_option_wins_over_the_environment(tmp_path, monkeypatch, command):
    """With an invalid LINKDYN_BACKEND a run stops (exit 2 naming the variable) unless
    --backend replaces it; the default (no option) defers to the variable."""
    hoeken = linkdyn.example_path("hoeken")
    args = {"analyze": ["analyze", hoeken, "--samples", "5"],
            "simulate": ["simulate", released_fourbar(tmp_path), "--duration", "0.02",
                         "--samples", "3", "--rtol", "1e-6"],
            "compare": ["compare", hoeken, hoeken, "--samples", "5"]}[command]
    monkeypatch.setenv("LINKDYN_BACKEND", "fortran")
    bad = run(*args, "-o", tmp_path / "bad")
    assert bad.exit_code == 2 and "LINKDYN_BACKEND" in bad.output, bad.output
    assert not (tmp_path / "bad").exists() or not any((tmp_path / "bad").iterdir())
    for backend in ("numpy", "auto"):
        ok = run(*args, "-o", tmp_path / backend, "--backend", backend)
        assert ok.exit_code == 0, ok.output
    monkeypatch.setenv("LINKDYN_BACKEND", "numpy")
    wrong = run(*args, "-o", tmp_path / "wrong", "--backend", "gpu")
    assert wrong.exit_code == 2 and "--backend" in wrong.output
    assert "gpu" in wrong.output and "compiled" in wrong.output   # click names the choices


def test_backend_option_reaches_the_library(tmp_path, monkeypatch):
    """The value given is the value the library runs with (not only some valid one)."""
    import linkdyn.analysis
    import linkdyn.forward

    seen = {}

    def spy(module, name):
        real = getattr(module, name)

        def wrapper(*a, **kw):
            seen[name] = kw.get("backend")
            return real(*a, **kw)
        monkeypatch.setattr(module, name, wrapper)
    spy(linkdyn.analysis, "analyze")
    spy(linkdyn.forward, "simulate")
    monkeypatch.delenv("LINKDYN_BACKEND", raising=False)
    assert run("analyze", linkdyn.example_path("hoeken"), "--samples", "5", "--backend", "numpy",
               "-o", tmp_path / "a").exit_code == 0
    assert run("simulate", released_fourbar(tmp_path), "--duration", "0.02", "--samples", "3",
               "--backend", "numpy", "-o", tmp_path / "s").exit_code == 0
    assert seen == {"analyze": "numpy", "simulate": "numpy"}
    assert run("analyze", linkdyn.example_path("hoeken"), "--samples", "5",
               "-o", tmp_path / "d").exit_code == 0
    assert seen["analyze"] is None          # the default: LINKDYN_BACKEND, else auto


def test_no_project_turns_the_energy_projection_off(tmp_path):
    """Projected (the default), every step's end is put back on the energy balance: the
    summary counts the projections and the drift is what one step's dense output adds; with
    --no-project there are none and the drift is the integrator's own, grown step by step
    (measured 8.1e-6 against 2.6e-7)."""
    model = released_fourbar(tmp_path)
    drift, count = {}, {}
    for flag in ([], ["--no-project"]):
        out = tmp_path / ("off" if flag else "on")
        r = run("simulate", model, "--duration", "0.3", "--samples", "4", "--rtol", "1e-5",
                "--atol", "1e-7", "--backend", "numpy", "-o", out, *flag)
        assert r.exit_code == 0, r.output
        sim = json.loads((out / "summary.json").read_text())["simulation"]
        drift[bool(flag)], count[bool(flag)] = sim["energy_balance_drift_rel"], \
            sim["energy_projections"]
    assert count[True] == 0 and count[False] > 0
    # the integrator alone drifts at about its tolerance; the projection removes that
    assert 1e-9 < drift[True] < 1e-3
    assert drift[False] < drift[True] / 10
    assert np.isfinite(drift[False])
