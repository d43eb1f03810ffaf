"""Disc cams from a follower motion (``linkdyn.cams``, ``linkdyn cam``): SVAJ by the laws'
closed forms, the pitch curve's curvature and the pressure angle against finite differences of
the profile's own points, dwells against circles, and the profile's points putting the follower
exactly on its prescribed lift (found here by resting the follower on the points)."""

from __future__ import annotations

import csv
import math
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner

from linkdyn import cams
from linkdyn.io import camfile
from linkdyn.cli import main
from linkdyn.motion import Segment

DOC = Path(__file__).resolve().parents[1] / "docs" / "cams.md"
H, W = 0.02, 300 * 2 * math.pi / 60      # lift 20 mm, 300 rpm
RISE = math.radians(100.0)


def cam(follower="roller", offset=0.005, roller=0.010, base=0.040, rise="cycloidal",
        back="poly345"):
    d60, d100 = math.radians(60.0), math.radians(100.0)
    segs = (Segment("dwell", 0.0, d60), Segment(rise, H, d100), Segment("dwell", H, d100),
            Segment(back, 0.0, d100))
    return cams.Cam("test", segs, base, follower, roller if follower == "roller" else 0.0,
                    offset if follower != "flat" else 0.0, W)


def run_cam(path, tmp_path):
    """``linkdyn cam PATH -o tmp_path/out``, in process: click's result."""
    return CliRunner().invoke(main, ["cam", str(path), "-o", str(tmp_path / "out")])


def refused(res, tmp_path, *words):
    """The run ``res`` of :func:`run_cam` refused its file: exit 2, no traceback, its message
    holding each of ``words`` (the field and the fix), nothing written."""
    assert res.exit_code == 2 and "Traceback" not in res.output, res.output
    for w in words:
        assert w in res.output, res.output
    assert not (tmp_path / "out").exists()


def test_svaj_of_a_cycloidal_rise_is_its_closed_form():
    p = cams.profile(cam(), 3601)
    on = (p.theta >= math.radians(60)) & (p.theta < math.radians(160))   # the jerk jumps at 160
    x = (p.theta[on] - math.radians(60)) / RISE
    b = RISE / W                                 # the rise's duration, s
    assert p.s[on] == pytest.approx(H * (x - np.sin(2 * np.pi * x) / (2 * np.pi)), abs=1e-14)
    assert p.v[on] == pytest.approx(H / b * (1 - np.cos(2 * np.pi * x)), abs=1e-12 * H / b)
    a = 2 * np.pi * H / b ** 2
    assert p.a[on] == pytest.approx(a * np.sin(2 * np.pi * x), abs=1e-12 * a)
    j = 4 * np.pi ** 2 * H / b ** 3
    assert p.j[on] == pytest.approx(j * np.cos(2 * np.pi * x), abs=1e-12 * j)


@pytest.mark.parametrize("follower, offset", [("knife", 0.0), ("knife", 0.008),
                                              ("roller", 0.0), ("roller", 0.005)])
def test_on_a_dwell_the_pitch_curve_is_a_circle(follower, offset):
    p = cams.profile(cam(follower, offset), 721)
    rb, rf = 0.040, (0.010 if follower == "roller" else 0.0)
    d = math.sqrt((rb + rf) ** 2 - offset ** 2)
    first = p.theta < math.radians(59)          # the first dwell, at lift 0
    # the pitch circle's radius, and its pressure angle atan(-e / d)
    assert p.rho_pitch[first] == pytest.approx(math.hypot(d, offset), rel=1e-12)
    assert p.pressure_angle[first] == pytest.approx(math.atan2(-offset, d), abs=1e-12)
    assert np.hypot(*p.pitch[:, first]) == pytest.approx(rb + rf, rel=1e-12)
    assert np.hypot(*p.profile[:, first]) == pytest.approx(rb, rel=1e-12)


def curvature(x, y, h):
    """Radius of curvature of the sampled curve (x, y), spacing h, by central differences."""
    x1, y1 = np.gradient(x, h), np.gradient(y, h)
    x2, y2 = np.gradient(x1, h), np.gradient(y1, h)
    return (x1 ** 2 + y1 ** 2) ** 1.5 / (x1 * y2 - y1 * x2)


@pytest.mark.parametrize("follower", ["knife", "roller"])
def test_curvature_and_pressure_angle_match_the_profiles_own_points(follower):
    n = 36001
    p = cams.profile(cam(follower), n)
    h = p.theta[1] - p.theta[0]
    inner = slice(5, -5)
    # the cam turns counter-clockwise: its frame sees the pitch curve run clockwise; compared
    # as curvatures (1/rho passes 0 where the curve turns from convex to concave), not across
    # the joins of the segments (where the jerk jumps)
    kappa = -1 / curvature(*p.pitch, h)
    joins = np.radians([0.0, 60.0, 160.0, 260.0, 360.0])
    smooth = np.min(np.abs(p.theta[:, None] - joins[None, :]), axis=1) > 4 * h
    err = np.abs(kappa - 1 / p.rho_pitch)[smooth]
    assert np.max(err) <= 1e-6 * np.max(np.abs(1 / p.rho_pitch))
    # the pressure angle: the follower's line (y) against the normal of the pitch curve, whose
    # tangent is the pitch points' difference turned back into the fixed frame
    tx, ty = np.gradient(p.pitch[0], h), np.gradient(p.pitch[1], h)
    c, s = np.cos(p.theta), np.sin(p.theta)
    fx, fy = c * tx - s * ty, s * tx + c * ty
    # the normal is the tangent turned by 90 deg: its angle from the follower's line (y) is
    # the tangent's angle from x
    assert np.max(np.abs(np.arctan2(fy, fx) - p.pressure_angle)[inner]) <= 1e-6


@pytest.mark.parametrize("follower", ["knife", "roller", "flat"])
def test_the_profiles_points_put_the_follower_on_its_lift(follower):
    # rest the follower on the cut profile (its points only) at each cam angle: where it
    # touches is the prescribed lift
    p = cams.profile(cam(follower), 20001)
    rb, e = 0.040, (0.005 if follower != "flat" else 0.0)
    rf = 0.010 if follower == "roller" else 0.0
    d = math.sqrt((rb + rf) ** 2 - e ** 2)
    for k in range(0, len(p.theta), 997):
        th = p.theta[k]
        c, s = math.cos(th), math.sin(th)
        qx = c * p.profile[0] - s * p.profile[1]       # the profile in the fixed frame at th
        qy = s * p.profile[0] + c * p.profile[1]
        if follower == "flat":
            top = np.max(qy) - rb                      # the face rests on the highest point
        elif rf:                                       # the roller on the nearest points
            near = np.abs(qx - e) <= rf
            lift = qy[near] + np.sqrt(np.maximum(rf ** 2 - (qx[near] - e) ** 2, 0.0))
            top = np.max(lift) - d
        else:                                          # the knife where its line cuts the
            cut = np.nonzero((qx[:-1] - e) * (qx[1:] - e) <= 0)[0]       # profile's polygon
            w = (e - qx[cut]) / (qx[cut + 1] - qx[cut])
            top = np.max(qy[cut] + w * (qy[cut + 1] - qy[cut])) - d
        assert top == pytest.approx(p.s[k], abs=2e-6 * H)


def test_a_flat_face_has_the_closed_form_radius_and_warns_of_a_cusp():
    p = cams.profile(cam("flat"), 3601)
    # rho = R_b + s + s'' (s'' per rad^2 = a / w^2)
    assert p.rho == pytest.approx(0.040 + p.s + p.a / W ** 2, abs=1e-15)
    assert not np.any(p.undercut)
    small = cams.profile(cam("flat", base=0.005), 3601)
    assert np.any(small.undercut) and "cusp" in camfile.text(small)


def test_a_roller_too_big_for_the_profile_is_reported_undercut():
    # a 50 mm lift in 45 deg on a 10 mm base circle: the pitch curve's nose bends tighter
    # than a 20 mm roller
    d45 = math.radians(45.0)
    segs = (Segment("cycloidal", 0.05, d45), Segment("cycloidal", 0.0, d45),
            Segment("dwell", 0.0, 2 * math.pi - 2 * d45))
    p = cams.profile(cams.Cam("nose", segs, 0.010, "roller", 0.020, 0.0, W), 3601)
    tight = (p.rho_pitch > 0) & (p.rho_pitch < 0.020)
    assert np.array_equal(p.undercut, tight) and np.any(tight)
    assert np.any(p.undercut)
    assert "UNDERCUT" in camfile.text(p) and "smaller roller" in camfile.text(p)


def doc_file() -> str:
    text = DOC.read_text("utf-8")
    return text.split("```toml\n", 1)[1].split("```", 1)[0]


def test_the_command_prints_in_the_files_units_and_writes_the_table(tmp_path):
    path = tmp_path / "cam.toml"
    path.write_text(doc_file(), "utf-8")
    res = run_cam(path, tmp_path)
    assert res.exit_code == 0, res.output
    design, n = camfile.read(path)
    p = cams.profile(design, n)
    k = np.argmax(np.abs(p.pressure_angle))
    assert f"max pressure angle {math.degrees(abs(p.pressure_angle[k])):.4g} deg" in res.output
    assert "lift 20 mm" in res.output
    rows = list(csv.DictReader((tmp_path / "out" / "cam.csv").open()))
    assert len(rows) == n
    assert float(rows[k]["pressure_angle_rad"]) == p.pressure_angle[k]
    # the docs show what the command prints
    shown = DOC.read_text("utf-8").split("$ linkdyn cam cam.toml\n", 1)[1].split("```", 1)[0]
    assert [ln for ln in shown.strip().splitlines() if not ln.startswith("wrote")] == \
        res.output.strip().splitlines()[:-1]


def test_the_joins_jump_by_the_laws_closed_forms(tmp_path):
    # a harmonic rise h over beta after and before a dwell: the acceleration jumps by
    # h pi^2 / (2 beta^2) w^2 at both its ends; a 3-4-5 return: continuous acceleration, the
    # jerk jumps by 60 h / beta^3 w^3 (its third derivative at either end); lift and velocity
    # never jump
    harmonic = cam(rise="harmonic")
    theta, jump = cams.joins(harmonic)
    assert np.degrees(theta) == pytest.approx([60.0, 160.0, 260.0, 0.0])
    a = H * math.pi ** 2 / (2 * RISE ** 2) * W ** 2
    j = 60 * H / RISE ** 3 * W ** 3
    assert np.max(np.abs(jump[:2])) <= 1e-15
    assert jump[2] == pytest.approx([a, a, 0.0, 0.0], abs=1e-12 * a)
    assert jump[3] == pytest.approx([0.0, 0.0, -j, j], abs=1e-12 * j)
    # the command says so, in the file's units
    path = tmp_path / "cam.toml"
    path.write_text(doc_file().replace('law = "cycloidal"', 'law = "harmonic"'), "utf-8")
    res = run_cam(path, tmp_path)
    assert res.exit_code == 0, res.output
    assert (f"ACCELERATION JUMPS at cam angles 60, 160 deg (by up to {a * 1000:.6g} mm/s^2)"
            in res.output)


@pytest.mark.parametrize("edit, field, words", [
    (("follower = \"roller\"", "follower = \"mushroom\""), "cam.follower", "unknown follower"),
    (("roller_radius = 10.0\n", ""), "cam.roller_radius", "missing required key"),
    (("angle = 60.0", "angle = 50.0"), "cam.segments", "not one turn"),
    (("to = 0.0", "to = 1.0"), "cam.segments", "not 0"),
    (("offset = 5.0", "offset = 60.0"), "cam.offset", "prime circle"),
    (("law = \"poly345\"", "law = \"poly999\""), "cam.segments[3].law", "unknown motion law"),
])
def test_a_bad_cam_file_is_named_with_its_fix(tmp_path, edit, field, words):
    path = tmp_path / "cam.toml"
    path.write_text(doc_file().replace(*edit), "utf-8")
    refused(run_cam(path, tmp_path), tmp_path, field, words)


TABLE = """[units]
length = "mm"
angle = "deg"

[cam]
name = "measured"
base_radius = 40.0
roller_radius = 10.0
rpm = 300.0
table = { angle = [ANGLES], lift = [LIFTS] }
"""


def table_file(path, angles, lifts):
    path.write_text(TABLE.replace("ANGLES", ", ".join(repr(float(a)) for a in angles))
                    .replace("LIFTS", ", ".join(repr(float(x)) for x in lifts)), "utf-8")
    return path


def test_a_table_of_points_gives_the_periodic_spline_through_them(tmp_path):
    # the lift h (1 - cos theta) / 2 given every 5 deg: the spline passes through every
    # point, is C2 (no join jumps below the jerk), and converges on the closed form (its
    # error O(d^4) in the lift, O(d^3) in the velocity, O(d^2) in the acceleration)
    deg = np.arange(0.0, 360.0, 5.0)
    path = table_file(tmp_path / "cam.toml", deg, 10.0 * (1 - np.cos(np.radians(deg))))
    design, n = camfile.read(path)
    p = cams.profile(design, 721)    # every 0.5 deg: the table's points among them
    at = np.isin(np.round(np.degrees(p.theta), 9), deg)
    assert np.sum(at) == len(deg)
    assert p.s[at] == pytest.approx(H / 2 * (1 - np.cos(p.theta[at])), abs=1e-15)
    th = p.theta
    assert p.s == pytest.approx(H / 2 * (1 - np.cos(th)), abs=3e-7 * H)
    assert p.v == pytest.approx(H / 2 * np.sin(th) * W, abs=2e-5 * H / 2 * W)
    assert p.a == pytest.approx(H / 2 * np.cos(th) * W ** 2, abs=2e-3 * H / 2 * W ** 2)
    # C3 with the closed form's lift and rate
    d = design.base_radius + design.roller_radius
    exact = np.arctan2(H / 2 * np.sin(th), d + H / 2 * (1 - np.cos(th)))
    assert p.pressure_angle == pytest.approx(exact, abs=5e-6)
    # continuity: nothing jumps but the jerk, by the spline's own third derivative either side
    knots, jump = cams.joins(design)
    assert np.max(np.abs(jump[:3])) <= 1e-12 * np.max(np.abs(p.a))
    eps = 1e-7
    left, right = (design.motion.svaj(knots + x)[3] * W ** 3 for x in (-eps, eps))
    assert jump[3] == pytest.approx(right - left, abs=1e-9 * np.max(np.abs(p.j)))
    res = run_cam(path, tmp_path)
    assert res.exit_code == 0, res.output
    assert "displacement, velocity and acceleration continuous at every join" in res.output


@pytest.mark.parametrize("angles, lifts, field, words", [
    ([0, 90, 180, 270], [0, 1, 2], "cam.table", "same number of points"),
    ([0, 180, 90, 270], [0, 1, 2, 1], "cam.table.angle", "increase within one turn"),
    ([0, 90, 180, 360], [0, 1, 2, 1], "cam.table.angle", "increase within one turn"),
    (None, None, "cam.segments", "by segments, by a table or by a formula")])
def test_a_bad_table_is_named_with_its_fix(tmp_path, angles, lifts, field, words):
    path = tmp_path / "cam.toml"
    if angles is None:   # segments and a table both
        path.write_text(doc_file().replace("[[cam.segments]]", "table = { angle = [0, 90, "
                        "180, 270], lift = [0, 1, 2, 1] }\n\n[[cam.segments]]", 1), "utf-8")
    else:
        table_file(path, angles, lifts)
    refused(run_cam(path, tmp_path), tmp_path, field, words)


FORMULA = """[units]
length = "mm"
angle = "deg"

[cam]
name = "by a formula"
base_radius = 40.0
roller_radius = 10.0
offset = 5.0
rpm = 300.0
formula = "LIFT"
"""

#: the doc file's cam (dwell 60 deg, cycloidal rise of 20 mm over 100 deg, dwell 100 deg, 3-4-5
#: return over 100 deg) written as one formula of the cam angle in deg
DRDR = ("where(theta < 60, 0, where(theta < 160, 20*((theta - 60)/100 - sin(2*pi*(theta - 60)"
        "/100)/(2*pi)), where(theta < 260, 20, 20*(1 - ((theta - 260)/100)**3*(10 - 15*(theta"
        " - 260)/100 + 6*((theta - 260)/100)**2)))))")


def test_a_lift_by_a_formula_is_the_built_in_laws_to_rounding(tmp_path):
    # the same cam by segments (each law's hand-written derivatives, linkdyn.laws) and by a
    # formula (its derivatives symbolic, linkdyn.expr): SVAJ, pressure angle, curvature and
    # points agree to 1e-12 of their peaks (1001 angles: none on a join, where a law's jerk
    # jumps and the two could take different sides)
    path = tmp_path / "cam.toml"
    path.write_text(FORMULA.replace("LIFT", DRDR), "utf-8")
    design, _ = camfile.read(path)
    laws_ = cams.profile(cam(), 1001)
    by_formula = cams.profile(design, 1001)
    for name in ("s", "v", "a", "j", "pressure_angle", "rho_pitch", "rho", "pitch", "profile"):
        x, y = getattr(by_formula, name), getattr(laws_, name)
        assert x == pytest.approx(y, rel=0, abs=1e-12 * np.max(np.abs(y))), name
    # the continuity line: the cycle closes smoothly (only there are joins looked for)
    theta, jump = cams.joins(design)
    assert theta == pytest.approx([0.0])
    assert np.max(np.abs(jump[:3])) <= 1e-12 * np.max(np.abs(laws_.a))
    res = run_cam(path, tmp_path)
    assert res.exit_code == 0, res.output
    assert "lift 20 mm" in res.output and "continuous" in res.output


def test_a_formula_that_jumps_where_the_cycle_closes_is_reported(tmp_path):
    # a harmonic rise over the whole turn, 10 (1 - cos(pi theta / 360)) (theta in deg): at 360
    # deg its lift is 20 mm, at 0 it is 0: the lift jumps by -20 mm where the cycle closes
    path = tmp_path / "cam.toml"
    path.write_text(FORMULA.replace("LIFT", "10*(1 - cos(pi*theta/360))"), "utf-8")
    design, _ = camfile.read(path)
    _, jump = cams.joins(design)
    assert jump[0] == pytest.approx([-H])
    res = run_cam(path, tmp_path)
    assert res.exit_code == 0, res.output
    assert "DISPLACEMENT JUMPS at cam angles 0 deg (by up to 20 mm)" in res.output


@pytest.mark.parametrize("lift, words", [
    ("20*sin(theta", "formula"),
    ("__import__('os')", "formula"),
    ("20*sin(theta)", "below 0"),
    ("log(theta - 10)", "not finite"),
    ("20*(1 - cos(t))", "formula")])
def test_a_bad_formula_is_named_with_its_fix(tmp_path, lift, words):
    path = tmp_path / "cam.toml"
    path.write_text(FORMULA.replace("LIFT", lift.replace('"', "'")), "utf-8")
    refused(run_cam(path, tmp_path), tmp_path, "cam.formula", words)


OSCILLATING = """[units]
length = "mm"
angle = "deg"

[cam]
name = "oscillating"
base_radius = 40.0
FOLLOWER
rpm = 300.0

[[cam.segments]]
law = "cycloidal"
to = SWING
angle = 105.0

[[cam.segments]]
law = "dwell"
angle = 75.0

[[cam.segments]]
law = "poly345"
to = 0.0
angle = 105.0

[[cam.segments]]
law = "dwell"
angle = 75.0
"""
ROLLER_ARM = 'follower = "roller"\nroller_radius = 10.0\npivot = 120.0\narm = 90.0'
FLAT_ARM = 'follower = "flat"\npivot = 100.0\noffset = 10.0'


def oscillating(tmp_path, follower, swing):
    path = tmp_path / "cam.toml"
    path.write_text(OSCILLATING.replace("FOLLOWER", follower).replace("SWING", repr(swing)),
                    "utf-8")
    return path


def to_fixed(theta, x, y):
    """Points of the cam's frame at the cam angles theta, in the fixed frame: R(theta) (x, y)."""
    c, s = np.cos(theta), np.sin(theta)
    return c * x - s * y, s * x + c * y


def on_dwell(theta):
    return (theta > math.radians(290.0)) & (theta < math.radians(355.0))


def curvature_error(p, points, rho, joins):
    """The largest difference of the sampled curve's curvature (``points`` of the cam's frame,
    which sees it run clockwise) from ``1 / rho``, relative to the largest, by central
    differences away from the ``joins`` (deg, where the jerk jumps)."""
    h = p.theta[1] - p.theta[0]
    kappa = -1 / curvature(*points, h)
    at = np.radians(joins)
    smooth = np.min(np.abs(p.theta[:, None] - at[None, :]), axis=1) > 4 * h
    return np.max(np.abs(kappa - 1 / rho)[smooth]) / np.max(np.abs(1 / rho))


def test_an_oscillating_roller_has_its_closed_forms(tmp_path):
    # the arm (pivot A at a = 120 mm, roller's centre F at L = 90 mm from it) swung 15 deg
    a, L, rb, rf = 0.120, 0.090, 0.040, 0.010
    design, _ = camfile.read(oscillating(tmp_path, ROLLER_ARM, 15.0))
    n = 36001
    p = cams.profile(design, n)
    # SVAJ: the arm's angle, the cycloidal law's closed form (rad)
    b, top = math.radians(105.0), math.radians(15.0)
    rise = p.theta < b
    u = p.theta[rise] / b
    assert p.s[rise] == pytest.approx(top * (u - np.sin(2 * np.pi * u) / (2 * np.pi)),
                                      abs=1e-14)
    assert p.v[rise] == pytest.approx(top / b * (1 - np.cos(2 * np.pi * u)) * W,
                                      abs=1e-12 * top / b * W)
    # on the bottom dwell: the prime and base circles; the pressure angle from the triangle
    # C A F (law of cosines: the angle at F, less the right angle of F's motion to AF)
    dw = on_dwell(p.theta)
    assert p.rho_pitch[dw] == pytest.approx(rb + rf, rel=1e-12)
    assert p.rho[dw] == pytest.approx(rb, rel=1e-12)
    assert np.hypot(*p.profile[:, dw]) == pytest.approx(rb, rel=1e-12)
    at_f = math.acos((L * L + (rb + rf) ** 2 - a * a) / (2 * L * (rb + rf)))
    assert np.abs(p.pressure_angle[dw]) == pytest.approx(at_f - math.pi / 2, abs=1e-12)
    # everywhere: the common normal (from the profile point to the roller's centre) passes
    # through the instant centre of cam and arm on the line of centres (Aronhold-Kennedy),
    # x = a s' / (1 + s'), s' the swing's rate per cam angle
    fx, fy = to_fixed(p.theta, *p.pitch)
    nx, ny = to_fixed(p.theta, *((p.pitch - p.profile) / rf))
    s1 = p.v / W
    steep = np.abs(ny) > 0.1
    x = (fx - fy / ny * nx)[steep]
    assert x == pytest.approx((a * s1 / (1 + s1))[steep], abs=1e-9 * a)
    # the pressure angle: from the roller centre's velocity (the arm turning clockwise about
    # A as the swing grows: -J (F - A)) to that normal
    vx, vy = fy, a - fx
    assert p.pressure_angle == pytest.approx(np.arctan2(vx * ny - vy * nx, vx * nx + vy * ny),
                                             abs=1e-12)
    assert np.hypot(fx - a, fy) == pytest.approx(L, rel=1e-12)
    # the pitch curve's radius of curvature by central differences of its own points
    assert curvature_error(p, p.pitch, p.rho_pitch, [0.0, 105.0, 180.0, 285.0, 360.0]) <= 1e-6


def test_an_oscillating_flat_face_has_its_closed_forms(tmp_path):
    # the face 10 mm from the arm's pivot (a = 100 mm), swung 10 deg
    a, f, rb = 0.100, 0.010, 0.040
    design, _ = camfile.read(oscillating(tmp_path, FLAT_ARM, 10.0))
    p = cams.profile(design, 36001)
    alpha0 = math.acos((rb + f) / a)
    # on the dwell: the base circle, and the pressure angle tan(phi) = -f / (a sin(alpha0))
    # (the face's point R_b n moving as -J (R_b n - A), n at alpha0)
    dw = on_dwell(p.theta)
    assert p.rho[dw] == pytest.approx(rb, rel=1e-12)
    assert np.hypot(*p.profile[:, dw]) == pytest.approx(rb, rel=1e-12)
    assert p.pressure_angle[dw] == pytest.approx(math.atan2(-f, a * math.sin(alpha0)),
                                                 abs=1e-12)
    # everywhere: the contact point is on the face (its normal n at alpha0 - s, at a cos -
    # f from C) and the normal through it passes through the instant centre a s' / (1 + s')
    al = alpha0 - p.s
    nx, ny = np.cos(al), np.sin(al)
    qx, qy = to_fixed(p.theta, *p.profile)
    assert nx * qx + ny * qy == pytest.approx(a * np.cos(al) - f, abs=1e-14)
    s1 = p.v / W
    x = qx - qy / ny * nx
    assert x == pytest.approx(a * s1 / (1 + s1), abs=1e-9 * a)
    # the profile's radius of curvature by central differences of its own points
    assert curvature_error(p, p.profile, p.rho, [0.0, 105.0, 180.0, 285.0, 360.0]) <= 1e-6


def test_the_command_prints_an_oscillating_followers_swing_in_angles(tmp_path):
    res = CliRunner().invoke(main, ["cam", str(oscillating(tmp_path, ROLLER_ARM, 15.0)), "-o",
                                    str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    assert "oscillating roller follower" in res.output and "swing 15 deg" in res.output
    rows = list(csv.DictReader((tmp_path / "out" / "cam.csv").open()))
    assert max(float(r["s_rad"]) for r in rows) == pytest.approx(math.radians(15.0))


@pytest.mark.parametrize("follower, swing, field, words", [
    ('follower = "roller"\nroller_radius = 10.0\npivot = 120.0', 15.0, "cam.arm",
     "missing required key"),
    ('follower = "roller"\nroller_radius = 10.0\npivot = 120.0\narm = 20.0', 15.0, "cam.arm",
     "cannot reach the prime circle"),
    ('follower = "flat"\npivot = 40.0\noffset = 10.0', 10.0, "cam.pivot", "further"),
    (ROLLER_ARM + "\noffset = 5.0", 15.0, "cam.offset", "pivot and arm"),
    (ROLLER_ARM, 200.0, "cam.segments", "past the line of centres")])
def test_a_bad_oscillating_follower_is_named_with_its_fix(tmp_path, follower, swing, field,
                                                         words):
    res = CliRunner().invoke(main, ["cam", str(oscillating(tmp_path, follower, swing)), "-o",
                                    str(tmp_path / "out")])
    assert res.exit_code == 2 and "Traceback" not in res.output, res.output
    assert field in res.output and words in res.output, res.output
    assert not (tmp_path / "out").exists()


def test_a_textbook_valve_cam_gives_its_printed_answers(tmp_path):
    # docs/cams.md "A textbook problem": a harmonic rise of 50 mm in 1/3 turn, a dwell of
    # 1/12, a harmonic return in 1/6, at 100 rpm; printed: the valve's largest speed 0.39 m/s
    # raising, 0.78 lowering, its largest acceleration 6.17 and 24.67 m/s^2
    block = DOC.read_text("utf-8").split("## A textbook problem", 1)[1]
    path = tmp_path / "valve.toml"
    path.write_text(block.split("```toml\n", 1)[1].split("```", 1)[0], "utf-8")
    res = run_cam(path, tmp_path)
    assert res.exit_code == 0, res.output
    rows = list(csv.DictReader((tmp_path / "out" / "cam.csv").open()))
    deg = np.degrees([float(r["theta_rad"]) for r in rows])
    v = np.abs([float(r["v_m_s"]) for r in rows])
    a = np.abs([float(r["a_m_s2"]) for r in rows])
    raising, lowering = deg <= 120.0, (deg >= 150.0) & (deg <= 210.0)
    printed = {"v raising": 0.39, "v lowering": 0.78, "a raising": 6.17, "a lowering": 24.67}
    ours = {"v raising": np.max(v[raising]), "v lowering": np.max(v[lowering]),
            "a raising": np.max(a[raising]), "a lowering": np.max(a[lowering])}
    for key, value in printed.items():
        assert ours[key] == pytest.approx(value, rel=0.01), key
    # and the closed forms: h pi w / (2 beta), h pi^2 w^2 / (2 beta^2)
    w, h = 100 * 2 * math.pi / 60, 0.050
    for key, beta in (("raising", 2 * math.pi / 3), ("lowering", math.pi / 3)):
        assert ours[f"v {key}"] == pytest.approx(h * math.pi * w / (2 * beta), rel=1e-12)
        assert ours[f"a {key}"] == pytest.approx(h * math.pi ** 2 * w ** 2 / (2 * beta ** 2),
                                                 rel=1e-12)
    assert "ACCELERATION JUMPS" in res.output
