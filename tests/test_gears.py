"""The gear pair and the rack and pinion against independent references.

a. closed forms of a gear train on fixed centres (external and internal) and of a rack driven
   by a pinion: the speed ratio, the torque ratio and the tooth force along the line of action
   (``|F| = tau_in / (r_a cos(pressure angle))`` for massless gears), the bearing carrying the
   separating force;
b. the dense explicit-matrix reference (``linkdyn.dynamics.dense``);
c. a simultaneous Newton-Euler solve written here: the tooth force applied at the pitch point
   (found here from the centres and radii), tangential unknown, its radial part at the pressure
   angle separating the gears;
d. power balance by finite differences of the energy;
e. finite differences of every joint's coordinate and rate (the gear's and the rack's cut
   coordinate included), and of the bodies' angles;
f. both backends equal; ``simulate`` of a geared mechanism without damping conserves energy;
g. the reader, the topology and the assembly: refused numbers (exit 2), a centre distance that
   is not the pitch radii's (exit 3, naming the joint), the bundled geared five-bar.

The models move their gears' centres (a planet on a carrier, a rack guided on a turning arm)
so that the terms of a moving line of centres and of a turning rack enter.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import linkdyn
from linkdyn import compiled
from linkdyn.analysis import analyze
from linkdyn.dynamics import dense
from linkdyn.errors import AssemblyError, ModelError
from linkdyn.model import Driver, Joint, Load, Model
from linkdyn.motion import ExpressionMotion

from builders import DEG, MM, body, pri, rev
from test_dynamics import (applied, body_states, check, check_reactions, cross,
                           five_point_derivative, kinetic_energy, perp, rot, size_of)

PA = 20 * DEG
GRAVITY = np.array([0.4, -9.81])


def gear(name, a, b, ra, rb, internal=0, pa=PA, phase=0.0):
    """A gear pair ``connect = [a, b]``, pitch radii in mm."""
    (ba, qa), (bb, qb) = a.split("."), b.split(".")
    return Joint(name, "gear", ba, qa, bb, qb, radius_a=ra * MM, radius_b=rb * MM,
                 internal=internal, pressure_angle=pa, phase=phase)


def rack(name, a, b, radius, axis=(1.0, 0.0), offset=0.0, pa=PA):
    """A rack on a's point along ``axis`` and a pinion of ``radius`` (mm) centred at b's point."""
    (ba, qa), (bb, qb) = a.split("."), b.split(".")
    return Joint(name, "rack", ba, qa, bb, qb, axis=np.array(axis, float), radius=radius * MM,
                 offset=offset * MM, pressure_angle=pa)


def torque(b, value):
    return Load("torque", b, value=lambda t: value * (1.0 + 0.3 * np.sin(2.0 * np.asarray(t))))


def force(b, point, fx, fy):
    return Load("force", b, point, value=lambda t: np.stack(np.broadcast_arrays(
        fx * (1.0 + 0.3 * np.cos(3.0 * np.asarray(t))), fy), axis=-1))


DRIVE = "0.4 + 2.0*t + 0.6*sin(3*t)"


def train(internal=0, ideal=False):
    """Two gears on ground pivots, the first driven; a load torque on the second. ``ideal``:
    mass centres on the centres, no gravity (the closed form's setting)."""
    ra, rb, dist = (60.0, 20.0, 40.0) if internal else (30.0, 60.0, 90.0)
    com1, com2 = ((0, 0), (0, 0)) if ideal else ((4, 2), (-3, 5))
    bodies = (body("ground", {"O1": (0, 0), "O2": (dist * math.cos(0.3), dist * math.sin(0.3))}),
              body("g1", {"O": (0, 0)}, 0.5, com1, 300.0),
              body("g2", {"O": (0, 0)}, 1.2, com2, 2500.0))
    joints = (rev("J1", "ground.O1", "g1.O"), rev("J2", "ground.O2", "g2.O"),
              gear("G", "g1.O", "g2.O", ra, rb, internal, phase=0.2))
    return Model("train", bodies, joints, (Driver("J1", ExpressionMotion(DRIVE)),),
                 (torque("g2", 1.5),), np.zeros(2) if ideal else GRAVITY,
                 assembly_phi={"g1": 0.0, "g2": 0.0})


def planetary(internal=0):
    """A sun (or ring) gear fixed to the ground, a planet on a driven carrier: the line of
    centres turns (moving centres). The carrier turns within (-pi, pi)."""
    ra, rb = (60.0, 20.0) if internal else (30.0, 15.0)
    arm = ra - rb if internal else ra + rb
    bodies = (body("ground", {"O": (0, 0)}),
              body("carrier", {"O": (0, 0), "C": (arm, 0)}, 0.4, (arm / 2, 3), 600.0),
              body("planet", {"C": (0, 0), "T": (rb, 0)}, 0.3, (2, -1), 80.0))
    joints = (rev("J1", "ground.O", "carrier.O"), rev("J2", "carrier.C", "planet.C"),
              gear("G", "ground.O", "planet.C", ra, rb, internal))
    return Model("planetary", bodies, joints,
                 (Driver("J1", ExpressionMotion("0.3 + 1.1*sin(2*t)")),),
                 (torque("planet", -0.2), force("planet", "T", 3.0, -2.0)), GRAVITY,
                 assembly_phi={"carrier": 0.3, "planet": 0.0})


def rack_and_pinion():
    """A driven pinion on a ground pivot moves a rack that slides on the ground."""
    bodies = (body("ground", {"O": (0, 30), "S": (0, 0)}),
              body("pinion", {"O": (0, 0)}, 0.3, (1, 2), 150.0),
              body("bar", {"S": (0, 0), "E": (200, 0)}, 1.5, (80, -5), 9000.0))
    joints = (rev("J1", "ground.O", "pinion.O"), pri("J2", "ground.S", "bar.S"),
              rack("R", "bar.S", "pinion.O", 30.0))
    return Model("rack", bodies, joints, (Driver("J1", ExpressionMotion(DRIVE)),),
                 (force("bar", "E", -20.0, 5.0),), GRAVITY,
                 assembly_phi={"pinion": 0.0, "bar": 0.0}, assembly_q={"J2": 0.0})


def rack_on_arm():
    """A rack guided on a driven arm that turns about the pinion's pivot, the pinion driven
    too: the rack turns (the rate of its axis enters)."""
    bodies = (body("ground", {"O": (0, 0)}),
              body("arm", {"O": (0, 0), "S": (0, -25)}, 0.6, (10, -10), 900.0),
              body("bar", {"S": (0, 0), "E": (120, 0)}, 0.8, (60, 0), 2000.0),
              body("pinion", {"O": (0, 0)}, 0.2, (1, 0), 60.0))
    joints = (rev("J1", "ground.O", "arm.O"), pri("J2", "arm.S", "bar.S"),
              rev("J3", "ground.O", "pinion.O"), rack("R", "bar.S", "pinion.O", 25.0))
    drivers = (Driver("J1", ExpressionMotion("0.2 + 0.5*sin(2*t)")),
               Driver("J3", ExpressionMotion("0.2 - 1.5*t")))
    return Model("rack-on-arm", bodies, joints, drivers, (force("bar", "E", 2.0, -6.0),),
                 GRAVITY, assembly_phi={"arm": 0.2, "bar": 0.2, "pinion": 0.2},
                 assembly_q={"J2": 0.0})


def example():
    return linkdyn.load(linkdyn.example_path("geared_fivebar"))


MODELS = {
    "train": train,
    "train-internal": lambda: train(1),
    "planetary": planetary,
    "planetary-internal": lambda: planetary(1),
    "rack": rack_and_pinion,
    "rack-on-arm": rack_on_arm,
    "geared-fivebar": example,
}
T = np.linspace(0.0, 1.3, 15)
_SOLUTIONS: dict = {}


def solution(name):
    if name not in _SOLUTIONS:
        _SOLUTIONS[name] = analyze(MODELS[name](), T, backend="numpy")
    return _SOLUTIONS[name]


def index(model, name):
    return [j.name for j in model.joints].index(name)


# ----------------------------------------------------------------------------------------------
# a. closed forms


@pytest.mark.parametrize("internal", [0, 1])
def test_gear_train_closed_form(internal):
    model = train(internal, ideal=True)
    sol = analyze(model, T)
    jt = model.joint("G")
    ra, rb = jt.radius_a, jt.radius_b
    s = -1.0 if internal else 1.0
    g1, g2 = model.body("g1"), model.body("g2")
    # speed ratio: w_2 = -s (r_a / r_b) w_1 (external opposite, internal the same way)
    check(sol.omega("g2"), -s * ra / rb * sol.omega("g1"), 1e-12, what="speed ratio")
    check(sol.alpha("g2"), -s * ra / rb * sol.alpha("g1"), 1e-12, what="acceleration ratio")
    # torques: gear 2  I_2 al_2 = T_load - F_t r_b,  gear 1  I_1 al_1 = tau - F_t r_a (F_t the
    # tangential force on gear 1's teeth against its rotation, on gear 2's along s)
    load = 1.5 * (1.0 + 0.3 * np.sin(2.0 * T))
    f_t = s * (load - g2.inertia * sol.alpha("g2")) / rb
    tau = g1.inertia * sol.alpha("g1") + ra * f_t
    check(sol.dyn.tau[:, 0], tau, 1e-10, what="driver torque")
    # the tooth force along the line of action: |F| = |F_t| / cos(pressure angle), at the
    # pressure angle to the common tangent; the bearing of gear 2 holds it
    F = sol.reactions.force[:, index(model, "G")]
    check(np.linalg.norm(F, axis=-1), np.abs(f_t) / math.cos(PA), 1e-10, what="|tooth force|")
    u = sol.point("g2", "O") - sol.point("g1", "O")
    u = u / np.linalg.norm(u, axis=-1)[:, None]
    tangential, radial = np.abs(cross(u, F)), np.sum(F * u, -1)
    check(np.arctan2(np.abs(radial), tangential), np.full(T.shape, PA), 1e-10,
          what="pressure angle")
    assert np.all(s * radial > 0), "the radial part separates the gears"
    check(sol.reactions.force[:, index(model, "J2")], -F, 1e-10, what="bearing of gear 2")
    # massless gears: |F| = tau_in / (r_a cos phi), the torque ratio r_b / r_a
    light = dataclasses.replace(model, bodies=tuple(
        dataclasses.replace(b, mass=0.0, inertia=0.0) for b in model.bodies))
    sl = analyze(light, T)
    check(np.linalg.norm(sl.reactions.force[:, index(model, "G")], axis=-1),
          np.abs(sl.dyn.tau[:, 0]) / (ra * math.cos(PA)), 1e-10, what="massless tooth force")
    check(sl.dyn.tau[:, 0], s * ra / rb * load, 1e-10, what="torque ratio")


def test_rack_and_pinion_closed_form():
    model = rack_and_pinion()
    sol = analyze(model, T)
    r = model.joint("R").radius
    # the rack moves with the pinion's pitch point below its centre: x = r phi (the pinion
    # on the rack's left, above it)
    check(sol.kin.q[:, index(model, "J2")], r * sol.phi("pinion"), 1e-12, what="travel")
    check(sol.kin.qd[:, index(model, "J2")], r * sol.omega("pinion"), 1e-12, what="speed")
    # the rack's own coordinate: the pinion centre's travel along it, d . e = -x
    check(sol.kin.q[:, index(model, "R")], -sol.kin.q[:, index(model, "J2")], 1e-12,
          what="rack coordinate")
    F = sol.reactions.force[:, index(model, "R")]
    check(np.abs(F[:, 1]), np.abs(F[:, 0]) * math.tan(PA), 1e-10, what="line of action")
    assert np.all(F[:, 1] > 0), "the radial part pushes the pinion off the rack"
    check(np.linalg.norm(F, axis=-1), np.abs(sol.dyn.lam[:, 0]) / math.cos(PA), 1e-12,
          what="|tooth force|")


# ----------------------------------------------------------------------------------------------
# b. dense reference


@pytest.mark.parametrize("name", list(MODELS))
def test_recursive_matches_dense(name):
    sol = solution(name)
    model, kin = sol.model, sol.kin
    assert np.all(sol.valid)
    d = dense.solve(model, kin, sol.loads.w_ext)
    check(d.twist, kin.tw, what="N qd vs twists")
    check(d.J, kin.J, 1e-12, scale=max(np.max(np.abs(kin.J)), 1.0), what="J")
    check(sol.dyn.tau, d.tau, what="tau")
    check(sol.dyn.lam, d.lam, scale=np.max(np.abs(d.force)) * max(size_of(model), 1.0),
          what="lambda")
    check_reactions(sol.reactions.force, sol.reactions.moment, d.force, d.moment, model,
                    size_of(model), what="recursive vs dense")


# ----------------------------------------------------------------------------------------------
# c. simultaneous Newton-Euler solve

UNKNOWNS = {"revolute": 2, "prismatic": 2, "gear": 1, "rack": 1}  # reaction unknowns per kind


def contact(sol, jt, sign):
    """A gear's or rack's pitch point (T, 2) and the tooth force on the second body per unit
    tangential force (T, 2), for the sign of the tangential force ``sign`` (T,): the radial
    part ``tan(pressure angle)`` separating the two."""
    tan = math.tan(jt.pressure_angle)
    cb = sol.point(jt.body_b, jt.point_b)
    if jt.kind == "gear":
        ca = sol.point(jt.body_a, jt.point_a)
        u = (cb - ca) / np.linalg.norm(cb - ca, axis=-1)[..., None]
        s = -1.0 if jt.internal else 1.0
        # the pitch point on the line of centres at r_a from C_a; the tangent -perp(u)
        return ca + jt.radius_a * u, -perp(u) + (s * tan * sign)[..., None] * u
    phi_a = sol.phi(jt.body_a) if jt.body_a != "ground" else np.zeros(sol.t.shape)
    e = rot(phi_a, np.asarray(jt.axis, float))
    n = perp(e)
    # the pitch point below the pinion's centre; the tangent along the rack
    return cb - jt.radius * n, e + (tan * sign)[..., None] * n


def ne_solve(sol, sign=None):
    """Efforts (T, nd), joint forces (T, nj, 2) and the tangential forces (T, nj) by every
    moving body's Newton-Euler equations about its mass centre, all unknowns at once; a gear's
    radial force follows its tangential force's ``sign`` (from a first solve without it)."""
    model = sol.model
    states = body_states(sol)
    names = [b.name for b in model.moving_bodies]
    row = {b: 3 * k for k, b in enumerate(names)}
    Tn = sol.t.shape
    col = np.cumsum([0] + [UNKNOWNS[j.kind] for j in model.joints])
    nj, nd = int(col[-1]), len(model.drivers)
    K = np.zeros(Tn + (3 * len(names), nj + nd))
    rhs = np.zeros(Tn + (3 * len(names),))

    def put(b, c, f, x, mz=0.0):
        if b in row:
            K[..., row[b], c] += f[..., 0]
            K[..., row[b] + 1, c] += f[..., 1]
            K[..., row[b] + 2, c] += cross(x - states[b].rC, f) + mz

    zero = np.zeros(Tn + (2,))
    axes = {}
    for k, jt in enumerate(model.joints):
        c, x = col[k], sol.point(jt.body_b, jt.point_b)
        if jt.kind == "revolute":
            for m, f in ((c, (1.0, 0.0)), (c + 1, (0.0, 1.0))):
                f = np.broadcast_to(np.array(f), Tn + (2,))
                put(jt.body_b, m, f, x)
                put(jt.body_a, m, -f, x)
        elif jt.kind == "prismatic":
            phi_a = sol.phi(jt.body_a) if jt.body_a != "ground" else np.zeros(Tn)
            e = rot(phi_a, np.asarray(jt.axis, float))
            axes[jt.name] = e
            put(jt.body_b, c, perp(e), x)
            put(jt.body_a, c, -perp(e), x)
            put(jt.body_b, c + 1, zero, x, 1.0)
            put(jt.body_a, c + 1, zero, x, -1.0)
        else:
            sg = np.zeros(Tn) if sign is None else sign[..., k]
            p, f = contact(sol, jt, sg)
            put(jt.body_b, c, f, p)
            put(jt.body_a, c, -f, p)
    for d, drv in enumerate(model.drivers):
        jt = model.joint(drv.joint)
        x = sol.point(jt.body_b, jt.point_b)
        if jt.kind == "revolute":
            put(jt.body_b, nj + d, zero, x, 1.0)
            put(jt.body_a, nj + d, zero, x, -1.0)
        else:
            put(jt.body_b, nj + d, axes[jt.name], x)
            put(jt.body_a, nj + d, -axes[jt.name], x)
    F, Mc, _, _ = applied(sol, states)
    for b in model.moving_bodies:
        s, r0 = states[b.name], row[b.name]
        rhs[..., r0:r0 + 2] = b.mass * s.aC - F[b.name]
        rhs[..., r0 + 2] = b.inertia * s.al - Mc[b.name]
    x = np.linalg.solve(K, rhs[..., None])[..., 0]
    force = np.zeros(Tn + (len(model.joints), 2))
    tangential = np.zeros(Tn + (len(model.joints),))
    for k, jt in enumerate(model.joints):
        c = col[k]
        if jt.kind == "revolute":
            force[..., k, :] = x[..., c:c + 2]
        elif jt.kind == "prismatic":
            force[..., k, :] = x[..., c, None] * perp(axes[jt.name])
        else:
            tangential[..., k] = x[..., c]
            sg = np.zeros(Tn) if sign is None else sign[..., k]
            force[..., k, :] = x[..., c, None] * contact(sol, jt, sg)[1]
    if sign is None:   # again, with the radial forces of the tangential ones found
        return ne_solve(sol, np.sign(tangential))
    return x[..., nj:], force, tangential


@pytest.mark.parametrize("name", list(MODELS))
def test_recursive_matches_simultaneous_newton_euler(name):
    sol = solution(name)
    model = sol.model
    tau, force, tangential = ne_solve(sol)
    check(sol.dyn.tau, tau, what="tau")
    fs = np.max(np.abs(force))
    for k, jt in enumerate(model.joints):
        check(sol.reactions.force[:, k], force[:, k], scale=fs, what=f"reaction {jt.name}")
        if jt.kind in ("gear", "rack"):   # the multiplier is the tangential force
            rows = sol.kin.layout.topo.row_slice(sol.kin.layout.topo.cut.index(k))
            check(sol.dyn.lam[:, rows][:, 0], tangential[:, k], scale=fs,
                  what=f"tangential force {jt.name}")


def test_newton_euler_reference_is_not_trivially_satisfied():
    """Guard: a tooth force without its radial part fails the comparison."""
    sol = solution("train")
    _, force, _ = ne_solve(sol)
    k = index(sol.model, "G")
    u = sol.point("g2", "O") - sol.point("g1", "O")
    u /= np.linalg.norm(u, axis=-1)[:, None]
    f = sol.reactions.force[:, k]
    tangential_only = f - np.sum(f * u, -1)[:, None] * u
    assert np.max(np.abs(tangential_only - force[:, k])) > 1e-3 * np.max(np.abs(force[:, k]))


# ----------------------------------------------------------------------------------------------
# d. power balance


@pytest.mark.parametrize("name", list(MODELS))
def test_power_balance(name):
    model = MODELS[name]()
    h = 1e-3
    centres = np.linspace(0.05, 1.2, 7)
    t = (centres[:, None] + np.arange(-2, 3) * h).reshape(-1)
    sol = analyze(model, t, backend="numpy")
    states = body_states(sol)
    _, _, pe, p_nc = applied(sol, states)
    ke = kinetic_energy(sol, states)
    check(sol.dyn.kinetic_energy, ke, 1e-12, what="kinetic energy")
    qd = sol.kin.qd[:, [index(model, d.joint) for d in model.drivers]]
    p_drv = np.sum(sol.dyn.tau * qd, -1)
    dEdt = five_point_derivative((ke + pe).reshape(len(centres), 5), h)
    lhs = (p_drv + p_nc).reshape(len(centres), 5)[:, 2]
    scale = max(np.max(np.abs(p_drv)), np.max(np.abs(p_nc)), np.max(np.abs(dEdt)))
    check(lhs, dEdt, 1e-7, scale=scale, what="driver + load power vs dE/dt")


# ----------------------------------------------------------------------------------------------
# e. finite differences of positions and rates


@pytest.mark.parametrize("name", list(MODELS))
def test_rates_match_finite_differences(name):
    model = MODELS[name]()
    h = 1e-4
    centres = np.linspace(0.05, 1.2, 6)
    t = (centres[:, None] + np.arange(-2, 3) * h).reshape(-1)
    sol = analyze(model, t, backend="numpy")
    assert np.all(sol.valid)
    kin = sol.kin
    shape = (len(centres), 5, -1)
    for x, dx, what in ((kin.q, kin.qd, "qd"), (kin.qd, kin.qdd, "qdd")):
        fd = five_point_derivative(np.moveaxis(x.reshape(shape), 1, -1), h)
        exact = dx.reshape(shape)[:, 2]
        check(exact, fd, 1e-7, scale=np.max(np.abs(exact)) + 1e-9, what=what)
    # the closure residual vanishes
    assert np.max(np.abs(kin.residual)) < 1e-10 * size_of(model)


# ----------------------------------------------------------------------------------------------
# f. backends, simulate


needs_numba = pytest.mark.skipif(compiled.numba is None, reason="needs numba")


@needs_numba
def test_both_backends_agree():
    for name in MODELS:
        a = analyze(MODELS[name](), T, backend="compiled").columns
        b = solution(name).columns
        # each column at the peak of its kind's (a column zero to rounding, such as a driven
        # joint's acceleration, at its siblings' scale: the backends' rounding differs)
        peak = {}
        for col, v in b.items():
            kind = col.split("_")[0]
            peak[kind] = max(peak.get(kind, 0.0), float(np.max(np.abs(v))))
        for col, v in b.items():
            scale = max(peak[col.split("_")[0]], 1e-9)
            assert np.max(np.abs(a[col] - v)) <= 1e-10 * scale, (name, col)


def free_train():
    """The gear train without a driver, released with a speed, under gravity alone."""
    m = train()
    return dataclasses.replace(m, drivers=(), loads=(), initial_q={"J1": 0.2},
                               initial_qd={"J1": 3.0})


def free_planetary():
    m = planetary()
    return dataclasses.replace(m, drivers=(), loads=(), initial_q={"J1": 0.3},
                               initial_qd={"J1": -1.0})


@pytest.mark.parametrize("backend", ["numpy", pytest.param("compiled", marks=needs_numba)])
@pytest.mark.parametrize("make", [free_train, free_planetary])
def test_simulate_conserves_energy(make, backend):
    t = np.linspace(0.0, 0.8, 41)
    sol = linkdyn.simulate(make(), t, rtol=1e-10, atol=1e-12, backend=backend)
    energy = sol.dyn.kinetic_energy + sol.loads.potential_energy
    scale = np.max(np.abs(sol.dyn.kinetic_energy)) + np.ptp(sol.loads.potential_energy)
    assert np.ptp(sol.loads.potential_energy) > 1e-3 * scale   # the motion is not trivial
    assert np.max(np.abs(energy - energy[0])) < 1e-6 * scale


# ----------------------------------------------------------------------------------------------
# g. reader, topology, assembly


GEAR_TEXT = """
[mechanism]
name = "pair"
[units]
length = "mm"
angle = "deg"
[[bodies]]
name = "ground"
points = { A = [0, 0], B = [90, 0] }
[[bodies]]
name = "g1"
points = { O = [0, 0] }
mass = 1.0
inertia = 100.0
[[bodies]]
name = "g2"
points = { O = [0, 0] }
mass = 1.0
inertia = 100.0
[[joints]]
name = "J1"
type = "revolute"
connect = ["ground.A", "g1.O"]
[[joints]]
name = "J2"
type = "revolute"
connect = ["ground.B", "g2.O"]
[[joints]]
name = "G"
type = "gear"
connect = ["g1.O", "g2.O"]
radius_a = 30.0
radius_b = 60.0
[[drivers]]
joint = "J1"
motion = { kind = "constant_speed", rpm = 60.0 }
"""


def read(text):
    return linkdyn.io.model_from_dict(__import__("tomllib").loads(text), source="pair.toml")


def test_the_reader_takes_a_gear_in_the_files_units():
    m = read(GEAR_TEXT)
    g = m.joint("G")
    assert g.kind == "gear" and g.radius_a == pytest.approx(0.03) and g.radius_b == 0.06
    assert g.pressure_angle == pytest.approx(20 * DEG) and g.internal == 0
    topo = linkdyn.topology.build(m)
    assert topo.mobility == 1 and index(m, "G") in topo.cut


@pytest.mark.parametrize("old, new, words", [
    ("radius_b = 60.0", "radius_b = 0.0", "radius_a and radius_b must be positive"),
    ("radius_b = 60.0", "radius_b = 60.0\ninternal = 2", "internal must be 0"),
    ("radius_b = 60.0", "radius_b = 60.0\naxis = [1, 0]", "a gear joint has no axis"),
])
def test_reader_refuses_bad_gear_numbers(old, new, words):
    with pytest.raises(ModelError) as err:
        read(GEAR_TEXT.replace(old, new))
    assert words in str(err.value) and "pair.toml" in str(err.value)


def test_a_centre_distance_that_is_not_the_radii_is_refused_naming_the_joint():
    m = read(GEAR_TEXT.replace("radius_b = 60.0", "radius_b = 50.0"))
    with pytest.raises(AssemblyError) as err:
        analyze(m, np.linspace(0, 1, 5))
    text = str(err.value)
    assert "joint 'G'" in text and "90 mm" in text and "80 mm" in text and "t = 0" in text


def test_a_pinion_off_its_rack_is_refused_naming_the_joint():
    m = rack_and_pinion()
    off = dataclasses.replace(m, joints=m.joints[:2] + (rack("R", "bar.S", "pinion.O", 28.0),))
    with pytest.raises(AssemblyError) as err:
        analyze(off, T)
    assert "joint 'R' (rack)" in str(err.value) and "0.03 m, not 0.028 m" in str(err.value)


def test_the_cli_reports_the_misfit_with_exit_3(tmp_path, capsys):
    from linkdyn.cli import main
    p = tmp_path / "pair.toml"
    p.write_text(GEAR_TEXT.replace("radius_b = 60.0", "radius_b = 50.0"))
    with pytest.raises(SystemExit) as ex:
        main(["check", str(p)])
    assert ex.value.code == 3
    assert "joint 'G'" in capsys.readouterr().err


def test_the_bundled_geared_fivebar_meshes_and_its_gears_turn_opposite():
    sol = analyze(example(), np.linspace(0, 1, 37))
    check(sol.omega("gear2"), -sol.omega("gear1"), 1e-12, what="gears")
    k = index(sol.model, "G")
    F = sol.reactions.force[:, k]
    check(np.linalg.norm(F, axis=-1), np.abs(sol.dyn.lam[:, 0]) / math.cos(PA), 1e-12,
          what="tooth force")


# ----------------------------------------------------------------------------------------------
# h. MuJoCo: a gear train on fixed centres as two hinges coupled by a joint equality
#
# MuJoCo has no gear pair, but a train on fixed centres is its joint equality
# ``q_J2 = c0 + ratio q_J1`` (as Pinocchio's mimic joint). With linkdyn's motion loaded, MuJoCo's
# M qacc + qfrc_bias = S tau + J^T lam + qfrc_loads gives [tau; lam] by least squares: tau must
# be linkdyn's driver torque, and the equality's generalized force on J2, J[:, J2] lam, the tooth
# force's moment about gear 2's centre, s r_b lam_linkdyn. (linkdyn's plane is MuJoCo's (x, z),
# a counter-clockwise hinge is about -y; see tests/test_mujoco.py.)


@pytest.mark.parametrize("internal", [0, 1])
def test_gear_train_matches_mujoco_joint_equality(internal):
    mujoco = pytest.importorskip("mujoco", reason="the MuJoCo check needs mujoco (the mujoco extra)")
    from test_mujoco import load_forces

    def _xz(v):   # linkdyn (x, y) -> MuJoCo 'x 0 y'
        return f"{v[0]:.17g} 0 {v[1]:.17g}"

    model = train(internal)
    sol = analyze(model, T)
    jt = model.joint("G")
    s = -1.0 if internal else 1.0
    ra, rb, phase = jt.radius_a, jt.radius_b, jt.phase
    o1, o2 = model.body("ground").points["O1"], model.body("ground").points["O2"]
    alpha = math.atan2(o2[1] - o1[1], o2[0] - o1[0])
    ratio = -ra / (s * rb)
    c0 = alpha + phase - ratio * alpha
    g = model.gravity
    bodies = []
    for name, at in (("g1", o1), ("g2", o2)):
        b = model.body(name)
        bodies.append(
            f'<body name="{name}" pos="{_xz(at)}"><joint name="J{name[1]}" type="hinge" '
            f'axis="0 -1 0"/><inertial pos="{_xz(b.com)}" mass="{b.mass:.17g}" '
            f'diaginertia="{b.inertia:.17g} {b.inertia:.17g} {b.inertia:.17g}"/></body>')
    xml = (f'<mujoco><compiler angle="radian"/><option gravity="{g[0]:.17g} 0 {g[1]:.17g}" '
           f'jacobian="dense"/><worldbody>{"".join(bodies)}</worldbody><equality>'
           f'<joint joint1="J2" joint2="J1" polycoef="{c0:.17g} {ratio:.17g} 0 0 0"/>'
           f'</equality></mujoco>')
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    taus, torques = [], []
    for k in range(len(T)):
        d.qpos[:] = sol.phi("g1")[k], sol.phi("g2")[k]
        d.qvel[:] = sol.omega("g1")[k], sol.omega("g2")[k]
        mujoco.mj_forward(m, d)
        assert abs(d.efc_pos[0]) < 1e-12   # linkdyn's motion satisfies MuJoCo's equality
        M = np.zeros((2, 2))
        mujoco.mj_fullM(m, d, M)
        J = np.array(d.efc_J[:2]).reshape(1, 2)
        qacc = np.array([sol.alpha("g1")[k], sol.alpha("g2")[k]])
        rhs = M @ qacc + d.qfrc_bias - load_forces(model, m, d, T[k])
        A = np.hstack((np.array([[1.0], [0.0]]), J.T))
        x = np.linalg.solve(A, rhs)
        taus.append(x[0])
        torques.append(J[0, 1] * x[1])
    check(sol.dyn.tau[:, 0], np.array(taus), 1e-9, what="tau vs MuJoCo")
    check(s * rb * sol.dyn.lam[:, 0], np.array(torques), 1e-9, what="tooth moment vs MuJoCo")
