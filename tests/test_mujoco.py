"""Driver efforts and loop forces against MuJoCo's rigid-body dynamics, on linkdyn's own
MJCF export (:mod:`linkdyn.io.mjcf`, ``linkdyn export --to mjcf``).

The exporter is the one recipe: the test does not build a second MJCF to compare with it. The
independent check is MuJoCo's own dynamics of the exported file: a wrong body placement, frame,
mass, inertia, gravity, spring, sign of a joint or cut, or actuator gear makes MuJoCo's
equations disagree with linkdyn's numbers. The test reads the structure back from MuJoCo's
compiled model (which body each joint moves, the actuators' gears and joints), not from the
exporter's code: linkdyn's plane (x, y) is MuJoCo's (x, z), and a joint's ``qpos`` is ``s q``,
``q`` linkdyn's coordinate and ``s = +1`` when the joint moves its second body (MuJoCo's
``jnt_bodyid``), ``-1`` when its first.

With linkdyn's positions, rates and accelerations loaded into ``qpos``, ``qvel`` and ``qacc``,
MuJoCo's equations of motion give

    M qacc + qfrc_bias - qfrc_passive = S tau + J^T lam + qfrc_loads,

``J = efc_J`` the connect rows (site1 minus site2, three per connect; the out-of-plane row is
identically zero), ``S`` the actuators' transmission (gear on the joint's dof), ``qfrc_passive``
the exported springs and dampers, ``qfrc_loads`` the loads MJCF cannot hold, applied here by
``mj_applyFT``. Least squares gives ``[tau; lam]``: ``tau`` must equal linkdyn's driver effort
and ``lam`` (the force on site1's body, the joint's second) linkdyn's reaction at the cut joint,
to 1e-12 of their peak. ``qfrc_inverse`` is NOT used: for a closed loop it mixes the loop force
into the crank's generalized force.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from linkdyn import example_path, load
from linkdyn.analysis import analyze
from linkdyn.io.mjcf import mjcf
from linkdyn.model import Driver, Load, Model
from linkdyn.motion import ConstantSpeed, ExpressionMotion

mujoco = pytest.importorskip("mujoco", reason="the MuJoCo check needs mujoco (the mujoco extra)")  # the extra linkdyn[mujoco]; the export itself needs none

from builders import DEG, RPM, body, pri, rev
from test_dynamics import coupled_carrier, coupled_five_bar

RTOL = 1e-12   # of the peak of each effort and reaction


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


def reversed_hoeken():
    """Hoeken with J1 and J2 written the other way round: MuJoCo's tree reaches each joint's
    first body from its second (qpos = -q, the driver's gear -1)."""
    m = hoeken((0.3, -9.81))
    j1, j2 = rev("J1", "crank.O1", "ground.O1"), rev("J2", "coupler.O2", "crank.O2")
    return dataclasses.replace(m, joints=(j1, j2) + m.joints[2:], drivers=(
        Driver("J1", ExpressionMotion("-(4.7*t + 0.8*sin(6*t))")),))


def reversed_slider():
    """The slider-crank with its slide written slider first, the slider's frame turned by
    -0.3 rad from the ground's (``angle`` 0.3 of the ground's to the slider's) and the axis in
    the slider's frame: a reversed slide between frames that are not parallel."""
    m = slider_crank()
    a = 0.3
    j4 = pri("J4", "slider.B", "ground.G", axis=(math.cos(a), math.sin(a)), angle=a)
    return dataclasses.replace(m, joints=m.joints[:3] + (j4,),
                               assembly_phi={**m.assembly_phi, "slider": -a},
                               assembly_q={"J4": -0.2289})


def spring_loaded():
    """The Hoeken linkage in a vertical plane with a spring (ground to the coupler point) and a
    damper (crank pin to rocker pin), exported as MuJoCo tendons; the crank accelerates."""
    loads = (Load("spring", "ground", "O4", body2="coupler", point2="P", stiffness=800.0,
                  free_length=0.15, name="k1"),
             Load("damper", "crank", "O2", body2="rocker", point2="O3", damping=3.0, name="c1"))
    return dataclasses.replace(hoeken((0.0, -9.81), loads),
                               drivers=(Driver("J1", ExpressionMotion("4.7*t + 0.8*sin(6*t)")),))


def example(name, q="0.3 + 6*t + 0.8*sin(5*t)"):
    """A bundled example whose driver accelerates (so inertia of every kind enters)."""
    m = load(example_path(name))
    return dataclasses.replace(m, drivers=(Driver(m.drivers[0].joint, ExpressionMotion(q)),))


def accelerated(m, q="0.3 + 6*t + 0.8*sin(5*t)"):
    """``m`` with its driver accelerating."""
    return dataclasses.replace(m, drivers=(Driver(m.drivers[0].joint, ExpressionMotion(q)),))


CASES = {
    "hoeken-seed": (hoeken, 45 * RPM),
    "hoeken-gravity-loads": (
        lambda: hoeken((0.7, -9.81), (
            Load("force", "coupler", "P", value=lambda t: np.array([-20.0, 35.0])),
            Load("torque", "rocker", value=lambda t: 0.5 + 0.0 * np.asarray(t)))),
        45 * RPM),
    "hoeken-spring-damper": (spring_loaded, 4.7),
    "slider-crank": (slider_crank, 20.0),
    "hoeken-reversed-joints": (reversed_hoeken, 4.7),
    "slider-crank-reversed-slide": (reversed_slider, 20.0),
    # linkdyn cuts the slide J4; MuJoCo's tree is cut at the wrist pin instead
    "slider-crank-example": (lambda: example("slider_crank"), 6.0),
    # prismatic tree joints between rotating bodies (frames turned by the slide's angle)
    "inverted-slider-crank": (lambda: example("inverted_slider_crank"), 6.0),
    # two loops, a tree with branches (MuJoCo's depth-first order differs from linkdyn's)
    "watt2": (lambda: example("watt2"), 6.0),
    # a coordinate coupling as a joint equality (one of its joints written child first), and a
    # coupling of two arms on a swinging carrier
    "coupled-five-bar": (lambda: accelerated(coupled_five_bar()), 6.0),
    "coupled-carrier": (coupled_carrier, 3.0),
}


# ----------------------------------------------------------------------------------------------
# MuJoCo's equations at linkdyn's motion


def load_forces(model, m, d, time):
    """The model's loads MJCF does not hold (forces, torques) at ``time`` as MuJoCo
    generalized forces (nv,), at the state already in ``d`` (linkdyn's z moment is MuJoCo's -y
    torque). Springs and dampers are in the export (MuJoCo's ``qfrc_passive``)."""
    q_loads = np.zeros(m.nv)
    for ld in model.loads:
        if ld.kind in ("spring", "damper"):
            continue
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
        else:  # pragma: no cover - the cases here have no other loads
            raise NotImplementedError(ld.kind)
    return q_loads


def set_state(model, sol, m, d, k):
    """Load linkdyn's sample k into ``d`` (qpos = s q, qvel = s qd) and return qacc = s qdd;
    ``s`` from the body MuJoCo's joint moves. Then check every named point is where linkdyn
    puts it."""
    index = {jt.name: j for j, jt in enumerate(model.joints)}
    qacc = np.zeros(m.nv)
    for jid in range(m.njnt):
        jt = model.joint(m.joint(jid).name)
        moved = m.body(m.jnt_bodyid[jid]).name
        assert moved in (jt.body_a, jt.body_b)
        s = 1.0 if moved == jt.body_b else -1.0
        j, dof = index[jt.name], m.jnt_dofadr[jid]
        d.qpos[m.jnt_qposadr[jid]] = s * sol.kin.q[k, j]
        d.qvel[dof] = s * sol.kin.qd[k, j]
        qacc[dof] = s * sol.kin.qdd[k, j]
    mujoco.mj_forward(m, d)
    for b in model.moving_bodies:
        for name in b.points:
            xyz = d.site_xpos[m.site(f"{b.name}.{name}").id]
            np.testing.assert_allclose(xyz[[0, 2]], sol.point(b.name, name)[k], atol=1e-12)
            assert abs(xyz[1]) < 1e-15
    return qacc


def _actuators(model, m):
    """S (nv, n_drivers): each actuator's gear on its joint's dof, in the drivers' order."""
    S = np.zeros((m.nv, m.nu))
    names = []
    for a in range(m.nu):
        jid = m.actuator_trnid[a, 0]
        S[m.jnt_dofadr[jid], a] = m.actuator_gear[a, 0]
        names.append(m.joint(jid).name)
    assert names == [drv.joint for drv in model.drivers]
    return S


def _peak_error(ref, got):
    return float(np.max(np.abs(ref - got)) / np.max(np.abs(ref)))


def check_against_mujoco(model, sol, xml, case=""):
    """MuJoCo's efforts and connect forces on the MJCF ``xml`` at linkdyn's motion ``sol``
    equal linkdyn's to RTOL of their peaks; returns the largest relative error."""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    nv = m.nv
    assert nv == len(model.moving_bodies)
    # the constraint rows in the equalities' order: 3 per connect, 1 per joint equality
    connect = [m.eq_type[e] == mujoco.mjtEq.mjEQ_CONNECT for e in range(m.neq)]
    assert all(c or m.eq_type[e] == mujoco.mjtEq.mjEQ_JOINT for e, c in enumerate(connect))
    start = np.cumsum([0] + [3 if c else 1 for c in connect])
    cut_names = [m.eq(e).name for e in range(m.neq) if connect[e]]
    couplings = [m.eq(e).name for e in range(m.neq) if not connect[e]]
    rows = [start[e] for e in range(m.neq) if connect[e]]
    row1 = [start[e] for e in range(m.neq) if not connect[e]]
    S = _actuators(model, m)
    taus, lams, torques = [], [], []
    for k in range(len(sol.t)):
        qacc = set_state(model, sol, m, d, k)
        M = np.zeros((nv, nv))
        mujoco.mj_fullM(m, d, M)                      # MuJoCo 4: mj_fullM(m, d, dst)
        assert d.nefc == 3 * len(cut_names) + len(couplings)
        J = np.array(d.efc_J[:d.nefc * nv]).reshape(d.nefc, nv)
        # the connect rows are d(site1 - site2)/dq, site1 on the joint's second body
        for c, name in zip(rows, cut_names):
            jt = model.joint(name)
            jac = []
            for site in (f"{jt.body_b}.{jt.point_b}", f"{jt.body_a}.{jt.point_a}"):
                jp = np.zeros((3, nv))
                mujoco.mj_jacSite(m, d, jp, None, m.site(site).id)
                jac.append(jp)
            np.testing.assert_allclose(J[c:c + 3], jac[0] - jac[1], atol=1e-14)
        q_loads = load_forces(model, m, d, sol.t[k])
        rhs = M @ qacc + d.qfrc_bias - d.qfrc_passive - q_loads
        A = np.hstack((S, J.T))
        x, *_ = np.linalg.lstsq(A, rhs, rcond=None)
        assert np.linalg.norm(A @ x - rhs) <= 1e-12 * np.linalg.norm(rhs)
        taus.append(x[:m.nu])
        lams.append(np.array([x[m.nu + r:m.nu + r + 3] for r in rows]).reshape(-1, 3))
        # a joint equality's force on joint1's dof, as a torque in q_1 (qpos_1 = s_1 q_1)
        torques.append([coupling_torque(model, m, J[r], x[m.nu + r], name)
                        for r, name in zip(row1, couplings)])
    taus, lams, torques = np.array(taus), np.array(lams), np.array(torques)
    worst = 0.0
    for c, drv in enumerate(model.drivers):
        err = _peak_error(sol.effort(drv.joint), taus[:, c])
        assert err <= RTOL, f"{case}: tau_{drv.joint} differs from MuJoCo by {err:.2e}"
        worst = max(worst, err)
    for c, name in enumerate(cut_names):
        ref = sol.reaction(name)
        err = _peak_error(ref, lams[:, c][:, [0, 2]])
        assert err <= RTOL, f"{case}: reaction at {name} differs from MuJoCo by {err:.2e}"
        assert np.max(np.abs(lams[:, c, 1])) <= RTOL * np.max(np.abs(ref))
        worst = max(worst, err)
    for c, name in enumerate(couplings):
        err = _peak_error(sol.columns[f"torque_{name}"], torques[:, c])
        assert err <= RTOL, f"{case}: torque_{name} differs from MuJoCo by {err:.2e}"
        worst = max(worst, err)
    return worst


def coupling_torque(model, m, row, lam, name):
    """The generalized force ``row[dof_1] lam`` of a joint equality on its joint1's dof, in
    linkdyn's sense of that joint (``qpos = s q``, ``s`` from the body MuJoCo's joint moves)."""
    j1 = model.joint(name).coupled[0]
    jid = m.joint(j1).id
    s = 1.0 if m.body(m.jnt_bodyid[jid]).name == model.joint(j1).body_b else -1.0
    return s * row[m.jnt_dofadr[jid]] * lam


# ----------------------------------------------------------------------------------------------
# the comparison


@pytest.mark.parametrize("case", list(CASES))
def test_efforts_and_loop_forces_match_mujoco(case):
    build, speed = CASES[case]
    model = build()
    t = np.linspace(0.0, 2 * math.pi / speed, 13)[:-1] + 0.01
    sol = analyze(model, t)
    export = mjcf(model, at=0.2)
    assert set(export.cut) <= {j.name for j in model.joints if j.kind in ("revolute", "coupling")}
    assert len(export.cut) == len(sol.topology.cut)
    check_against_mujoco(model, sol, export.text, case)


@pytest.mark.parametrize("name", ["hoeken", "slider_crank", "watt2", "inverted_slider_crank"])
def test_the_export_loads_assembled_at_its_time(name):
    """qpos0 (the joints' ``ref``) is the pose at ``at``; the keyframe adds the rates and the
    servos' targets (each actuator's length equals its target: the servo holds the motion)."""
    model = load(example_path(name))
    at = 0.037
    sol = analyze(model, np.array([at]))
    m = mujoco.MjModel.from_xml_string(mjcf(model, at=at).text)
    d = mujoco.MjData(m)
    mujoco.mj_forward(m, d)
    size = max(np.ptp(np.concatenate([sol.point(b.name, p) for b in model.moving_bodies
                                      for p in b.points]), axis=0))
    for b in model.moving_bodies:
        for p in b.points:
            xyz = d.site_xpos[m.site(f"{b.name}.{p}").id]
            np.testing.assert_allclose(xyz[[0, 2]], sol.point(b.name, p)[0], atol=1e-14 * size)
    assert np.max(np.abs(d.efc_pos), initial=0.0) <= 1e-14 * size       # the loops are closed
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    assert d.time == at
    np.testing.assert_allclose(d.actuator_length, d.ctrl, atol=1e-14)
    # the rates keep the loops closed: J qvel = 0
    J = np.array(d.efc_J[:d.nefc * m.nv]).reshape(d.nefc, m.nv)
    assert np.max(np.abs(J @ d.qvel), initial=0.0) <= 1e-12 * np.max(np.abs(d.qvel)) * size
    for b in model.moving_bodies:   # and turn every body at linkdyn's rate
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, m.body(b.name).id, vel, 0)
        np.testing.assert_allclose(-vel[1], sol.omega(b.name)[0], atol=1e-12)


# ----------------------------------------------------------------------------------------------
# the slot joint (pin in slot)
#
# MuJoCo has no point-on-line equality, so the export leaves the slot out (``leave_out``) and
# the slot's one constraint row is built here from MuJoCo's point Jacobians: the pin's velocity
# as a point of the pin body minus the velocity of the slotted body's point at the pin, along
# the slot's normal n. MuJoCo's M, bias forces and applied loads of the open tree then give
# [tau; lam] by least squares; lam n is the force of the slotted body on the pin, linkdyn's
# reaction at the slot.


def _slot_cases():
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
    export = mjcf(model, leave_out=(slot.name,))
    assert export.cut == () and f"joint '{slot.name}'" in export.omitted
    m = mujoco.MjModel.from_xml_string(export.text)
    d = mujoco.MjData(m)
    nv = m.nv
    assert nv == len(model.bodies) - 1 and m.neq == 0
    S = _actuators(model, m)
    taus, lams, normals = [], [], []
    for k in range(len(t)):
        qacc = set_state(model, sol, m, d, k)
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
        q_loads = load_forces(model, m, d, t[k])
        rhs = M @ qacc + d.qfrc_bias - d.qfrc_passive - q_loads
        A = np.hstack((S, row[:, None]))
        x, *_ = np.linalg.lstsq(A, rhs, rcond=None)
        assert np.linalg.norm(A @ x - rhs) <= 1e-12 * np.linalg.norm(rhs)
        taus.append(x[:m.nu])
        lams.append(x[-1])
        normals.append(n)
    taus, force = np.array(taus), np.array(lams)[:, None] * np.array(normals)
    for c_, drv in enumerate(model.drivers):
        err = _peak_error(sol.effort(drv.joint), taus[:, c_])
        assert err <= RTOL, f"{case}: tau_{drv.joint} differs from MuJoCo by {err:.2e}"
    err = _peak_error(sol.reaction(slot.name), force)
    assert err <= RTOL, f"{case}: slot reaction differs from MuJoCo by {err:.2e}"


# ----------------------------------------------------------------------------------------------
# models with free degrees of freedom (linkdyn simulate)


@pytest.mark.parametrize("name, backend", [("fourbar_release", "auto"),
                                           ("toggle_spring", "compiled")])
def test_a_simulated_motion_satisfies_mujocos_equations(name, backend):
    """A model without drivers (its free joints in the tree, as ``simulate`` keeps them),
    placed at its simulated pose: at every output sample of ``simulate`` MuJoCo's equations of
    the export hold with linkdyn's accelerations, the cut-joint forces being linkdyn's
    reactions (no effort: S is empty). (The stiff toggle on the compiled backend, so on the
    compiled worker: under auto its many evaluations switched to compiling the right-hand
    side cold on the other worker, 56 s of CPU.)"""
    from linkdyn import simulate

    if backend == "compiled":
        pytest.importorskip("numba", reason="the compiled right-hand side needs numba")
    model = load(example_path(name))
    t = np.linspace(0.0, 0.03, 5)      # five states, the last where the export is placed
    sol = simulate(model, t, rtol=1e-9, atol=1e-11, backend=backend)
    export = mjcf(model, at=0.03)
    m = mujoco.MjModel.from_xml_string(export.text)
    assert m.nu == len(model.drivers)
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    for b in model.moving_bodies:           # placed where the simulation is at 0.03 s
        for p in b.points:
            np.testing.assert_allclose(d.site_xpos[m.site(f"{b.name}.{p}").id][[0, 2]],
                                       sol.point(b.name, p)[-1], atol=1e-9)
    assert check_against_mujoco(model, sol, export.text, name) <= RTOL


# ----------------------------------------------------------------------------------------------
# massless links and point masses


@pytest.mark.parametrize("case", ["hoeken-massless-coupler", "slider-crank-point-masses"])
def test_massless_links_and_point_masses_get_mujocos_lower_bounds(case):
    """MuJoCo needs every moving body's mass and inertia positive: the export gives a massless
    link or point mass MuJoCo's lower bounds (1e-12 of the largest), names them, and MuJoCo's
    efforts and cut forces then differ from linkdyn's by about that fraction."""
    from test_dynamics import MODELS

    model = dataclasses.replace(MODELS[case](), drivers=(
        Driver("J1", ExpressionMotion("4 + 5*t + 0.8*sin(6*t)")),))
    light = [b.name for b in model.moving_bodies if b.mass == 0 or b.inertia == 0]
    assert light
    t = np.linspace(0.0, 1.0, 9)
    sol = analyze(model, t)
    export = mjcf(model, at=0.1)
    assert any(all(n in x for n in light) and "boundmass" in x for x in export.omitted)
    m = mujoco.MjModel.from_xml_string(export.text)
    big = max(b.mass for b in model.moving_bodies)
    for b in model.moving_bodies:          # only the light bodies are raised, to tiny values
        k = m.body(b.name).id
        if b.mass == 0:
            assert 0 < m.body_mass[k] <= 1e-11 * big
        else:
            assert m.body_mass[k] == b.mass
        assert np.all(m.body_inertia[k] > 0)
    # MuJoCo's equations see the bounds: raised to 1e-3 of the largest they are off ...
    with pytest.raises(AssertionError, match="differs from MuJoCo"):
        check_against_mujoco(model, sol, _bounded(export.text, 1e-3), case)
    # ... and at the export's they agree with linkdyn's to 1e-12
    assert check_against_mujoco(model, sol, export.text, case) <= RTOL


def _bounded(text, fraction):
    """``text`` with MuJoCo's bounds raised to ``fraction`` of the largest mass and inertia."""
    import re
    out = re.sub(r'boundmass="([^"]+)"',
                 lambda g: f'boundmass="{float(g[1]) / 1e-12 * fraction!r}"', text)
    return re.sub(r'boundinertia="([^"]+)"',
                  lambda g: f'boundinertia="{float(g[1]) / 1e-12 * fraction!r}"', out)
