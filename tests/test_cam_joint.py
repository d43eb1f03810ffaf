"""The cam-follower joint (``type = "cam"``): the follower it drives sits exactly on the motion
``linkdyn cam`` designs (its lift by the cam's own SegmentMotion), the contact force of a
translating roller follower with a spring is the closed form ``(m s'' w^2 + k (s + preload)) /
cos(pressure angle)`` along the common normal, the camshaft torque is the power balance
of that follower, the joint's coordinate has the rates of its finite differences, the summary
finds where the follower would leave the cam, and both backends agree. (The dense reference,
the simultaneous Newton-Euler solve, power balance and the body balances run on it in
``tests/test_dynamics.py``: ``cam-follower``.)"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn import cams
from linkdyn.cli import main
from linkdyn.design.overview import contact
from linkdyn.motion import ConstantSpeed

from builders import MM, RPM
from test_dynamics import (cam_follower, cam_of, flat_follower, follower_point, pitch_normal,
                           rocker_cam, rocker_flat)

W = 300 * RPM


def still(model):
    """``model`` with no gravity and no damper: the follower's closed form is then its inertia
    and its spring only."""
    return dataclasses.replace(model, gravity=np.zeros(2),
                               loads=tuple(x for x in model.loads if x.kind == "spring"))


def design(model, theta):
    """The cam's design quantities at the cam angles ``theta`` by ``linkdyn cam``'s model:
    the lift and its derivatives by the cam's SegmentMotion, the pressure angle (C3)."""
    cam = cam_of(model.joint("K"))
    s, s1, s2, _ = cam.motion.svaj(np.mod(theta, 2 * math.pi))
    d0 = math.sqrt((cam.base_radius + cam.roller_radius) ** 2 - cam.offset ** 2)
    return cam, d0, s, s1, s2, np.arctan2(s1 - cam.offset, d0 + s)


def follower_turn(model, w, n):
    """``n`` samples over one turn at the cam speed ``w`` of the translating follower of a
    :func:`still` ``model``, and its closed form there: the lift and its derivatives
    (:func:`design`), the spring, the follower's mass, the spring's compression ``c0`` at
    s = 0; the contact force's vertical part is ``m w^2 s'' + k (s + c0)``."""
    t = np.linspace(0.0, 2 * math.pi / w, n + 1)[:-1]
    _, d0, s, s1, s2, _ = design(model, w * t)
    spring = model.loads[0]
    return t, s, s2, spring, model.body("follower").mass, spring.free_length - (0.2 - d0)


@pytest.mark.parametrize("offset, law", [(5.0, "cycloidal"), (30.0, "harmonic"),
                                         (-20.0, "modified_trapezoid")])
def test_the_follower_sits_on_its_prescribed_motion(offset, law):
    # a small offset, and large ones either side (|e s'| up to 0.31 rho^2) with other laws
    model = cam_follower(offset=offset, law=law)
    t = np.linspace(0.0, 2 * math.pi / W, 41)[:-1] + 1e-3
    sol = linkdyn.analyze(model, t)
    cam, d0, s, s1, s2, _ = design(model, W * t)
    lift = model.joint("K").numbers["lift"]
    # the follower's guide coordinate is d0 + s(theta) to 1e-12 of the lift, its rates w s',
    # w^2 s'' (the joint's own q is the same lift)
    assert np.max(np.abs(sol.columns["q_J2"] - d0 - s)) <= 1e-12 * lift
    assert np.max(np.abs(sol.columns["q_K"] - s)) <= 1e-12 * lift
    assert np.max(np.abs(sol.columns["qd_J2"] - W * s1)) <= 1e-10 * W * np.max(np.abs(s1))
    assert np.max(np.abs(sol.columns["qdd_J2"] - W * W * s2)) <= 1e-9 * W * W * np.max(
        np.abs(s2))
    # the roller's centre is on the pitch curve linkdyn cam draws (C1): at the cam angle
    # theta it is R(-theta) (e, d0 + s) in the cam's frame, so at (e, d0 + s) on the ground
    F = sol.point("follower", "F")
    assert np.max(np.abs(F - np.stack((np.full_like(s, cam.offset), d0 + s), -1))) <= 1e-12 * lift
    # and the profile's points of linkdyn cam lie on that same pitch curve (C1 vs the joint)
    p = cams.profile(cam, 73)
    assert np.max(np.abs(np.hypot(*p.pitch) - np.hypot(cam.offset, d0 + p.s))) <= 1e-15


def test_contact_force_and_camshaft_torque_of_a_spring_loaded_roller_follower():
    model = still(cam_follower())
    t = np.linspace(0.0, 2 * math.pi / W, 37)[:-1] + 2e-4
    sol = linkdyn.analyze(model, t)
    _, d0, s, s1, s2, phi = design(model, W * t)
    m = model.body("follower").mass
    spring = model.loads[0]
    k, preload = spring.stiffness, spring.free_length - (0.2 - d0)
    # the follower's y equation: F cos(phi) = m w^2 s'' + k (s + preload)
    y_force = m * W * W * s2 + k * (s + preload)
    closed = y_force / np.cos(phi)
    f = np.linalg.norm(np.stack((sol.columns["Fx_K"], sol.columns["Fy_K"])), axis=0)
    assert np.max(np.abs(f - closed)) <= 1e-9 * np.max(closed)
    # along the common normal: at the pressure angle to the follower's line, pushing it up
    assert np.max(np.abs(np.arctan2(-np.asarray(sol.columns["Fx_K"]),
                                    sol.columns["Fy_K"]) - phi)) <= 1e-9
    # the camshaft's power (no inertia torque at a constant speed) is the follower's:
    # tau w = (m y'' + k (s + preload)) y' with y' = w s'
    tau = y_force * s1
    assert np.max(np.abs(sol.columns["tau_J1"] - tau)) <= 1e-9 * np.max(np.abs(tau))
    # the summary's contact: never lost, its least force the closed form's
    c = contact(sol)["K"]
    assert c["lost_samples"] == 0 and c["min_force_N"] == pytest.approx(np.min(closed), rel=1e-9)


def with_numbers(model, name="K", **numbers):
    """``model`` with more numbers on its joint ``name``."""
    return dataclasses.replace(model, joints=tuple(
        dataclasses.replace(j, numbers={**j.numbers, **numbers}) if j.name == name else j
        for j in model.joints))


def test_the_contact_stress_of_the_roller_is_hertz_line_contact_by_hand():
    # a steel cam and a bronze roller 8 mm wide: at each sample the contact force by the
    # follower's equation of motion, the profile's radius by C2-C4 written out, and the
    # half-width and peak pressure by Shigley's form of Hertz's two cylinders (diameters d),
    # b = sqrt(2 F / (pi L) ((1 - v1^2)/E1 + (1 - v2^2)/E2) / (1/d1 + 1/d2)), p = 2 F/(pi b L)
    from linkdyn.design.overview import contact_stress

    E1, v1, E2, v2, L = 206e9, 0.3, 110e9, 0.34, 8 * MM
    model = with_numbers(still(cam_follower()), roller_width=L, cam_modulus=E1,
                         cam_poisson=v1, roller_modulus=E2, roller_poisson=v2)
    t = np.linspace(0.0, 2 * math.pi / W, 73)[:-1] + 2e-4
    sol = linkdyn.analyze(model, t)
    cam, d0, s, s1, s2, phi = design(model, W * t)
    e, rf = cam.offset, cam.roller_radius
    spring = model.loads[0]
    force = (model.body("follower").mass * W * W * s2
             + spring.stiffness * (s + spring.free_length - (0.2 - d0))) / np.cos(phi)
    # C2: P' = (d0 + s, s' - e), P'' = (2 s' - e, s'' - d0 - s); C4: |P'|^3 / (P'' x P')
    p1x, p1y, p2x, p2y = d0 + s, s1 - e, 2 * s1 - e, s2 - d0 - s
    rho = np.hypot(p1x, p1y) ** 3 / (p2x * p1y - p2y * p1x) - rf
    b = np.sqrt(2 * force / (math.pi * L) * ((1 - v1 ** 2) / E1 + (1 - v2 ** 2) / E2)
                / (1 / (2 * rho) + 1 / (2 * rf)))
    p = 2 * force / (math.pi * b * L)
    hz = contact_stress(sol)["K"]
    assert np.max(np.abs(hz["cam_radius_m"] - rho)) <= 1e-9 * np.max(np.abs(rho))
    assert np.max(np.abs(hz["cam_angle_rad"] - np.mod(W * t, 2 * math.pi))) <= 1e-12
    assert np.max(np.abs(hz["half_width_m"] - b)) <= 1e-9 * np.max(b)
    assert np.max(np.abs(hz["p_max_Pa"] - p)) <= 1e-9 * np.max(p)
    # the summary's peak and where it is
    k = int(np.argmax(p))
    peak = contact(sol)["K"]["stress"]
    assert peak["max_pressure_Pa"] == pytest.approx(p[k], rel=1e-9)
    assert peak["max_time_s"] == t[k] and peak["force_N"] == pytest.approx(force[k], rel=1e-9)
    assert peak["half_width_m"] == pytest.approx(b[k], rel=1e-9)
    # the report page: a panel of the peak pressure over the cycle (the page's frames of the
    # by-hand p) and the key result of its peak, at its sample
    from linkdyn import report
    from linkdyn.design import summary
    data = report.page_data(sol, summary=summary(sol))
    panel, = [x for x in data["plots"] if x["title"].startswith("Contact stress at K")]
    at = [int(np.argmin(np.abs(t - x))) for x in data["series"]["t"]]
    shown = np.array(data["series"][panel["series"][0]["key"]], float)
    assert panel["unit"] == "N/mm^2"                     # the page's lengths are in mm
    assert np.max(np.abs(shown * 1e6 - p[at])) <= 1e-6 * np.max(p)
    key, = [x for x in data["key"] if x["label"] == "contact stress K"]
    assert key["value"] * 1e6 == pytest.approx(p[k], rel=1e-9) and key["t"] == t[k]
    # no roller_width, no stress
    plain = linkdyn.analyze(still(cam_follower()), t[:5])
    assert "stress" not in contact(plain)["K"]
    data = report.page_data(plain, summary=summary(plain))
    assert not [x for x in data["plots"] if x["title"].startswith("Contact stress")]
    assert not [x for x in data["key"] if x["label"].startswith("contact stress")]


def test_hertz_line_contact_against_its_closed_form():
    # two equal steel cylinders (R1 = R2 = R: R_eff = R/2, E* = E / (2 (1 - v^2))): b =
    # sqrt(4 F R_eff / (pi L E*)) = sqrt(4 F R (1 - v^2) / (pi L E)), p = sqrt(F E* / (pi L
    # R_eff)) = sqrt(F E / (pi L R (1 - v^2))); a concave cam of radius -2 R under a roller R
    # has R_eff = 2 R; no force, no contact
    R, L, E, v, F = 0.01, 0.008, 206e9, 0.3, 500.0
    b, p, Re = cams.hertz_line(np.array([F, -1.0]), R, R, L, E, v, E, v)
    assert Re[0] == pytest.approx(R / 2, rel=1e-15)
    assert b[0] == pytest.approx(math.sqrt(4 * F * R * (1 - v * v) / (math.pi * L * E)),
                                 rel=1e-14)
    assert p[0] == pytest.approx(math.sqrt(F * E / (math.pi * L * R * (1 - v * v))),
                                 rel=1e-14)
    assert b[1] == 0 and p[1] == 0
    assert cams.hertz_line(F, -2 * R, R, L, E, v, E, v)[2] == pytest.approx(2 * R, rel=1e-15)


def rocker_closed_form(model, t):
    """An oscillating roller follower at the times ``t`` by its cam angle ``theta = W t`` alone:
    the arm's angle ``g0 - s``, the unit normal n of the pitch curve (C2), the contact force's
    magnitude along n by the arm's moment balance about its pivot A, ``I_A g'' = (F - A) x
    (f n) + (F - A) x F_spring`` (no gravity, no damper), and the camshaft torque by power
    balance, ``tau W = I_A g' g'' + k (l - l0) l'``."""
    jt = model.joint("K")
    s, s1, s2, _ = cam_of(jt).motion.svaj(np.mod(W * t, 2 * math.pi))
    F, Ft = follower_point(jt, s, s1)
    n = pitch_normal(jt, W * t)
    arm, spring = model.body("arm"), model.loads[0]
    A, S = np.array([jt.numbers["pivot"], 0.0]), model.body("ground").points["S"]
    I_A = arm.inertia + arm.mass * np.sum(np.asarray(arm.com) ** 2)
    gd, gdd = -W * s1, -W * W * s2
    r = F - S
    l = np.linalg.norm(r, axis=-1)
    tension = spring.stiffness * (l - spring.free_length)
    f_spring = -tension[:, None] * r / l[:, None]
    lever = lambda x: (F[:, 0] - A[0]) * x[:, 1] - (F[:, 1] - A[1]) * x[:, 0]
    f = (I_A * gdd - lever(f_spring)) / lever(n)
    tau = (I_A * gd * gdd + tension * np.sum(r * Ft * W, -1) / l) / W
    return s, F, n, f, tau


def test_an_oscillating_follower_sits_on_its_swing_and_pushes_along_the_normal():
    model = still(rocker_cam())
    lift = model.joint("K").numbers["swing"]
    t = np.linspace(0.0, 2 * math.pi / W, 37)[:-1] + 2e-4
    sol = linkdyn.analyze(model, t)
    s, F, n, f, tau = rocker_closed_form(model, t)
    g0 = model.assembly_phi["arm"]
    # the arm's angle is g0 - s(theta) to 1e-12 of the swing; the joint's q the swing itself
    assert np.max(np.abs(sol.columns["q_J2"] - (g0 - s))) <= 1e-12 * lift
    assert np.max(np.abs(sol.columns["q_K"] - s)) <= 1e-12 * lift
    assert np.max(np.abs(sol.point("arm", "F") - F)) <= 1e-12 * lift * 0.09
    # the contact force: along the normal, of the arm's moment balance's magnitude
    force = np.stack((sol.columns["Fx_K"], sol.columns["Fy_K"]), -1)
    assert np.max(np.abs(force - f[:, None] * n)) <= 1e-9 * np.max(np.abs(f))
    assert np.min(f) > 0   # a case that pushes throughout, so the direction is tested
    # the camshaft's torque by power balance
    assert np.max(np.abs(sol.columns["tau_J1"] - tau)) <= 1e-9 * np.max(np.abs(tau))


def test_a_flat_face_rides_the_cam_and_takes_the_force_where_C5_puts_the_contact():
    model = still(flat_follower())
    jt = model.joint("K")
    t = np.linspace(0.0, 2 * math.pi / W, 37)[:-1] + 2e-4
    sol = linkdyn.analyze(model, t)
    s, s1, s2, _ = cam_of(jt).motion.svaj(np.mod(W * t, 2 * math.pi))
    rb, h = jt.numbers["base_radius"], jt.numbers["lift"]
    # the face (through F) at R_b + s, q the lift
    assert np.max(np.abs(sol.columns["q_J2"] - rb - s)) <= 1e-12 * h
    assert np.max(np.abs(sol.columns["q_K"] - s)) <= 1e-12 * h
    # the follower's y equation: F = m w^2 s'' + k (s + preload), normal to the face (no
    # pressure angle); C5: the contact at x = s' on the ground, the moment about F (x = e)
    # (s' - e) F; the camshaft's torque by power balance, tau w = F w s'
    spring, e = model.loads[0], model.body("ground").points["G"][0]
    f = model.body("follower").mass * W * W * s2 + spring.stiffness * (
        s + spring.free_length - (0.2 - rb))
    for name, want in (("Fy_K", f), ("M_K", (s1 - e) * f), ("tau_J1", s1 * f)):
        assert np.max(np.abs(sol.columns[name] - want)) <= 1e-9 * np.max(np.abs(want)), name
    assert np.max(np.abs(sol.columns["Fx_K"])) <= 1e-12 * np.max(f)


def test_an_oscillating_flat_face_swings_on_its_design_and_balances_the_arm():
    model = still(rocker_flat())
    jt = model.joint("K")
    x = jt.numbers
    t = np.linspace(0.0, 2 * math.pi / W, 37)[:-1] + 2e-4
    sol = linkdyn.analyze(model, t)
    s, s1, s2, _ = cam_of(jt).motion.svaj(np.mod(W * t, 2 * math.pi))
    # the face's normal at alpha = alpha0 - s, h = a cos(alpha) - f from C; the arm's frame
    # (its +y the normal) at alpha - pi/2
    a, off = x["pivot"], x["offset"]
    al = math.acos((x["base_radius"] + off) / a) - s
    assert np.max(np.abs(sol.columns["q_J2"] - (al - math.pi / 2))) <= 1e-12 * x["swing"]
    assert np.max(np.abs(sol.columns["q_K"] - s)) <= 1e-12 * x["swing"]
    # the envelope's point of tangency: H n + H_nu perp(n), H_nu = h_theta / nu_theta =
    # a sin(alpha) s' / (-s' - 1); the arm's moment balance about its pivot A gives the force
    n = np.stack((np.cos(al), np.sin(al)), -1)
    Hn = a * np.sin(al) * s1 / (-s1 - 1.0)
    X = (a * np.cos(al) - off)[:, None] * n + Hn[:, None] * np.stack((-n[:, 1], n[:, 0]), -1)
    arm, spring = model.body("arm"), model.loads[0]
    A, S = np.array([a, 0.0]), model.body("ground").points["S"]
    I_A = arm.inertia + arm.mass * np.sum(np.asarray(arm.com) ** 2)
    F = sol.point("arm", "F")
    r = F - S
    l = np.linalg.norm(r, axis=-1)
    tension = spring.stiffness * (l - spring.free_length)
    fs = -tension[:, None] * r / l[:, None]
    cross = lambda p, v: p[:, 0] * v[:, 1] - p[:, 1] * v[:, 0]
    gd, gdd = -W * s1, -W * W * s2
    f = (I_A * gdd - cross(F - A, fs)) / cross(X - A, n)
    force = np.stack((sol.columns["Fx_K"], sol.columns["Fy_K"]), -1)
    assert np.min(f) > 0 and np.max(np.abs(force - f[:, None] * n)) <= 1e-9 * np.max(f)
    assert np.max(np.abs(sol.columns["M_K"] - cross(X - F, force))) <= 1e-9 * np.max(f) * a
    # the camshaft's torque by power balance: tau W = I_A g' g'' + k (l - l0) l'
    ld = np.sum(r * np.stack((-F[:, 1] + A[1], F[:, 0] - A[0]), -1) * gd[:, None], -1) / l
    tau = (I_A * gd * gdd + tension * ld) / W
    assert np.max(np.abs(sol.columns["tau_J1"] - tau)) <= 1e-9 * np.max(np.abs(tau))


def test_the_summary_finds_where_the_follower_would_leave_the_cam():
    w = 1200 * RPM
    fast = still(cam_follower(w))
    t, s, s2, spring, m, c0 = follower_turn(fast, w, 72)
    sol = linkdyn.analyze(fast, t)
    need = m * w * w * s2 + spring.stiffness * (s + c0)
    c = contact(sol)["K"]
    # the samples where the closed form's force is below zero (none near zero here)
    assert np.min(np.abs(need)) > 1.0
    assert c["lost_samples"] == int(np.sum(need < 0)) > 0
    assert c["lost_from_s"] == t[need < 0][0] and c["lost_to_s"] == t[need < 0][-1]


def test_the_summary_gives_the_spring_that_keeps_the_follower_on_the_cam():
    # the translating follower's closed form: the contact force's vertical part is m w^2 s''
    # + k (s + c0) (c0 the spring's compression at s = 0), so the least added compression P
    # is max(-need) (the free length longer by P / k), and the least stiffness r k (same free
    # length) is k max(-m w^2 s'' / (k (s + c0))) over the lost samples
    w = 1200 * RPM
    fast = still(cam_follower(w))
    t, s, s2, spring, m, c0 = follower_turn(fast, w, 72)
    need = m * w * w * s2 + spring.stiffness * (s + c0)
    fix = contact(linkdyn.analyze(fast, t))["K"]["springs"]["loads[0]"]
    P = np.max(-need)
    assert P > 1.0
    assert fix["tension_change_N"] == pytest.approx(-P, rel=1e-9)
    assert fix["free_length_m"] == pytest.approx(spring.free_length + P / spring.stiffness,
                                                 rel=1e-9)
    lost = need < 0
    r = np.max(-m * w * w * s2[lost] / (spring.stiffness * (s[lost] + c0)))
    assert fix["stiffness_N_m"] == pytest.approx(r * spring.stiffness, rel=1e-9)


def test_the_spring_the_summary_gives_keeps_an_oscillating_face_on_the_cam():
    # no closed form here: the arm run again with each fix loses no sample, and its least
    # contact force is zero (the fix is the least one, exact at the worst sample)
    w = 900 * RPM
    fast = rocker_flat(w)
    t = np.linspace(0.0, 2 * math.pi / w, 49)[:-1]
    sol = linkdyn.analyze(fast, t)
    c = contact(sol)["K"]
    assert c["lost_samples"] > 0
    (label, fix), = c["springs"].items()
    k = [i for i, x in enumerate(fast.loads) if x.kind == "spring"][0]
    scale = np.max(np.abs(sol.reactions.force[:, [j.name for j in fast.joints].index("K")]))
    for change in ({"free_length": fix["free_length_m"]}, {"stiffness": fix["stiffness_N_m"]}):
        loads = tuple(dataclasses.replace(x, **change) if i == k else x
                      for i, x in enumerate(fast.loads))
        again = contact(linkdyn.analyze(dataclasses.replace(fast, loads=loads), t))["K"]
        assert again["min_force_N"] == pytest.approx(0.0, abs=1e-9 * scale), change
        # lost nowhere: where the fix is exact the force is zero to rounding, either sign, and
        # the summary counts a loss only beyond rounding
        assert again["lost_samples"] == 0, change


def test_the_jump_speed_is_the_translating_followers_closed_form():
    # without damper and gravity the force's vertical part is m w^2 s'' + k (s + c0): it first
    # reaches zero at w^2 = min k (s + c0) / (-m s'') over the samples where s'' < 0
    w = 300 * RPM
    model = still(cam_follower(w))
    t, s, s2, spring, m, c0 = follower_turn(model, w, 72)
    falling = s2 < 0
    ratio = np.full_like(s, np.inf)
    ratio[falling] = spring.stiffness * (s[falling] + c0) / (-m * s2[falling])
    c = contact(linkdyn.analyze(model, t))["K"]
    assert c["lost_samples"] == 0
    assert c["jump_speed_rad_s"] == pytest.approx(math.sqrt(np.min(ratio)), rel=1e-9)
    assert c["jump_time_s"] == t[np.argmin(ratio)]


def test_at_the_jump_speed_the_least_contact_force_is_zero():
    # with gravity and a damper (the force then A + B w + C w^2): run again at the speed
    # found, the least contact force is zero; 1 % slower no sample is lost, 1 % faster some are
    from linkdyn.design.overview import contact_forces

    model = cam_follower(300 * RPM)
    t = np.linspace(0.0, 2 * math.pi / W, 37)[:-1]
    sol = linkdyn.analyze(model, t)
    c = contact(sol)["K"]
    scale = np.max(np.abs(contact_forces(sol, sol.dyn, sol.reactions)["K"]))
    least = []
    for r in (0.99, 1.0, 1.01):
        wj = r * c["jump_speed_rad_s"]
        fast = dataclasses.replace(model, drivers=(
            dataclasses.replace(model.drivers[0], motion=ConstantSpeed(wj)),))
        run = linkdyn.analyze(fast, t * W / wj)
        least.append(np.min(contact_forces(run, run.dyn, run.reactions)["K"]))
    assert least[0] > 0 > least[2]
    assert least[1] == pytest.approx(0.0, abs=1e-9 * scale)


def test_no_jump_speed_when_a_load_depends_on_time():
    # a force along the guide that varies in time does not scale with the cam's speed: no
    # speed is claimed (a constant one keeps it)
    from linkdyn.model import Load

    def push(amplitude):
        return Load("force", "follower", "F", value=lambda t: np.stack(np.broadcast_arrays(
            0.0, -5.0 * (1.0 + amplitude * np.sin(40.0 * np.asarray(t)))), -1))

    model = cam_follower(300 * RPM)
    t = np.linspace(0.0, 2 * math.pi / W, 25)[:-1]
    steady = dataclasses.replace(model, loads=model.loads + (push(0.0),))
    assert contact(linkdyn.analyze(steady, t))["K"]["jump_speed_rad_s"] > 0
    pulsed = dataclasses.replace(model, loads=model.loads + (push(0.5),))
    assert "jump_speed_rad_s" not in contact(linkdyn.analyze(pulsed, t))["K"]


def test_simulate_finds_the_jump_speed_of_a_follower_speeding_up():
    # the translating follower and its spring (no gravity, no damper) on a free camshaft with a
    # large flywheel, sped up by a constant torque, 0.1 % of the speed a turn, from one turn's
    # gain below the closed-form jump speed w_j^2 = min k (s + c0) / (-m s''): the cam passes
    # the angle of the least ratio below w_j in its first turn, above it in the second; the
    # run's contact force first crosses zero at the cam's speed w_j, to within the speed
    # gained over two turns, and at the cam angle simulate names the closed form's ratio is
    # that speed squared
    from linkdyn.forward import simulate
    from linkdyn.model import Load

    model = still(cam_follower())
    theta = np.linspace(0.0, 2 * math.pi, 36001)
    _, d0, s, s1, s2, _ = design(model, theta)
    spring, m = model.loads[0], model.body("follower").mass
    c0 = spring.free_length - (0.2 - d0)

    def ratio(s, s2):   # k (s + c0) / (-m s''), the speed squared where the force is zero
        return np.where(s2 < 0, spring.stiffness * (s + c0) / (-m * np.minimum(s2, -1e-300)),
                        np.inf)

    wj = math.sqrt(np.min(ratio(s, s2)))
    inertia, gain = 1.0, 1e-3               # kg m^2; the speed's gain over a turn
    torque = gain * wj * wj * inertia / (2 * math.pi)
    free = dataclasses.replace(
        model, drivers=(), initial_q={"J1": 0.0}, initial_qd={"J1": (1 - gain) * wj},
        bodies=tuple(dataclasses.replace(b, inertia=inertia) if b.name == "cam" else b
                     for b in model.bodies),
        loads=model.loads + (Load("torque", "cam", value=lambda t: np.full(np.shape(t),
                                                                           torque)),))
    t = np.linspace(0.0, 3 * 2 * math.pi / wj, 361)
    c = contact(simulate(free, t, backend="numpy"))["K"]
    leave = c["leaves"]
    assert "jump_speed_rad_s" not in c and "springs" not in c    # no prescribed speed
    # in the first turn past w_j, or the next if its dip below zero, a few degrees wide, falls
    # between two of the samples (3 deg apart)
    assert wj <= leave["cam_speed_rad_s"] <= (1 + 2 * gain) * wj
    # the cam angle where it goes: next to the closed form's least ratio, and the ratio there
    # is the speed squared (to the angle interpolated between samples 3 deg apart, and the
    # camshaft's own acceleration, a term s' alpha / (s'' w^2) of 2e-4 here)
    least = theta[np.argmin(ratio(s, s2))]
    assert abs(leave["cam_angle_rad"] - least) <= math.radians(2.0)
    _, _, s, s1, s2, _ = design(model, np.array([leave["cam_angle_rad"]]))
    assert ratio(s, s2)[0] == pytest.approx(leave["cam_speed_rad_s"] ** 2, rel=3e-3)
    assert c["lost_samples"] > 0 and leave["time_s"] <= c["lost_from_s"]


@pytest.mark.parametrize("build", [cam_follower, rocker_cam, flat_follower, rocker_flat])
def test_the_joint_coordinate_has_the_rates_of_its_finite_differences(build):
    model = build()
    h = 1e-4
    centres = np.array([0.013, 0.031, 0.12, 0.16])
    t = (centres[:, None] + np.arange(-2, 3) * h).reshape(-1)
    sol = linkdyn.analyze(model, t)
    q, qd, qdd = (np.asarray(sol.columns[f"{x}_K"]).reshape(-1, 5) for x in ("q", "qd", "qdd"))
    five = lambda f: (f[:, 0] - 8 * f[:, 1] + 8 * f[:, 3] - f[:, 4]) / (12 * h)
    assert np.max(np.abs(five(q) - qd[:, 2])) <= 1e-7 * np.max(np.abs(qd))
    assert np.max(np.abs(five(qd) - qdd[:, 2])) <= 1e-6 * np.max(np.abs(qdd))


def test_both_backends_run_the_cam_follower():
    pytest.importorskip("numba", reason="the compiled backend needs numba (the fast extra)")
    model = cam_follower()
    t = np.linspace(0.0, 2 * math.pi / W, 13)
    a = linkdyn.analyze(model, t, backend="numpy")
    b = linkdyn.analyze(model, t, backend="compiled")
    for name in ("tau_J1", "Fx_K", "Fy_K", "q_K", "qd_K", "qdd_K", "q_J2", "Fx_J1", "M_J2"):
        x, y = np.asarray(a.columns[name]), np.asarray(b.columns[name])
        assert np.max(np.abs(x - y)) <= 1e-11 * max(np.max(np.abs(x)), 1e-3), name


def test_the_bundled_example_reads_writes_and_reports_its_contact(tmp_path):
    path = linkdyn.example_path("cam_follower")
    model = linkdyn.load(path)
    jt = model.joint("K")
    assert (jt.numbers["lift"], jt.numbers["rise"]) == pytest.approx((0.02, math.radians(90)))
    # written back with its law by name, and read again the same
    out = tmp_path / "cam.toml"
    linkdyn.save(model, out)
    assert 'law = "cycloidal"' in out.read_text("utf-8")
    assert linkdyn.load(out).joint("K").numbers == pytest.approx(jt.numbers)
    res = CliRunner().invoke(main, ["analyze", str(path), "--samples", "37", "-o",
                                    str(tmp_path / "run")])
    assert res.exit_code == 0, res.output
    assert "contact K: least force" in res.output and "never lost" in res.output
    # at 1000 rpm the follower leaves the cam, and the summary says which spring holds it
    fast = tmp_path / "fast.toml"
    fast.write_text(path.read_text("utf-8").replace("rpm = 300.0", "rpm = 1000.0"), "utf-8")
    res = CliRunner().invoke(main, ["analyze", str(fast), "--samples", "37", "-o",
                                    str(tmp_path / "fast")])
    assert res.exit_code == 0, res.output
    assert "LOSS OF CONTACT" in res.output
    assert "loads.spring keeps it on at this speed with free length" in res.output


@pytest.mark.parametrize("edits, words", [
    ({'law = "cycloidal"': 'law = "dwell"'}, "not dwell"),
    ({"lift = 20.0": "lift = 0.0"}, "lift must be positive"),
    ({"fall = 90.0": "fall = 200.0"}, "at most one turn"),
    ({'law = "cycloidal"': 'law = "cycloid"'}, "Did you mean"),
    # linkdyn cam's own checks: a pitch curve bending tighter than the roller (C4), and one
    # whose polar angle falls too unevenly for the contact's Newton iterations
    ({"base_radius = 40.0": "base_radius = 3.0", "roller_radius = 10.0": "roller_radius = 15.0"},
     "undercut"),
    ({"offset = 5.0": "offset = 45.0", "lift = 20.0": "lift = 100.0", "rise = 90.0": "rise = 30.0"},
     "polar angle")])
def test_a_cam_that_makes_no_cam_is_refused(tmp_path, edits, words):
    text = linkdyn.example_path("cam_follower").read_text("utf-8")
    for old, new in edits.items():
        assert old in text
        text = text.replace(old, new)
    path = tmp_path / "bad.toml"
    path.write_text(text, "utf-8")
    res = CliRunner().invoke(main, ["check", str(path)])
    assert res.exit_code == 2 and "joints" in res.output and words in res.output, res.output
    assert "Traceback" not in res.output


def test_a_sweep_of_the_base_circle_ranks_the_least_contact_force():
    # the bundled follower (spring, gravity): its contact force is (m (w^2 s'' + g) + k (s +
    # c0)) / cos(pressure angle), c0 = l0 - (200 mm - d0) the spring's compression at s = 0,
    # d0 = sqrt((R_b + R_f)^2 - e^2) growing with the base circle; min_contact_K is its least
    from linkdyn import studies

    path = linkdyn.example_path("cam_follower")
    model = linkdyn.load(path)
    t = np.linspace(0.0, 2 * math.pi / W, 25)[:-1]
    radii = [40.0, 50.0, 60.0]
    df = studies.sweep(path, {"joints.K.base_radius": radii}, t, ["min_contact_K"])
    theta = math.radians(7.5) + W * t
    spring, m = model.loads[0], model.body("follower").mass
    cam = cam_of(model.joint("K"))
    s, s1, s2, _ = cam.motion.svaj(np.mod(theta, 2 * math.pi))
    expected = []
    for rb in radii:
        d0 = math.sqrt((rb * MM + cam.roller_radius) ** 2 - cam.offset ** 2)
        c0 = spring.free_length - (0.2 - d0)
        ny = m * (W * W * s2 + 9.81) + spring.stiffness * (s + c0)
        expected.append(np.min(ny / np.cos(np.arctan2(s1 - cam.offset, d0 + s))))
    assert df["min_contact_K"].to_numpy() == pytest.approx(expected, rel=1e-9)
    assert studies.metrics.sense("min_contact_K") == "max"


def test_the_compiled_continuation_follows_numpys_nodes():
    # a cam's loop is no dyad: the branch is followed by Newton's method node by node, on the
    # compiled backend by compiled_nodes.follow (the kinematics kernel's Newton): numpy's
    # nodes, reach, coordinates and rates to rounding
    pytest.importorskip("numba", reason="the compiled continuation needs numba (the fast extra)")
    from linkdyn.kinematics import compile_layout, compiled_nodes
    from linkdyn.kinematics.positions import follow
    model = linkdyn.load(linkdyn.example_path("cam_fourbar"))
    lay = compile_layout(model)
    t = np.linspace(-0.05, 0.25, 7)
    ref = follow([model], lay, t)
    got = follow([model], lay, t, newton_nodes=compiled_nodes.follow)
    assert np.array_equal(got.nodes, ref.nodes) and np.array_equal(got.reach, ref.reach)
    for a, b in ((got.Q, ref.Q), (got.QD, ref.QD)):
        assert np.all(np.isfinite(b)) and a.shape == b.shape
        assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(b))
    # its node accelerations (for the samples' quintic guesses) are numpy's kinematics' there
    assert ref.QDD is None and got.QDD.shape == got.Q.shape
    kin = linkdyn.kinematics.solve(model, got.nodes, backend="numpy")
    topo = lay.topo
    qdd = np.array([kin.joint_motion[2][topo.tree_joint[i]] for i in range(1, topo.n)])
    assert np.max(np.abs(got.QDD[1:] - qdd)) <= 1e-9 * np.max(np.abs(qdd))


@pytest.mark.parametrize("name", ["cam_fourbar", "cam_flat_rocker"])
def test_the_contact_found_from_the_last_samples_or_from_rest_is_numpys(name):
    # the compiled backend starts each sample's contact search (the kind's locate) from the
    # contact of the sample before, kept when the pitch point's polar angle misses by little;
    # with the samples scrambled they lie far apart and the search starts from s = 0. Either
    # way the contacts, and all that reads them, are numpy's (always from s = 0) to rounding
    pytest.importorskip("numba", reason="the compiled backend needs numba (the fast extra)")
    model = linkdyn.load(linkdyn.example_path(name))
    t = np.linspace(0.0, 2 * math.pi / model.drivers[0].motion.speed, 1201)
    scrambled = np.random.default_rng(26).permutation(t)
    back = np.argsort(scrambled)
    a = linkdyn.analyze(model, t, backend="numpy")
    b = linkdyn.analyze(model, t, backend="compiled")
    c = linkdyn.analyze(model, scrambled, backend="compiled")
    names = [k for k in a.columns if k.split("_")[0] in ("q", "qdd", "Fx", "Fy", "tau")]
    assert "q_K" in names and "Fx_K" in names
    for k in names:
        x = np.asarray(a.columns[k])
        big = max(np.max(np.abs(x)), 1e-3)
        for y in (np.asarray(b.columns[k]), np.asarray(c.columns[k])[back]):
            assert np.max(np.abs(x - y)) <= 1e-10 * big, k


def test_the_compiled_newton_closes_the_samples_as_numpys():
    # the samples of a mechanism whose loops are not all dyads, closed on the compiled backend
    # by the kinematics kernel's Newton in its blocks (compiled.run with newton=True): numpy's
    # state.close's coordinates to rounding; a sample from a guess too far for Newton's method
    # is left open (above ACCEPT) for numpy's damped restart, which analyze then runs on it
    # alone
    pytest.importorskip("numba", reason="the compiled Newton needs numba (the fast extra)")
    from linkdyn.kinematics import compile_layout, compiled_nodes
    from linkdyn.kinematics import compiled as kc
    from linkdyn.kinematics.positions import ACCEPT, follow
    from linkdyn.kinematics.state import close
    model = linkdyn.load(linkdyn.example_path("cam_fourbar"))
    lay = compile_layout(model)
    t = np.linspace(0.0, 0.2, 201)
    q_ind, qd_ind, qdd_ind = lay.driver_values(t)
    branch = follow([model], lay, t, newton_nodes=compiled_nodes.follow)
    guess = branch.guess(lay, t)
    ref, ref_err, _ = close(lay, q_ind, guess, branch.modes)

    def closed(start):
        out = kc.run(lay, t, q_ind, qd_ind, qdd_ind, q=start, newton=True)
        return out["q"].reshape(start.shape), out["err"].reshape(t.shape)
    got, err = closed(guess)
    assert np.all(ref_err <= ACCEPT) and np.all(err <= ACCEPT)
    assert np.max(np.abs(got - ref)) <= 1e-12 * np.max(np.abs(ref))
    far = guess.copy()
    far[list(lay.topo.dependent), 7] += 2.5    # rad: no nearby guess
    _, err = closed(far)
    assert not err[7] <= ACCEPT and np.all(np.delete(err, 7) <= ACCEPT)
    sol = linkdyn.analyze(model, t, backend="compiled")
    assert np.all(sol.valid)
