"""Spatial driver efforts and loop forces against Pinocchio's rigid-body dynamics.

The test builds each mechanism's open tree in Pinocchio by its own code from the model's
bodies, joints and axes (not through linkdyn's kinematics or its MJCF export): a spanning tree
from the ground, cut at the joint ``CUT`` names; each revolute joint a
``JointModelRevoluteUnaligned`` about its axis at its point, a universal joint two of them in
series (the first axis fixed in its first body, the second in its second, a massless body
between), every body's inertia turned into its joint's frame, every named point an operational
frame. Pinocchio's coordinates are the joints' rotations from the design pose, linkdyn's
results columns ``q_J1``, ``q_J3.1``, ``q_J3.2``...; positions, velocities and accelerations of
every point are checked to be linkdyn's before any force is compared.

With linkdyn's motion, Pinocchio's inverse dynamics of the open tree (``rnea``, gravity
included) less the generalized forces of the applied loads must be the driver's effort on its
joint plus ``Jc^T lam``, ``Jc`` the cut joint's constraint Jacobian from Pinocchio's frame
Jacobians (a spherical joint: the velocity of B's point less A's; a revolute joint: that and
the relative angular velocity across the axis). Least squares gives ``[tau; lam]``: ``tau``
must be linkdyn's effort and, where the rows are independent, ``lam`` the reaction by A on B.
"""

from __future__ import annotations

import numpy as np
import pytest

from linkdyn import example_path, load
from linkdyn.spatial import analyze

pin = pytest.importorskip("pinocchio", reason="the Pinocchio check needs pin (the test extra)")

RTOL = 1e-9      # of each effort's and reaction's peak (they agree to ~1e-14)
#: The joint each model's loop is cut at in Pinocchio's tree.
CUT = {"rsur": "J2", "spherical_fourbar": "J4"}


def _perpendiculars(e):
    t1 = np.cross(e, np.eye(3)[int(np.argmin(np.abs(e)))])
    t1 /= np.linalg.norm(t1)
    return np.stack([t1, np.cross(e, t1)])


def build(model, cut):
    """Pinocchio's model of ``model``'s tree without the joint ``cut``.

    Returns
    -------
    pin.Model, dict
        The model; ``coords`` Pinocchio's coordinate names (results columns ``J1``, ``J3.1``)
        in ``q`` order.
    """
    bodies = {b.name: b for b in model.bodies}

    def glob(body, x):                       # a body's point at the design pose, global
        return bodies[body].origin + bodies[body].rotation @ x

    pm = pin.Model()
    pm.gravity.linear = np.asarray(model.gravity, float)
    frame_of = {"ground": (0, np.zeros(3))}   # body -> (its Pinocchio joint, that joint's origin)
    coords = []
    todo = [j for j in model.joints if j.name != cut]
    while todo:
        jt = next(j for j in todo if (j.body_a in frame_of) != (j.body_b in frame_of))
        todo.remove(jt)
        forward = jt.body_a in frame_of                 # the tree runs from A to B
        parent, child = (jt.body_a, jt.body_b) if forward else (jt.body_b, jt.body_a)
        s = 1.0 if forward else -1.0
        origin = glob(jt.body_b, bodies[jt.body_b].points[jt.point_b])
        pj, po = frame_of[parent]
        # a chain of rotations about global axes (at the design pose) through the joint's point
        axes = [bodies[jt.body_a].rotation @ jt.axis]
        if jt.kind == "universal":
            axes.append(bodies[jt.body_b].rotation @ jt.axis2)
        names = [jt.name] if jt.kind == "revolute" else [f"{jt.name}.1", f"{jt.name}.2"]
        assert jt.kind in ("revolute", "universal"), jt.kind
        if not forward:
            axes, names = axes[::-1], names[::-1]
        for n, (axis, name) in enumerate(zip(axes, names)):
            place = pin.SE3(np.eye(3), origin - po if n == 0 else np.zeros(3))
            pj = pm.addJoint(pj, pin.JointModelRevoluteUnaligned(*(s * axis)), place, name)
            po = origin
            coords.append(name)
        # the body's inertia about its mass centre, turned into the joint's (global) axes
        b = bodies[child]
        inertia = pin.Inertia(b.mass, glob(child, b.com) - origin,
                              b.rotation @ b.inertia @ b.rotation.T)
        pm.appendBodyToJoint(pj, inertia, pin.SE3.Identity())
        frame_of[child] = (pj, origin)
    for b in model.bodies:
        pj, po = frame_of[b.name]
        for name, x in b.points.items():
            pm.addFrame(pin.Frame(f"{b.name}.{name}", pj, pin.SE3(np.eye(3), glob(b.name, x) - po),
                                  pin.FrameType.OP_FRAME))
    return pm, coords


def _jacobian(pm, data, frame):
    return pin.getFrameJacobian(pm, data, pm.getFrameId(frame), pin.LOCAL_WORLD_ALIGNED)


def efforts(model, sol, cut):
    """Pinocchio's driver efforts (T, n_d) and cut multipliers (T, rows) at ``sol``'s motion."""
    pm, coords = build(model, cut)
    data = pm.createData()
    cols = sol.columns()
    jt = model.joint(cut)
    size = sol.plan.size
    peak = {x: max(np.max(np.abs(cols[f"{x}{c}_{b.name}.{p}"])) for b in model.moving_bodies
                   for p in b.points for c in "xyz") for x in "va"}
    taus, lams = [], []
    for k in range(len(sol.t)):
        q, v, a = (np.array([cols[f"{p}_{c}"][k] for c in coords]) for p in ("q", "qd", "qdd"))
        pin.forwardKinematics(pm, data, q, v, a)
        pin.updateFramePlacements(pm, data)
        pin.computeJointJacobians(pm, data, q)
        # Pinocchio's tree moves every point as linkdyn's
        for b in model.moving_bodies:
            for p in b.points:
                f = pm.getFrameId(f"{b.name}.{p}")
                vel = pin.getFrameVelocity(pm, data, f, pin.LOCAL_WORLD_ALIGNED).linear
                acc = pin.getFrameClassicalAcceleration(pm, data, f, pin.LOCAL_WORLD_ALIGNED).linear
                for prefix, got, scale in (("", data.oMf[f].translation, size),
                                           ("v", vel, peak["v"]), ("a", acc, peak["a"])):
                    np.testing.assert_allclose(
                        got, [cols[f"{prefix}{c}_{b.name}.{p}"][k] for c in "xyz"],
                        atol=1e-12 * scale)
        # the cut's rows: B's point's velocity less A's (and the relative rotation across e)
        JB, JA = (_jacobian(pm, data, f"{jt.body_b}.{jt.point_b}") if jt.body_b != "ground"
                  else np.zeros((6, pm.nv)),
                  _jacobian(pm, data, f"{jt.body_a}.{jt.point_a}") if jt.body_a != "ground"
                  else np.zeros((6, pm.nv)))
        Jc = (JB - JA)[:3]
        if jt.kind == "revolute":
            e = sol.rotation(jt.body_a)[k] @ jt.axis if jt.body_a != "ground" else jt.axis
            Jc = np.vstack([Jc, _perpendiculars(e) @ (JB - JA)[3:]])
        # the applied loads as generalized forces: J_point^T F, J_w^T T
        Q = np.zeros(pm.nv)
        for ld in model.loads:
            value = np.asarray(ld.value(sol.t[k:k + 1]), float).reshape(3)
            J = _jacobian(pm, data, f"{ld.body}.{ld.point}" if ld.kind == "force"
                          else f"{ld.body}.{next(iter(model.body(ld.body).points))}")
            Q += (J[:3] if ld.kind == "force" else J[3:]).T @ value
        rhs = pin.rnea(pm, data, q, v, a) - Q
        S = np.zeros((pm.nv, len(model.drivers)))
        for c, d in enumerate(model.drivers):
            S[coords.index(d.joint), c] = 1.0
        A = np.hstack([S, Jc.T])
        x, *_ = np.linalg.lstsq(A, rhs, rcond=None)
        assert np.linalg.norm(A @ x - rhs) <= 1e-11 * np.linalg.norm(rhs)
        taus.append(x[:S.shape[1]])
        lams.append(x[S.shape[1]:])
    return np.array(taus), np.array(lams)


def _peak_error(ref, got):
    return float(np.max(np.abs(ref - got)) / np.max(np.abs(ref)))


@pytest.mark.parametrize("name", list(CUT))
def test_spatial_efforts_and_loop_forces_match_pinocchio(name):
    model = load(example_path(name))
    sol = analyze(model, np.linspace(0.0, 1.0, 5) + 0.021)
    taus, lams = efforts(model, sol, CUT[name])
    for c, d in enumerate(model.drivers):
        assert _peak_error(sol.effort(d.joint), taus[:, c]) <= RTOL
    if sol.redundancy is None:       # the spherical cut's three rows: the force by A on B
        assert _peak_error(sol.reaction(CUT[name])[:, :3], lams) <= RTOL
