"""A mechanism started exactly at a singular but reachable position is named as such (exit 3,
"starts at a singular position"), not as a position it "cannot reach": pylinkage's own demo
four-bar (crank 1, coupler 3, rocker 1, ground 3), saved with coupler and rocker in line."""

from __future__ import annotations

import json
import math
from pathlib import Path

from click.testing import CliRunner

from linkdyn.cli import main

DEMO = Path(__file__).parent / "data" / "pylinkage" / "fourbar_linkage.json"


def cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def test_a_start_with_links_in_line_is_named_singular(tmp_path):
    toml = tmp_path / "demo.toml"
    assert cli("import", DEMO, "-o", toml).exit_code == 0
    # pylinkage's saved positions close the loop with B, D and C in line (a dead centre of
    # the crank): |B C| = |B D| + |D C|, by hand from the file
    pos = {j["id"]: j["position"] for j in json.loads(DEMO.read_text())["joints"]}
    assert math.dist(pos["B"], pos["C"]) == math.dist(pos["B"], pos["D"]) + math.dist(
        pos["D"], pos["C"])
    for extra in ([], ["--allow-singular"]):   # nothing to keep: no sample can be solved
        r = cli("analyze", toml, "-o", tmp_path / "o", "--samples", 11, "--backend", "numpy",
                *extra)
        assert r.exit_code == 3, r.output
        assert "at t = 0 s (q_A = 0 rad): the mechanism starts at a singular position" in r.output
        assert "cannot reach" not in r.output and "Traceback" not in r.output
    # started away from it, the same linkage runs
    toml.write_text(toml.read_text().replace("start = 0.0", "start = 0.5"))
    r = cli("analyze", toml, "-o", tmp_path / "o", "--samples", 11, "--duration", 1,
            "--backend", "numpy")
    assert r.exit_code == 0, r.output
