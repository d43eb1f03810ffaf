"""Driver efforts and loop forces against MuJoCo's rigid-body dynamics.

Each linkdyn model is rebuilt as an MJCF open tree (the same spanning tree, cut at the same
joint) closed by ``<equality><connect site1=... site2=...>``. linkdyn's plane (x, y) is MuJoCo's
(x, z): a point (x, y) maps to (x, 0, y), a counter-clockwise angle in linkdyn is a rotation about
MuJoCo's -y, hence every hinge has ``axis="0 -1 0"``, and a moment about linkdyn's z is a torque
along MuJoCo's -y.

With linkdyn's positions, rates and accelerations loaded into ``qpos``, ``qvel`` and ``qacc``,
MuJoCo's equations of motion give

    M qacc + qfrc_bias = S tau + J^T lam + qfrc_loads,

``J = efc_J`` the connect rows (site1 minus site2, three per connect; the out-of-plane row is
identically zero), ``S`` the driven degrees of freedom. Least squares gives ``[tau; lam]``:
``tau`` must equal linkdyn's driver effort and ``lam`` (the force on site1's body) linkdyn's
reaction at the cut joint (site1 is on the joint's second body, so ``lam`` is the force by the
first body on the second). ``qfrc_inverse`` is NOT used: for a closed loop it mixes the loop
force into the crank's generalized force.
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET

import mujoco
import numpy as np
import pytest

from linkdyn.analysis import analyze
from linkdyn.model import PRISMATIC, REVOLUTE, Driver, Load, Model
from linkdyn.motion import ConstantSpeed, ExpressionMotion

from builders import DEG, RPM, body, pri, rev

RTOL = 1e-8


# ----------------------------------------------------------------------------------------------
# models (SI)


def hoeken(gravity=(0.0, 0.0), loads=()):
    """The seed paper's Hoeken four-bar (Table 1 inertias are about O_i), cut at J4."""
    bodies = (
        body("ground", {"O1": (0, 0), "O4": (89.5, 0)}),
        body("crank", {"O1": (0, 0), "O2": (38.1, 0)}, 1.5, (19.05, 0), 725.80 - 1.5 * 19.05**2),
        body("coupler", {"O2": (0, 0), "O3": (115.2, 0), "P": (230.4, 0)}, 5.0, (115.2, 0),
              88473.60 - 5.0 * 115.2**2),
        body("rocker", {"O3": (0, 0), "O4": (115.2, 0)}, 3.0, (57.6, 0),
              13271.76 - 3.0 * 57.6**2),
    )
    joints = (rev("J1", "ground.O1", "crank.O1"),
              rev("J2", "crank.O2", "coupler.O2"),
              rev("J3", "coupler.O3", "rocker.O3"),
              rev("J4", "ground.O4", "rocker.O4"))
    return Model("hoeken", bodies, joints, (Driver("J1", ConstantSpeed(45 * RPM)),), loads,
                 np.array(gravity, float),
                 assembly_phi={"crank": 0.0, "coupler": 77.12 * DEG, "rocker": -77.12 * DEG},
                 cut=("J4",))


def slider_crank():
    """Offset slider-crank in a vertical plane with a gas load, cut at the wrist pin J3 (a
    MuJoCo ``connect`` closes a revolute loop; the slider's prismatic joint stays in the tree).
    The crank is driven by an expression, so its acceleration is not zero."""
    bodies = (
        body("ground", {"O": (0, 0), "G": (0, 20)}),
        body("crank", {"O": (0, 0), "A": (50, 0)}, 0.3, (25, 3), 62.5),
        body("rod", {"A": (0, 0), "B": (180, 0)}, 0.6, (90, -4), 1620.0),
        body("slider", {"B": (0, 0), "F": (20, 0)}, 0.8, (5, 3), 133.33),
    )
    joints = (rev("J1", "ground.O", "crank.O"),
              rev("J2", "crank.A", "rod.A"),
              rev("J3", "rod.B", "slider.B"),
              pri("J4", "ground.G", "slider.B"))
    loads = (Load("force", "slider", "F", value=lambda t: np.array([-200.0, 15.0])),
             Load("torque", "rod", value=lambda t: 0.8 + 0.4 * np.sin(3 * np.asarray(t))))
    return Model("slider-crank", bodies, joints,
                 (Driver("J1", ExpressionMotion("20*t + 2*sin(7*t)")),), loads,
                 np.array([0.0, -9.81]),
                 assembly_phi={"crank": 0.0, "rod": 6.38 * DEG, "slider": 0.0},
                 assembly_q={"J4": 0.2289}, cut=("J3",))


CASES = {
    "hoeken-seed": (hoeken, 45 * RPM),
    "hoeken-gravity-loads": (
        lambda: hoeken((0.7, -9.81), (
            Load("force", "coupler", "P", value=lambda t: np.array([-20.0, 35.0])),
            Load("torque", "rocker", value=lambda t: 0.5 + 0.0 * np.asarray(t)))),
        45 * RPM),
    "slider-crank": (slider_crank, 20.0),
}


# ----------------------------------------------------------------------------------------------
# MJCF from a linkdyn model


def _xz(v):
    """linkdyn (x, y) -> MuJoCo 'x 0 y'."""
    return f"{v[0]:.17g} 0 {v[1]:.17g}"


def _tree(model):
    """Spanning tree of the model without its cut joints: child -> (parent, joint)."""
    cut = set(model.cut or ())
    tree, seen, queue = {}, {"ground"}, ["ground"]
    while queue:
        here = queue.pop(0)
        for jt in model.joints:
            if jt.name in cut or here not in (jt.body_a, jt.body_b):
                continue
            child = jt.body_b if jt.body_a == here else jt.body_a
            if child not in seen:
                seen.add(child)
                tree[child] = (here, jt)
                queue.append(child)
    return tree


def mjcf(model):
    """MJCF text of the model's open tree with its cut joints as ``connect`` constraints.

    At ``qpos = 0`` every child body's frame is parallel to its parent's and its joint point
    coincides with the parent's, so a hinge's ``qpos`` is ``phi_child - phi_parent`` and a slide's
    is the displacement of the child's joint point from the parent's along the axis.
    """
    tree = _tree(model)
    g = np.asarray(model.gravity, float)
    root = ET.Element("mujoco", model=model.name)
    ET.SubElement(root, "compiler", angle="radian")
    ET.SubElement(root, "option", gravity=f"{g[0]:.17g} 0 {g[1]:.17g}", jacobian="dense")
    world = ET.SubElement(root, "worldbody")
    elements = {"ground": world}
    for name, pt in model.body("ground").points.items():
        ET.SubElement(world, "site", name=f"ground.{name}", pos=_xz(pt))
    pending = list(tree)
    while pending:
        for child in list(pending):
            parent, jt = tree[child]
            if parent not in elements:
                continue
            pending.remove(child)
            pb, cb = model.body(parent), model.body(child)
            p_parent = pb.points[jt.point_a if jt.body_a == parent else jt.point_b]
            p_child = cb.points[jt.point_b if jt.body_b == child else jt.point_a]
            el = ET.SubElement(elements[parent], "body", name=child,
                               pos=_xz(np.asarray(p_parent) - np.asarray(p_child)))
            if jt.kind == REVOLUTE:
                ET.SubElement(el, "joint", name=jt.name, type="hinge", axis="0 -1 0",
                              pos=_xz(p_child))
            else:
                assert jt.body_b == child and jt.angle == 0.0, "slide: child second, no angle"
                ET.SubElement(el, "joint", name=jt.name, type="slide",
                              axis=_xz(np.asarray(jt.axis) / np.linalg.norm(jt.axis)),
                              pos=_xz(p_child))
            ET.SubElement(el, "inertial", pos=_xz(cb.com), mass=f"{cb.mass:.17g}",
                          diaginertia=" ".join([f"{cb.inertia:.17g}"] * 3))
            for name, pt in cb.points.items():
                ET.SubElement(el, "site", name=f"{child}.{name}", pos=_xz(pt))
            elements[child] = el
    eq = ET.SubElement(root, "equality")
    for name in model.cut or ():
        jt = model.joint(name)
        assert jt.kind == REVOLUTE, "a connect closes a revolute loop only"
        # site1 on the second body: the constraint force on site1's body is by A on B
        ET.SubElement(eq, "connect", name=name, site1=f"{jt.body_b}.{jt.point_b}",
                      site2=f"{jt.body_a}.{jt.point_a}")
    return ET.tostring(root, encoding="unicode"), tree


def _load_forces(model, m, d, time):
    """The model's force and torque loads at ``time`` as MuJoCo generalized forces (nv,), at
    the state already in ``d`` (linkdyn's z moment is MuJoCo's -y torque)."""
    q_loads = np.zeros(m.nv)
    for ld in model.loads:
        bid = m.body(ld.body).id
        if ld.kind == "force":
            f = np.asarray(ld.value(time), float)
            point = d.site_xpos[m.site(f"{ld.body}.{ld.point}").id].copy()
            mujoco.mj_applyFT(m, d, np.array([f[0], 0.0, f[1]]), np.zeros(3), point, bid,
                              q_loads)
        elif ld.kind == "torque":
            tq = float(np.asarray(ld.value(time)))
            mujoco.mj_applyFT(m, d, np.zeros(3), np.array([0.0, -tq, 0.0]),
                              d.xipos[bid].copy(), bid, q_loads)
        else:  # pragma: no cover - the cases here have no springs or dampers
            raise NotImplementedError(ld.kind)
    return q_loads


def _relative(sol, child, parent, jt, what):
    """Hinge: phi/omega/alpha of the child minus the parent's; slide: linkdyn's q/qd/qdd."""
    if jt.kind == PRISMATIC:
        k = [j.name for j in sol.model.joints].index(jt.name)
        return {"q": sol.kin.q, "qd": sol.kin.qd, "qdd": sol.kin.qdd}[what][:, k]
    f = {"q": sol.phi, "qd": sol.omega, "qdd": sol.alpha}[what]
    base = np.zeros(sol.t.shape) if parent == "ground" else f(parent)
    return f(child) - base


# ----------------------------------------------------------------------------------------------
# the comparison


@pytest.mark.parametrize("case", list(CASES))
def test_efforts_and_loop_forces_match_mujoco(case):
    build, speed = CASES[case]
    model = build()
    t = np.linspace(0.0, 2 * math.pi / speed, 13)[:-1] + 0.01
    sol = analyze(model, t)
    xml, tree = mjcf(model)
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    nv = m.nv
    assert nv == len(tree) and m.neq == len(model.cut)

    dof = {jt.name: m.jnt_dofadr[m.joint(jt.name).id] for _, jt in tree.values()}
    drivers = model.drivers
    cut_names = list(model.cut)

    taus, lams = [], []
    for k in range(len(t)):
        for child, (parent, jt) in tree.items():
            i = m.jnt_qposadr[m.joint(jt.name).id]
            d.qpos[i] = _relative(sol, child, parent, jt, "q")[k]
            d.qvel[dof[jt.name]] = _relative(sol, child, parent, jt, "qd")[k]
        qacc = np.zeros(nv)
        for child, (parent, jt) in tree.items():
            qacc[dof[jt.name]] = _relative(sol, child, parent, jt, "qdd")[k]
        mujoco.mj_forward(m, d)

        # the mapping is right: every named point is where linkdyn puts it
        for b in model.moving_bodies:
            for name in b.points:
                xyz = d.site_xpos[m.site(f"{b.name}.{name}").id]
                np.testing.assert_allclose(xyz[[0, 2]], sol.point(b.name, name)[k], atol=1e-12)
                assert abs(xyz[1]) < 1e-15

        M = np.zeros((nv, nv))
        mujoco.mj_fullM(m, d, M)                      # MuJoCo 4: mj_fullM(m, d, dst)
        assert d.nefc == 3 * len(cut_names)
        J = np.array(d.efc_J[:d.nefc * nv]).reshape(d.nefc, nv)
        # the connect rows are d(site1 - site2)/dq
        for c, name in enumerate(cut_names):
            jt = model.joint(name)
            jac = []
            for site in (f"{jt.body_b}.{jt.point_b}", f"{jt.body_a}.{jt.point_a}"):
                jp = np.zeros((3, nv))
                mujoco.mj_jacSite(m, d, jp, None, m.site(site).id)
                jac.append(jp)
            np.testing.assert_allclose(J[3 * c:3 * c + 3], jac[0] - jac[1], atol=1e-14)

        # applied loads as generalized forces (linkdyn z moment -> MuJoCo -y torque)
        q_loads = _load_forces(model, m, d, t[k])

        # S: the actuator's generalized force on the tree dof (+tau on the joint's second body)
        S = np.zeros((nv, len(drivers)))
        for c, drv in enumerate(drivers):
            jt = model.joint(drv.joint)
            child = next(ch for ch, (_, j) in tree.items() if j.name == jt.name)
            S[dof[jt.name], c] = 1.0 if jt.body_b == child else -1.0

        rhs = M @ qacc + d.qfrc_bias - q_loads
        A = np.hstack((S, J.T))
        x, *_ = np.linalg.lstsq(A, rhs, rcond=None)
        assert np.linalg.norm(A @ x - rhs) <= 1e-10 * np.linalg.norm(rhs)
        taus.append(x[:len(drivers)])
        lams.append(x[len(drivers):].reshape(len(cut_names), 3))
    taus, lams = np.array(taus), np.array(lams)

    for c, drv in enumerate(drivers):
        ref = sol.effort(drv.joint)
        err = np.max(np.abs(ref - taus[:, c])) / np.max(np.abs(ref))
        assert err <= RTOL, f"{case}: tau_{drv.joint} differs from MuJoCo by {err:.2e}"
    for c, name in enumerate(cut_names):
        ref = sol.reaction(name)
        mj = lams[:, c][:, [0, 2]]
        err = np.max(np.abs(ref - mj)) / np.max(np.abs(ref))
        assert err <= RTOL, f"{case}: reaction at {name} differs from MuJoCo by {err:.2e}"
        assert np.max(np.abs(lams[:, c, 1])) <= 1e-9 * np.max(np.abs(ref))


# ----------------------------------------------------------------------------------------------
# the slot joint (pin in slot)
#
# MuJoCo has no point-on-line equality, so the slot's one constraint row is built here from
# MuJoCo's point Jacobians: the pin's velocity as a point of the pin body minus the velocity of
# the slotted body's point at the pin, along the slot's normal n. MuJoCo's M, bias forces and
# applied loads of the open tree (slot removed) then give [tau; lam] by least squares; lam n is
# the force of the slotted body on the pin, linkdyn's reaction at the slot.


def _slot_cases():
    from linkdyn import example_path, load
    from test_dynamics import slotted_lever

    yoke = load(example_path("scotch_yoke"))
    return {
        # the crank accelerates, so inertia of every kind enters
        "scotch-yoke": dataclasses.replace(
            yoke, drivers=(Driver("J1", ExpressionMotion("12*t + 1.5*sin(5*t)")),)),
        "slotted-lever": dataclasses.replace(
            slotted_lever(), drivers=(Driver("J1", ExpressionMotion("0.3 + 6*t + sin(3*t)")),)),
    }


@pytest.mark.parametrize("case", ["scotch-yoke", "slotted-lever"])
def test_slot_joint_matches_mujoco(case):
    model = _slot_cases()[case]
    slot = next(j for j in model.joints if j.kind == "slot")
    t = np.linspace(0.0, 1.0, 9) + 0.01
    sol = analyze(model, t)
    xml, tree = mjcf(dataclasses.replace(
        model, joints=tuple(j for j in model.joints if j is not slot), cut=()))
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    nv = m.nv
    assert nv == len(tree) == len(model.bodies) - 1 and m.neq == 0
    dof = {jt.name: m.jnt_dofadr[m.joint(jt.name).id] for _, jt in tree.values()}
    taus, lams, normals = [], [], []
    for k in range(len(t)):
        qacc = np.zeros(nv)
        for child, (parent, jt) in tree.items():
            d.qpos[m.jnt_qposadr[m.joint(jt.name).id]] = _relative(sol, child, parent, jt, "q")[k]
            d.qvel[dof[jt.name]] = _relative(sol, child, parent, jt, "qd")[k]
            qacc[dof[jt.name]] = _relative(sol, child, parent, jt, "qdd")[k]
        mujoco.mj_forward(m, d)
        for b in model.moving_bodies:
            for name in b.points:
                xyz = d.site_xpos[m.site(f"{b.name}.{name}").id]
                np.testing.assert_allclose(xyz[[0, 2]], sol.point(b.name, name)[k], atol=1e-12)
        M = np.zeros((nv, nv))
        mujoco.mj_fullM(m, d, M)
        # the slot row: n . (J_pin on b - J_point at the pin on a), n normal to the slot
        pin = d.site_xpos[m.site(f"{slot.body_b}.{slot.point_b}").id].copy()
        jac = []
        for body in (slot.body_b, slot.body_a):
            jp = np.zeros((3, nv))
            if body != "ground":
                mujoco.mj_jac(m, d, jp, None, pin, m.body(body).id)
            jac.append(jp)
        phi_a = 0.0 if slot.body_a == "ground" else sol.phi(slot.body_a)[k]
        c, s = math.cos(phi_a), math.sin(phi_a)
        e = np.array([c * slot.axis[0] - s * slot.axis[1], s * slot.axis[0] + c * slot.axis[1]])
        n = np.array([-e[1], e[0]])
        row = np.array([n[0], 0.0, n[1]]) @ (jac[0] - jac[1])
        # linkdyn's rates keep the pin in the slot
        assert abs(row @ d.qvel) <= 1e-12 * np.linalg.norm(row) * np.linalg.norm(d.qvel)
        q_loads = _load_forces(model, m, d, t[k])
        S = np.zeros((nv, len(model.drivers)))
        for c_, drv in enumerate(model.drivers):
            jt = model.joint(drv.joint)
            child = next(ch for ch, (_, j) in tree.items() if j.name == jt.name)
            S[dof[jt.name], c_] = 1.0 if jt.body_b == child else -1.0
        rhs = M @ qacc + d.qfrc_bias - q_loads
        A = np.hstack((S, row[:, None]))
        x, *_ = np.linalg.lstsq(A, rhs, rcond=None)
        assert np.linalg.norm(A @ x - rhs) <= 1e-10 * np.linalg.norm(rhs)
        taus.append(x[:len(model.drivers)])
        lams.append(x[-1])
        normals.append(n)
    taus, force = np.array(taus), np.array(lams)[:, None] * np.array(normals)
    for c_, drv in enumerate(model.drivers):
        ref = sol.effort(drv.joint)
        err = np.max(np.abs(ref - taus[:, c_])) / np.max(np.abs(ref))
        assert err <= RTOL, f"{case}: tau_{drv.joint} differs from MuJoCo by {err:.2e}"
    ref = sol.reaction(slot.name)
    err = np.max(np.abs(ref - force)) / np.max(np.abs(ref))
    assert err <= RTOL, f"{case}: slot reaction differs from MuJoCo by {err:.2e}"
