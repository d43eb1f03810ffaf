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
whole machine for minutes.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

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
CEILING = "benchmarks/bench_ceiling.py --clock cpu"
HOEKEN = "benchmarks/bench_hoeken.py --samples 1000000 --clock cpu"

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


@pytest.mark.bench
@pytest.mark.parametrize("command", sorted({f.command for f in FIGURES.values()}))
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
