"""A moving body's free-body diagram: every force on it at each sample, which sum to ``m a_G``.

The forces on body b, global components (N), each at its point of application (m, global):

- each joint's reaction on b: ``+F`` where b is the joint's second body, ``-F`` where it is the
  first (``Fx_``, ``Fy_`` are by the first body on the second), at the second body's joint point;
- a slider driver's effort and a sliding joint's friction force, inside their joint (along its
  axis on the second body, minus that on the first), at the same point;
- gravity ``m g`` at the mass centre G;
- each applied load with a force (``force``, ``spring``, ``damper``, ``joint_force``): the loads
  stage (:func:`linkdyn.loads.wrenches`) run on that load alone, at its point on b.

Couples have no force and are not listed: torques, a revolute driver's or friction's couple, a
prismatic joint's moment. By Newton's law the forces sum to the mass times the mass centre's
acceleration ``m a_G`` (:func:`mass_centre`), the force polygon's closing side; that the listed
forces do is a check of the whole solution (``tests/test_report.py``, ``test_free_body_*``).

A spatial solution (:class:`linkdyn.spatial.SpatialSolution`) has the same free body in three
components, (T, 3): each joint's reaction force (the spatial reaction ``[F; M]`` by A on B,
about B's point: its ``F``, signed as above) at B's joint point, a sliding driver's effort along
its axis (:func:`spatial_effort_force`), the weight at G and each force, spring, damper and
``joint_force`` (the spatial loads stage, :func:`linkdyn.spatial.dynamics.loads`, run on that
load alone); couples again left out.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .. import joints as jk
from ..kinematics import point_acceleration
from ..planar import last, rotate


@dataclass(frozen=True)
class Force:
    """One force on a body: its ``label`` (a joint's name, ``driver J``, ``friction J``, a
    load's label or ``weight``), ``kind`` (``joint``, ``driver``, ``friction``, ``weight`` or
    ``load``), point of application ``at`` (T, 2) m and its name ``where`` (``BODY.POINT``, or
    ``G`` for the mass centre), ``force`` (T, 2) N, global components, and ``sign``: +1 where
    the body is the joint's second body, -1 where it is the first (a joint's force is ``sign``
    times its reaction ``Fx_``, ``Fy_``; +1 for a weight or a load)."""

    label: str
    kind: str
    at: np.ndarray
    force: np.ndarray
    where: str = ""
    sign: float = 1.0


def mass_centre(sol, i: int) -> tuple[np.ndarray, np.ndarray]:
    """Position and acceleration (2, T) of body i's mass centre G (tree index), global, m and
    m/s^2: ``r_G = r_i + d``, ``a_G = a_i + alpha perp(d) - w^2 d``, ``d = R_i c_i``.
    A spatial solution: (T, 3) each, ``i`` the plan's body index."""
    if getattr(sol, "space", "planar") == "spatial":
        from ..spatial.dynamics import point_of
        r, _, a = point_of(sol.plan, sol.motion, sol.plan.topo.bodies[i], sol.plan.com[i])
        return r, a
    kin = sol.kin
    lay, pose = kin.layout, kin.pose
    d = pose.rotate(i, lay.com[i])
    return pose.r[i] + d, point_acceleration(kin.twists[i], kin.rates[i], d)


def effort_wrench(sol, joint, effort) -> tuple[np.ndarray, np.ndarray]:
    """The wrench ``effort p`` of an effort (T,) inside ``joint`` on its second body, about its
    second body's joint point: the couple (T,) N m and the force (T, 2) N, global (``p`` the
    joint's motion vector with its axis fixed in the first body; minus both on the first)."""
    e = rotate(sol.phi(joint.body_a), np.asarray(joint.axis, float))
    p = np.broadcast_to(jk.get(joint.kind).motion_vector(1.0, e, np.ndim(effort)),
                        (3,) + np.shape(effort))
    return effort * p[0], effort[..., None] * last(p[1:])


def spatial_effort_force(sol, joint: str) -> np.ndarray:
    """A spatial sliding driver's effort as a force (T, 3) N, global, on its joint's second
    body: the effort along the joint's axis (fixed in the first body); minus it on the
    first. (An angular driver's effort is a couple: no force.)"""
    from ..spatial import kinematics as sk
    m, p = sol.model, sol.plan
    j = [x.name for x in m.joints].index(joint)
    pose = sk.joint_pose(p, sol.motion.tree, j, m.joints[j])
    return sol.effort(joint)[:, None] * (pose.RA @ p.geometry[j].e)


def free_body(sol, body: str) -> tuple[list[Force], np.ndarray]:
    """The forces on ``body`` (see the module docstring) and ``m a_G`` (T, 2) N ((T, 3) for
    a spatial solution).

    Returns
    -------
    forces : list of Force
        Joint reactions (model joint order), driver efforts and friction forces, the weight,
        then the applied loads (model load order); a force that is zero at every sample left
        out.
    m_a : ndarray (T, 2)
        The body's mass times its mass centre's acceleration, N: the sum of ``forces``.
    """
    if getattr(sol, "space", "planar") == "spatial":
        return _spatial_free_body(sol, body)
    from ..loads import wrenches

    m = sol.model
    i = sol.body_index(body)
    lay = sol.kin.layout
    shape = np.shape(sol.t)
    forces: list[Force] = []

    def add(label, kind, at, f, where, sign=1.0):
        f = np.broadcast_to(np.asarray(f, float), shape + (2,))
        if np.any(f != 0):
            forces.append(Force(label, kind, np.broadcast_to(at, shape + (2,)), f, where, sign))

    # the joints' reactions on b, drivers' and friction's forces inside their joints
    drivers = {d.joint: k for k, d in enumerate(m.drivers)}
    fr = getattr(sol, "friction", None)
    frk = {j: k for k, (j, a) in enumerate(zip(fr.joints, fr.angular)) if not a} if fr else {}
    for k, j in enumerate(m.joints):
        if body not in (j.body_a, j.body_b) or j.body_a == j.body_b:
            continue
        sign = 1.0 if j.body_b == body else -1.0
        at, where = sol.point(j.body_b, j.point_b), f"{j.body_b}.{j.point_b}"
        add(j.name, "joint", at, sign * sol.reactions.force[..., k, :], where, sign)
        if j.name in drivers and not jk.get(j.kind).angular:
            add(f"driver {j.name}", "driver", at,
                sign * effort_wrench(sol, j, sol.dyn.tau[..., drivers[j.name]])[1], where, sign)
        if j.name in frk:
            add(f"friction {j.name}", "friction", at,
                sign * effort_wrench(sol, j, fr.effort[frk[j.name]])[1], where, sign)
    # gravity: the loads stage with no load, the body's share
    r_g, a_g = mass_centre(sol, i)
    weight = wrenches(replace(m, loads=()), sol.kin).wrenches[i]
    add("weight", "weight", last(r_g), last(weight[1:]), "G")
    # each applied load alone (without gravity), at its point on b
    nog = np.zeros(2)
    for ld, label, owner, point in _on(m, body):   # (friction: above, from the reactions)
        w = wrenches(replace(m, loads=(ld,), gravity=nog), sol.kin).wrenches[i]
        add(label, "load", sol.point(owner, point), last(w[1:]), f"{owner}.{point}")
    return forces, lay.mass[i] * last(a_g)


def _on(m, body: str):
    """The loads of ``m`` that act as a force on ``body`` (forces, springs, dampers, a
    ``joint_force`` of a joint of it; not couples, not friction), each with its label and the
    body and point it acts at: ``(load, label, owner, point)``."""
    from ..loads import labels
    for ld, label in zip(m.loads, labels(m)):
        if ld.kind not in ("force", "spring", "damper", "joint_force"):
            continue
        if ld.kind == "joint_force":
            j = m.joint(ld.joint)
            if body in (j.body_a, j.body_b):
                yield ld, label, j.body_b, j.point_b
        elif body in (ld.body, ld.body2):
            yield ld, label, body, (ld.point if ld.body == body else ld.point2)


def _spatial_free_body(sol, body: str) -> tuple[list[Force], np.ndarray]:
    """:func:`free_body` of a spatial solution: the forces (T, 3) and ``m a_G`` (T, 3)."""
    from ..spatial.dynamics import loads as spatial_loads

    m, p = sol.model, sol.plan
    i = p.topo.bodies.index(body)
    shape = (len(sol.t), 3)
    forces: list[Force] = []

    def add(label, kind, at, f, where, sign=1.0):
        f = np.broadcast_to(np.asarray(f, float), shape)
        if np.any(f != 0):
            forces.append(Force(label, kind, np.broadcast_to(at, shape), f, where, sign))

    drivers = {d.joint for d in m.drivers}
    for j in m.joints:
        if body not in (j.body_a, j.body_b) or j.body_a == j.body_b:
            continue
        sign = 1.0 if j.body_b == body else -1.0
        at, where = sol.point(j.body_b, j.point_b), f"{j.body_b}.{j.point_b}"
        add(j.name, "joint", at, sign * sol.reaction(j.name)[:, :3], where, sign)
        if j.name in drivers and not p.kinds[[x.name for x in m.joints].index(j.name)].angular:
            add(f"driver {j.name}", "driver", at, sign * spatial_effort_force(sol, j.name),
                where, sign)
    r_g, a_g = mass_centre(sol, i)
    weight = spatial_loads(replace(m, loads=()), p, sol.motion, sol.coords).w_ext[:, i, 3:]
    add("weight", "weight", r_g, weight, "G")
    nog = np.zeros(3)
    for ld, label, owner, point in _on(m, body):
        w = spatial_loads(replace(m, loads=(ld,), gravity=nog), p, sol.motion,
                          sol.coords).w_ext[:, i, 3:]
        add(label, "load", sol.point(owner, point), w, f"{owner}.{point}")
    return forces, p.mass[i] * a_g
