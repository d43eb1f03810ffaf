"""docs/performance.md's figures are what its commands print, not typed by hand (issue 23).

A figure the page checks is marked in its source by an HTML comment just before it,
``<!-- fig KEY -->5`` or ``<!-- fig KEY -->23-42`` (a range: the runs the page reports), which
the rendered page does not show. ``FIGURES`` names, for each KEY, the command that produces
it (written on the page as ``PYTHONPATH=src python benchmarks/...``), the pattern that reads
the figure from the command's output, and its kind:

- ``exact``: a computed result (a count, an accuracy): the command prints the page's text;
- ``timing``: the command's value lies within a factor ``TOLERANCE`` of the page's range (the
  page says the machine, and that its timings vary with the machine's load).

That every marked figure has its command, and every command is on the page, is checked always;
running the commands is marked ``bench`` (``make bench``, ``pytest -m bench``): they time the
whole machine for minutes. Where a script's default size runs for many minutes, the page's
command (and so this test) runs a smaller one, which the page names.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "performance.md"
NUMBER = r"[-+]?\d[\d,]*(?:\.\d+)?(?:e[-+]?\d+)?"
MARK = re.compile(r"<!-- fig ([\w.]+) -->\s*(" + NUMBER + r")(?:-(" + NUMBER + r"))?")
TOLERANCE = 2.5   # a timing: the command's value within [low / 2.5, high x 2.5] of the page's


@dataclass(frozen=True)
class Figure:
    command: str    # as the page writes it, after "PYTHONPATH=src python "
    pattern: str    # its group 1 is the figure in the command's output
    kind: str       # "exact" or "timing"


MODES = "benchmarks/bench_modes.py"
PAGE_PLAY = "benchmarks/bench_page.py"
FRICTION = "benchmarks/bench_friction.py --samples 100000"
CAM = "benchmarks/bench_cam.py --samples 20000 --repeat 10"
CEILING = "benchmarks/bench_ceiling.py --clock cpu"
HOEKEN = "benchmarks/bench_hoeken.py --samples 1000000 --clock cpu"

KERNELS = "benchmarks/bench_kernels.py --clock cpu"
INVERSE = "benchmarks/bench_inverse.py"
CHUNK = "benchmarks/bench_sweep.py --chunk-only --designs 20000"
SWEEP_KERNELS = "benchmarks/bench_sweep.py --kernels"
SIMULATE = ("benchmarks/bench_simulate.py --only planar --duration 2 --windows 20 --chain-duration 0.3 "
            "--tols 1e-4,1e-8,1e-10 --samples 11 --repeat 50 --turns 10 --turn-tols 1e-8 --best 2")
SPATIAL = ("benchmarks/bench_simulate.py --only spatial --spatial-duration 0.5 --samples 11 "
           "--steps 1e-3,1e-4 --best 2 --repeat 100")
COMPILE = "benchmarks/bench_compile.py"
SPATIAL_ID = "benchmarks/bench_spatial.py --samples 20000 --repeat 3"
AUTO = "benchmarks/bench_auto.py --windows 20 --chain-duration 0.3 --press-duration 1.0"


def _spatial_rows() -> dict[str, Figure]:
    """bench_spatial.py's figures: each model's rate and its time by stage (timings), the
    Stewart platform's Pinocchio loops and ratio (timings), and how far Pinocchio's numbers
    are from linkdyn's (exact: the same arithmetic on any run)."""
    heads = {"rsur": r"\[RSUR four-bar\]", "stewart": r"\[Stewart platform \(6-UPS\)\]"}
    stages = {"closing": r"closing the loops \(continuation, Newton\)",
              "motion": r"poses, J, twists, twist rates", "singular": r"singular-position test",
              "coordinates": r"cut joints' coordinates and rates", "loads": r"loads",
              "wstar": r"dynamics: w\*, composite wrenches, Q",
              "efforts": r"dynamics: efforts and multipliers",
              "reactions": r"reactions \(minimum norm\)"}
    out = {}
    for model, head in heads.items():
        out[f"spatial.{model}_rate"] = Figure(
            SPATIAL_ID, head + r".*?linkdyn\.analyze \(numpy\)\s+" + NUMBER + r" s\s+(" + NUMBER
            + ") samples/s", "timing")
        for key, label in stages.items():
            out[f"spatial.{model}_{key}"] = Figure(
                SPATIAL_ID, head + r".*?" + label + r"\s+(\d+)\n", "timing")
    for key, label in (("pinocchio_inverse", r"inverse \(rnea, Jc, \[S, Jc\^T\] solve\)"),
                       ("pinocchio_forward", r"forward \(constraintDynamics\)")):
        out[f"spatial.{key}"] = Figure(SPATIAL_ID, label + r"\s+(" + NUMBER + ") samples/s",
                                       "timing")
    out["spatial.ratio"] = Figure(SPATIAL_ID, r"ratio to the inverse loop\s+(" + NUMBER + ")",
                                  "timing")
    for key, label in (("agree_points", "points"), ("agree_forces", "actuator forces"),
                       ("agree_accelerations", "accelerations")):
        out[f"spatial.{key}"] = Figure(SPATIAL_ID, r"agrees with linkdyn:.*?" + label + r" ("
                                       + NUMBER + ")", "exact")
    return out


def _simulate_rows() -> dict[str, Figure]:
    """The work-precision tables' figures: each row of a model's table (the planar Hoeken's and
    the chain's, the spatial RSUR's and quarter car's), its time a timing (wall on the planar
    tables, CPU on the spatial ones), its steps, right-hand sides, energy drift, closure and
    error exact (the same arithmetic on any run)."""
    out = {}
    # a row's columns: wall s, CPU s, steps, RHS (blank for MuJoCo), energy drift, closure, error
    columns = {"wall": 0, "cpu": 1, "steps": 2, "rhs": 3, "drift": 4, "closure": 5, "error": 6}

    def row(key, command, lead, what, mujoco=False):
        parts = [NUMBER, NUMBER, r"\d+", r"\d+", NUMBER, NUMBER, NUMBER]
        if mujoco:
            del parts[3]
        at = columns[what] - (mujoco and columns[what] > 3)
        parts[at] = "(" + parts[at] + ")"
        out[key] = Figure(command, lead + r"\s+".join(parts),
                          "timing" if what in ("wall", "cpu") else "exact")

    tables = (
        (SIMULATE, "linkdyn compiled DOP853", ("hoeken", r"Hoeken \+ flywheel"),
         ("chain", r"parallelogram chain"), ("0.0001", "1e-08", "1e-10"),
         ("wall", "steps", "rhs", "drift", "error"), ("wall", "steps", "error")),
        (SPATIAL, "linkdyn DOP853", ("rsur", r"RSUR four-bar released"),
         ("car", r"quarter car dropped"), ("0.0001", "1e-06", "1e-08"),
         ("cpu", "steps", "rhs", "drift", "closure", "error"),
         ("cpu", "steps", "drift", "closure", "error")))
    for command, solver, *models, tols, mine, theirs in tables:
        for model, head in models:
            for tol in tols:
                tag = str(round(-np.log10(float(tol))))
                lead = head + r".*?" + re.escape(f"{solver} rtol {tol}") + r"\s+"
                for what in mine:
                    row(f"simulate.{model}_{tag}_{what}", command, lead, what)
            for tag, dt in (("mj3", "0.001"), ("mj4", "0.0001")):
                lead = head + r".*?MuJoCo RK4 dt " + re.escape(dt) + r"\s+"
                for what in theirs:
                    row(f"simulate.{model}_{tag}_{what}", command, lead, what, mujoco=True)
    for model, head in (("hoeken", r"Hoeken \+ flywheel"), ("chain", r"parallelogram chain")):
        out[f"simulate.{model}_numpy_8_wall"] = Figure(
            SIMULATE, head + r".*?linkdyn DOP853 rtol 1e-08\s+(" + NUMBER + ")", "timing")
    return out


FIGURES = {
    # equilibrium and modes of the IFToMM four-bar with a spring
    "modes.newton_steps": Figure(MODES, r"\((\d+) Newton steps\)", "exact"),
    "modes.accuracy": Figure(MODES, r"accuracy (" + NUMBER + ")", "exact"),
    "modes.ms": Figure(MODES, r"equilibrium \+ modes\s+(" + NUMBER + ") ms", "timing"),
    "modes.linearization_ms": Figure(MODES, r"\((" + NUMBER + r") ms each\)", "timing"),
    # the report page's playback at 2000 frames
    "page.paused": Figure(PAGE_PLAY, r"paused\s+(" + NUMBER + ") frames/s", "timing"),
    "page.playing": Figure(PAGE_PLAY, r"playing\s+(" + NUMBER + ") frames/s", "timing"),
    "page.ratio": Figure(PAGE_PLAY, r"ratio\s+(" + NUMBER + ")", "timing"),
    # joint friction against none
    "friction.plain": Figure(FRICTION, r"without friction\s+(" + NUMBER + ") samples/s",
                             "timing"),
    "friction.rubbing": Figure(FRICTION, r"friction at 4 pins\s+(" + NUMBER + ") samples/s",
                               "timing"),
    "friction.ratio": Figure(FRICTION, r"ratio\s+(" + NUMBER + ")", "timing"),
    "friction.iterations": Figure(FRICTION, r"\(Newton (\d+) iterations\)", "exact"),
    # a cam-driven four-bar against the same four-bar driven at its input
    "cam.plain": Figure(CAM, r"plain four-bar\s+(" + NUMBER + ") samples/s", "timing"),
    "cam.cam": Figure(CAM, r"cam-driven four-bar\s+(" + NUMBER + ") samples/s", "timing"),
    "cam.ratio": Figure(CAM, r"ratio\s+(" + NUMBER + ")", "timing"),
    # the ceilings: what each hand-written kernel stores, and its rate
    "ceiling.kinematics_numbers": Figure(CEILING, r"kinematics: ceiling[^\n]*? (\d+) numbers "
                                         r"per sample", "exact"),
    "ceiling.analysis_numbers": Figure(CEILING, r"full analysis: ceiling[^\n]*? (\d+) "
                                       r"numbers per sample", "exact"),
    "ceiling.kinematics_rate": Figure(CEILING, r"kinematics: ceiling.*?into fresh outputs\s+("
                                      + NUMBER + ") samples/s", "timing"),
    "ceiling.analysis_rate": Figure(CEILING, r"full analysis: ceiling.*?into fresh outputs\s+("
                                    + NUMBER + ") samples/s", "timing"),
    # linkdyn's rates on Hoeken, each backend
    "hoeken.numpy_kinematics": Figure(HOEKEN, r"\[numpy\]\nkinematics\s+(" + NUMBER + ")",
                                      "timing"),
    "hoeken.numpy_analysis": Figure(HOEKEN, r"\[numpy\].*?full analysis\s+(" + NUMBER + ")",
                                    "timing"),
    "hoeken.compiled_kinematics": Figure(HOEKEN, r"\[compiled\]\nkinematics\s+(" + NUMBER
                                         + ")", "timing"),
    "hoeken.compiled_analysis": Figure(HOEKEN, r"\[compiled\].*?full analysis\s+(" + NUMBER
                                       + ")", "timing"),
    "hoeken.handwritten": Figure(HOEKEN, r"closed form for this one four-bar in numpy: ("
                                 + NUMBER + ")/s", "timing"),
    # where the compiled kernels' time goes
    "kernels.kinematics": Figure(KERNELS, r"kinematics kernel\s+(" + NUMBER + ") ns", "timing"),
    "kernels.dynamics": Figure(KERNELS, r"dynamics kernel\s+(" + NUMBER + ") ns", "timing"),
    "kernels.block512": Figure(KERNELS, r"blocks of\s+512\s+(" + NUMBER + ")", "timing"),
    "kernels.block1024": Figure(KERNELS, r"blocks of\s+1024\s+(" + NUMBER + ")", "timing"),
    "kernels.block2048": Figure(KERNELS, r"blocks of\s+2048\s+(" + NUMBER + ")", "timing"),
    "kernels.dyad": Figure(KERNELS, r"close the dyads\s+(" + NUMBER + ")", "timing"),
    "kernels.place": Figure(KERNELS, r"place the bodies\s+(" + NUMBER + ")", "timing"),
    "kernels.twists": Figure(KERNELS, r"\btwists\s+(" + NUMBER + ")", "timing"),
    "kernels.factor": Figure(KERNELS, r"factor J_dep \(once per sample\)\s+(" + NUMBER + ")",
                             "timing"),
    "kernels.arctan2": Figure(KERNELS, r"compiled\.arctan2 over an array\s+(" + NUMBER + ")",
                              "timing"),
    "kernels.atan2": Figure(KERNELS, r"math\.atan2 over an array\s+(" + NUMBER + ")", "timing"),
    "kernels.fresh": Figure(KERNELS, r"fresh (" + NUMBER + ") GB/s", "timing"),
    "kernels.touched": Figure(KERNELS, r"already touched (" + NUMBER + ") GB/s", "timing"),
    # the full inverse dynamics against code written for this one four-bar
    "inverse.c_scalar": Figure(INVERSE, r"C, scalar \([^)]*\)\s+(" + NUMBER + ") ns", "timing"),
    "inverse.c_vector": Figure(INVERSE, r"C, vectorized \([^)]*\)\s+(" + NUMBER + ") ns",
                               "timing"),
    "inverse.c_vector_ratio": Figure(INVERSE, r"C, vectorized \([^)]*\)\s+" + NUMBER
                                     + r" ns/sample\s+ratio\s+(" + NUMBER + ")", "timing"),
    "inverse.numpy_hand": Figure(INVERSE, r"numpy, hand-written, chunks of 8192\s+(" + NUMBER
                                 + ") ns", "timing"),
    "inverse.numpy_hand_ratio": Figure(INVERSE, r"numpy, hand-written, chunks of 8192\s+"
                                       + NUMBER + r" ns/sample\s+ratio\s+(" + NUMBER + ")",
                                       "timing"),
    "inverse.compiled": Figure(INVERSE, r"linkdyn compiled\s+(" + NUMBER + ") ns", "timing"),
    "inverse.compiled_ratio": Figure(INVERSE, r"linkdyn compiled\s+" + NUMBER
                                     + r" ns/sample\s+ratio\s+(" + NUMBER + ")", "timing"),
    "inverse.batch": Figure(INVERSE, r"x 360 samples in one batch\s+(" + NUMBER + ") ns",
                            "timing"),
    "inverse.batch_ratio": Figure(INVERSE, r"x 360 samples in one batch\s+" + NUMBER
                                  + r" ns/sample\s+ratio\s+(" + NUMBER + ")", "timing"),
    "inverse.numpy": Figure(INVERSE, r"linkdyn numpy\s+(" + NUMBER + ") ns", "timing"),
    "inverse.numpy_ratio": Figure(INVERSE, r"linkdyn numpy\s+" + NUMBER
                                  + r" ns/sample\s+ratio\s+(" + NUMBER + ")", "timing"),
    "inverse.kin_kernel": Figure(INVERSE, r"by stage[^\n]*\n\s+kinematics\s+(" + NUMBER + ")",
                                 "timing"),
    "inverse.dyn_kernel": Figure(INVERSE, r"dynamics and reactions\s+(" + NUMBER + ") ns",
                                 "timing"),
    "inverse.rest": Figure(INVERSE, r"the rest of analyze \([^)]*\) (" + NUMBER + ")", "timing"),
    "inverse.user": Figure(INVERSE, r"linkdyn compiled\s+user\s+(" + NUMBER + ")", "timing"),
    "inverse.system": Figure(INVERSE, r"linkdyn compiled\s+user\s+" + NUMBER + r", system\s+("
                             + NUMBER + ")", "timing"),
    # the first compilation of every stage's kernels, CPU seconds
    **{f"compile.{key}": Figure(COMPILE, r"\n" + stage + r"\s+(" + NUMBER + ") s", "timing")
       for key, stage in (("kinematics", "kinematics"), ("dynamics", "dynamics"),
                          ("reactions", "reactions"), ("rhs", "simulate right-hand side"),
                          ("sweep", "fused sweep"), ("all", "all"))},
    # a sweep's chunk and its kernels
    "sweep.chunk": Figure(CHUNK, r"\btotal (" + NUMBER + ")", "timing"),
    "sweep.solve": Figure(CHUNK, r"\bsolve (" + NUMBER + ")", "timing"),
    "sweep.metrics": Figure(CHUNK, r"\bmetrics (" + NUMBER + ")", "timing"),
    "sweep.rate": Figure(CHUNK, r"(" + NUMBER + ") design-samples per CPU second", "timing"),
    "sweep.projected": Figure(CHUNK, r"at this rate: (" + NUMBER + ") s", "timing"),
    "sweep.total_ns": Figure(CHUNK, r"CPU ns per design-sample:.*\btotal (\d+)", "timing"),
    "sweep.kernel_ns": Figure(CHUNK, r"compiled kinematics and dynamics (\d+)", "timing"),
    "sweep.branch_ns": Figure(CHUNK, r"the branch \(continuation nodes\) (\d+)", "timing"),
    "sweep.metrics_ns": Figure(CHUNK, r"CPU ns per design-sample:.*\bmetrics (\d+)", "timing"),
    "sweep.two_stages": Figure(SWEEP_KERNELS, r"then dynamics stage (\d+(?:\.\d+)?)", "timing"),
    "sweep.fused": Figure(SWEEP_KERNELS, r"sweep kernel \(fused\) (" + NUMBER + ")", "timing"),
    "sweep.metrics_only": Figure(SWEEP_KERNELS, r"keeping the metrics only \([^)]*\) (" + NUMBER
                                 + ")", "timing"),
    # spatial inverse dynamics (numpy) beside Pinocchio
    **_spatial_rows(),
    # forward dynamics
    **_simulate_rows(),
    "simulate.turns_free": Figure(SIMULATE, r"crank turns.*?\n\s+1e-08\s+no\s+\d+\s+" + NUMBER
                                  + r"\s+\d+\s+\d+\s+(" + NUMBER + ")", "exact"),
    "simulate.turns_projected": Figure(SIMULATE, r"crank turns.*?\n\s+1e-08\s+yes\s+\d+\s+"
                                       + NUMBER + r"\s+\d+\s+\d+\s+(" + NUMBER + ")", "exact"),
    "simulate.rhs_numpy": Figure(SIMULATE, r"numpy:\s+(" + NUMBER + ") us", "timing"),
    "simulate.rhs_compiled": Figure(SIMULATE, r"compiled:\s+(" + NUMBER + ") us", "timing"),
    # auto against the better explicit choice
    "auto.chain": Figure(AUTO, r"parallelogram chain.*?this process: auto / compiled \(wall\): ("
                         + NUMBER + ")", "timing"),
    "auto.press": Figure(AUTO, r"press.*?this process: auto / compiled \(wall\): (" + NUMBER + ")",
                         "timing"),
    "auto.chain_fresh": Figure(AUTO, r"parallelogram chain.*?fresh process: auto / compiled "
                               r"\(wall\): (" + NUMBER + ")", "timing"),
    "auto.press_fresh": Figure(AUTO, r"press.*?fresh process: auto / compiled \(wall\): ("
                               + NUMBER + ")", "timing"),
    "auto.chain_here_after": Figure(AUTO, r"parallelogram chain.*?\n\s+auto\s[^\n]*?compiled "
                                    r"after (\d+) evaluations \(this process\)", "exact"),
    # in a fresh process: where the estimate or the clock (a timing) switched
    "auto.chain_after": Figure(AUTO, r"parallelogram chain.*?\n\s+auto\s[^\n]*?compiled after "
                               r"(\d+) evaluations \(fresh process\)", "timing"),
    "auto.press_after": Figure(AUTO, r"press.*?\n\s+auto\s[^\n]*?compiled after (\d+) "
                               r"evaluations \(fresh process\)", "timing"),
}


def page_figures() -> dict[str, tuple[str, str]]:
    """Each marked figure on the page: KEY -> (low, high) as written (equal for one value)."""
    out = {}
    for key, low, high in MARK.findall(PAGE.read_text(encoding="utf-8")):
        assert key not in out, f"docs/performance.md marks {key} twice"
        out[key] = (low, high or low)
    return out


def value(text: str) -> float:
    return float(text.replace(",", ""))


def test_every_marked_figure_names_its_command_on_the_page():
    text = PAGE.read_text(encoding="utf-8")
    marked = page_figures()
    assert sorted(marked) == sorted(FIGURES), "a figure marked on the page without its " \
        "command here, or one here the page does not mark"
    for key, fig in FIGURES.items():
        assert f"PYTHONPATH=src python {fig.command}" in text, (key, fig.command)
        low, high = marked[key]
        assert value(low) <= value(high), key
        if fig.kind == "exact":
            assert low == high, f"{key}: a computed figure is one value"
    # the page says how its timings are checked, and on which machine
    assert f"within a factor of {TOLERANCE}" in text and "2-core" in text


def _run(command: str) -> str:
    script, *args = command.split()
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    done = subprocess.run([sys.executable, str(ROOT / script), *args], capture_output=True,
                          text=True, timeout=1800, cwd=ROOT, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout


COMMANDS = sorted({f.command for f in FIGURES.values()})


@pytest.mark.bench
@pytest.mark.parametrize("command", COMMANDS, ids=[c.replace(",", " ") for c in COMMANDS])
def test_the_pages_figures_are_what_its_command_prints(command):
    out = _run(command)
    marked = page_figures()
    for key, fig in FIGURES.items():
        if fig.command != command:
            continue
        found = re.search(fig.pattern, out, re.S)
        assert found, (key, out[-2000:])
        low, high = marked[key]
        if fig.kind == "exact":
            assert found.group(1) == low, (key, found.group(1), low)
        else:
            got = value(found.group(1))
            assert value(low) / TOLERANCE <= got <= value(high) * TOLERANCE, (key, got, low, high)
