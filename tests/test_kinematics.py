"""Kinematics: the general recursive solver against closed forms, finite differences, loop
closure, branch continuity and batching.

Tolerances are relative to the peak of each quantity over the run (or to the mechanism's size
for positions), never absolute numbers picked to make a test pass.
"""

from __future__ import annotations

import dataclasses
import math
import tomllib

import numpy as np
import pytest

import linkdyn
from linkdyn import kinematics
from linkdyn.cli import example_names, example_text
from linkdyn.io import model_from_dict
from linkdyn.model import REVOLUTE

MM, DEG = 1e-3, math.pi / 180
EXAMPLES = example_names()


def load(name):
    return linkdyn.load(linkdyn.example_path(name))


def period(mech) -> float:
    """Duration of one cycle as the CLI computes it: [analysis] duration, or cycles x the first
    constant-speed driver's period."""
    if mech.duration:
        return mech.duration
    return (mech.cycles or 1.0) * next(d.period for d in mech.drivers if d.period)


def size(mech) -> float:
    """Characteristic length of the mechanism: extent of all its points, m."""
    pts = np.array([p for b in mech.bodies for p in b.points.values()])
    return float(np.max(np.ptp(pts, axis=0)))


def wrap(x):
    return (np.asarray(x) + np.pi) % (2 * np.pi) - np.pi


def body_index(kin, body):
    return kin.layout.topo.bodies.index(body)


def phi(kin, body):
    return kin.phi[..., body_index(kin, body)]


def omega(kin, body):
    return kin.tw[..., body_index(kin, body), 0]


def alpha(kin, body):
    return kin.twd[..., body_index(kin, body), 0]


def point_acceleration(kin, body, name):
    """a_P = a_O + alpha perp(r_P - r_O) - omega^2 (r_P - r_O), from the solver's twists."""
    i = body_index(kin, body)
    d = kin.point(body, name) - kin.r[..., i, :]
    perp_d = np.stack((-d[..., 1], d[..., 0]), axis=-1)
    return (kin.twd[..., i, 1:] + kin.twd[..., i, :1] * perp_d
            - kin.tw[..., i, :1] ** 2 * d)


def assert_rel(actual, expected, rtol, what, floor=0.0):
    """max |actual - expected| <= rtol * max(peak |expected|, floor)."""
    actual, expected = np.asarray(actual), np.asarray(expected)
    assert actual.shape == expected.shape, what
    scale = max(float(np.max(np.abs(expected))), floor)
    err = float(np.max(np.abs(actual - expected)))
    assert err <= rtol * scale, f"{what}: error {err:.3e} > {rtol:g} x peak {scale:.3e}"
    return err / scale if scale else 0.0


# ------------------------------------------------------------------------------------------
# closed-form four-bar (Hoeken, seed paper Table 1)

# ground O1-O4, crank O1-O2, coupler O2-O3, rocker O3-O4 (mm); crank at 45 rpm
HOEKEN_A, HOEKEN_B, HOEKEN_C, HOEKEN_D = 38.1 * MM, 115.2 * MM, 115.2 * MM, 89.5 * MM
HOEKEN_P = 230.4 * MM                      # coupler point P on the line O2-O3, from O2
HOEKEN_W = 45.0 * 2 * math.pi / 60         # rad/s


def four_bar_closed_form(th1, w1, al1, a, b, c, d, branch=+1):
    """Textbook four-bar: ground pivots O1 = 0 and O4 = d (on +X), crank a at th1, coupler b
    from the crank pin A to B, rocker c from B to O4 (the rocker's angle th3 is that of B -> O4,
    as the rocker's frame is in the model).

    Position: B is the intersection of the circles (A, b) and (O4, c); ``branch = +1`` puts B to
    the left of A -> O4. Velocity and acceleration: derivatives of the loop equation
    a e^{i th1} + b e^{i th2} + c e^{i th3} = d, solved for the two unknown rates.
    """
    A = a * np.exp(1j * th1)
    D = d - A
    L = np.abs(D)
    u = D / L
    x = (L**2 + b**2 - c**2) / (2 * L)
    h = np.sqrt(b**2 - x**2)
    B = A + (x + 1j * branch * h) * u
    th2 = np.unwrap(np.angle(B - A))
    th3 = np.unwrap(np.angle(d - B))
    s23 = np.sin(th2 - th3)
    # i a w1 e^{i th1} + i b w2 e^{i th2} + i c w3 e^{i th3} = 0, times e^{-i th3} and e^{-i th2}
    w2 = -a * w1 * np.sin(th1 - th3) / (b * s23)
    w3 = a * w1 * np.sin(th1 - th2) / (c * s23)
    # sum (i al_k - w_k^2) L_k e^{i th_k} = 0:  i (al2 b e2 + al3 c e3) = S
    S = (a * w1**2 * np.exp(1j * th1) + b * w2**2 * np.exp(1j * th2) + c * w3**2 * np.exp(1j * th3)
         - 1j * al1 * a * np.exp(1j * th1))
    al2 = -np.real(S * np.exp(-1j * th3)) / (b * s23)
    al3 = np.real(S * np.exp(-1j * th2)) / (c * s23)
    return dict(th2=th2, th3=th3, w2=w2, w3=w3, al2=al2, al3=al3, A=A, B=B)


def xy(z):
    return np.stack((np.real(z), np.imag(z)), axis=-1)


def test_hoeken_model_is_table_1():
    mech = load("hoeken")
    pts = {b.name: b.points for b in mech.bodies}
    np.testing.assert_allclose(pts["ground"]["O4"], [HOEKEN_D, 0], atol=1e-15)
    np.testing.assert_allclose(pts["crank"]["O2"] - pts["crank"]["O1"], [HOEKEN_A, 0], atol=1e-15)
    np.testing.assert_allclose(pts["coupler"]["O3"] - pts["coupler"]["O2"], [HOEKEN_B, 0],
                               atol=1e-15)
    np.testing.assert_allclose(pts["coupler"]["P"] - pts["coupler"]["O2"], [HOEKEN_P, 0],
                               atol=1e-15)
    np.testing.assert_allclose(pts["rocker"]["O4"] - pts["rocker"]["O3"], [HOEKEN_C, 0],
                               atol=1e-15)
    q, qd, qdd = mech.drivers[0].motion.evaluate(np.array([0.0, 1.0]))
    np.testing.assert_allclose(qd, HOEKEN_W, rtol=1e-12)
    np.testing.assert_allclose(qdd, 0.0, atol=0)


def _check_hoeken_against_closed_form(kin, t, branch):
    th1 = HOEKEN_W * t
    cf = four_bar_closed_form(th1, HOEKEN_W, 0.0, HOEKEN_A, HOEKEN_B, HOEKEN_C, HOEKEN_D, branch)
    rtol = 1e-9
    # absolute body angles, rates, accelerations
    assert_rel(phi(kin, "crank"), th1, rtol, "phi_crank")
    assert_rel(phi(kin, "coupler"), cf["th2"], rtol, "phi_coupler")
    assert_rel(phi(kin, "rocker"), cf["th3"], rtol, "phi_rocker")
    assert_rel(omega(kin, "crank"), np.full_like(t, HOEKEN_W), rtol, "omega_crank")
    assert_rel(omega(kin, "coupler"), cf["w2"], rtol, "omega_coupler")
    assert_rel(omega(kin, "rocker"), cf["w3"], rtol, "omega_rocker")
    assert_rel(alpha(kin, "crank"), np.zeros_like(t), rtol, "alpha_crank", floor=1.0)
    assert_rel(alpha(kin, "coupler"), cf["al2"], rtol, "alpha_coupler")
    assert_rel(alpha(kin, "rocker"), cf["al3"], rtol, "alpha_rocker")
    # joint coordinates (model joint order J1..J4): q = phi_second - phi_first
    q_cf = np.stack((th1, cf["th2"] - th1, cf["th3"] - cf["th2"], cf["th3"]), -1)
    qd_cf = np.stack((np.full_like(t, HOEKEN_W), cf["w2"] - HOEKEN_W, cf["w3"] - cf["w2"],
                      cf["w3"]), -1)
    qdd_cf = np.stack((0 * t, cf["al2"], cf["al3"] - cf["al2"], cf["al3"]), -1)
    for k in range(4):
        assert_rel(kin.q[:, k], q_cf[:, k], rtol, f"q_J{k + 1}")
        assert_rel(kin.qd[:, k], qd_cf[:, k], rtol, f"qd_J{k + 1}")
        assert_rel(kin.qdd[:, k], qdd_cf[:, k], rtol, f"qdd_J{k + 1}", floor=1.0)
    # pins and the coupler point
    P = cf["A"] + HOEKEN_P * np.exp(1j * cf["th2"])
    assert_rel(kin.point("crank", "O2"), xy(cf["A"]), rtol, "crank.O2")
    assert_rel(kin.point("coupler", "O3"), xy(cf["B"]), rtol, "coupler.O3")
    assert_rel(kin.point("rocker", "O3"), xy(cf["B"]), rtol, "rocker.O3")
    assert_rel(kin.point("coupler", "P"), xy(P), rtol, "coupler.P")


def newton_layout(mech):
    """The mechanism's layout with the closed-form dyad plan removed, so positions come from the
    general Newton continuation."""
    lay = kinematics.compile_layout(mech)
    assert lay.dyads is not None, "the default solve must be the closed form for this test"
    return dataclasses.replace(lay, dyads=None)


@pytest.mark.parametrize("path", ["default", "newton"])
def test_hoeken_matches_closed_form_four_bar_over_a_full_turn(path):
    mech = load("hoeken")
    t = np.linspace(0.0, period(mech), 181)
    assert period(mech) == pytest.approx(60 / 45, rel=1e-12)
    lay = newton_layout(mech) if path == "newton" else None
    kin = kinematics.solve(mech, t, layout=lay)
    assert kin.valid.all()
    _check_hoeken_against_closed_form(kin, t, branch=+1)


def test_hoeken_closed_form_is_nontrivial():
    # guard against a closed form that is accidentally identically satisfied: the coupler and
    # rocker really move, and their accelerations change sign over the turn
    t = np.linspace(0.0, 4 / 3, 181)
    cf = four_bar_closed_form(HOEKEN_W * t, HOEKEN_W, 0.0, HOEKEN_A, HOEKEN_B, HOEKEN_C,
                              HOEKEN_D)
    assert np.ptp(cf["th3"]) > 0.5 and np.ptp(cf["w2"]) > 1.0
    assert cf["al2"].min() < 0 < cf["al2"].max()
    # the closed form's own rates agree with a finite difference of its angles
    h = 1e-6
    cfp = four_bar_closed_form(HOEKEN_W * (t + h), HOEKEN_W, 0.0, HOEKEN_A, HOEKEN_B, HOEKEN_C,
                               HOEKEN_D)
    cfm = four_bar_closed_form(HOEKEN_W * (t - h), HOEKEN_W, 0.0, HOEKEN_A, HOEKEN_B, HOEKEN_C,
                               HOEKEN_D)
    assert_rel((cfp["th3"] - cfm["th3"]) / (2 * h), cf["w3"], 1e-6, "closed-form w3")
    assert_rel((cfp["w2"] - cfm["w2"]) / (2 * h), cf["al2"], 1e-6, "closed-form al2")


# ------------------------------------------------------------------------------------------
# closed-form offset slider-crank

SC_R, SC_L, SC_E = 50.0 * MM, 180.0 * MM, 20.0 * MM   # crank, rod, slide line above the crank axis
SC_W = 300.0 * 2 * math.pi / 60


def slider_crank_closed_form(th, w, al, r, l, e):
    """Wrist pin B = (x, e) with |B - A| = l, A = r (cos th, sin th), x on the far side:
    x = r cos th + s, s = sqrt(l^2 - u^2), u = e - r sin th; rod angle atan2(u, s)."""
    u = e - r * np.sin(th)
    ud = -r * w * np.cos(th)
    udd = -r * (al * np.cos(th) - w**2 * np.sin(th))
    s = np.sqrt(l**2 - u**2)
    sd = -u * ud / s
    sdd = -(ud**2 + u * udd) / s - (u * ud) ** 2 / s**3
    x = r * np.cos(th) + s
    xd = -r * w * np.sin(th) + sd
    xdd = -r * al * np.sin(th) - r * w**2 * np.cos(th) + sdd
    psi = np.arctan2(u, s)
    psid = (s * ud - u * sd) / l**2
    psidd = (s * udd - u * sdd) / l**2 - 2 * psid * (u * ud + s * sd) / l**2
    return dict(x=x, xd=xd, xdd=xdd, psi=psi, psid=psid, psidd=psidd)


def test_slider_crank_matches_closed_form():
    mech = load("slider_crank")
    t = np.linspace(0.0, period(mech), 121)
    kin = kinematics.solve(mech, t)
    assert kin.valid.all()
    cf = slider_crank_closed_form(SC_W * t, SC_W, 0.0, SC_R, SC_L, SC_E)
    j4 = [j.name for j in mech.joints].index("J4")
    rtol = 1e-9
    # q_J4: wrist pin B from the ground point G = (0, e) along the slide axis +X
    assert_rel(kin.q[:, j4], cf["x"], rtol, "q_J4")
    assert_rel(kin.qd[:, j4], cf["xd"], rtol, "qd_J4")
    assert_rel(kin.qdd[:, j4], cf["xdd"], rtol, "qdd_J4")
    assert_rel(kin.point("slider", "B"), np.stack((cf["x"], np.full_like(t, SC_E)), -1),
               rtol, "slider.B")
    assert_rel(phi(kin, "rod"), cf["psi"], rtol, "phi_rod")
    assert_rel(omega(kin, "rod"), cf["psid"], rtol, "omega_rod")
    assert_rel(alpha(kin, "rod"), cf["psidd"], rtol, "alpha_rod")
    # the slider translates: no rotation at all
    size_rate = SC_W
    assert_rel(phi(kin, "slider"), np.zeros_like(t), rtol, "phi_slider", floor=1.0)
    assert_rel(omega(kin, "slider"), np.zeros_like(t), rtol, "omega_slider", floor=size_rate)
    assert_rel(alpha(kin, "slider"), np.zeros_like(t), rtol, "alpha_slider",
               floor=size_rate**2)
    # stroke of an offset slider-crank: sqrt((l + r)^2 - e^2) - sqrt((l - r)^2 - e^2)
    stroke = math.sqrt((SC_L + SC_R) ** 2 - SC_E**2) - math.sqrt((SC_L - SC_R) ** 2 - SC_E**2)
    fine = kinematics.solve(mech, np.linspace(0.0, period(mech), 2001)).q[:, j4]
    assert np.ptp(fine) == pytest.approx(stroke, rel=1e-6)


# ------------------------------------------------------------------------------------------
# velocities and accelerations against finite differences of positions

H = 1e-3                     # s
# a shorter step for the cams whose motion law bends faster than the others' (the stencil's
# truncation error (h w)^4 s^(5) / 30 grows as the rise's span to the -4th: ~2e-6 of the peak
# rate at 1e-3 s for a 105 deg rise at 300 rpm); their segment ends sit between stencils
STEP = {"cam_fourbar": 5e-4, "cam_flat_rocker": 5e-4}
STENCIL = np.arange(-2, 3)   # 5-point stencils, O(h^4)
N_BASE = 25


def _fd(x, H=H):
    """First and second derivatives at the stencil centres; x is (N_BASE * 5, ...), sampled
    at the step ``H`` (s)."""
    x = x.reshape((N_BASE, 5) + x.shape[1:])
    d1 = (x[:, 0] - 8 * x[:, 1] + 8 * x[:, 3] - x[:, 4]) / (12 * H)
    d2 = (-x[:, 0] + 16 * x[:, 1] - 30 * x[:, 2] + 16 * x[:, 3] - x[:, 4]) / (12 * H**2)
    return d1, d2


def _centre(x):
    return x.reshape((N_BASE, 5) + x.shape[1:])[:, 2]


@pytest.mark.parametrize("name", EXAMPLES)
def test_rates_match_finite_differences(name):
    mech = load(name)
    T = period(mech)
    h = STEP.get(name, H)
    t = (np.linspace(0.0, T, N_BASE)[:, None] + h * STENCIL).ravel()
    kin = kinematics.solve(mech, t)
    assert kin.valid.all()
    rv, ra = 1e-6, 1e-5           # measured worst: ~1e-7 (velocity), ~1e-7 (acceleration)
    # characteristic rates of this mechanism, for quantities that are identically zero
    w_ref = float(np.max(np.abs(kin.tw[..., 0])))
    L = size(mech)
    n_checked = 0
    for k, j in enumerate(mech.joints):
        d1, d2 = _fd(kin.q[:, k], h)
        unit = 1.0 if j.kind == REVOLUTE else L
        assert_rel(d1, _centre(kin.qd[:, k]), rv, f"qd_{j.name}", floor=unit * w_ref)
        assert_rel(d2, _centre(kin.qdd[:, k]), ra, f"qdd_{j.name}", floor=unit * w_ref**2)
        n_checked += 1
    for b in mech.moving_bodies:
        d1, d2 = _fd(phi(kin, b.name), h)
        assert_rel(d1, _centre(omega(kin, b.name)), rv, f"omega_{b.name}", floor=w_ref)
        assert_rel(d2, _centre(alpha(kin, b.name)), ra, f"alpha_{b.name}", floor=w_ref**2)
        for p in b.points:
            d1, d2 = _fd(kin.point(b.name, p), h)
            assert_rel(d1, _centre(kin.point_velocity(b.name, p)), rv, f"v_{b.name}.{p}",
                       floor=L * w_ref)
            acc = kin.point_acceleration(b.name, p)
            assert_rel(d2, _centre(acc), ra, f"a_{b.name}.{p}", floor=L * w_ref**2)
            assert_rel(acc, point_acceleration(kin, b.name, p), 1e-12, f"a_{b.name}.{p} formula",
                       floor=L * w_ref**2)
            n_checked += 1
    assert n_checked >= len(mech.joints) + len(mech.moving_bodies)


# ------------------------------------------------------------------------------------------
# loop closure

@pytest.mark.parametrize("name", EXAMPLES)
def test_loop_closure_residual_and_joint_geometry(name):
    mech = load(name)
    t = np.linspace(0.0, period(mech), 73)
    kin = kinematics.solve(mech, t)
    assert kin.valid.all()
    assert kin.residual.shape == t.shape
    assert np.max(kin.residual) <= 1e-10
    L = size(mech)
    cut = {mech.joints[j].name for j in kin.layout.topo.cut}
    assert cut, "every example has at least one loop"
    for k, j in enumerate(mech.joints):
        pa, pb = kin.point(j.body_a, j.point_a), kin.point(j.body_b, j.point_b)
        fa, fb = phi(kin, j.body_a), phi(kin, j.body_b)
        if j.kind == REVOLUTE:
            # the two pins coincide, and q is the relative angle (not wrapped)
            assert np.max(np.linalg.norm(pb - pa, axis=-1)) <= 1e-10 * L, j.name
            np.testing.assert_allclose(kin.q[:, k], fb - fa, rtol=0, atol=1e-12)
        elif j.kind == "gear":
            # the centres at the pitch distance, and the pitch circles roll on each other: the
            # arcs rolled relative to the line of centres are equal (opposite for internal)
            sgn = -1.0 if j.internal else 1.0
            d = pb - pa
            alpha = np.arctan2(d[:, 1], d[:, 0])
            assert np.max(np.abs(np.linalg.norm(d, axis=-1) - abs(j.radius_a + sgn * j.radius_b))
                          ) <= 1e-10 * L, j.name
            roll = j.radius_a * (fa - alpha) + sgn * j.radius_b * (fb - alpha - j.phase)
            assert np.max(np.abs(roll)) <= 1e-10 * L, j.name
            np.testing.assert_allclose(kin.q[:, k], j.radius_a * (fa - alpha), rtol=0,
                                       atol=1e-12 * L)
        elif j.kind in ("cam", "rocker_cam"):
            # the follower's point on the pitch curve linkdyn cam draws (C1): at its polar angle
            # in the cam's frame, the pitch point's radius; q the lift there
            from test_dynamics import cam_contact, cam_of, cam_polar, follower_point

            psi, r = cam_polar(fa, pb - pa)
            s = cam_of(j).motion.svaj(cam_contact(j, psi))[0]
            F = follower_point(j, s)[0]
            assert np.max(np.abs(r - np.hypot(F[..., 0], F[..., 1]))) <= 1e-10 * L, j.name
            np.testing.assert_allclose(kin.q[:, k], s, rtol=0, atol=1e-12 * L)
        elif j.kind in ("flat_cam", "rocker_flat_cam"):
            # the face (normal n, the follower's +y axis) at the cam's support distance H(nu)
            # from its centre, nu the normal's angle in the cam's frame; q the lift (or swing)
            # whose face lies at that distance (C5: h = R_b + s, or a cos(alpha0 - s) - f)
            from test_dynamics import support

            n = np.stack((-np.sin(fb), np.cos(fb)), -1)
            h = np.sum(n * (pb - pa), -1)
            H_nu = np.array([support(j, v) for v in fb + np.pi / 2 - fa])
            assert np.max(np.abs(h - H_nu)) <= 1e-10 * L, j.name
            x = j.numbers
            if j.kind == "flat_cam":
                s = h - x["base_radius"]
            else:
                a, f = x["pivot"], x["offset"]
                s = np.arccos((x["base_radius"] + f) / a) - np.arccos((h + f) / a)
            np.testing.assert_allclose(kin.q[:, k], s, rtol=0, atol=1e-12 * np.ptp(s))
        else:
            # a slider's frames keep their relative angle (a slot's pin turns freely); the points
            # stay on the slide line through P_a
            if j.kind != "slot":
                assert np.max(np.abs(wrap(fb - fa - j.angle))) <= 1e-10, j.name
            c, s = np.cos(fa), np.sin(fa)
            e = np.stack((c * j.axis[0] - s * j.axis[1], s * j.axis[0] + c * j.axis[1]), -1)
            d = pb - pa
            assert np.max(np.abs(d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0])) <= 1e-10 * L, j.name
            np.testing.assert_allclose(kin.q[:, k], np.sum(d * e, -1), rtol=0, atol=1e-12 * L)


def test_a_wrong_pin_would_be_seen():
    # guard for the geometry check above: the points of a tree joint and a non-joint pair differ
    kin = kinematics.solve(load("hoeken"), np.linspace(0.0, 1.0, 5))
    gap = np.linalg.norm(kin.point("coupler", "P") - kin.point("rocker", "O4"), axis=-1)
    assert np.min(gap) > 0.05


# ------------------------------------------------------------------------------------------
# branch continuity over a full turn of Grashof linkages

# (example, winding numbers of the moving bodies over one crank turn)
GRASHOF = [("hoeken", {"crank": 1, "coupler": 0, "rocker": 0}),
           ("drag_link", {"crank": 1, "coupler": 1, "follower": 1})]


@pytest.mark.parametrize("name,turns", GRASHOF)
def test_no_branch_jump_over_a_full_turn(name, turns):
    mech = load(name)
    T = period(mech)
    t = np.linspace(0.0, T, 361)
    kin = kinematics.solve(mech, t)
    assert kin.valid.all()
    dt = t[1] - t[0]
    step = 2 * math.pi / 360           # crank travel per sample
    for b in turns:
        f, w = phi(kin, b), omega(kin, b)
        jump = np.abs(np.diff(f))
        # a flip to the other assembly mode moves the body by a finite angle in one step
        assert jump.max() <= 3 * step, (b, jump.max())
        # and each step is the integral of omega (trapezoid rule, error O(dt^3))
        trap = np.diff(f) - dt * (w[1:] + w[:-1]) / 2
        assert np.max(np.abs(trap)) <= 1e-3 * step, (b, np.max(np.abs(trap)))
    # after one period the configuration repeats; the crank has turned once
    for b, n in turns.items():
        assert phi(kin, b)[-1] - phi(kin, b)[0] == pytest.approx(2 * math.pi * n, abs=1e-9)
        w_peak = np.max(np.abs(omega(kin, b)))
        al_peak = max(np.max(np.abs(alpha(kin, b))), w_peak**2)
        assert omega(kin, b)[-1] == pytest.approx(omega(kin, b)[0], abs=1e-9 * w_peak)
        assert alpha(kin, b)[-1] == pytest.approx(alpha(kin, b)[0], abs=1e-9 * al_peak)
    for b in mech.moving_bodies:
        for p in b.points:
            xy0, xy1 = kin.point(b.name, p)[[0, -1]]
            assert np.linalg.norm(xy1 - xy0) <= 1e-10 * size(mech)
    np.testing.assert_allclose(wrap(kin.q[-1] - kin.q[0]), 0.0, atol=1e-9)


def test_hoeken_rocker_stays_on_one_side():
    # the rocker of the default branch points down-right from O3 for the whole turn
    kin = kinematics.solve(load("hoeken"), np.linspace(0.0, 4 / 3, 361))
    f = phi(kin, "rocker")
    assert np.all(f < 0) and np.all(f > -math.pi)


# ------------------------------------------------------------------------------------------
# the [assembly] guess picks the branch

HOEKEN_ASSEMBLY = "phi = { crank = 0.0, coupler = 77.12, rocker = -77.12 }"


def hoeken_other_branch():
    """Hoeken with the guess mirrored across the ground line O1-O4 (the crank lies on it at
    t = 0): the other assembly mode, O3 below the ground line."""
    text = example_text("hoeken")
    assert HOEKEN_ASSEMBLY in text
    text = text.replace(HOEKEN_ASSEMBLY, "phi = { crank = 0.0, coupler = -77.12, rocker = 77.12 }")
    return model_from_dict(tomllib.loads(text), source="hoeken-other-branch.toml")


def test_assembly_guess_selects_the_other_branch():
    T = 4 / 3
    t = np.linspace(0.0, T, 181)
    up = kinematics.solve(load("hoeken"), t)
    down = kinematics.solve(hoeken_other_branch(), t)
    assert up.valid.all() and down.valid.all()
    # the rocker angle changes sign: O3 is above the ground line in one mode, below in the other
    assert np.all(phi(up, "rocker") < 0) and np.all(phi(down, "rocker") > 0)
    assert phi(down, "coupler")[0] == pytest.approx(-77.11 * DEG, abs=0.01 * DEG)
    assert phi(down, "rocker")[0] == pytest.approx(77.11 * DEG, abs=0.01 * DEG)
    # still consistent: closes, and agrees with the closed form on the mirrored branch
    assert np.max(down.residual) <= 1e-10
    _check_hoeken_against_closed_form(down, t, branch=-1)
    # mirror symmetry: the other mode at crank angle th is the reflection of this mode at -th
    # (i.e. at T - t); angles change sign, rates keep theirs (time also runs backwards)
    for b in ("coupler", "rocker"):
        np.testing.assert_allclose(wrap(phi(down, b) + phi(up, b)[::-1]), 0.0, atol=1e-9)
        np.testing.assert_allclose(omega(down, b), omega(up, b)[::-1], rtol=0,
                                   atol=1e-9 * np.max(np.abs(omega(up, b))))
        np.testing.assert_allclose(alpha(down, b), -alpha(up, b)[::-1], rtol=0,
                                   atol=1e-9 * np.max(np.abs(alpha(up, b))))


# ------------------------------------------------------------------------------------------
# batch equals loop

N_BATCH = 50


def _same(a, b, rtol, what):
    """Equal within rtol of the peak; revolute angles compared modulo 2 pi by the caller."""
    scale = max(float(np.max(np.abs(a))), 1e-300)
    err = float(np.max(np.abs(a - b)))
    assert err <= rtol * scale, f"{what}: {err:.2e} > {rtol:g} x {scale:.2e}"


# loop sizes: 50 single-sample solves where a solve is cheap (closed-form dyads), 10 spread over
# the period for the examples whose lone solve continues from t = 0 at ~0.1 s a solve (the
# prismatic examples, the slot of the scotch yoke, the gears of the geared five-bar) and for the
# cam's (~0.3 s: its steps solve the contact by Newton's method on top of the closure's)
N_LOOP = {"inverted_slider_crank": 10, "slider_crank": 10, "scotch_yoke": 10,
          "geared_fivebar": 10, "cam_follower": 10, "cam_fourbar": 10, "cam_flat_rocker": 10}


@pytest.mark.parametrize("name", EXAMPLES)
def test_batch_equals_loop_one_sample_at_a_time(name):
    mech = load(name)
    t = np.linspace(0.0, period(mech), N_BATCH)
    batch = kinematics.solve(mech, t)
    k = np.linspace(0, N_BATCH - 1, N_LOOP.get(name, N_BATCH)).astype(int)
    rows = [kinematics.solve(mech, t[i:i + 1]) for i in k]
    assert all(r.valid.all() for r in rows) and batch.valid.all()
    # a lone sample follows the branch from the assembly at t = 0, so even the unwrapped
    # angles agree. Measured worst: 7e-13 (q), 1.3e-12 (qd), 7e-12 (qdd), in the inverted
    # slider-crank, whose Newton solve stops at a 1e-12 residual; ~1e-15 elsewhere
    _same(batch.q[k], np.array([r.q[0] for r in rows]), 1e-12, f"{name} q")
    _same(batch.phi[k], np.array([r.phi[0] for r in rows]), 1e-12, f"{name} phi")
    _same(batch.qd[k], np.array([r.qd[0] for r in rows]), 1e-11, f"{name} qd")
    _same(batch.qdd[k], np.array([r.qdd[0] for r in rows]), 1e-11, f"{name} qdd")


@pytest.mark.parametrize("name", EXAMPLES)
def test_the_branch_does_not_depend_on_the_first_sample_time(name):
    # a run starting at 0.6 T continues the branch assembled at t = 0 (the [assembly] guess
    # describes t = 0), unwrapped angles included
    mech = load(name)
    T = period(mech)
    full = kinematics.solve(mech, np.linspace(0.0, T, 11))
    late = kinematics.solve(mech, np.linspace(0.6 * T, T, 5))
    assert late.valid.all()
    _same(full.phi[6::1], late.phi, 1e-12, "phi")
    _same(full.q[6::1], late.q, 1e-12, "q")


# ------------------------------------------------------------------------------------------
# sample counts and time arrays

@pytest.mark.parametrize("n", [1, 2, 5])
def test_shapes_for_small_sample_counts(n):
    mech = load("stephenson")
    T = period(mech)
    t = np.linspace(0.0, T, n)
    kin = kinematics.solve(mech, t)
    nj, nb = len(mech.joints), len(mech.bodies)
    assert kin.t.shape == (n,)
    assert kin.q.shape == kin.qd.shape == kin.qdd.shape == (n, nj)
    assert kin.phi.shape == (n, nb) and kin.r.shape == (n, nb, 2)
    assert kin.tw.shape == kin.twd.shape == (n, nb, 3)
    assert kin.valid.shape == kin.residual.shape == kin.pivot.shape == (n,)
    assert kin.point("output", "T").shape == (n, 2)
    assert kin.valid.all()
    # the same values as the corresponding samples of a fine run
    ref = kinematics.solve(mech, np.linspace(0.0, T, 4 * (n - 1) + 1 if n > 1 else 9))
    idx = np.arange(n) * 4
    for attr in ("q", "qd", "qdd"):
        a, b = getattr(kin, attr), getattr(ref, attr)[idx]
        np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * np.max(np.abs(b)))
    sol = linkdyn.analyze(mech, t)
    assert all(v.shape == (n,) for v in sol.columns.values())
    assert len(sol.to_dataframe()) == n


def test_two_samples_span_a_full_turn():
    # T = 2 over exactly one period: the end sample is the start configuration, crank + 2 pi
    mech = load("hoeken")
    kin = kinematics.solve(mech, np.array([0.0, period(mech)]))
    assert kin.valid.all()
    # q_J2 = phi_coupler - phi_crank loses the crank's turn; the rocker's pivot angle repeats
    np.testing.assert_allclose(kin.q[1] - kin.q[0], [2 * math.pi, -2 * math.pi, 0, 0], atol=1e-9)
    np.testing.assert_allclose(kin.qd[1], kin.qd[0], atol=1e-9)


def test_time_must_be_one_dimensional_and_not_empty():
    mech = load("hoeken")
    with pytest.raises(linkdyn.ModelError, match="1-D"):
        kinematics.solve(mech, np.zeros((2, 3)))
    with pytest.raises(linkdyn.ModelError, match="at least one sample"):
        kinematics.solve(mech, np.array([]))


def hoeken_design(crank_mm: float):
    text = example_text("hoeken")
    assert "O2 = [38.1, 0.0]" in text
    return model_from_dict(tomllib.loads(text.replace("O2 = [38.1, 0.0]",
                                                      f"O2 = [{float(crank_mm)!r}, 0.0]")))


def test_batch_of_designs_equals_loop():
    # 50 Hoeken designs (crank 30..46 mm, all crank-rockers) solved at once and one at a time
    designs = [hoeken_design(a) for a in np.linspace(30.0, 46.0, N_BATCH)]
    t = np.linspace(0.0, 2 / 3, 13)           # half a turn keeps the loop cheap
    batch = kinematics.solve(designs, t)
    assert batch.q.shape == (N_BATCH, 13, 4) and batch.valid.shape == (N_BATCH, 13)
    assert batch.valid.all()
    loop = [kinematics.solve(m, t) for m in designs]
    for attr in ("q", "qd", "qdd", "phi", "tw", "twd"):
        _same(getattr(batch, attr), np.array([getattr(k, attr) for k in loop]), 1e-12, attr)
    _same(batch.point("coupler", "P"), np.array([k.point("coupler", "P") for k in loop]), 1e-12,
          "coupler.P")
    # the designs really differ: the rocker swing grows with the crank
    swing = np.ptp(batch.phi[:, :, body_index(batch, "rocker")], axis=-1)
    assert np.all(np.diff(swing) > 0)


def test_a_design_that_cannot_assemble_is_nan_in_its_own_samples_only():
    designs = [hoeken_design(38.1), hoeken_design(400.0), hoeken_design(40.0)]
    t = np.linspace(0.0, 0.5, 7)
    batch = kinematics.solve(designs, t)
    assert batch.valid[0].all() and batch.valid[2].all()
    assert not batch.valid[1].any() and np.isnan(batch.q[1]).all()
    ref = kinematics.solve(designs[2], t)
    _same(batch.q[2], ref.q, 1e-12, "q of design 2")


# ------------------------------------------------------------------------------------------
# a loop that stops closing: validity ends at the limit position

def non_grashof_hoeken():
    """Ground 180 mm, crank 60 mm (coupler and rocker 115.2 mm): s + l > p + q, the crank
    cannot pass the angle where coupler and rocker are stretched in line."""
    text = example_text("hoeken").replace("O2 = [38.1, 0.0]", "O2 = [60.0, 0.0]")
    text = text.replace("O4 = [89.5, 0.0] }", "O4 = [180.0, 0.0] }")
    return model_from_dict(tomllib.loads(text))


NG_LIMIT = math.acos((180.0**2 + 60.0**2 - 230.4**2) / (2 * 180.0 * 60.0))   # 142.27 deg


def test_past_the_limit_position_samples_are_invalid_not_wrong():
    mech = non_grashof_hoeken()
    t = np.linspace(0.0, 4 / 3, 181)
    kin = kinematics.solve(mech, t)
    beyond = HOEKEN_W * t > NG_LIMIT
    # no sample past the limit is reported as closed, and every reported sample does close
    assert not np.any(kin.valid & beyond)
    assert np.all(np.isnan(kin.q[~kin.valid]))
    assert np.max(kin.residual[kin.valid]) <= 1e-10
    # a run that stops short of the limit is entirely valid
    short = kinematics.solve(mech, np.linspace(0.0, 0.99 * NG_LIMIT / HOEKEN_W, 21))
    assert short.valid.all()


def test_validity_ends_exactly_at_the_limit_position():
    mech = non_grashof_hoeken()
    t = np.linspace(0.0, 4 / 3, 361)
    kin = kinematics.solve(mech, t)
    first_bad = int(np.argmin(kin.valid))
    assert HOEKEN_W * t[first_bad - 1] <= NG_LIMIT < HOEKEN_W * t[first_bad]


@pytest.mark.parametrize("name", ["hoeken", "slider_crank"])
def test_unsorted_and_repeated_times(name):
    # samples in any order, with repeats, give the values of the sorted run
    mech = load(name)
    T = period(mech)
    t = np.array([0.7, 0.1, 0.4, 0.4, 0.0, 0.95]) * T
    kin = kinematics.solve(mech, t)
    order = np.argsort(t, kind="stable")
    ref = kinematics.solve(mech, t[order])
    assert kin.valid.all()
    for attr in ("q", "qd", "qdd", "phi"):
        _same(getattr(kin, attr)[order], getattr(ref, attr), 1e-12, attr)
    np.testing.assert_array_equal(kin.q[2], kin.q[3])


# ------------------------------------------------------------------------------------------
# closed-form dyads against Newton's method

def _tilted_slider_crank(swap: bool):
    """The bundled slider-crank on a slide tilted 30 deg, the slider turned 15 deg on it, the
    prismatic joint written in either order (the line fixed in the ground, or in the slider)."""
    text = example_text("slider_crank").replace(
        'axis = [1.0, 0.0]', 'axis = [0.8660254037844387, 0.5]\nangle = 15.0').replace(
        'slider = 0.0 }', 'slider = 15.0 }')
    if swap:
        text = text.replace('connect = ["ground.G", "slider.B"]',
                            'connect = ["slider.B", "ground.G"]').replace(
            'angle = 15.0', 'angle = -15.0').replace(
            'axis = [0.8660254037844387, 0.5]', 'axis = [0.9659258262890683, 0.25881904510252074]')
    mech = model_from_dict(tomllib.loads(text))
    return dataclasses.replace(mech, assembly_q={})


@pytest.mark.parametrize("case", ["hoeken", "drag_link", "watt2", "stephenson", "fivebar",
                                  "slider_crank", "tilted_slide", "tilted_slide_swapped",
                                  "inverted_slider_crank"])
def test_closed_form_dyads_agree_with_newton(case):
    mech = (_tilted_slider_crank(case.endswith("swapped")) if case.startswith("tilted")
            else load(case))
    lay = kinematics.compile_layout(mech)
    assert lay.dyads is not None, "this mechanism decomposes into dyads"
    shapes = {d.shape for d in lay.dyads}
    assert shapes <= {"chain", "split", "slide", "swing"}
    if case in ("slider_crank", "tilted_slide", "tilted_slide_swapped"):
        assert shapes == {"slide"}
    if case == "inverted_slider_crank":
        assert shapes == {"swing"}
    t = np.linspace(0.0, period(mech), 181)
    closed = kinematics.solve(mech, t, layout=lay)
    newton = kinematics.solve(mech, t, layout=dataclasses.replace(lay, dyads=None))
    assert closed.valid.all() and newton.valid.all()
    assert closed.residual.max() <= 1e-14
    for attr in ("q", "qd", "qdd", "phi", "tw", "twd"):
        _same(getattr(closed, attr), getattr(newton, attr), 1e-10, f"{case} {attr}")


def test_inverted_slider_crank_cut_at_the_pivot_matches_the_slider_cut():
    # cut at the lever pivot J4 the loop is not a dyad of ours and Newton's method solves it;
    # the motion must be the same as with the (automatic) slider cut solved in closed form
    text = example_text("inverted_slider_crank")
    data = tomllib.loads(text)
    data["topology"] = {"cut": ["J4"]}
    pivot = model_from_dict(data)
    assert kinematics.compile_layout(pivot).dyads is None
    t = np.linspace(0.0, 1.0, 121)
    a, b = kinematics.solve(load("inverted_slider_crank"), t), kinematics.solve(pivot, t)
    for attr in ("q", "qd", "qdd", "phi"):
        _same(a.__getattribute__(attr), b.__getattribute__(attr), 1e-10, attr)
