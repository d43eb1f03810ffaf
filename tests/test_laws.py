"""Motion laws (``linkdyn.laws``) and the drivers that swing a joint by them (``kind =
"segments"``): closed forms of each law's peaks, finite differences of the coordinate, the
joins and the period, a driven bar's torque by its closed form, the model file round trip and
the messages for a bad segment."""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn import laws
from linkdyn.cli import main
from linkdyn.motion import Segment, SegmentMotion

U = np.linspace(0.0, 1.0, 200001)

# (law, peak s', peak |s''|): closed forms
PEAKS = [("harmonic", math.pi / 2, math.pi ** 2 / 2), ("cycloidal", 2.0, 2 * math.pi),
         ("poly345", 15 / 8, 10 / math.sqrt(3)), ("poly4567", 35 / 16, 84 * math.sqrt(5) / 25),
         ("modified_sine", 4 * math.pi / (math.pi + 4), 4 * math.pi ** 2 / (math.pi + 4)),
         ("modified_trapezoid", 2.0, 8 * math.pi / (2 + math.pi))]


@pytest.mark.parametrize("law, v, a", PEAKS)
def test_each_law_rises_from_rest_to_rest_with_its_closed_form_peaks(law, v, a):
    s, s1, s2, s3 = laws.rise(law, U)
    assert (s[0], s[-1], s1[0], s1[-1]) == pytest.approx((0.0, 1.0, 0.0, 0.0), abs=1e-14)
    # peaks on a fine grid, within its spacing's error of the closed form
    assert np.max(s1) == pytest.approx(v, rel=1e-9)
    assert np.max(np.abs(s2)) == pytest.approx(a, rel=1e-8)
    # the derivatives against central differences of the law itself (not across the joins of
    # a modified law's pieces, where the derivative of its jerk jumps)
    h = U[1] - U[0]
    joins = np.array([0.125, 0.375, 0.5, 0.625, 0.875])
    smooth = np.min(np.abs(U[1:-1, None] - joins[None, :]), axis=1) > 3 * h
    for f, df in ((s, s1), (s1, s2), (s2, s3)):
        fd = (f[2:] - f[:-2]) / (2 * h)
        assert np.max(np.abs(fd - df[1:-1])[smooth]) <= 1e-6 * np.max(np.abs(df))
    # and every derivative up to the acceleration continuous, the joins included
    for f in (s, s1, s2):
        assert np.max(np.abs(np.diff(f))) <= 1e-3 * np.max(np.abs(f))


def test_a_dwell_holds_still():
    assert all(np.all(x == 0) for x in laws.rise("dwell", U))


def motion(repeat=True):
    # 0 -> 60 deg (cycloidal, 0.5 s), dwell 0.25 s, back to 0 (poly345, 0.4 s), dwell 0.1 s
    r = math.radians(60.0)
    return SegmentMotion(0.2, (Segment("cycloidal", 0.2 + r, 0.5), Segment("dwell", 0.0, 0.25),
                               Segment("poly345", 0.2, 0.4), Segment("dwell", 0.0, 0.1)), repeat)


def test_a_segment_motion_is_the_laws_end_to_end_and_repeats():
    m = motion()
    assert m.period == pytest.approx(1.25)
    t = np.linspace(-1.0, 3.0, 400001)
    q, qd, qdd, qddd = m.svaj(t)
    # the closed forms, written out here: the cycloidal rise over [0, 0.5] s
    r = math.radians(60.0)
    u = t[(t >= 0) & (t <= 0.5)] / 0.5
    assert q[(t >= 0) & (t <= 0.5)] == pytest.approx(
        0.2 + r * (u - np.sin(2 * np.pi * u) / (2 * np.pi)), abs=1e-14)
    on = (t > 0.5) & (t < 0.75)
    assert np.all(q[on] == q[on][0]) and np.all(qd[on] == 0)
    # the rate and acceleration are the derivatives of the coordinate (central differences;
    # not across a join, where the jerk jumps)
    h = t[1] - t[0]
    joins = np.concatenate([k * 1.25 + np.array([0.0, 0.5, 0.75, 1.15]) for k in range(-1, 3)])
    smooth = np.min(np.abs(t[1:-1, None] - joins[None, :]), axis=1) > 2 * h
    for f, df in ((q, qd), (qd, qdd)):
        fd = (f[2:] - f[:-2]) / (2 * h)
        assert np.max(np.abs(fd - df[1:-1])[smooth]) <= 1e-7 * np.max(np.abs(df))
    # and continuous across every join: the coordinate and (every law ends at rest) the rate
    for x in (q, qd):
        assert np.max(np.abs(np.diff(x))) <= 1e-3 * np.max(np.abs(x))
    # periodic: the same motion one period later, and before t = 0
    t0 = np.linspace(0.0, 1.25, 101)
    for a, b in zip(m.evaluate(t0), m.evaluate(t0 + 1.25)):
        assert a == pytest.approx(b, abs=1e-12)
    for a, b in zip(m.evaluate(t0), m.evaluate(t0 - 2.5)):
        assert a == pytest.approx(b, abs=1e-12)


def test_a_motion_that_does_not_repeat_holds_its_last_value():
    m = SegmentMotion(0.0, (Segment("harmonic", 0.3, 2.0),), repeat=False)
    q, qd, qdd = m.evaluate(np.array([-1.0, 0.0, 1.0, 2.0, 5.0]))
    assert q == pytest.approx([0.0, 0.0, 0.15, 0.3, 0.3], abs=1e-15)
    assert qd[[0, 4]] == pytest.approx([0.0, 0.0]) and qdd[4] == 0.0
    assert m.period is None
    with pytest.raises(linkdyn.ModelError, match="jump at each repeat"):
        SegmentMotion(0.0, (Segment("harmonic", 0.3, 2.0),), repeat=True)


BAR = """
[mechanism]
name = "indexing arm"
[units]
length = "mm"
angle = "deg"
[[bodies]]
name = "ground"
points = { O = [0.0, 0.0] }
[[bodies]]
name = "arm"
points = { O = [0.0, 0.0] }
mass = 2.0
com = [100.0, 0.0]
inertia = 5000.0
[[joints]]
name = "J1"
type = "revolute"
connect = ["ground.O", "arm.O"]
[[drivers]]
joint = "J1"
motion = { kind = "segments", start = 10.0, segments = [
  { law = "cycloidal", to = 70.0, time = 0.5 },
  { law = "dwell", time = 0.25 },
  { law = "poly4567", to = 10.0, time = 0.5 },
  { law = "dwell", time = 0.25 } ] }
"""


def test_an_arm_driven_by_segments_needs_the_torque_of_its_inertia(tmp_path):
    path = tmp_path / "arm.toml"
    path.write_text(BAR, "utf-8")
    model = linkdyn.load(path)
    assert model.drivers[0].period == pytest.approx(1.5)
    t = np.linspace(0.0, 1.5, 601)
    sol = linkdyn.analyze(model, t)
    # no gravity: tau = I_O qdd, I_O = I_c + m d^2 (kg m^2), qdd from the laws' closed forms
    i_o = 5000e-6 + 2.0 * 0.1 ** 2
    h, T = math.radians(60.0), 0.5
    u1 = np.clip(t / T, 0, 1)
    u2 = np.clip((t - 0.75) / T, 0, 1)
    qdd = np.where(t <= 0.5, h * 2 * np.pi * np.sin(2 * np.pi * u1) / T ** 2, 0.0)
    s2 = 420 * u2 ** 2 - 1680 * u2 ** 3 + 2100 * u2 ** 4 - 840 * u2 ** 5
    qdd = qdd + np.where((t >= 0.75) & (t <= 1.25), -h * s2 / T ** 2, 0.0)
    assert sol.effort("J1") == pytest.approx(i_o * qdd, abs=1e-12 * i_o * np.max(np.abs(qdd)))
    # --cycles counts the motion's period
    res = CliRunner().invoke(main, ["analyze", str(path), "--cycles", "2", "--samples", "11",
                                    "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    import csv
    rows = list(csv.DictReader((tmp_path / "out" / "results.csv").open()))
    assert float(rows[-1]["t"]) == pytest.approx(3.0)


def test_a_segment_motion_round_trips_through_a_model_file(tmp_path):
    path = tmp_path / "arm.toml"
    path.write_text(BAR, "utf-8")
    model = linkdyn.load(path)
    linkdyn.save(model, tmp_path / "again.toml")
    text = (tmp_path / "again.toml").read_text("utf-8")
    again = linkdyn.load(tmp_path / "again.toml")
    # in the file's own unit (deg), the same motion
    motion = tomllib.loads(text)["drivers"][0]["motion"]
    assert motion["start"] == pytest.approx(10.0) and motion["segments"][0]["to"] == 70
    t = np.linspace(0.0, 3.0, 301)
    for a, b in zip(model.drivers[0].motion.evaluate(t), again.drivers[0].motion.evaluate(t)):
        assert a == pytest.approx(b, abs=1e-12)


@pytest.mark.parametrize("segment, field, words", [
    ('{ law = "cubic", to = 70.0, time = 0.5 }', "segments[0].law", "unknown motion law"),
    ('{ law = "cycloidal", time = 0.5 }', "segments[0].to", "missing required key 'to'"),
    ('{ law = "dwell", to = 3.0, time = 0.5 }', "segments[0].to", "takes no 'to'"),
    ('{ law = "cycloidal", to = 70.0, time = -1.0 }', "segments[0].time", "positive"),
    ('{ law = "cycloidal", to = 70.0, time = 0.5 }', "segments", "jump at each repeat"),
])
def test_a_bad_segment_is_named_with_its_fix(tmp_path, segment, field, words):
    end = "time = 0.25 } ] }"
    text = BAR.replace(BAR[BAR.index("motion = {"):BAR.rindex(end) + len(end)],
                       f'motion = {{ kind = "segments", start = 10.0, segments = [{segment}] }}')
    path = tmp_path / "bad.toml"
    path.write_text(text, "utf-8")
    res = CliRunner().invoke(main, ["check", str(path)])
    assert res.exit_code == 2 and "Traceback" not in res.output
    assert f"drivers[0].motion.{field}" in res.output and words in res.output
