"""The slot joint (pin in slot) against closed forms and an equivalent mechanism.

The dense explicit-matrix reference, the simultaneous Newton–Euler solve, power balance, the
body wrench balance, statics by virtual work and batch-equals-loop hold the slot models of
tests/test_dynamics.py ("scotch-yoke", "slotted-lever"); finite differences of positions and
rates, loop closure and the dense reference also run on the bundled example
(``scotch_yoke``). Here:

a. the bundled Scotch yoke against its closed form: yoke at r cos(theta), the pin at
   r sin(theta) along the slot, and every force from the two bodies' Newton–Euler equations
   written out by hand;
b. a slot is a revolute joint plus a prismatic one through a massless block: the slotted
   lever equals the inverted slider-crank with a massless block, joint by joint;
c. finite differences of the slot coordinate when the slot turns (the n_dot terms);
d. the slot's place in the model: reader, topology (always cut, one row, Gruebler), and the
   compiled backend (auto runs numpy; an explicit "compiled" says it cannot);
e. random slotted levers (geometry, masses, loads, gravity) equal to their massless-block
   equivalent.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import linkdyn
from linkdyn import compiled, joints, kinematics, topology
from linkdyn.analysis import analyze
from linkdyn.cli import example_text
from linkdyn.errors import ModelError
from linkdyn.io import model_from_dict
from linkdyn.model import Driver, Joint, Load, Model
from linkdyn.motion import ConstantSpeed

from builders import RPM, body, pri, rev, slot
from test_dynamics import check, inverted_slider_crank, size_of, slotted_lever, times

G = 9.81


def yoke_example():
    return linkdyn.load(linkdyn.example_path("scotch_yoke"))


# ----------------------------------------------------------------------------------------------
# a. closed form of the bundled Scotch yoke


def test_scotch_yoke_closed_form():
    model = yoke_example()
    t = np.linspace(0.0, 0.5, 37)                        # one turn at 120 rpm
    sol = analyze(model, t)
    c = sol.columns
    r, w = 0.060, 120 * 2 * np.pi / 60
    th = w * t
    # kinematics: x = r cos(theta) (the yoke), s = r sin(theta) (the pin along the slot)
    L = r
    check(c["q_J1"], th, 1e-13, scale=2 * np.pi, what="theta")
    check(c["q_J2"], r * np.cos(th), 1e-12, scale=L, what="yoke x")
    check(c["qd_J2"], -r * w * np.sin(th), 1e-12, scale=L * w, what="yoke xd")
    check(c["qdd_J2"], -r * w**2 * np.cos(th), 1e-12, scale=L * w**2, what="yoke xdd")
    check(c["q_J3"], r * np.sin(th), 1e-12, scale=L, what="pin along the slot")
    check(c["qd_J3"], r * w * np.cos(th), 1e-12, scale=L * w, what="pin rate")
    check(c["qdd_J3"], -r * w**2 * np.sin(th), 1e-12, scale=L * w**2, what="pin acceleration")
    assert np.max(np.abs(c["phi_yoke"])) <= 1e-14
    # forces: yoke (1.5 kg, mass centre (80, 10) mm from C) along x:
    #   m xdd = -Fx_J3 - 150   (the pin pushes on the yoke with -F_J3; the guide is normal to x)
    m_y, m_c = 1.5, 0.4
    xdd = -r * w**2 * np.cos(th)
    fx = -(m_y * xdd + 150.0)
    F = max(np.max(np.abs(fx)), m_y * G)
    check(c["Fx_J3"], fx, 1e-12, scale=F, what="slot normal force")
    check(c["Fy_J3"], np.zeros_like(t), 1e-12, scale=F, what="slot force along the slot")
    # crank about O (constant speed): tau + A x F_J3 + c x m_c g = 0, the mass centre at r/2
    tau = r * np.sin(th) * fx + 0.5 * r * np.cos(th) * m_c * G
    check(c["tau_J1"], tau, 1e-12, scale=F * r, what="crank torque")
    # guide: Fx_J2 = 0 (normal to the slide), Fy_J2 = m_y g, and the yoke's moment about C:
    #   M + (A - C) x (-F_J3) + (G - C) x m_y g = (G - C) x m_y a
    check(c["Fx_J2"], np.zeros_like(t), 1e-12, scale=F, what="guide force along the slide")
    check(c["Fy_J2"], np.full_like(t, m_y * G), 1e-12, scale=F, what="guide normal force")
    d = np.array([0.080, 0.010])
    moment = -d[1] * m_y * xdd - r * np.sin(th) * fx + d[0] * m_y * G
    check(c["M_J2"], moment, 1e-12, scale=F * 0.2, what="guide moment")
    # the crank bearing carries the rest: F_J1 = m_c a_c - F_J3 - m_c g
    a_c = -0.5 * r * w**2 * np.stack((np.cos(th), np.sin(th)))
    check(c["Fx_J1"], m_c * a_c[0] - fx, 1e-12, scale=F, what="bearing x")
    check(c["Fy_J1"], m_c * a_c[1] + m_c * G, 1e-12, scale=F, what="bearing y")
    # a closed form that a wrong normal (the slot's axis instead of its normal) would break
    assert np.max(np.abs(c["Fx_J3"])) > 100


# ----------------------------------------------------------------------------------------------
# b. a slot = revolute + prismatic through a massless block


def test_slotted_lever_equals_inverted_slider_crank_with_a_massless_block():
    lever = slotted_lever()
    inv = inverted_slider_crank()
    bodies = tuple(dataclasses.replace(b, mass=0.0, inertia=0.0, com=np.zeros(2))
                   if b.name == "block" else b for b in inv.bodies)
    inv = dataclasses.replace(inv, bodies=bodies)
    t = times(lever, 13)
    a, b = analyze(lever, t), analyze(inv, t)
    assert a.kin.layout.topo.cut == (1,) and a.kin.layout.topo.rows == (1,)
    size = size_of(lever)
    for body in ("crank", "lever"):
        check(a.phi(body), b.phi(body), 1e-12, scale=2 * np.pi, what=f"phi {body}")
        check(a.alpha(body), b.alpha(body), 1e-11, what=f"alpha {body}")
    ca, cb = a.columns, b.columns
    for key in ("q_J3", "qd_J3", "qdd_J3"):
        check(ca[key], cb[key], 1e-11, what=key)
    check(a.dyn.tau, b.dyn.tau, 1e-11, what="crank torque")
    fs = np.max(np.abs(b.reactions.force))
    for name in ("J1", "J4"):   # the same joints in both models
        check(a.reaction(name), b.reaction(name), 1e-11, scale=fs, what=f"reaction {name}")
    # the lever's push on the crank pin: through the block, the prismatic joint's reaction
    check(a.reactions.force[:, 1], b.reactions.force[:, 2], 1e-11, scale=fs, what="pin force")
    check(a.reactions.force[:, 1], -b.reactions.force[:, 1], 1e-11, scale=fs, what="pin force")
    # a massless block carries no moment in its guide; the slot reports none either
    check(b.reactions.moment[:, 2], np.zeros_like(t), 1e-11, scale=fs * size, what="guide M")
    assert "M_J3" not in ca and np.max(np.abs(a.reactions.moment[:, 1])) <= 1e-12 * fs * size


# ----------------------------------------------------------------------------------------------
# c. finite differences when the slot turns


def test_slot_coordinate_rates_match_finite_differences_when_the_slot_turns():
    model = slotted_lever()
    h = 1e-4
    centres = times(model, 7)[:-1] + 0.05
    t = (centres[:, None] + h * np.arange(-2, 3)).ravel()
    kin = kinematics.solve(model, t)
    assert kin.valid.all()
    q = kin.q[:, 1].reshape(-1, 5)
    d1 = (q[:, 0] - 8 * q[:, 1] + 8 * q[:, 3] - q[:, 4]) / (12 * h)
    d2 = (-q[:, 0] + 16 * q[:, 1] - 30 * q[:, 2] + 16 * q[:, 3] - q[:, 4]) / (12 * h**2)
    qd, qdd = kin.qd[:, 1].reshape(-1, 5)[:, 2], kin.qdd[:, 1].reshape(-1, 5)[:, 2]
    check(qd, d1, 1e-8, what="qd of the slot")
    check(qdd, d2, 1e-5, what="qdd of the slot")
    # the pin stays on the turning slot's line and q is its displacement along it
    pin, s = kin.point("crank", "A"), kin.point("lever", "S")
    phi = kin.phi[:, kin.layout.topo.bodies.index("lever")]
    e = np.stack((np.cos(phi), np.sin(phi)), -1)
    d = pin - s
    assert np.max(np.abs(d[:, 0] * e[:, 1] - d[:, 1] * e[:, 0])) <= 1e-12 * size_of(model)
    np.testing.assert_allclose(kin.q[:, 1], np.sum(d * e, -1), rtol=0, atol=1e-12)


# ----------------------------------------------------------------------------------------------
# d. reader, topology, backends


def yoke_text(old="", new=""):
    text = example_text("scotch_yoke")
    assert old in text
    return text.replace(old, new, 1)


def read(text):
    import tomllib
    return model_from_dict(tomllib.loads(text), source="scotch_yoke.toml")


def test_the_registry_lists_the_slot_and_the_reader_takes_it():
    assert joints.names()[:3] == ("revolute", "prismatic", "slot")
    kind = joints.get("slot")
    assert (kind.freedoms, kind.rows, kind.tree, kind.reaction) == (2, 1, False, ("Fx", "Fy"))
    with pytest.raises(joints.UnknownJointKind, match="known kinds: revolute, prismatic, slot"):
        joints.get("ball")
    model = yoke_example()
    assert model.joint("J3").kind == "slot"
    np.testing.assert_allclose(model.joint("J3").axis, [0.0, 1.0])


@pytest.mark.parametrize("old, new, field, words", [
    ('type = "slot"', 'type = "slott"', "joints.J3.type", ["slot"]),
    ('axis = [0.0, 1.0]', 'axis = [0.0, 1.0]\nangle = 10.0', "joints.J3.angle",
     ["slot joint has no angle", '"prismatic"']),
    ('axis = [0.0, 1.0]', 'axis = [0.0, 0.0]', "joints.J3.axis", ["zero"]),
    ('joint = "J1"', 'joint = "J3"', "drivers[0].joint", ["slot joint", "cannot be driven"]),
])
def test_reader_messages(old, new, field, words):
    with pytest.raises(ModelError) as err:
        read(yoke_text(old, new))
    assert err.value.field == field, str(err.value)
    assert all(w in str(err.value) for w in words), str(err.value)


def test_topology_always_cuts_a_slot_and_counts_one_row():
    model = yoke_example()
    topo = topology.build(model)
    assert [model.joints[j].name for j in topo.cut] == ["J3"]
    assert topo.rows == (1,) and topo.n_rows == 1 and topo.mobility == 1
    # asking to cut another joint still leaves the slot cut (it cannot place a body)
    with pytest.raises(ModelError, match="mobility|path to the ground|not connected"):
        topology.build(dataclasses.replace(model, cut=("J2",)))
    # a slot counts one constraint in Gruebler: a second slot (the crank pin on the ground's
    # x axis) leaves mobility 0
    extra = dataclasses.replace(model.joints[2], name="J4", body_a="ground", point_a="O",
                                axis=np.array([1.0, 0.0]))
    with pytest.raises(ModelError, match=r"mobility 0 .*3\*\(3-1\) - 2\*1 - 2\*1 - 1\*2 "
                                         r".*1 revolute, 1 prismatic, 2 slot"):
        topology.build(dataclasses.replace(model, joints=model.joints + (extra,)))
    # a body held only by a slot cannot be placed: the message says so
    with pytest.raises(ModelError, match="held only by slot joint.*'J3'") as err:
        topology.build(dataclasses.replace(model, joints=model.joints[:1] + model.joints[2:]))
    assert err.value.field == "bodies.yoke"


def test_an_unknown_kind_built_in_python_is_a_model_error():
    model = yoke_example()
    odd = dataclasses.replace(model, joints=model.joints[:2] + (
        dataclasses.replace(model.joints[2], kind="ball"),))
    with pytest.raises(ModelError) as err:
        topology.build(odd)
    assert err.value.field == "joints.J3.type" and "slot" in err.value.fix


def test_the_compiled_backend_runs_the_slot():
    model = yoke_example()
    kinds = [j.kind for j in model.joints]
    assert compiled.unsupported(kinds) == []
    big = linkdyn.backend.Work(10**9, len(model.bodies) - 1)
    assert linkdyn.backend.choose("auto", big, kinds).compiled == (compiled.numba is not None)
    if compiled.numba is None:
        return
    # every column as numpy gives it (tests/test_golden.py holds both to the stored numbers)
    t = np.linspace(0, 0.1, 5)
    a, b = analyze(model, t, backend="compiled"), analyze(model, t, backend="numpy")
    assert a.kin.arrays is not None and b.kin.arrays is None
    for key, col in b.columns.items():
        np.testing.assert_allclose(a.columns[key], col, rtol=0,
                                   atol=1e-12 * max(1.0, float(np.max(np.abs(col)))))


def test_a_slot_joint_is_not_a_tree_joint():
    with pytest.raises(NotImplementedError, match="slot joint cannot be a tree joint"):
        joints.get("slot").motion_vector(1, None, 0)
    assert isinstance(Joint("J", "slot", "a", "p", "b", "q"), Joint)


# ----------------------------------------------------------------------------------------------
# e. property-based: random slotted levers against their massless-block equivalent


@st.composite
def slotted_levers(draw):
    """A crank (radius r) driving a lever pivoted at distance d below it through a pin in a slot
    offset ``off`` from the lever's pivot line; random masses, loads and gravity."""
    f = lambda lo, hi: draw(st.floats(lo, hi, allow_nan=False, allow_infinity=False))
    r = f(20, 80)
    d = r + f(30, 150)
    off = f(-10, 10)
    mass = [f(0.1, 2.0) for _ in range(2)]
    g = (f(-10, 10), f(-10, 10))
    load = (f(-50, 50), f(-50, 50))
    torque = f(-5, 5)
    theta0 = f(-3, 3)
    return r, d, off, mass, g, load, torque, theta0


def lever_models(case):
    r, d, off, (m1, m2), g, load, torque, theta0 = case
    crank = body("crank", {"O2": (0, 0), "A": (r, 0)}, m1, (0.4 * r, 3), m1 * r**2 / 12)
    lever = body("lever", {"O4": (0, 0), "S": (0, off), "T": (2.5 * d, 0)}, m2, (d, 4),
                 m2 * (2.5 * d) ** 2 / 12)
    ground = body("ground", {"O2": (0, 0), "O4": (0, -d)})
    loads = (Load("force", "lever", "T", value=lambda t: np.array(load)),
             Load("torque", "lever", value=lambda t: torque + 0.0 * np.asarray(t)))
    drivers = (Driver("J1", ConstantSpeed(60 * RPM, theta0)),)
    phi_lever = float(np.arctan2(r * np.sin(theta0) + d, r * np.cos(theta0)))
    a = Model("slot", (ground, crank, lever),
              (rev("J1", "ground.O2", "crank.O2"), slot("J3", "lever.S", "crank.A"),
               rev("J4", "ground.O4", "lever.O4")), drivers, loads, np.array(g),
              assembly_phi={"crank": theta0, "lever": phi_lever})
    block = body("block", {"A": (0, 0)})
    b = Model("block", (ground, crank, block, lever),
              (rev("J1", "ground.O2", "crank.O2"), rev("J2", "crank.A", "block.A"),
               pri("J3", "lever.S", "block.A"), rev("J4", "ground.O4", "lever.O4")),
              drivers, loads, np.array(g),
              assembly_phi={"crank": theta0, "lever": phi_lever, "block": phi_lever},
              assembly_q={"J3": float(np.hypot(r * np.cos(theta0), r * np.sin(theta0) + d))})
    return a, b


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(slotted_levers())
def test_random_slotted_levers_equal_their_massless_block_equivalent(case):
    a_model, b_model = lever_models(case)
    t = np.linspace(0.0, 1.0, 9)
    a, b = analyze(a_model, t), analyze(b_model, t)
    check(a.phi("lever"), b.phi("lever"), 1e-10, scale=np.pi, what="lever angle")
    check(a.dyn.tau, b.dyn.tau, 1e-9, what="crank torque")
    fs = np.max(np.abs(b.reactions.force))
    for name in ("J1", "J4"):
        check(a.reaction(name), b.reaction(name), 1e-9, scale=fs, what=f"reaction {name}")
    check(a.reaction("J3"), b.reaction("J3")[:, :2], 1e-9, scale=fs, what="pin force")
    check(a.columns["qdd_J3"], b.columns["qdd_J3"], 1e-9, what="slot acceleration")
