"""Free bodies in spatial models (``free = "P"``, issue 27): the reader writes the body's six
freedoms as the prismatic joints ``B_x``, ``B_y``, ``B_z`` and the revolute joints ``B_rx``,
``B_ry``, ``B_rz`` through massless carriages (``io.linkage.free_bodies``, the planar
reader's function).

Checked against means that share no code with the expansion:

- a body hanging from three vertical springs (stiffness k each, at 120 degrees about its mass
  centre): its vertical motion from rest is the mass-spring closed form ``z(t) = z_eq + (z0 -
  z_eq) cos(w t)``, ``w = sqrt(3 k / m)``, ``z_eq`` the springs' static stretch ``m g / (3 k)``
  below their free length; its energy (recomputed here from results.csv's points, quaternion
  and angular velocity) is constant; the same model written by hand with the explicit chain
  gives the same table; ``equilibrium`` gives the static stretch and ``modes`` the six
  closed-form frequencies (bounce, sway, tilt, yaw);
- a torque-free body spun about a tilted principal axis keeps its angular momentum
  ``R I R^T omega`` (and spins steadily about that axis);
- what cannot be represented is refused with exit 2 naming the field.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np
import pytest
from click.testing import CliRunner

import linkdyn
from linkdyn.cli import main
from linkdyn.modal import equilibrium

G = 9.81
M, K, L0, H, A = 2.0, 400.0, 0.5, 1.0, 0.2
INERTIA = [0.03, 0.03, 0.05]
STRETCH = M * G / (3 * K)
W = math.sqrt(3 * K / M)
ANGLES = [90.0, 210.0, 330.0]


def feet():
    """The springs' three body points (body frame, m), at 120 degrees about the mass centre."""
    return {f"S{k}": [A * math.cos(math.radians(a)), A * math.sin(math.radians(a)), 0.0]
            for k, a in enumerate(ANGLES)}


def springs() -> str:
    return "".join(f"""
[[loads]]
kind = "spring"
name = "spring{k}"
body = "ground"
point = "S{k}"
body2 = "puck"
point2 = "S{k}"
stiffness = {K}
free_length = {L0}
""" for k in range(3))


def _pts(d: dict) -> str:
    return "{ " + ", ".join(f"{n} = [{', '.join(repr(float(c)) for c in v)}]"
                            for n, v in d.items()) + " }"


def hanging(z0: float, by_hand: bool = False) -> str:
    """The puck (its point C at its mass centre) hanging from three springs to ground points
    right above its feet, released from rest with C at height ``z0``."""
    ground = {n: [x, y, H] for n, (x, y, _) in feet().items()}
    body = f"""
[[bodies]]
name = "puck"
points = {_pts({"C": [0.0, 0.0, 0.0], **feet()})}
mass = {M}
inertia = {INERTIA}
"""
    if by_hand:          # the explicit chain: ground -> x -> y -> z -> rx -> ry -> (rz) puck
        names = ["x", "y", "z", "rx", "ry", "rz"]
        axes = [[1, 0, 0], [0, 1, 0], [0, 0, 1]] * 2
        ground["O"] = [0.0, 0.0, 0.0]
        chain = "".join(f"""
[[bodies]]
name = "c{n}"
points = {{ O = [0.0, 0.0, 0.0] }}
mass = 0.0
inertia = [0.0, 0.0, 0.0]
""" for n in names[:-1])
        ends = ["ground.O"] + [f"c{n}.O" for n in names[:-1]] + ["puck.C"]
        chain += "".join(f"""
[[joints]]
name = "puck_{n}"
type = "{'prismatic' if k < 3 else 'revolute'}"
connect = ["{ends[k]}", "{ends[k + 1]}"]
axis = {axes[k]}
""" for k, n in enumerate(names))
    else:
        body += 'free = "C"\n'
        chain = ""
    return f"""
[mechanism]
name = "puck on springs"
space = "spatial"
gravity = [0.0, 0.0, {-G}]
[[bodies]]
name = "ground"
points = {_pts(ground)}
{body}{chain}{springs()}
[initial]
q = {{ puck_x = 0.0, puck_y = 0.0, puck_z = {z0}, puck_rx = 0.0, puck_ry = 0.0, puck_rz = 0.0 }}
"""


def read(text: str) -> linkdyn.Model:
    return linkdyn.model_from_dict(tomllib.loads(text))


Z_EQ = H - L0 - STRETCH
Z0 = Z_EQ + 0.03


def test_the_reader_writes_the_six_freedoms_as_named_joints():
    model = read(hanging(Z0))
    assert [j.name for j in model.joints] == [f"puck_{s}" for s in
                                              ("x", "y", "z", "rx", "ry", "rz")]
    carriages = [b for b in model.bodies if b.name.startswith("puck_")]
    assert [b.name for b in carriages] == ["puck_x", "puck_y", "puck_z", "puck_rx", "puck_ry"]
    assert all(b.mass == 0.0 and not np.any(b.inertia) for b in carriages)


@pytest.fixture(scope="module")
def run():
    # a little over one period of the bounce (2 pi / W = 0.26 s): the whole swing down and up,
    # 0.02 s between samples
    t = np.linspace(0.0, 0.3, 16)
    return t, {m: linkdyn.simulate(read(hanging(Z0, m)), t, rtol=1e-10, atol=1e-12)
               for m in (False, True)}


def test_a_hanging_body_bounces_as_the_mass_spring_closed_form(run):
    t, sims = run
    cols = sims[False].columns()
    want = Z_EQ + (Z0 - Z_EQ) * np.cos(W * t)
    np.testing.assert_allclose(cols["q_puck_z"], want, rtol=0, atol=1e-9)
    np.testing.assert_allclose(cols["z_puck.C"], want, rtol=0, atol=1e-9)
    for c in ("q_puck_x", "q_puck_y", "q_puck_rx", "q_puck_ry", "q_puck_rz"):
        np.testing.assert_allclose(cols[c], 0.0, rtol=0, atol=1e-9, err_msg=c)


def test_its_energy_is_constant(run):
    t, sims = run
    cols = sims[False].columns()
    z, vz = cols["z_puck.C"], cols["vz_puck.C"]
    spring = 0.0
    for k, (x, y, _) in enumerate(feet().values()):
        p = np.stack([cols[f"{c}_puck.S{k}"] for c in "xyz"], -1)
        length = np.linalg.norm(p - np.array([x, y, H]), axis=-1)
        spring = spring + 0.5 * K * (length - L0) ** 2
    energy = 0.5 * M * vz ** 2 + M * G * z + spring
    scale = 0.5 * 3 * K * (Z0 - Z_EQ) ** 2
    assert np.ptp(energy) < 1e-6 * scale
    assert abs(sims[False].energy_drift) < 1e-6


def test_it_equals_the_same_model_written_by_hand(run):
    _, sims = run
    free, hand = sims[False].columns(), sims[True].columns()
    shared = [c for c in free if c in hand and not c.startswith(("work",))]
    assert len(shared) > 50
    for c in shared:
        np.testing.assert_allclose(free[c], hand[c], rtol=1e-9, atol=1e-9, err_msg=c)


def test_equilibrium_is_the_static_stretch():
    eq = equilibrium(read(hanging(Z0)))
    q = dict(zip(eq.free, eq.q))
    assert H - L0 - q["puck_z"] == pytest.approx(STRETCH, abs=1e-12)
    for c in ("puck_x", "puck_y", "puck_rx", "puck_ry", "puck_rz"):
        assert q[c] == pytest.approx(0.0, abs=1e-12)


def spinning(omega: np.ndarray, v: np.ndarray) -> str:
    """A top with three different principal moments, tilted at its design pose, free at a
    point P off its mass centre, with no load: P's velocity ``v`` and the angular velocity
    ``omega`` (global, rad/s) at t = 0 (at the design pose the turns' axes are the global
    axes, so ``qd_rx, qd_ry, qd_rz`` are omega's components)."""
    rates = {"top_x": v[0], "top_y": v[1], "top_z": v[2],
             "top_rx": omega[0], "top_ry": omega[1], "top_rz": omega[2]}
    return f"""
[mechanism]
name = "torque-free top"
space = "spatial"
[units]
angle = "rad"
[[bodies]]
name = "ground"
points = {{ O = [0.0, 0.0, 0.0] }}
[[bodies]]
name = "top"
points = {{ P = [0.0, 0.0, 0.0], Q = [0.1, 0.0, 0.0] }}
com = [0.05, 0.02, -0.03]
mass = 1.5
inertia = [0.04, 0.05, 0.08]
origin = [0.3, -0.2, 0.1]
rotation = [0.3, -0.5, 0.2]
free = "P"
[initial]
q = {{ {", ".join(f"{c} = 0.0" for c in rates)} }}
qd = {{ {", ".join(f"{c} = {float(x)!r}" for c, x in rates.items())} }}
"""


@pytest.mark.parametrize("axis", [0, 2])
def test_a_torque_free_spin_about_a_principal_axis_keeps_its_angular_momentum(axis):
    probe = read(spinning(np.zeros(3), np.zeros(3)))
    top = probe.body("top")
    R0, c = np.asarray(top.rotation), np.asarray(top.com)
    omega = 3.0 * R0[:, axis]                           # the principal axis, global
    v = np.cross(omega, R0 @ (np.asarray(top.points["P"]) - c))   # P about a still centre
    model = read(spinning(omega, v))
    t = np.linspace(0.0, 0.8, 17)
    sim = linkdyn.simulate(model, t, rtol=1e-10, atol=1e-12)
    R, w = sim.rotation("top"), sim.omega("top")
    momentum = np.einsum("tij,jk,tlk,tl->ti", R, np.asarray(top.inertia), R, w)
    np.testing.assert_allclose(momentum, np.broadcast_to(momentum[0], momentum.shape), rtol=0,
                               atol=1e-8)
    np.testing.assert_allclose(momentum[0], R0 @ np.asarray(top.inertia) @ R0.T @ omega,
                               rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(w, np.broadcast_to(omega, w.shape), rtol=0, atol=1e-8)
    # steady spin: R(t) = exp(w t n) R0, the mass centre still
    n = omega / np.linalg.norm(omega)
    N = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    a = np.linalg.norm(omega) * t
    want = np.eye(3) + np.sin(a)[:, None, None] * N + (1 - np.cos(a))[:, None, None] * (N @ N)
    np.testing.assert_allclose(R, want @ R0, rtol=0, atol=1e-8)
    P = sim.point("top", "P")
    centre = P + np.einsum("tij,j->ti", R, c - np.asarray(top.points["P"]))
    np.testing.assert_allclose(centre, np.broadcast_to(centre[0], centre.shape), rtol=0, atol=1e-8)


@pytest.mark.parametrize("change, words", [
    (('free = "C"', 'free = "Z"'), ["bodies.puck.free", "'Z'"]),
    (('free = "C"', "free = 3"), ["bodies.puck.free", "point"]),
    (('name = "ground"\n', 'name = "ground"\nfree = "O"\n'), ["bodies.ground.free"]),
    (("[[loads]]", '[[bodies]]\nname = "puck_rx"\npoints = { O = [0, 0, 0] }\nmass = 1\n'
                   'inertia = [1, 1, 1]\n[[loads]]'), ["bodies.puck.free", "puck_rx"]),
    (("points = { S0", "points = { puck_origin = [0, 0, 0], S0"),
     ["bodies.puck.free", "puck_origin"]),
    (("mass = 2.0", 'mass = 2.0\norigin = "up"'), ["bodies.puck.origin"]),
])
def test_what_cannot_be_represented_is_refused_naming_the_field(change, words, tmp_path):
    text = hanging(Z0)
    assert change[0] in text
    file = tmp_path / "m.toml"
    file.write_text(text.replace(change[0], change[1], 1))
    res = CliRunner().invoke(main, ["check", str(file)])
    assert res.exit_code == 2 and "Traceback" not in res.output, res.output
    for w in words + ["m.toml"]:
        assert w in res.output, res.output


def test_the_cli_simulates_it_with_readable_columns(tmp_path):
    file = tmp_path / "puck.toml"
    file.write_text(hanging(Z0) + "[analysis]\nduration = 0.2\nsamples = 11\n")
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["simulate", str(file), "-o", str(out)])
    assert res.exit_code == 0, res.output
    head = (out / "results.csv").read_text().splitlines()[0].split(",")
    for c in ("x", "y", "z", "rx", "ry", "rz"):
        assert f"q_puck_{c}" in head


def test_the_written_model_holds_the_chain_and_reads_back_the_same():
    from linkdyn.io.writer import model_to_dict
    model = read(hanging(Z0))
    again = linkdyn.model_from_dict(model_to_dict(model))
    assert [b.name for b in again.bodies] == [b.name for b in model.bodies]
    assert [j.name for j in again.joints] == [j.name for j in model.joints]
    assert equilibrium(again).q == pytest.approx(equilibrium(model).q, abs=1e-14)


def test_its_modes_are_the_closed_forms():
    # about the equilibrium (spring length L = l0 + m g / (3 k)): bounce 3 k / m; sway as a
    # pendulum of length L, g / L (twice); tilt about x or y, k sum(y_i^2) / I = 3 k a^2 / (2 I);
    # yaw as a trifilar pendulum, m g a^2 / (I_zz L)
    from linkdyn.modal import modes
    length = L0 + STRETCH
    w2 = [3 * K / M, G / length, G / length, 3 * K * A ** 2 / (2 * INERTIA[0]),
          3 * K * A ** 2 / (2 * INERTIA[1]), M * G * A ** 2 / (INERTIA[2] * length)]
    md = modes(equilibrium(read(hanging(Z0))))
    assert md.stable
    assert np.sort(md.frequencies) == pytest.approx(np.sort(np.sqrt(w2)) / (2 * math.pi),
                                                    rel=1e-9)
