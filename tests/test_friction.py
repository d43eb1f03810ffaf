"""Joint friction that grows with the joint load (``kind = "friction"``), by independent means.

a. a simultaneous Newton-Euler solve written here (tests/test_dynamics.py's equations) with one
   friction unknown per friction joint and its equation f = -c |F| tanh(qd / v), solved by a
   fixed-point iteration (no code shared with linkdyn.friction's Newton);
b. power balance per sample: drivers' power + loads' power + friction power = dKE/dt + dPE/dt
   (five-point difference in time);
c. closed forms: a block pushed up and lowered along an incline; a block pushed horizontally up
   an incline, which locks exactly when mu > tan(alpha); a crank's pin (its friction couple is
   mu r |F|: the friction circle rho = mu r); Hoeken with friction at its four pins (more work
   per cycle, equal to the frictionless run at mu = 0);
d. both backends agree; the model file reads and writes friction; the command line reports it.
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.analysis import analyze
from linkdyn.cli import main
from linkdyn.errors import AssemblyError, ModelError
from linkdyn.friction import joint_friction
from linkdyn.design import summary
from linkdyn.model import PRISMATIC, REVOLUTE, Body, Driver, Load, Model
from linkdyn.motion import ConstantSpeed

from builders import DEG, MM, body, pri, rev, slot
from test_dynamics import (MODELS, applied, body_states, check, cross, five_point_derivative,
                           joint_columns, kinetic_energy, ne_system, rot, times)

G = 9.81


def with_friction(model, mu=0.15, radius=8 * MM, joints=None, speed=None):
    """``model`` with friction in ``joints`` (default all of them)."""
    names = joints or [j.name for j in model.joints]
    extra = tuple(joint_friction(model, j, mu, radius, speed) for j in names)
    return dataclasses.replace(model, loads=model.loads + extra)


class _Frictionless:
    """A solution seen without its friction loads (test_dynamics' equations know no friction)."""

    def __init__(self, sol):
        self._sol = sol
        self.model = dataclasses.replace(
            sol.model, loads=tuple(ld for ld in sol.model.loads if ld.kind != "friction"))

    def __getattr__(self, name):
        return getattr(self._sol, name)


def friction_loads(model):
    return [ld for ld in model.loads if ld.kind == "friction"]


def ne_friction_solve(sol, iterations=400):
    """Reaction unknowns, efforts and friction efforts of the simultaneous Newton-Euler solve
    with friction: K x + K_f f = rhs, f_j = -c_j |F_j(x)| tanh(qd_j / v_j), by fixed-point
    iteration on f from 0. Returns (x (T, n), f (T, k), normals)."""
    view = _Frictionless(sol)
    K, rhs, normals, states = ne_system(view)
    model = sol.model
    col, _ = joint_columns(view.model)
    T = sol.t.shape
    rows = {b.name: 3 * k for k, b in enumerate(model.moving_bodies)}
    fl = friction_loads(model)
    Kf = np.zeros(K.shape[:-1] + (len(fl),))

    def put(b, c, f, x, mz=0.0):
        if b in rows:
            r0 = rows[b]
            Kf[..., r0, c] += f[..., 0]
            Kf[..., r0 + 1, c] += f[..., 1]
            Kf[..., r0 + 2, c] += cross(x - states[b].rC, f) + mz

    zero = np.zeros(T + (2,))
    arm, speed, qd, which = [], [], [], []
    extra = []   # (static arm, stiction speed, viscous, preload) of each
    for c, ld in enumerate(fl):
        jt = model.joint(ld.joint)
        k = [j.name for j in model.joints].index(ld.joint)
        x = sol.point(jt.body_b, jt.point_b)
        # a unit friction effort: a couple (revolute) or a force along the axis at b's point
        lever = ld.radius if jt.kind == REVOLUTE else 1.0
        if jt.kind == REVOLUTE:
            put(jt.body_b, c, zero, x, 1.0)
            put(jt.body_a, c, zero, x, -1.0)
        else:
            e = normals[jt.name][0]
            put(jt.body_b, c, e, x)
            put(jt.body_a, c, -e, x)
        arm.append(ld.coefficient * lever)
        mu_s = ld.coefficient if ld.static_coefficient is None else ld.static_coefficient
        v_s = 10 * ld.transition_speed if ld.stiction_speed is None else ld.stiction_speed
        extra.append((mu_s * lever, v_s, ld.viscous, ld.preload))
        speed.append(ld.transition_speed)
        qd.append(sol.kin.qd[..., k])
        which.append((jt.kind, col[k]))
    Kinv = np.linalg.inv(K)
    f = np.zeros(T + (len(fl),))
    for _ in range(iterations):
        xs = np.einsum("...ij,...j->...i", Kinv, rhs - np.einsum("...ij,...j->...i", Kf, f))
        # f = -(a_d + (a_s - a_d) exp(-(qd/v_s)^2)) (|F| + preload) tanh(qd/v) - b qd
        new = np.stack([-(a + (a_s - a) * np.exp(-(v / v_s) ** 2))
                        * ((np.linalg.norm(xs[..., c0:c0 + 2], axis=-1) if kind == REVOLUTE
                            else np.abs(xs[..., c0])) + pre) * np.tanh(v / s) - b * v
                        for a, s, v, (kind, c0), (a_s, v_s, b, pre)
                        in zip(arm, speed, qd, which, extra)], axis=-1)
        if np.max(np.abs(new - f)) <= 1e-16 * max(np.max(np.abs(new)), 1e-300):
            f = new
            break
        f = new
    xs = np.einsum("...ij,...j->...i", Kinv, rhs - np.einsum("...ij,...j->...i", Kf, f))
    return xs, f, normals


FRICTION_MODELS = {
    "hoeken-loaded": lambda: with_friction(MODELS["hoeken-loaded"]()),
    "slider-crank": lambda: with_friction(MODELS["slider-crank"](), 0.2),
    "scotch-yoke": lambda: with_friction(MODELS["scotch-yoke"](), 0.2, 6 * MM),
    "stephenson": lambda: with_friction(MODELS["stephenson"](), 0.1, 5 * MM),
    "slider-crank-stribeck": lambda: stribeck(MODELS["slider-crank"]()),
}


def stribeck(model):
    """Friction at every joint with a static coefficient, a blend speed near the joints'
    rates, viscous terms and preloads."""
    extra = []
    for j in model.joints:
        revolute = j.kind == REVOLUTE
        extra.append(joint_friction(model, j.name, 0.12, 7 * MM, 0.05 if revolute else 0.01,
                                    static_coefficient=0.3,
                                    stiction_speed=3.0 if revolute else 0.3,
                                    viscous=0.002 if revolute else 0.5, preload=40.0))
    return dataclasses.replace(model, loads=model.loads + tuple(extra))


@pytest.mark.parametrize("name", list(FRICTION_MODELS))
def test_friction_matches_simultaneous_newton_euler(name):
    model = FRICTION_MODELS[name]()
    sol = analyze(model, times(model, 23))
    assert np.all(sol.valid)
    x, f, normals = ne_friction_solve(sol)
    check(sol.friction.effort.T, f, 1e-9, what="friction efforts")
    assert np.max(np.abs(f)) > 0   # the friction is there
    _, n_unknowns = joint_columns(_Frictionless(sol).model)
    for k, drv in enumerate(model.drivers):
        check(sol.dyn.tau[..., k], x[..., n_unknowns + k], 1e-9, what=f"tau {drv.joint}")
    # the reported reactions (friction excluded) are the Newton-Euler reaction unknowns
    col, _ = joint_columns(_Frictionless(sol).model)
    scale = np.max(np.abs(sol.reactions.force))
    for k, jt in enumerate(model.joints):
        F = sol.reactions.force[..., k, :]
        if jt.kind == REVOLUTE:
            ref = x[..., col[k]:col[k] + 2]
        else:
            ref = x[..., col[k], None] * normals[jt.name][1]
        check(F, ref, 1e-9, scale=scale, what=f"reaction {jt.name}")
    # Newton's report: converged below 1e-12 of the scale, in a few iterations
    assert sol.friction.residual <= 1e-12
    assert 1 <= sol.friction.iterations < 20


def test_friction_changes_the_effort_beyond_the_tolerance():
    """Guard: the frictionless effort fails the friction Newton-Euler comparison."""
    model = FRICTION_MODELS["hoeken-loaded"]()
    t = times(model, 23)
    sol, bare = analyze(model, t), analyze(MODELS["hoeken-loaded"](), t)
    x, _, _ = ne_friction_solve(sol)
    _, n = joint_columns(bare.model)
    err = np.max(np.abs(bare.dyn.tau[..., 0] - x[..., n])) / np.max(np.abs(x[..., n]))
    assert err > 1e-3


@pytest.mark.parametrize("name", list(FRICTION_MODELS))
def test_power_balance_with_friction(name):
    model = FRICTION_MODELS[name]()
    m0 = model.drivers[0].motion
    h = 2e-3 / max(abs(m0.speed), 1.0)
    centres = times(model, 9)[:-1] + 0.0123
    t = (centres[:, None] + np.arange(-2, 3) * h).reshape(-1)
    sol = analyze(model, t)
    view = _Frictionless(sol)
    states = body_states(view)
    _, _, pe, p_loads = applied(view, states)
    ke = kinetic_energy(view, states)
    qd = sol.kin.qd
    p_drv = sum(sol.dyn.tau[..., k] * qd[..., [j.name for j in model.joints].index(d.joint)]
                for k, d in enumerate(model.drivers))
    # the friction's power computed here from its effort and the joint's rate
    p_fric = sum(sol.friction.effort[k] * qd[..., [j.name for j in model.joints].index(j)]
                 for k, j in enumerate(sol.friction.joints))
    check(np.sum(sol.friction.power, axis=0), p_fric, 1e-13,
          scale=np.max(np.abs(p_fric)), what="friction power")
    assert np.all(sol.friction.power <= 0)   # friction only dissipates
    dEdt = five_point_derivative((ke + pe).reshape(len(centres), 5), h)
    lhs = (p_drv + p_loads + p_fric).reshape(len(centres), 5)[:, 2]
    scale = max(np.max(np.abs(p_drv)), np.max(np.abs(dEdt)), np.max(np.abs(p_fric)))
    check(lhs, dEdt, 1e-7, scale=scale, what="efforts' + loads' + friction power vs dE/dt")
    # the solution's own load power includes the friction's
    check(sol.loads.power, p_loads + p_fric, 1e-12, scale=np.max(np.abs(p_loads + p_fric)),
          what="load power")


# ----------------------------------------------------------------------------------------------
# closed forms


def incline_block(angle, mu, speed, mass=2.0):
    """A block on a guide at ``angle`` from the horizontal, driven along it at ``speed`` (m/s)
    against gravity, with friction mu in the guide."""
    bodies = (Body("ground", {"O": np.zeros(2)}),
              Body("block", {"B": np.zeros(2)}, mass, np.zeros(2), 0.01))
    joints = (pri("J1", "ground.O", "block.B", (math.cos(angle), math.sin(angle))),)
    m = Model("incline", bodies, joints, (Driver("J1", ConstantSpeed(speed, 0.1)),),
              gravity=np.array([0.0, -G]))
    return with_friction(m, mu, speed=1e-9)


@pytest.mark.parametrize("mu", [0.0, 0.2, 0.5])
def test_block_pushed_along_an_incline(mu):
    angle, m = 20 * DEG, 2.0
    t = np.linspace(0, 1, 5)
    up = analyze(incline_block(angle, mu, 0.5, m), t)
    down = analyze(incline_block(angle, mu, -0.5, m), t)
    W = m * G
    check(up.dyn.tau[..., 0], np.full(5, W * (math.sin(angle) + mu * math.cos(angle))), 1e-12)
    # lowering it: the load drives it unless mu > tan(angle) (self-locking: the driver pushes)
    check(down.dyn.tau[..., 0], np.full(5, W * (math.sin(angle) - mu * math.cos(angle))), 1e-12,
          scale=W)
    assert (down.dyn.tau[0, 0] < 0) == (mu > math.tan(angle))
    # the reported reaction is the normal force alone (friction excluded)
    F = up.reaction("J1")[..., :2]
    n = np.array([-math.sin(angle), math.cos(angle)])
    check(F, np.broadcast_to(W * math.cos(angle) * n, F.shape), 1e-12, scale=W)


def pushed_up_an_incline(alpha, mu):
    """A block on a guide at ``alpha`` from the vertical, pushed horizontally by a slider whose
    vertical slot carries the block's pin; friction mu in the guide only."""
    c, s = math.sin(alpha), math.cos(alpha)   # the guide's direction (cos, sin of 90 - alpha)
    bodies = (Body("ground", {"O": np.zeros(2), "H": np.zeros(2)}),
              Body("pusher", {"P": np.zeros(2)}, 1.0, np.zeros(2), 0.01),
              Body("block", {"B": np.zeros(2)}, 3.0, np.zeros(2), 0.01))
    joints = (pri("J1", "ground.H", "pusher.P"), pri("J2", "ground.O", "block.B", (c, s)),
              slot("J3", "pusher.P", "block.B", (0.0, 1.0)))
    x0 = 0.2
    m = Model("wedge", bodies, joints, (Driver("J1", ConstantSpeed(0.3, x0)),),
              gravity=np.array([0.0, -G]), assembly_q={"J1": x0, "J2": x0 / c, "J3": x0 * s / c})
    return with_friction(m, mu, joints=["J2"], speed=1e-9)


def test_horizontal_push_up_an_incline_and_its_lock():
    alpha = 35 * DEG
    t = np.linspace(0, 0.5, 6)
    W = 3.0 * G
    for mu in (0.0, 0.3, 0.95 * math.tan(alpha)):
        sol = analyze(pushed_up_an_incline(alpha, mu), t)
        P = W * (math.cos(alpha) + mu * math.sin(alpha)) / (math.sin(alpha) - mu * math.cos(alpha))
        check(sol.dyn.tau[..., 0], np.full(6, P), 1e-10, what=f"push at mu = {mu}")
    # beyond mu = tan(alpha) no push drives it: exit 3 naming the joint and that it locks
    with pytest.raises(AssemblyError, match=r"locks at joint J2") as err:
        analyze(pushed_up_an_incline(alpha, 1.05 * math.tan(alpha)), t)
    assert err.value.time == pytest.approx(0.0)
    # a run none of whose samples can be driven stops even when such samples are allowed
    with pytest.raises(AssemblyError, match=r"locks at joint J2"):
        analyze(pushed_up_an_incline(alpha, 1.05 * math.tan(alpha)), t, allow_singular=True)
    # in a batch of designs the locked design's rows are NaN and flagged, the other's solved
    sol = analyze([pushed_up_an_incline(alpha, 1.05 * math.tan(alpha)),
                   pushed_up_an_incline(alpha, 0.3)], t, allow_singular=True)
    assert not np.any(sol.valid[0]) and np.all(sol.friction.locked[0])
    assert np.all(sol.valid[1]) and not np.any(sol.friction.locked[1])


def test_journal_friction_circle():
    """A crank turning at constant speed under gravity with friction in its pin: the driver's
    torque is gravity's plus mu r |F|, F = m (a_C - g) computed here; rho = |M_f| / |F| = mu r."""
    w, mass, rc, mu, r = 7.0, 1.2, 0.08, 0.25, 0.01
    bodies = (Body("ground", {"O": np.zeros(2)}),
              Body("crank", {"O": np.zeros(2)}, mass, np.array([rc, 0.0]), 0.002))
    m = Model("pin", bodies, (rev("J1", "ground.O", "crank.O"),),
              (Driver("J1", ConstantSpeed(w)),), gravity=np.array([0.0, -G]))
    m = with_friction(m, mu, r, speed=1e-9)
    t = np.linspace(0.01, 0.9, 31)
    sol = analyze(m, t)
    phi = w * t
    r_c = rc * np.stack([np.cos(phi), np.sin(phi)], -1)
    g = np.array([0.0, -G])
    F = mass * (-w ** 2 * r_c - g)                      # the pin's force on the crank
    tau = -cross(r_c, mass * g[None]) + mu * r * np.linalg.norm(F, axis=-1)
    check(sol.dyn.tau[..., 0], tau, 1e-12)
    check(sol.reaction("J1"), F, 1e-12)
    rho = np.abs(sol.friction.effort[0]) / np.linalg.norm(sol.reaction("J1"), axis=-1)
    check(rho, np.full_like(rho, mu * r), 1e-12)


def massless_slider_crank(mu, c=40.0, w=5.0):
    """A slider-crank of massless links (crank 50 mm, rod 180 mm, the slider's guide through the
    crank pivot) turning at ``w`` rad/s against a damper ``c`` N s/m on the slider (its output
    load, ``press``), friction ``mu`` in the slider's guide only."""
    bodies = (body("ground", {"O": (0, 0), "F": (-2000, 0)}),
              body("crank", {"O": (0, 0), "A": (50, 0)}), body("rod", {"A": (0, 0), "B": (180, 0)}),
              body("slider", {"B": (0, 0)}))
    joints = (rev("J1", "ground.O", "crank.O"), rev("J2", "crank.A", "rod.A"),
              rev("J3", "rod.B", "slider.B"), pri("J4", "ground.O", "slider.B"))
    press = Load("damper", "slider", "B", body2="ground", point2="F", damping=c, name="press")
    m = Model("press", bodies, joints, (Driver("J1", ConstantSpeed(w)),), (press,),
              assembly_phi={"crank": 0.0, "rod": 0.0, "slider": 0.0}, assembly_q={"J4": 0.23},
              output=("press",))
    return with_friction(m, mu, joints=["J4"], speed=1e-9)


def test_slider_crank_instantaneous_efficiency():
    """Massless links, friction in the guide only: the rod is a two-force member at angle beta,
    the guide's normal force |s sin beta| and the slider's balance s cos beta (1 - mu |tan beta|)
    = c v give eta = c v^2 / (s cos beta v) = 1 - mu |tan beta| at every sample (closed form of
    the crank angle); over the run the work into the damper over the drivers' work."""
    a, b, c, w, mu = 0.05, 0.18, 40.0, 5.0, 0.3
    t = np.linspace(0.01, 2 * math.pi / w - 0.01, 23)   # clear of the dead centres
    sol = analyze(massless_slider_crank(mu, c, w), t)
    phi = w * t
    root = np.sqrt(b ** 2 - (a * np.sin(phi)) ** 2)
    eta = 1.0 - mu * np.abs(a * np.sin(phi)) / root
    p_out, eta_sol = (sol.columns[k] for k in ("output_power", "efficiency"))
    check(eta_sol, eta, 1e-10, what="eta(t)")
    v = -a * w * np.sin(phi) * (1.0 + a * np.cos(phi) / root)   # the slider's dx/dt
    check(p_out, c * v ** 2, 1e-10, what="power into the damper")
    s = summary(sol)["output"]
    w_out = np.trapezoid(c * v ** 2, t)
    assert s["output_work_J"] == pytest.approx(w_out, rel=1e-10)
    assert s["efficiency"] == pytest.approx(w_out / np.trapezoid(c * v ** 2 / eta, t), rel=1e-10)
    assert s["efficiency_least"] == pytest.approx(np.min(eta), rel=1e-10)
    # no friction: every watt put in reaches the damper
    bare = analyze(massless_slider_crank(0.0, c, w), t)
    check(bare.columns["efficiency"], np.ones_like(t), 1e-12, what="eta at mu = 0")


def test_hoeken_with_friction_at_four_pins():
    bare = MODELS["hoeken"]()
    t = times(bare, 361)
    ref = analyze(bare, t)
    zero = analyze(with_friction(bare, 0.0), t)
    check(zero.dyn.tau, ref.dyn.tau, 1e-12, what="mu = 0")
    check(zero.reactions.force, ref.reactions.force, 1e-12, what="mu = 0 reactions")
    sol = analyze(with_friction(bare, 0.1, 6 * MM), t)
    work = np.trapezoid(sol.driver_power, t)
    assert work > np.trapezoid(ref.driver_power, t) + 1e-3
    # over a cycle the drivers' net work is what the friction dissipates (no external loads)
    lost = -np.trapezoid(np.sum(sol.friction.power, 0), t)
    assert work == pytest.approx(lost, rel=1e-3)
    assert np.max(np.abs(sol.dyn.tau - ref.dyn.tau)) > 1e-3 * np.max(np.abs(ref.dyn.tau))


@pytest.mark.parametrize("name", list(FRICTION_MODELS))
def test_backends_agree_with_friction(name):
    model = FRICTION_MODELS[name]()
    t = times(model, 29)
    a, b = analyze(model, t, backend="numpy"), analyze(model, t, backend="compiled")
    check(b.dyn.tau, a.dyn.tau, 1e-12, what="tau")
    check(b.reactions.force, a.reactions.force, 1e-12, what="reactions")
    check(b.friction.effort, a.friction.effort, 1e-12, what="friction")


@pytest.mark.parametrize("name", ["hoeken-loaded", "stephenson"])
def test_backends_agree_with_friction_over_many_samples(name):
    """Over more samples than the compiled kernel takes at once (it works a block of samples
    at a time, its scratch reused from block to block): every reaction's whole wrench (the
    moment too), the efforts and the friction agree with numpy's at every sample."""
    model = FRICTION_MODELS[name]()
    t = times(model, 2500)
    a, b = analyze(model, t, backend="numpy"), analyze(model, t, backend="compiled")
    check(b.dyn.tau, a.dyn.tau, 1e-12, what="tau")
    check(np.asarray(b.reactions.on_second), np.asarray(a.reactions.on_second), 1e-12,
          what="reactions")
    check(b.friction.effort, a.friction.effort, 1e-12, what="friction")


def test_backends_agree_where_friction_locks():
    """The wedge pushed up its incline on both backends: the same pushes below the lock, and
    beyond mu = tan(alpha) the same samples locked at the same joint."""
    alpha, t = 35 * DEG, np.linspace(0, 0.5, 6)
    # one batch: a design below the lock, one beyond it (a run of one design that locks at
    # every sample stops, allowed or not)
    m = [pushed_up_an_incline(alpha, mu) for mu in (0.3, 1.05 * math.tan(alpha))]
    a, b = (analyze(m, t, backend=k, allow_singular=True) for k in ("numpy", "compiled"))
    np.testing.assert_array_equal(b.friction.locked, a.friction.locked)
    np.testing.assert_array_equal(b.friction.lock_joint, a.friction.lock_joint)
    check(b.dyn.tau[0], a.dyn.tau[0], 1e-12, what="tau at mu = 0.3")
    np.testing.assert_array_equal(np.isnan(b.dyn.tau), np.isnan(a.dyn.tau))
    assert not np.any(a.friction.locked[0]) and np.all(a.friction.locked[1])


def test_batch_of_designs_with_friction():
    base = MODELS["hoeken-loaded"]()
    t = times(base, 17)
    designs = [with_friction(base, mu) for mu in (0.05, 0.2)]
    batch = analyze(designs, t)
    for k, m in enumerate(designs):
        one = analyze(m, t)
        check(batch.design(k).dyn.tau, one.dyn.tau, 1e-12, what=f"design {k}")
        check(batch.design(k).friction.effort, one.friction.effort, 1e-12)


# ----------------------------------------------------------------------------------------------
# the model file and the command line

TOML = """
[mechanism]
name = "crank with friction"
gravity = [0, -9.81]
[units]
length = "mm"
angle = "deg"
[[bodies]]
name = "ground"
points = { O = [0, 0] }
[[bodies]]
name = "crank"
points = { O = [0, 0], A = [80, 0] }
mass = 1.2
com = [80, 0]
inertia = 2000
[[joints]]
name = "J1"
type = "revolute"
connect = ["ground.O", "crank.O"]
[[drivers]]
joint = "J1"
motion = { kind = "constant_speed", rpm = 60 }
[[loads]]
kind = "friction"
name = "pin"
joint = "J1"
coefficient = 0.25
radius = 10
{extra}
[analysis]
cycles = 1
samples = 73
"""


def test_model_file_reads_and_writes_friction(tmp_path):
    p = tmp_path / "m.toml"
    p.write_text(TOML.replace("{extra}", "transition_speed = 2.0\nstatic_coefficient = 0.3\n"
                                         "stiction_speed = 5.0\nviscous = 0.001\npreload = 20"))
    m = linkdyn.load(p)
    (ld,) = m.loads
    assert (ld.kind, ld.joint, ld.coefficient) == ("friction", "J1", 0.25)
    assert ld.radius == pytest.approx(0.01) and ld.transition_speed == pytest.approx(2 * DEG)
    # deg/s -> rad/s; N m s/deg -> N m s/rad
    assert ld.stiction_speed == pytest.approx(5 * DEG) and ld.viscous == pytest.approx(0.001 / DEG)
    assert (ld.static_coefficient, ld.preload) == (0.3, 20.0)
    q = tmp_path / "back.toml"
    linkdyn.save(m, q)
    back = linkdyn.load(q).loads[0]
    assert (back.kind, back.joint, back.name, back.body, back.body2) == (
        ld.kind, ld.joint, ld.name, ld.body, ld.body2)
    for key in ("coefficient", "radius", "transition_speed", "static_coefficient",
                "stiction_speed", "viscous", "preload"):
        assert getattr(back, key) == pytest.approx(getattr(ld, key), rel=1e-14)
    p.write_text(TOML.replace("{extra}", ""))   # the default transition speed
    assert linkdyn.load(p).loads[0].transition_speed == 0.01


@pytest.mark.parametrize("edit, field", [
    (lambda s: s.replace("radius = 10\n", ""), "loads.pin.radius"),
    (lambda s: s.replace("coefficient = 0.25", "coefficient = -1"), "loads.pin.coefficient"),
    (lambda s: s.replace('joint = "J1"\ncoeff', 'joint = "J9"\ncoeff'), "loads.pin.joint"),
    (lambda s: s.replace("{extra}", "transition_speed = 0"), "loads.pin.transition_speed"),
])
def test_bad_friction_is_exit_2_naming_the_field(tmp_path, edit, field):
    p = tmp_path / "m.toml"
    p.write_text(edit(TOML).replace("{extra}", ""))
    with pytest.raises(ModelError) as err:
        linkdyn.load(p)
    assert err.value.field == field
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["analyze", str(p), "-o", str(out)])
    assert res.exit_code == 2 and field in res.output and "Traceback" not in res.output
    assert not out.exists()


def test_cli_reports_friction(tmp_path):
    p = tmp_path / "m.toml"
    p.write_text(TOML.replace("{extra}", ""))
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["analyze", str(p), "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "friction:" in res.output and "efficiency" in res.output
    import pandas as pd
    df = pd.read_csv(out / "results.csv")
    assert {"friction_J1", "friction_power_J1"} <= set(df.columns)
    s = json.loads((out / "summary.json").read_text())["friction"]
    # one turn at 1 rev/s: the energy lost is the integral of mu r |F| w (computed here)
    sol = analyze(linkdyn.load(p), np.linspace(0, 1, 73))
    lost = np.trapezoid(0.25 * 0.01 * np.linalg.norm(sol.reaction("J1"), axis=-1)
                        * np.tanh(2 * math.pi / 0.01) * 2 * math.pi, sol.t)
    assert s["joints"]["J1"]["energy_lost_J"] == pytest.approx(lost, rel=1e-9)
    assert s["energy_lost_per_cycle_J"] == pytest.approx(lost, rel=1e-9)
    # no load takes work out over the turn (gravity's is zero): all the input is lost
    assert s["efficiency"] == pytest.approx(0.0, abs=1e-9)
    assert s["newton_iterations"] >= 1 and s["residual_rel"] <= 1e-12


BRAKE = '[[loads]]\nkind = "torque"\nname = "brake"\nbody = "crank"\nvalue = -0.5'


def test_output_load_efficiency_from_the_model_file(tmp_path):
    """``[analysis] output`` names the brake on the crank: at 1 rev/s it takes 0.5 N m x 2 pi
    rad/s = pi W, so over the turn (gravity's work and the kinetic energy's change are zero)
    the efficiency is pi / (pi + the pin's friction loss); the file writes it back."""
    p = tmp_path / "m.toml"
    p.write_text(TOML.replace("{extra}", BRAKE) + 'output = ["brake"]\n')
    m = linkdyn.load(p)
    assert m.output == ("brake",)
    linkdyn.save(m, tmp_path / "back.toml")
    assert linkdyn.load(tmp_path / "back.toml").output == ("brake",)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["analyze", str(p), "-o", str(out), "--units", "model"])
    assert res.exit_code == 0, res.output
    assert "output (brake)" in res.output
    import pandas as pd
    df = pd.read_csv(out / "results.csv")
    col = next(k for k in df.columns if k.startswith("output_power"))
    np.testing.assert_allclose(df[col], math.pi, rtol=1e-12)
    summ = json.loads((out / "summary.json").read_text())
    s, lost = summ["output"], summ["friction"]["energy_lost_J"]
    assert s["output_work_J"] == pytest.approx(math.pi, rel=1e-12)
    assert s["efficiency"] == pytest.approx(math.pi / (math.pi + lost), rel=1e-9)
    # instantaneously gravity lends and takes back power: eta(t) spans the cycle's value
    assert 0 < s["efficiency_least"] < s["efficiency"] < s["efficiency_largest"]
    # the report's key results carry them
    from linkdyn import report
    sol = analyze(m, np.linspace(0, 1, 73))
    html = report.render(sol, summ)
    assert "efficiency to brake" in html and "Instantaneous efficiency" in html
    items = {it["label"]: it for it in report.key_results(sol, summ)}
    assert items["efficiency to brake"]["value"] == pytest.approx(100 * s["efficiency"])
    assert items["least instantaneous efficiency"]["value"] == pytest.approx(
        100 * s["efficiency_least"], rel=1e-12)
    assert items["energy lost in friction"]["value"] == lost


@pytest.mark.parametrize("names", ['["pin"]', '["nope"]', '"brake"', '["brake", "brake"]'])
def test_bad_output_is_exit_2_naming_the_field(tmp_path, names):
    p = tmp_path / "m.toml"
    p.write_text(TOML.replace("{extra}", BRAKE) + f"output = {names}\n")
    with pytest.raises(ModelError) as err:
        linkdyn.load(p)
    assert err.value.field.startswith("analysis.output")
    res = CliRunner().invoke(main, ["analyze", str(p), "-o", str(tmp_path / "out")])
    assert res.exit_code == 2 and "analysis.output" in res.output


def test_locking_mechanism_is_exit_3(tmp_path):
    m = pushed_up_an_incline(35 * DEG, 1.05 * math.tan(35 * DEG))
    p = tmp_path / "wedge.toml"
    linkdyn.save(dataclasses.replace(m, duration=0.5, samples=6), p)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["analyze", str(p), "-o", str(out)])
    assert res.exit_code == 3 and "locks at joint J2" in res.output
    assert "Traceback" not in res.output and not out.exists()


def test_sweep_metrics_friction_loss_and_efficiency(tmp_path):
    """A sweep's friction metrics are each design's own run's energy lost and efficiency."""
    p = tmp_path / "m.toml"
    # a brake torque on the crank makes the efficiency a real fraction
    p.write_text(TOML.replace("{extra}", BRAKE) + 'output = ["brake"]\n')
    m = linkdyn.load(p)
    t = np.linspace(0, 1, 73)
    masses = [0.6, 1.2, 2.4]
    df = linkdyn.sweep(m, {"bodies.crank.mass": masses}, t,
                       metrics=["friction_loss", "efficiency", "output_efficiency"])
    for k, mass in enumerate(masses):
        one = dataclasses.replace(m, bodies=tuple(
            dataclasses.replace(b, mass=mass) if b.name == "crank" else b for b in m.bodies))
        sol = analyze(one, t)
        lost = -np.trapezoid(sol.friction.power[0], t)
        work = np.trapezoid(sol.driver_power, t)
        assert df["friction_loss"][k] == pytest.approx(lost, rel=1e-9)
        assert df["efficiency"][k] == pytest.approx(1 - lost / work, rel=1e-9)
        # the brake takes 0.5 N m x 2 pi out over the turn: the rest of the work is lost
        assert work == pytest.approx(lost + 0.5 * 2 * math.pi, rel=1e-6)
        assert 0.5 < df["efficiency"][k] < 1
        # the work into the named output, the brake, over the drivers' work
        assert df["output_efficiency"][k] == pytest.approx(math.pi / work, rel=1e-9)
    from linkdyn.studies import metrics
    assert metrics.sense("efficiency") == metrics.sense("output_efficiency") == "max"


@pytest.mark.parametrize("stiction, mu_eff", [(1e-3, 0.2), (1e6, 0.45)])
def test_incline_with_static_coefficient_viscous_and_preload(stiction, mu_eff):
    """Pushed up at 0.5 m/s: F = W sin + mu (W cos + P0) + b v, with mu the dynamic coefficient
    far above the stiction speed and the static one far below it."""
    angle, mass, v, b, p0 = 25 * DEG, 2.0, 0.5, 3.0, 7.0
    m = incline_block(angle, 0.0, v, mass)
    m = dataclasses.replace(m, loads=(joint_friction(
        m, "J1", 0.2, transition_speed=1e-9, static_coefficient=0.45, stiction_speed=stiction,
        viscous=b, preload=p0),))
    sol = analyze(m, np.linspace(0, 1, 5))
    W = mass * G
    expect = W * math.sin(angle) + mu_eff * (W * math.cos(angle) + p0) + b * v
    check(sol.dyn.tau[..., 0], np.full(5, expect), 1e-12)


def test_sweep_varies_a_friction_coefficient(tmp_path):
    """A friction number as a design parameter reaches each design: the pin's loss is
    proportional to its coefficient (the crank's pin force does not depend on it)."""
    p = tmp_path / "m.toml"
    p.write_text(TOML.replace("{extra}", ""))
    mus = [0.1, 0.2, 0.4]
    df = linkdyn.sweep(p, {"loads.pin.coefficient": mus}, np.linspace(0, 1, 73),
                       metrics=["friction_loss"])
    loss = df["friction_loss"].to_numpy()
    one = analyze(linkdyn.load(p), np.linspace(0, 1, 73))
    ref = -np.trapezoid(one.friction.power[0], one.t) / 0.25
    np.testing.assert_allclose(loss, ref * np.array(mus), rtol=1e-9)
