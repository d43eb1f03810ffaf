"""``linkdyn check`` assembles the model over its run: it names where a loop locks (checked
against the closed-form limit positions), the slider-crank's stroke and transmission angle
(closed form), and accepts models meant for ``simulate``."""

from __future__ import annotations

import math
import re

import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main


def _check(tmp_path, text):
    path = tmp_path / "m.toml"
    path.write_text(text, "utf-8")
    return CliRunner().invoke(main, ["check", str(path)])


def _example(name):
    return linkdyn.example_path(name).read_text("utf-8")


def test_check_accepts_a_model_meant_for_simulate_and_names_its_free_coordinate(tmp_path):
    res = _check(tmp_path, _example("fourbar_release"))
    assert res.exit_code == 0, res.output
    assert "free coordinates (integrated by linkdyn simulate): J1, from [initial] q: " \
           "q_J1 = 30 deg" in res.output
    assert res.output.rstrip().endswith("model OK")


def test_a_rod_shorter_than_its_crank_exits_3_naming_where_it_locks(tmp_path):
    # crank 50 mm, rod 40 mm, slide line 20 mm above the pivot: the pin at 50 sin(theta) must
    # stay within 40 mm of the line, so the crank turns from 0 up to 180 + asin(0.4) deg only
    text = _example("slider_crank").replace("B = [180.0, 0.0] }", "B = [40.0, 0.0] }")
    text = text.replace("q = { J4 = 228.9 }", "q = { J4 = 40.0 }").replace("rod = 6.38",
                                                                          "rod = 30.0")
    res = _check(tmp_path, text)
    assert res.exit_code == 3, res.output
    assert "cannot turn fully (crank + offset >= rod)" in res.output
    m = re.search(r"loop cut at J4 \(ground, crank, rod, slider\) stops closing: it closes up "
                  r"to q_J1 = ([0-9.]+) deg", res.output)
    assert m, res.output
    assert float(m.group(1)) == pytest.approx(180 + math.degrees(math.asin(0.4)), abs=2e-3)
    assert "model OK" not in res.output and "Traceback" not in res.output


def test_a_non_grashof_four_bar_driven_a_full_turn_exits_3_at_its_limit(tmp_path):
    text = _example("hoeken").replace("O2 = [38.1, 0.0]", "O2 = [60.0, 0.0]")
    res = _check(tmp_path, text.replace("O4 = [89.5, 0.0] }", "O4 = [180.0, 0.0] }"))
    assert res.exit_code == 3, res.output
    limit = math.degrees(math.acos((180.0**2 + 60.0**2 - 230.4**2) / (2 * 180.0 * 60.0)))
    m = re.search(r"closes up to q_J1 = ([0-9.]+) deg", res.output)
    assert m and float(m.group(1)) == pytest.approx(limit, abs=2e-3), res.output


def test_check_gives_the_slider_cranks_stroke_and_transmission_angle(tmp_path):
    res = _check(tmp_path, _example("slider_crank"))
    assert res.exit_code == 0, res.output
    r, l, e = 50.0, 180.0, 20.0
    m = re.search(r"stroke ([0-9.]+) mm .*transmission angle ([0-9.]+) \.\. ([0-9.]+) deg",
                  res.output)
    assert m, res.output
    assert float(m.group(1)) == pytest.approx(
        math.sqrt((l + r) ** 2 - e ** 2) - math.sqrt((l - r) ** 2 - e ** 2), rel=1e-3)
    # the rod's largest angle to the slide line, asin((r + e) / l), at theta = 90 deg; it
    # lies along the line (90 deg to the normal) where r sin(theta) = e
    assert float(m.group(2)) == pytest.approx(90 - math.degrees(math.asin((r + e) / l)),
                                              abs=0.05)
    assert float(m.group(3)) == pytest.approx(90.0, abs=0.3)


def test_check_gives_hoekens_transmission_angle_range_in_closed_form(tmp_path):
    res = _check(tmp_path, _example("hoeken"))
    assert res.exit_code == 0, res.output
    a, b, c, d = 38.1, 115.2, 115.2, 89.5
    mu = [math.degrees(math.acos((b * b + c * c - a * a - d * d + s * 2 * a * d) / (2 * b * c)))
          for s in (1, -1)]
    m = re.search(r"transmission angle ([0-9.]+) \.\. ([0-9.]+) deg", res.output)
    assert float(m.group(1)) == pytest.approx(min(mu), rel=1e-3)
    assert float(m.group(2)) == pytest.approx(max(mu), rel=1e-3)



def test_analyze_gives_the_slider_cranks_stroke_and_transmission_angle_in_closed_form(tmp_path):
    # the bundled offset slider-crank: crank r = 50, rod l = 180, offset e = 20 (mm); the slider
    # sits at sqrt((l +- r)^2 - e^2) from the crank pivot along the guide at the dead centres,
    # and the rod leans most from the guide, asin((r + e) / l), with the crank normal to it
    import json
    r, l, e = 50.0, 180.0, 20.0
    lo, hi = math.sqrt((l - r) ** 2 - e * e), math.sqrt((l + r) ** 2 - e * e)
    mu_min = 90.0 - math.degrees(math.asin((r + e) / l))
    res = CliRunner().invoke(main, ["analyze", str(linkdyn.example_path("slider_crank")),
                                    "--samples", "181", "-o", str(tmp_path / "o"), "--backend", "numpy"])
    assert res.exit_code == 0, res.output
    (sc,) = json.loads((tmp_path / "o" / "summary.json").read_text())["slider_cranks"]
    assert (sc["rod"], sc["slider"], sc["guide"]) == ("rod", "slider", "J4")
    # 181 samples, 2 deg of crank apart: a dead centre lies within 1 deg of one, where the
    # slider is within about r (1 deg)^2 of its extreme
    tol = r * math.radians(1.0) ** 2
    assert [x * 1e3 for x in sc["travel_m"]] == pytest.approx([lo, hi], abs=tol)
    assert sc["stroke_m"] * 1e3 == pytest.approx(hi - lo, abs=2 * tol)
    assert math.degrees(sc["transmission_angle_rad"]["min"]) == pytest.approx(mu_min, abs=0.03)
    m = re.search(r"slider-crank rod/slider: stroke ([0-9.]+) mm \(q_J4 ([0-9.]+) \.\. "
                  r"([0-9.]+) mm\); transmission angle ([0-9.]+) \.\. ([0-9.]+) deg", res.output)
    assert m, res.output
    got = [float(x) for x in m.groups()]
    assert got[:4] == pytest.approx([hi - lo, lo, hi, mu_min], rel=1e-3)
    # the report's summary shows them in mm and deg, as its other tables
    from linkdyn.report.tables import summary_html
    page = summary_html(json.loads((tmp_path / "o" / "summary.json").read_text()))
    assert "<th>stroke (mm)</th>" in page and f"<td>{hi - lo:.1f}</td>" in page
