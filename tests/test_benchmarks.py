"""The benchmark scripts run, on a few samples, and their own checks pass.

Each script checks its references before it times anything: ``bench_hoeken.py`` that the
per-sample baselines and the hand-written numpy four-bar agree with linkdyn, ``bench_ceiling.py``
that every row of its hand-written compiled kernels (kinematics; torque, pin forces, kinetic
energy) agrees with linkdyn's numpy path, ``bench_inverse.py`` that its C, numpy and sympy
baselines of the full inverse dynamics do. A wrong reference would make a wrong comparison, so
those checks run here; the timings they print mean nothing at this size. They time the
compiled backend too: the test extras install numba.

Marked ``bench``: ``make test`` (pytest's default ``-m "not bench"``, pyproject.toml) leaves
them out; ``make bench`` runs them first, ``pytest -m bench`` alone.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.bench
BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def run(script, *args):
    done = subprocess.run([sys.executable, str(BENCHMARKS / script), *args], capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


def test_bench_hoeken():
    out = run("bench_hoeken.py", "--samples", "3000", "--baseline-samples", "40", "--repeat", "1")
    for line in ("[numpy]", "[compiled]", "kinematics", "full analysis"):
        assert line in out


def test_bench_kernels():
    out = run("bench_kernels.py", "--samples", "3000")
    assert "kinematics kernel" in out and "close the dyads" in out and "fresh" in out


def test_bench_ceiling():
    out = run("bench_ceiling.py", "--samples", "3000", "--repeat", "1")
    assert out.count("ceiling, hand-written compiled kernel") == 2
    assert "47 numbers per sample" in out and "59 numbers per sample" in out


def test_bench_inverse():
    # its checks: each baseline's 18 rows (C, numpy, sympy.mechanics) against linkdyn's numpy
    # backend before timing; C and sympy are skipped, saying so, where absent
    out = run("bench_inverse.py", "--samples", "3000", "--repeat", "1", "--designs", "10")
    assert "numpy, hand-written, chunks of 8192" in out and "linkdyn compiled by stage" in out
    assert "10 designs x 360 samples in one batch" in out and "linkdyn numpy" in out
    assert ("C, scalar" in out) != ("no C compiler" in out)
    assert ("sympy.mechanics, lambdified" in out) != ("sympy is not installed" in out)


def test_bench_sweep():
    out = run("bench_sweep.py", "--designs", "12", "--samples", "20", "--no-ceiling")
    for words in ("one worker", "workers", "peak memory at 3 designs", "per core"):
        assert words in out


def test_bench_simulate():
    out = run("bench_simulate.py", "--duration", "0.1", "--windows", "2", "--chain-duration",
              "0.05", "--tols", "1e-4", "--steps", "1e-3", "--samples", "3", "--repeat", "2",
              "--turns", "1", "--turn-tols", "1e-4", "--only", "planar")
    assert out.count("  linkdyn DOP853 rtol 0.0001") == 2 and out.count("MuJoCo RK4 dt") == 2
    assert out.count("  linkdyn compiled DOP853 rtol 0.0001") == 2
    assert "one right-hand side of Hoeken" in out and "  compiled: " in out
    assert "Hoeken spinning freely (with the flywheel of hoeken_motor), 1 crank turns" in out


def test_bench_simulate_spatial():
    # the spatial models side by side with MuJoCo (linkdyn's MJCF export), a short run
    out = run("bench_simulate.py", "--only", "spatial", "--spatial-duration", "0.01",
              "--spatial-tols", "1e-4", "--spatial-ref", "1e-6", "--steps", "1e-3",
              "--samples", "3", "--best", "1")
    assert out.count("  linkdyn DOP853 rtol 0.0001") == 2
    assert "RSUR four-bar released" in out and "quarter car" in out
    if "MuJoCo not installed" not in out:
        assert out.count("MuJoCo RK4 dt 0.001") == 2
    assert "Hoeken" not in out


def test_bench_spatial():
    # its check: Pinocchio's points, actuator forces and accelerations are linkdyn's (1e-10)
    out = run("bench_spatial.py", "--samples", "300", "--repeat", "1", "--pinocchio-samples",
              "20")
    assert "[RSUR four-bar]" in out and "[Stewart platform (6-UPS)]" in out
    assert out.count("reactions (minimum norm)") == 2
    if "Pinocchio: not installed" not in out:
        assert "agrees with linkdyn" in out and "ratio to the inverse loop" in out


def test_bench_friction():
    out = run("bench_friction.py", "--samples", "2000", "--repeat", "1")
    assert "ratio" in out


def test_bench_cam():
    # its check: the plain four-bar's input follows the cam's arm (1e-9 rad) before timing
    out = run("bench_cam.py", "--samples", "2000", "--repeat", "1")
    assert "cam-driven four-bar" in out and "ratio" in out


def test_bench_modes():
    out = run("bench_modes.py", "--repeat", "1", "--executions", "2")
    assert "accuracy" in out and "equilibrium + modes" in out and "2 linearizations" in out
    assert "one Linearization" in out and "spring sweep of 2 stiffnesses" in out


def test_bench_page():
    # the page's playback against its paused frame rate in headless Chromium (few samples: the
    # rates mean nothing at this size; the script runs and says its ratio and verdict)
    out = run("bench_page.py", "--samples", "200", "--repeat", "1")
    for words in ("report.html playback", "paused", "playing", "frames/s", "(target >= 0.8:"):
        assert words in out
