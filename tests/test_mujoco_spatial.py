"""Spatial models' driver efforts and cut-joint reactions against MuJoCo's rigid-body dynamics,
on linkdyn's own MJCF export (:mod:`linkdyn.spatial.mjcf`, ``linkdyn export --to mjcf``).

As in ``test_mujoco.py``, the export is the one recipe and MuJoCo's own equations of the
exported file are the independent side. The test loads linkdyn's motion into MuJoCo through the
export's documented coordinates, read back from MuJoCo's compiled model: a hinge or slide
named ``NAME`` has ``qpos`` the results column ``q_NAME`` (its rates ``qd_NAME``,
``qdd_NAME``); a ball joint's quaternion is the child's rotation relative to its parent and
MuJoCo's body frame (``body_quat``), its ``qvel`` the relative angular velocity in the
child's frame, ``qacc`` that vector's rate. Every named point, every body's angular velocity,
angular acceleration and every point's velocity and acceleration are then checked to be
MuJoCo's (``site_xpos``, ``mj_objectVelocity``, ``mj_objectAcceleration``), so a wrong body
placement, axis, sign or joint order fails there. Then

    M qacc + qfrc_bias - qfrc_passive - qfrc_loads = S tau + J^T lam

(``J = efc_J``, three connect rows per equality, each ``d(site1 - site2)/dq``; the loads MJCF
cannot hold applied by ``mj_applyFT``) is solved by least squares for ``[tau; lam]``: ``tau``
must be linkdyn's efforts, and where the cut joints' rows map one-to-one onto MuJoCo's (no
redundant constraint) ``lam`` the reaction by A on B at each cut joint (a revolute joint's two
connects as their resultant about B's point).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from linkdyn import example_path, load
from linkdyn.errors import ModelError
from linkdyn.io.mjcf import mjcf
from linkdyn.spatial import analyze

mujoco = pytest.importorskip("mujoco", reason="the MuJoCo check needs mujoco (the mujoco extra)")

RTOL = 1e-9    # of the peak of each effort and reaction (the bar; they agree to ~1e-13)


def _hat(w):
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def _quat_to_matrix(qt):
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, np.asarray(qt, float))
    return R.reshape(3, 3)


def _matrix_to_quat(R):
    qt = np.zeros(4)
    mujoco.mju_mat2Quat(qt, np.asarray(R, float).ravel())
    return qt


def set_state(sol, cols, m, d, k):
    """linkdyn's sample ``k`` (``cols``: its results columns) into ``d``; returns ``qacc``.
    Checks MuJoCo's bodies move as linkdyn's (positions, velocities, accelerations of every
    body and named point)."""
    qacc = np.zeros(m.nv)

    def vector(prefix, name):
        """A column triple at sample k: ``omega_x_crank`` ... or a point's ``x_crank.A`` ..."""
        return np.array([cols[f"{prefix}{c}_{name}" if prefix in ("", "v", "a")
                              else f"{prefix}_{c}_{name}"][k] for c in "xyz"])

    for jid in range(m.njnt):
        name, qa, va = m.joint(jid).name, m.jnt_qposadr[jid], m.jnt_dofadr[jid]
        if m.jnt_type[jid] == mujoco.mjtJoint.mjJNT_BALL:
            child = m.body(m.jnt_bodyid[jid])
            parent = m.body(m.body_parentid[child.id]).name
            Rc = sol.rotation(child.name)[k]
            Rp = np.eye(3) if parent == "world" else sol.rotation(parent)[k]
            wp, ap = ((np.zeros(3), np.zeros(3)) if parent == "world"
                      else (vector("omega", parent), vector("alpha", parent)))
            wc, ac = vector("omega", child.name), vector("alpha", child.name)
            # R_c = R_p R_body Q; qvel = R_c^T (w_c - w_p), qacc its rate
            d.qpos[qa:qa + 4] = _matrix_to_quat(
                _quat_to_matrix(m.body_quat[child.id]).T @ Rp.T @ Rc)
            d.qvel[va:va + 3] = Rc.T @ (wc - wp)
            qacc[va:va + 3] = Rc.T @ (ac - ap + np.cross(wc, wp))
        else:
            d.qpos[qa], d.qvel[va] = cols[f"q_{name}"][k], cols[f"qd_{name}"][k]
            qacc[va] = cols[f"qdd_{name}"][k]
    mujoco.mj_forward(m, d)
    model, size = sol.model, sol.plan.size
    points = [(b.name, p) for b in model.moving_bodies for p in b.points]
    scale_v = max(np.max(np.abs(cols[f"v{c}_{b}.{p}"])) for b, p in points for c in "xyz")
    scale_a = max(np.max(np.abs(cols[f"a{c}_{b}.{p}"])) for b, p in points for c in "xyz")
    # accelerations without gravity (MuJoCo's cacc carries -g)
    gravity = m.opt.gravity.copy()
    m.opt.gravity[:] = 0
    d.qacc[:] = qacc
    mujoco.mj_rnePostConstraint(m, d)
    m.opt.gravity[:] = gravity
    for b in model.moving_bodies:
        bid = m.body(b.name).id
        vel, acc = np.zeros(6), np.zeros(6)
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_XBODY, bid, vel, 0)
        mujoco.mj_objectAcceleration(m, d, mujoco.mjtObj.mjOBJ_XBODY, bid, acc, 0)
        np.testing.assert_allclose(vel[:3], vector("omega", b.name), atol=1e-12 * scale_v / size)
        np.testing.assert_allclose(acc[:3], vector("alpha", b.name), atol=1e-11 * scale_a / size)
        for name in b.points:
            sid = m.site(f"{b.name}.{name}").id
            np.testing.assert_allclose(d.site_xpos[sid], vector("", f"{b.name}.{name}"),
                                       atol=1e-12 * size)
            # the point's velocity v + w x r and acceleration a + al x r + w x (w x r)
            r = d.site_xpos[sid] - d.xpos[bid]
            np.testing.assert_allclose(vel[3:] + np.cross(vel[:3], r),
                                       vector("v", f"{b.name}.{name}"), atol=1e-12 * scale_v)
            np.testing.assert_allclose(
                acc[3:] + np.cross(acc[:3], r) + np.cross(vel[:3], np.cross(vel[:3], r)),
                vector("a", f"{b.name}.{name}"), atol=1e-11 * scale_a)
    return qacc


def load_forces(model, m, d, time):
    """The loads MJCF does not hold (forces at points, couples; global) as generalized forces."""
    q_loads = np.zeros(m.nv)
    for ld in model.loads:
        if ld.kind in ("spring", "damper"):
            continue
        bid = m.body(ld.body).id
        value = np.asarray(ld.value(np.array([time])), float).reshape(3)
        if ld.kind == "force":
            point = d.site_xpos[m.site(f"{ld.body}.{ld.point}").id].copy()
            mujoco.mj_applyFT(m, d, value, np.zeros(3), point, bid, q_loads)
        elif ld.kind == "torque":
            mujoco.mj_applyFT(m, d, np.zeros(3), value, d.xipos[bid].copy(), bid, q_loads)
        else:  # pragma: no cover - the cases here have no other loads
            raise NotImplementedError(ld.kind)
    return q_loads


def _peak_error(ref, got):
    return float(np.max(np.abs(ref - got)) / np.max(np.abs(ref)))


def mujoco_efforts(sol, xml):
    """MuJoCo's efforts (T, n_drivers) and each equality's force on site1's body with the
    site's position (name -> ((T, 3), (T, 3))) at linkdyn's motion ``sol``."""
    m = mujoco.MjModel.from_xml_string(xml)
    m.opt.jacobian = mujoco.mjtJacobian.mjJAC_DENSE
    d = mujoco.MjData(m)
    nv = m.nv
    S = np.zeros((nv, m.nu))
    for a in range(m.nu):
        S[m.jnt_dofadr[m.actuator_trnid[a, 0]], a] = m.actuator_gear[a, 0]
    assert [m.joint(m.actuator_trnid[a, 0]).name for a in range(m.nu)] == [
        drv.joint for drv in sol.model.drivers]
    names = [m.eq(e).name for e in range(m.neq)]
    taus, lams, where = [], [], []
    cols = sol.columns()
    for k in range(len(sol.t)):
        qacc = set_state(sol, cols, m, d, k)
        M = np.zeros((nv, nv))
        mujoco.mj_fullM(m, d, M)
        assert d.nefc == 3 * m.neq
        J = np.array(d.efc_J[:d.nefc * nv]).reshape(d.nefc, nv)
        sites = []
        for e in range(m.neq):   # the rows are d(site1 - site2)/dq
            jac = []
            for sid in m.eq_obj1id[e], m.eq_obj2id[e]:
                jp = np.zeros((3, nv))
                mujoco.mj_jacSite(m, d, jp, None, sid)
                jac.append(jp)
            np.testing.assert_allclose(J[3 * e:3 * e + 3], jac[0] - jac[1], atol=1e-13)
            sites.append(d.site_xpos[m.eq_obj1id[e]].copy())
        rhs = M @ qacc + d.qfrc_bias - d.qfrc_passive - load_forces(sol.model, m, d, sol.t[k])
        A = np.hstack((S, J.T))
        x, *_ = np.linalg.lstsq(A, rhs, rcond=None)
        assert np.linalg.norm(A @ x - rhs) <= 1e-11 * np.linalg.norm(rhs)
        taus.append(x[:m.nu])
        lams.append(x[m.nu:].reshape(m.neq, 3))
        where.append(sites)
    lams, where = np.array(lams), np.array(where)
    return np.array(taus), {n: (lams[:, e], where[:, e]) for e, n in enumerate(names)}


def check_against_mujoco(sol, xml, reactions=True):
    """linkdyn's efforts (and cut reactions) equal MuJoCo's to RTOL of their peaks; returns
    the largest relative difference."""
    taus, eq = mujoco_efforts(sol, xml)
    worst = 0.0
    for c, drv in enumerate(sol.model.drivers):
        err = _peak_error(sol.effort(drv.joint), taus[:, c])
        assert err <= RTOL, f"effort at {drv.joint} differs from MuJoCo's by {err:.2e}"
        worst = max(worst, err)
    if not reactions:
        return worst
    for name in [n for n in eq if not n.endswith(".axis")]:
        force, at = eq[name]
        couple = np.zeros_like(force)
        if f"{name}.axis" in eq:     # a revolute cut: the two connects' resultant about B's point
            f2, at2 = eq[f"{name}.axis"]
            force, couple = force + f2, np.cross(at2 - at, f2)
        ref = sol.reaction(name)
        err = _peak_error(ref, np.concatenate([force, couple], 1))
        assert err <= RTOL, f"reaction at {name} differs from MuJoCo's by {err:.2e}"
        worst = max(worst, err)
    return worst


# the examples, over a part of their run with every speed and acceleration nonzero; the over-
# constrained spherical four-bar's reactions are not unique (linkdyn reports the minimum-norm
# one and the undetermined part): its efforts only
CASES = {"rsur": (1.0, True), "spherical_fourbar": (1.0, False), "rps3": (2.0, True),
         "spatial_slider_crank": (1.0, True),
         "stewart": (1.0, True)}


@pytest.mark.parametrize("name", list(CASES))
def test_spatial_efforts_and_cut_reactions_match_mujoco(name):
    duration, reactions = CASES[name]
    model = load(example_path(name))
    sol = analyze(model, np.linspace(0.0, duration, 4) + 0.013)
    assert (sol.redundancy is None) == reactions
    export = mjcf(model, at=0.3)
    assert set(export.cut) == {model.joints[j].name for j in sol.plan.topo.cut}
    assert check_against_mujoco(sol, export.text, reactions) <= RTOL


def test_the_spatial_export_loads_assembled_at_its_time():
    """qpos0 and the keyframe are the pose, rates and driver targets at ``at``: every point where
    linkdyn puts it, the loops closed, the rates closing them, each servo at its target."""
    model = load(example_path("stewart"))
    at = 0.37
    sol = analyze(model, np.array([at]))
    m = mujoco.MjModel.from_xml_string(mjcf(model, at=at).text)
    d = mujoco.MjData(m)
    size = sol.plan.size
    for reset in (lambda: mujoco.mj_resetData(m, d), lambda: mujoco.mj_resetDataKeyframe(m, d, 0)):
        reset()
        mujoco.mj_forward(m, d)
        for b in model.moving_bodies:
            for p in b.points:
                np.testing.assert_allclose(d.site_xpos[m.site(f"{b.name}.{p}").id],
                                           sol.point(b.name, p)[0], atol=1e-13 * size)
        assert np.max(np.abs(d.efc_pos)) <= 1e-13 * size
    assert d.time == at
    np.testing.assert_allclose(d.actuator_length, d.ctrl, atol=1e-14 * size)
    J = np.array(d.efc_J[:d.nefc * m.nv]).reshape(d.nefc, m.nv)
    assert np.max(np.abs(J @ d.qvel)) <= 1e-12 * np.max(np.abs(d.qvel)) * size
    for b in model.moving_bodies:       # every body turns at linkdyn's rate
        vel = np.zeros(6)
        mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_BODY, m.body(b.name).id, vel, 0)
        np.testing.assert_allclose(vel[:3], sol.omega(b.name)[0], atol=1e-12)


@pytest.mark.parametrize("name", ["quarter_car", "bricard"])
def test_a_simulated_spatial_motion_satisfies_mujocos_equations(name):
    """A released mechanism (no driver; its free joint in the tree as ``simulate`` keeps it):
    MuJoCo's equations of the export hold with linkdyn's accelerations (the least squares of
    ``mujoco_efforts`` leaves no residual), the cut forces being linkdyn's reactions where
    statics determines them (the quarter car: a ball joint in the tree, springs and a damper as
    tendons, two spherical cuts; Bricard's over-constrained loop, IFToMM A04, has a redundant
    row: its motion only)."""
    from linkdyn import simulate

    model = load(example_path(name))
    sol = simulate(model, np.array([0.0, 0.02]), backend="numpy")
    export = mjcf(model, at=0.02, sol=sol)
    assert mujoco.MjModel.from_xml_string(export.text).nu == 0
    assert check_against_mujoco(sol, export.text, reactions=sol.redundancy is None) <= RTOL


def test_the_command_exports_a_spatial_model_and_refuses_a_loop_mujoco_cannot_close(tmp_path):
    """``linkdyn export --to mjcf`` writes a spatial model MuJoCo loads; a loop whose only
    revolute joint is driven and which has no spherical joint (the spatial slider-crank with a
    universal joint for its ball joint and a cylindrical one for its slide), which no MuJoCo
    equality closes, exits 2 naming the joint."""
    from click.testing import CliRunner

    from linkdyn.cli import main

    text = example_path("rsur").read_text()
    path, out = tmp_path / "rsur.toml", tmp_path / "rsur.xml"
    path.write_text(text)
    res = CliRunner().invoke(main, ["export", str(path), "--to", "mjcf", "-o", str(out)])
    assert res.exit_code == 0, res.output
    assert "closed by connect: J2" in res.output and "torque 'rocker'" in res.output
    m = mujoco.MjModel.from_xml_string(out.read_text())
    assert m.njnt == 4 and m.neq == 1 and m.nu == 1         # J1, J3.1, J3.2, J4; J2; J1
    # an over-constrained loop without drivers (Grübler-Kutzbach 0, mobility 1) is simulated
    bricard = tmp_path / "bricard.toml"
    bricard.write_text(example_path("bricard").read_text())
    res = CliRunner().invoke(main, ["export", str(bricard), "--to", "mjcf", "--at", "0.01",
                                    "-o", str(out)])
    assert res.exit_code == 0, res.output
    m = mujoco.MjModel.from_xml_string(out.read_text())
    assert m.njnt == 5 and m.neq == 2 and m.nu == 0         # J1..J5; J6 and J6.axis
    # R (driven), U, U, C: mobility 1, no joint MuJoCo can close that is not driven
    text = example_path("spatial_slider_crank").read_text()
    assert 'type = "spherical"' in text and 'type = "prismatic"' in text
    path.write_text(text.replace('type = "spherical"', 'type = "universal"\naxis = [1.0, 0.0, 0.0]'
                                 '\naxis2 = [0.0, 1.0, 0.0]').replace('type = "prismatic"',
                                                                      'type = "cylindrical"'))
    res = CliRunner().invoke(main, ["export", str(path), "--to", "mjcf", "-o", str(out)])
    assert res.exit_code == 2 and "which MuJoCo has no equality constraint" in res.output
    assert "joints.J" in res.output and "Traceback" not in res.output


def test_a_loop_cut_where_mujoco_cannot_close_it_is_cut_at_a_joint_it_can():
    """The RSUR cut at its universal joint (``[topology] cut``): MuJoCo's tree cuts the
    spherical joint of the loop instead, and MuJoCo's equations still give linkdyn's effort and
    the spherical joint's reaction (a tree joint's in linkdyn's solution)."""
    model = dataclasses.replace(load(example_path("rsur")), cut=("J3",))
    sol = analyze(model, np.linspace(0.0, 1.0, 3) + 0.013)
    assert [model.joints[j].name for j in sol.plan.topo.cut] == ["J3"]
    export = mjcf(model, at=0.3, sol=sol)
    assert export.cut == ("J2",)
    assert check_against_mujoco(sol, export.text) <= RTOL
