"""A MuJoCo model (MJCF) of a spatial mechanism: ``linkdyn export MODEL --to mjcf``.

MuJoCo's axes are the model's (x, y, z); numbers are SI. What is written:

- linkdyn's open tree (:class:`~linkdyn.topology.Topology`) as nested ``<body>`` elements,
  each body's frame its linkdyn frame at the pose of the time ``at`` (``pos`` and ``quat``
  relative to its parent's). A tree joint is its kind's chain of elementary screws, each
  screw one MuJoCo joint at the child's joint point: a turning screw a ``hinge``, a sliding
  one a ``slide``, with the axis the screw's, signed for the child as the tree runs (parent
  to child: the chain reversed and every axis negated when the child is the joint's first
  body), and ``ref`` the coordinate at ``at``. So ``qpos`` of such a joint is linkdyn's
  coordinate ``q_<joint><suffix>`` itself (``J1``, ``J3.1``, ``J3.2``, ``J5.s``, ``J5.r``):
  revolute one hinge, prismatic one slide, universal two hinges (the first axis fixed in
  the parent), cylindrical a slide and a hinge. A spherical tree joint is a ``ball`` (its
  ``qpos`` a unit quaternion, the identity at ``at``; its ``qvel`` the child's angular
  velocity relative to the parent in the child's frame), not linkdyn's three Cardan angles.
- each cut joint as ``<equality><connect>`` between B's point (``site1``) and A's: the force
  on site1's body is the reaction by A on B. A spherical joint is one connect; a revolute
  joint two, the second between copies of the axis's point one mechanism size along the axis
  (sites ``BODY.JOINT.axis``, equality ``JOINT.axis``): six rows of which five are
  independent, the joint's reaction their resultant (the force ``lam_1 + lam_2``, the couple
  ``l e x lam_2`` about B's point, ``l e`` the second pair's offset on B). A loop linkdyn cuts
  at a prismatic, cylindrical or universal joint, which no MuJoCo equality closes, is cut at a
  spherical (else revolute) joint of the loop instead (:func:`mujoco_cut`; MuJoCo's tree need
  not be linkdyn's); a loop without one that is neither driven nor free is refused, naming the
  joint.
- a model with free degrees of freedom keeps them in the tree as ``linkdyn simulate`` does,
  placed at its simulated pose at ``at``;
- drivers, loads, masses and bounds as the planar exporter (:mod:`linkdyn.io.mjcf`): each
  driver a ``<position>`` actuator on its joint (gear 1: its force is the driver's effort);
  springs and dampers spatial tendons; forces, torques, joint torques and forces left out and
  named; full inertia tensors (``fullinertia``, the body frame, about the mass centre); a
  keyframe ``linkdyn`` with the positions, rates and driver targets at ``at``.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from ..errors import ModelError
from ..io import mjcf_common as common
from ..model import GROUND
from . import algebra as sa
from . import joints as sj

#: The cut joint kinds MuJoCo closes, with the ``connect`` equalities each takes.
CONNECTS = {"spherical": 1, "revolute": 2}


def _vec(v) -> str:
    """A 3-vector at round-trip precision."""
    return " ".join(repr(float(x)) for x in v)


def _free(model) -> bool:
    """Whether ``model`` has free degrees of freedom: its mobility (the closure Jacobian's rank,
    not Grübler–Kutzbach's count, which an over-constrained loop undercuts) exceeds its
    drivers."""
    from . import check
    return check(model)["mobility"] > len(model.drivers)


def _solve(model, at: float):
    """The solution at ``[at]``: spatial ``analyze``, or ``simulate`` from ``[initial]``."""
    if not _free(model):
        from . import analyze
        return analyze(model, np.array([at]))
    from ..forward import simulate
    return simulate(model, np.array([0.0, at]) if at > 0 else np.array([0.0]))


def mujoco_cut(model):
    """``model`` with cut joints MuJoCo can close: itself when every cut joint is spherical or
    revolute, else with ``cut`` naming, for each other cut joint, a spherical (else revolute)
    joint of its loop instead, the one farthest from the ground that is neither driven nor a
    free joint of ``[initial]``.

    Raises
    ------
    ModelError
        A loop with no such joint (naming the cut joint MuJoCo cannot close).
    """
    import dataclasses

    from .. import topology
    from .forward import partition

    # a simulation's free joints stay in the tree (placeholder drivers), as simulate keeps them
    inner = partition(model).inner if _free(model) else model
    keep = {d.joint for d in inner.drivers}
    for _ in range(len(model.joints)):
        topo = topology.build(dataclasses.replace(inner, cut=model.cut))
        bad = [j for j in topo.cut if model.joints[j].kind not in CONNECTS]
        if not bad:
            return model
        jt = model.joints[bad[0]]
        # the loop jt closes: the tree joints on the path between its two bodies
        ia, ib = topo.bodies.index(jt.body_a), topo.bodies.index(jt.body_b)
        path = [model.joints[topo.tree_joint[i]]
                for i in sorted(np.flatnonzero(topo.ancestors[ia] ^ topo.ancestors[ib]),
                                reverse=True)]
        swap = sorted((x for x in path if x.kind in CONNECTS and x.name not in keep),
                      key=lambda x: x.kind != "spherical")
        if not swap:
            raise ModelError(
                f"joint '{jt.name}' is a cut {jt.kind} joint, which MuJoCo has no equality "
                "constraint for (it closes spherical and revolute joints only), and its loop "
                "has no spherical or revolute joint that is neither driven nor free to cut "
                "instead", file=model.source, field=f"joints.{jt.name}.type",
                fix="Model the loop with a spherical or revolute joint MuJoCo can cut")
        cut = [model.joints[j].name for j in topo.cut if j != bad[0]] + [swap[0].name]
        model = dataclasses.replace(model, cut=tuple(cut))
    raise AssertionError("unreachable: each pass cuts one joint MuJoCo closes")  # pragma: no cover


def mjcf(model, *, at: float = 0.0, sol=None, kp: float | None = None) -> common.Mjcf:
    """The MJCF model of the spatial ``model``, placed at its pose at the time ``at``.

    Parameters
    ----------
    model : Model
        ``space == "spatial"``.
    at : float
        Time (s) whose pose places the bodies and fills the keyframe.
    sol : SpatialSolution, optional
        The motion already solved (``analyze``, or ``simulate`` for a model with free degrees
        of freedom), its sample nearest ``at`` used; solved here if not given, or if its loops
        are cut where MuJoCo cannot close them (:func:`mujoco_cut`).
    kp : float, optional
        Stiffness of every driver's position servo (N m/rad or N/m), as the planar exporter's.

    Returns
    -------
    Mjcf

    Raises
    ------
    ModelError
        A loop MuJoCo cannot close (no spherical or revolute joint that is neither driven nor
        free).
    AssemblyError
        The mechanism cannot be assembled at ``at`` (or the simulation to ``at`` fails).
    """
    cut_here = mujoco_cut(model)
    if sol is None or cut_here is not model:
        # solved on MuJoCo's tree: the same motion, the tree's coordinates and poses
        sol = _solve(cut_here, float(at))
    p, tree, motion = sol.plan, sol.motion.tree, sol.motion
    topo = p.topo
    assert all(model.joints[j].kind in CONNECTS for j in topo.cut), "MuJoCo's cuts"
    k = int(np.argmin(np.abs(np.asarray(sol.t) - at)))      # the sample at ``at``
    at = float(sol.t[k])
    R, o, V = tree.R[k], tree.o[k], motion.V[k]               # (n, 3, 3), (n, 3), (n, 6)
    body_of = {b.name: b for b in model.bodies}
    points = [o[i] + R[i] @ x for i, name in enumerate(topo.bodies)
              for x in body_of[name].points.values()]
    size = common.size_of(points)
    radius = 0.01 * size

    root = ET.Element("mujoco", model=model.name)
    root.append(ET.Comment(
        f" linkdyn export: the model's axes (x, y, z); SI units; bodies at their pose at "
        f"t = {at!r} s "))
    compiler = ET.SubElement(root, "compiler", angle="radian", inertiafromgeom="false")
    moving = model.moving_bodies
    omitted = common.light_bounds(compiler, moving, [float(np.min(np.linalg.eigvalsh(b.inertia)))
                                                     for b in moving], size)
    opt = ET.SubElement(root, "option", gravity=_vec(model.gravity))
    ET.SubElement(opt, "flag", contact="disable")
    ET.SubElement(root, "default").append(
        ET.Element("geom", contype="0", conaffinity="0", rgba="0.4 0.5 0.7 1"))
    world = ET.SubElement(root, "worldbody")
    for name, pt in body_of[GROUND].points.items():
        ET.SubElement(world, "site", name=f"{GROUND}.{name}", pos=_vec(pt), size=repr(radius))

    elements, state, q = {0: world}, {}, {}       # state: joint name -> (qpos, qvel)
    for i in range(1, topo.n):                         # parent[i] < i: parents come first
        name, par = topo.bodies[i], topo.parent[i]
        b, jt, s = body_of[name], model.joints[topo.tree_joint[i]], int(topo.sign[i])
        # the child's frame in its parent's: R_par^T R_i, R_par^T (o_i - o_par)
        el = ET.SubElement(elements[par], "body", name=name, pos=_vec(R[par].T @ (o[i] - o[par])),
                           quat=_vec(sa.quaternion((R[par].T @ R[i])[None])[0]))
        anchor = R[i].T @ (tree.c[k, i] - o[i])        # the joint's point, child's frame
        if jt.kind == "spherical":
            ET.SubElement(el, "joint", name=jt.name, type="ball", pos=_vec(anchor))
            # qvel: the relative angular velocity in the child's frame
            state[jt.name] = ([1.0, 0.0, 0.0, 0.0], list(R[i].T @ (V[i, :3] - V[par, :3])))
        else:
            screws, coords = tree.S[i][k], motion.q[k, p.cols[i]]
            rates = motion.qd[k, p.cols[i]]
            suffixes = [sfx for sfx, _ in p.kinds[topo.tree_joint[i]].coordinates_named]
            # the chain from parent to child: reversed when the child is the joint's first body
            order = range(len(suffixes)) if s > 0 else reversed(range(len(suffixes)))
            for m in order:
                w, v = screws[m, :3], screws[m, 3:]
                turning = bool(np.any(w))
                axis = R[i].T @ (w if turning else v)  # signed for the child, child's frame
                ET.SubElement(el, "joint", name=jt.name + suffixes[m],
                              type="hinge" if turning else "slide", axis=_vec(axis),
                              pos=_vec(anchor), ref=repr(float(coords[m])))
                q[jt.name + suffixes[m]] = float(coords[m])
                state[jt.name + suffixes[m]] = ([coords[m]], [rates[m]])
        I = b.inertia
        ET.SubElement(el, "inertial", pos=_vec(b.com), mass=repr(float(b.mass)),
                      fullinertia=_vec([I[0, 0], I[1, 1], I[2, 2], I[0, 1], I[0, 2], I[1, 2]]))
        pts = list(b.points.values())
        for a, c in zip(pts, pts[1:] + pts[:1] if len(pts) > 2 else pts[1:]):
            ET.SubElement(el, "geom", type="capsule", size=repr(radius),
                          fromto=f"{_vec(a)} {_vec(c)}")
        for pname, pt in b.points.items():
            ET.SubElement(el, "site", name=f"{name}.{pname}", pos=_vec(pt), size=repr(radius))
        elements[i] = el

    cut = tuple(model.joints[j].name for j in topo.cut)
    if cut:
        _connects(root, model, topo, elements, R, size, radius)
    omitted += common.loads(root, model)
    if omitted:
        root.append(ET.Comment(" left out (MJCF cannot hold them): " + ", ".join(omitted) + " "))
    ctrl = common.drivers(root, model, gear={d.joint: 1 for d in model.drivers}, q=q,
                          angular={jt.name: sj.get(jt.kind).angular for jt in model.joints},
                          moving_mass=sum(b.mass for b in moving), size=size, kp=kp)
    order = [el.get("name") for el in world.iter("joint")]     # MuJoCo's order: the document's
    key = ET.SubElement(ET.SubElement(root, "keyframe"), "key", name="linkdyn", time=repr(at),
                        qpos=_vec([x for n in order for x in state[n][0]]),
                        qvel=_vec([x for n in order for x in state[n][1]]))
    if ctrl:
        key.set("ctrl", _vec(ctrl))
    ET.indent(root)
    return common.Mjcf(ET.tostring(root, encoding="unicode") + "\n", cut, tuple(omitted))


def _connects(root, model, topo, elements, R, size: float, radius: float) -> None:
    """The cut joints' ``connect`` equalities (site1 on B: the force on B by A); a revolute
    joint's second pair of sites one ``size`` along its axis on both bodies."""
    eq = ET.SubElement(root, "equality")
    index = topo.bodies.index
    for j in topo.cut:
        jt = model.joints[j]
        ET.SubElement(eq, "connect", name=jt.name, site1=f"{jt.body_b}.{jt.point_b}",
                      site2=f"{jt.body_a}.{jt.point_a}")
        if jt.kind != "revolute":
            continue
        a, b = index(jt.body_a), index(jt.body_b)
        e = R[a] @ (jt.axis / np.linalg.norm(jt.axis))           # the axis, global
        ends = {}
        for body, i, point in ((jt.body_b, b, jt.point_b), (jt.body_a, a, jt.point_a)):
            local = model.body(body).points[point] + size * (R[i].T @ e)
            site = f"{body}.{jt.name}.axis"
            ET.SubElement(elements[i], "site", name=site, pos=_vec(local), size=repr(radius))
            ends[body] = site
        ET.SubElement(eq, "connect", name=f"{jt.name}.axis", site1=ends[jt.body_b],
                      site2=ends[jt.body_a])
