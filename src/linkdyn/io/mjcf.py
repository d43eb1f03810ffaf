"""A MuJoCo model (MJCF) of a linkdyn mechanism: ``linkdyn export MODEL --to mjcf``.

This module writes planar models; :func:`mjcf` hands a spatial one (``space = "spatial"``) to
:func:`linkdyn.spatial.mjcf.mjcf`. What both share is :mod:`linkdyn.io.mjcf_common`.

The mechanism's plane (x, y) is MuJoCo's (x, z) plane: a point ``(x, y)`` is ``x 0 y``, and a
counter-clockwise rotation in linkdyn (about +z, out of the plane) is a rotation about MuJoCo's
-y, so every hinge has ``axis="0 -1 0"`` and a moment about linkdyn's z is a torque along
MuJoCo's -y. Numbers are SI (m, kg, kg m^2, s), as MuJoCo assumes.

What is written:

- the open tree as nested ``<body>`` elements, placed at the mechanism's pose at the time
  ``at`` (each body's frame at its pose relative to its parent's): a revolute tree joint is a
  ``hinge``, a prismatic one a ``slide``, each with ``ref`` its coordinate at that pose, so that
  ``qpos`` of a joint is ``s q`` (``q`` linkdyn's coordinate ``q_<joint>``, ``s = +1`` when the
  child body is the joint's second body, ``-1`` when its first) and the model loads assembled;
- a coupling (``q_1 = ratio q_2 + offset_angle``) as ``<equality><joint joint1 joint2
  polycoef="0 s_1 s_2 ratio 0 0 0">`` (MuJoCo's joint equality holds ``qpos_1 - qpos0_1`` to
  the polynomial in ``qpos_2 - qpos0_2``, and ``qpos0`` is the pose's ``s q``); its two joints
  must be joints of MuJoCo's tree, else it is refused naming the coupling;
- each other cut joint as ``<equality><connect site1=B.q site2=A.p>`` (site1 on the joint's second
  body: the constraint force on site1's body is linkdyn's reaction, by the first body on the
  second). A connect closes a revolute joint only: a loop cut by linkdyn at a prismatic joint
  is cut here at a revolute joint of the same loop instead (MuJoCo's tree need not be
  linkdyn's); a loop with no revolute joint to cut, or a slot joint, which MuJoCo has no
  equality for, is refused with a message naming the joint;
- a model with free degrees of freedom (``linkdyn simulate``'s) keeps its free joints in the
  tree, as the simulation does; its pose at ``at`` is simulated from ``[initial]``;
- each driver as a ``<position>`` actuator on its joint, ``gear = s``, so that its length is
  ``q`` and its force linkdyn's effort (``tau_<joint>`` or ``force_<joint>``); ``ctrl`` is the
  target coordinate, which the user sets from the motion law each step (the law is written as a
  ``<custom><text>`` entry); stiffness ``kp`` and ``dampratio = 1``;
- masses, mass centres and inertias (``<inertial>``; the planar inertia about the mass centre
  is MuJoCo's inertia about y, and the two out-of-plane ones are set equal to it: they do not
  enter the planar motion), gravity, springs and dampers (spatial tendons between the two
  points, ``stiffness``, ``springlength``, ``damping``); every named point a ``<site>``
  ``BODY.POINT``; a keyframe ``at`` with the positions, rates and driver targets at that time.

MuJoCo needs every moving body's mass and inertia positive: a massless link or a point mass
is given MuJoCo's lower bounds (``<compiler boundmass boundinertia>``, :data:`BOUND` times the
largest moving mass and the largest of the inertias and that mass times the size squared, at
least 1e-14), named in :attr:`Mjcf.omitted`. Point forces, torques, joint
torques and forces and friction depend on time or on the state in
ways MJCF cannot hold; they are left out and named in :attr:`Mjcf.omitted` (and a comment of
the file). Writing the file needs no ``mujoco``; loading it in MuJoCo does
(``pip install 'linkdyn[mujoco]'``).
"""

from __future__ import annotations

import dataclasses
import math
import xml.etree.ElementTree as ET

import numpy as np

from .. import joints as jk
from ..errors import ModelError
from ..model import GROUND, Model
from .mjcf_common import (BOUND, KP_RATE, Mjcf, drivers, free as _free, light_bounds, loads,
                          num as _num, size_of as _size)

__all__ = ["BOUND", "KP_RATE", "Mjcf", "mjcf", "mujoco_cut"]


def _xz(v) -> str:
    """linkdyn (x, y) -> MuJoCo 'x 0 y' (round-trip precision)."""
    return f"{float(v[0])!r} 0 {float(v[1])!r}"


def _rotate(angle: float, v) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([c * v[0] - s * v[1], s * v[0] + c * v[1]])


def mujoco_cut(model: Model, leave_out: tuple[str, ...] = ()):
    """The topology of MuJoCo's tree: linkdyn's own when every cut joint is revolute, else
    each cut prismatic joint swapped for the revolute joint of its loop farthest from the
    ground (not driven, not cut).

    Returns
    -------
    Topology
        With every cut joint revolute.

    Raises
    ------
    ModelError
        A slot joint, or a loop with no revolute joint to cut (naming the joint and its field).
    """
    from .. import topology

    inner = _tree_model(model)
    topo = topology.build(inner)
    for _ in range(len(model.joints)):
        bad = [j for j in topo.cut if model.joints[j].kind not in ("revolute", "coupling")
               and model.joints[j].name not in leave_out]
        if not bad:
            return _coupled_in_tree(model, topo, leave_out)
        jt = model.joints[bad[0]]
        field = f"joints.{jt.name}.type"
        if not jk.get(jt.kind).tree:
            raise ModelError(
                f"joint '{jt.name}' is a {jt.kind} joint, which MuJoCo has no equality "
                "constraint for", file=model.source, field=field,
                fix="Export a model without it (MJCF closes loops at revolute joints "
                    f"only); in Python, mjcf(model, leave_out=('{jt.name}',)) writes the rest "
                    "for a constraint of your own")
        # the tree joints on the loop jt closes: the path between its two bodies
        ia, ib = topo.bodies.index(jt.body_a), topo.bodies.index(jt.body_b)
        path = np.flatnonzero(topo.ancestors[ia] ^ topo.ancestors[ib])
        driven = {d.joint for d in inner.drivers}
        swap = [i for i in sorted(path, reverse=True)
                if model.joints[topo.tree_joint[i]].kind == "revolute"
                and model.joints[topo.tree_joint[i]].name not in driven]
        if not swap:
            raise ModelError(
                f"the loop cut at {jt.kind} joint '{jt.name}' has no revolute joint that is not "
                "driven, and a MuJoCo connect constraint closes a revolute joint only",
                file=model.source, field=field,
                fix="Model the loop with a revolute joint MuJoCo can cut")
        cut = [model.joints[j].name for j in topo.cut if j != bad[0]
               and jk.get(model.joints[j].kind).tree]
        cut.append(model.joints[topo.tree_joint[swap[0]]].name)
        topo = topology.build(dataclasses.replace(inner, cut=tuple(cut)))
    raise AssertionError("unreachable: each pass cuts one revolute joint more")  # pragma: no cover


def _coupled_in_tree(model: Model, topo, leave_out):
    """``topo``, once every joint a coupling couples is a joint of MuJoCo's tree (a joint
    equality relates two joints' ``qpos``); else the ModelError naming the coupling."""
    cut = {model.joints[j].name for j in topo.cut}
    for jt in model.joints:
        if jt.kind == "coupling" and jt.name not in leave_out:
            loose = [n for n in jt.coupled if n in cut]
            if loose:
                raise ModelError(
                    f"coupling '{jt.name}' couples joint '{loose[0]}', which closes a loop in "
                    "MuJoCo's tree (a connect constraint), and a MuJoCo joint equality relates "
                    "two joints of the tree", file=model.source, field=f"joints.{jt.name}.joints",
                    fix=f"Cut the loop at another joint: [topology] cut = [...] without "
                        f"'{loose[0]}'")
    return topo



def _tree_model(model: Model) -> Model:
    """``model`` itself, or for a model with free degrees of freedom the same with a
    placeholder driver on each free joint (:func:`linkdyn.forward.partition`), so that its
    topology builds and keeps those joints in the tree."""
    if not _free(model):
        return model
    from ..forward import partition
    return partition(model).inner


def _solve(model: Model, at: float):
    """The solution at ``[at]``: ``analyze``, or ``simulate`` from ``[initial]`` to ``at`` for a
    model with free degrees of freedom."""
    if not _free(model):
        from ..analysis import analyze
        return analyze(model, np.array([at]))
    from ..forward import simulate
    return simulate(model, np.array([0.0, at]) if at > 0 else np.array([0.0]))


def mjcf(model: Model, *, at: float = 0.0, sol=None, kp: float | None = None,
         leave_out: tuple[str, ...] = ()) -> Mjcf:
    """The MJCF model of ``model``, placed at its pose at the time ``at`` (a spatial model's
    by :func:`linkdyn.spatial.mjcf.mjcf`).

    Parameters
    ----------
    model : Model
    at : float
        Time (s) whose pose places the bodies (``ref`` of every joint) and fills the keyframe.
    sol : Solution, optional
        The model's motion already solved (``analyze``, or ``simulate`` for a model with free
        degrees of freedom), its sample nearest ``at`` used; solved here at ``at`` if not
        given (a model with free degrees of freedom is simulated from ``[initial]`` to
        ``at``).
    kp : float, optional
        Stiffness of every driver's position servo (N m/rad, or N/m for a slider); default
        ``KP_RATE`` times the moving mass times the mechanism's size squared (a slider: times
        the moving mass).
    leave_out : tuple of str
        Cut joints to leave out of the equality constraints (their loops stay open in MuJoCo,
        for a constraint the user writes; a slot joint can only be left out).

    Returns
    -------
    Mjcf

    Raises
    ------
    ModelError
        A joint MuJoCo cannot close (a slot; a loop without a revolute joint to cut).
    AssemblyError
        The mechanism cannot be assembled at ``at`` (or the simulation to ``at`` fails).
    """
    if model.space == "spatial":
        if leave_out:
            raise ModelError("leave_out is for planar models", field="leave_out",
                             fix="Leave it empty for a spatial model")
        from ..spatial.mjcf import mjcf as spatial_mjcf
        return spatial_mjcf(model, at=at, sol=sol, kp=kp)
    if sol is None:
        sol = _solve(model, float(at))
    topo = mujoco_cut(model, leave_out)
    cuts = {model.joints[j].name for j in topo.cut}
    for name in leave_out:
        if name not in cuts:
            raise ModelError(f"joint '{name}' is not a cut joint of the exported tree "
                             f"(those are {sorted(cuts)})", field="leave_out",
                             fix="Leave out cut joints only")
    k = int(np.argmin(np.abs(np.asarray(sol.t) - at)))   # the sample at ``at``
    at = float(sol.t[k])

    def phi(name):
        return 0.0 if name == GROUND else float(sol.phi(name)[k])

    def origin(name):
        """Global position (2,) of a body frame's origin, m."""
        b = model.body(name)
        if name == GROUND or not b.points:
            return np.zeros(2)
        p, local = next(iter(b.points.items()))
        return np.asarray(sol.point(name, p)[k], float) - _rotate(phi(name), local)

    joint_index = {jt.name: j for j, jt in enumerate(model.joints)}
    q = {jt.name: float(sol.kin.q[k, j]) for j, jt in enumerate(model.joints)}
    qd = {jt.name: float(sol.kin.qd[k, j]) for j, jt in enumerate(model.joints)}
    points = [np.asarray(sol.point(b.name, p)[k]) for b in model.moving_bodies for p in b.points]
    points += [np.asarray(x, float) for x in model.body(GROUND).points.values()]
    size = _size(points)
    radius = 0.01 * size

    root = ET.Element("mujoco", model=model.name)
    root.append(ET.Comment(
        " linkdyn export: the plane (x, y) of the mechanism is MuJoCo's (x, z); SI units; "
        f"bodies at their pose at t = {at!r} s "))
    compiler = ET.SubElement(root, "compiler", angle="radian", inertiafromgeom="false")
    moving = model.moving_bodies
    omitted_bounds = light_bounds(compiler, moving, [b.inertia for b in moving], size)
    g = np.asarray(model.gravity, float)
    opt = ET.SubElement(root, "option", gravity=_xz(g))
    ET.SubElement(opt, "flag", contact="disable")
    ET.SubElement(root, "default").append(
        ET.Element("geom", contype="0", conaffinity="0", rgba="0.4 0.5 0.7 1"))
    world = ET.SubElement(root, "worldbody")
    for name, pt in model.body(GROUND).points.items():
        ET.SubElement(world, "site", name=f"{GROUND}.{name}", pos=_xz(pt), size=_num(radius))

    elements, sign = {0: world}, {}
    moving_mass = 0.0
    for i in range(1, topo.n):                       # parent[i] < i: parents come first
        name, parent = topo.bodies[i], topo.bodies[topo.parent[i]]
        jt, s = model.joints[topo.tree_joint[i]], topo.sign[i]
        b = model.body(name)
        moving_mass += b.mass
        # the child's frame in its parent's: rotation phi_c - phi_p, origin R(-phi_p)(r_c - r_p)
        rel = phi(name) - phi(parent)
        pos = _rotate(-phi(parent), origin(name) - origin(parent))
        el = ET.SubElement(elements[topo.parent[i]], "body", name=name, pos=_xz(pos),
                           axisangle=f"0 -1 0 {rel!r}")
        p_child = b.points[jt.point_b if s > 0 else jt.point_a]
        if jk.get(jt.kind).angular:
            ET.SubElement(el, "joint", name=jt.name, type="hinge", axis="0 -1 0",
                          pos=_xz(p_child), ref=_num(s * q[jt.name]))
        else:
            # the axis (in the first body's frame) in the child's frame: R(phi_a - phi_c) axis
            axis = _rotate(phi(jt.body_a) - phi(name), np.asarray(jt.axis, float))
            axis = axis / np.linalg.norm(axis)
            ET.SubElement(el, "joint", name=jt.name, type="slide", axis=_xz(axis),
                          pos=_xz(p_child), ref=_num(s * q[jt.name]))
        ET.SubElement(el, "inertial", pos=_xz(b.com), mass=_num(b.mass),
                      diaginertia=" ".join([_num(b.inertia)] * 3))
        pts = list(b.points.values())
        for a, c in zip(pts, pts[1:] + pts[:1] if len(pts) > 2 else pts[1:]):
            ET.SubElement(el, "geom", type="capsule", size=_num(radius),
                          fromto=f"{_xz(a)} {_xz(c)}")
        for pname, pt in b.points.items():
            ET.SubElement(el, "site", name=f"{name}.{pname}", pos=_xz(pt), size=_num(radius))
        elements[i], sign[jt.name] = el, s

    cut = tuple(model.joints[j].name for j in topo.cut if model.joints[j].name not in leave_out)
    if cut:
        eq = ET.SubElement(root, "equality")
        for name in cut:
            jt = model.joints[joint_index[name]]
            if jt.kind == "coupling":
                # q_1 = ratio q_2 + offset about the pose (qpos0 = ref): qpos_1 - ref_1 =
                # s_1 s_2 ratio (qpos_2 - ref_2), qpos = s q
                j1, j2 = jt.coupled
                ET.SubElement(eq, "joint", name=name, joint1=j1, joint2=j2,
                              polycoef=f"0 {_num(sign[j1] * sign[j2] * jt.ratio)} 0 0 0")
                continue
            # site1 on the second body: the constraint force on site1's body is by A on B
            ET.SubElement(eq, "connect", name=name, site1=f"{jt.body_b}.{jt.point_b}",
                          site2=f"{jt.body_a}.{jt.point_a}")

    omitted = [f"joint '{name}'" for name in leave_out] + omitted_bounds
    omitted += loads(root, model)
    if omitted:
        root.append(ET.Comment(" left out (MJCF cannot hold them): " + ", ".join(omitted) + " "))
    angular = {jt.name: jk.get(jt.kind).angular for jt in model.joints}
    ctrl = drivers(root, model, gear=sign, q=q, angular=angular, moving_mass=moving_mass,
                   size=size, kp=kp)
    order = [el.get("name") for el in world.iter("joint")]     # MuJoCo's order: the document's
    key = ET.SubElement(ET.SubElement(root, "keyframe"), "key", name="linkdyn", time=_num(at),
                        qpos=" ".join(_num(sign[n] * q[n]) for n in order),
                        qvel=" ".join(_num(sign[n] * qd[n]) for n in order))
    if ctrl:
        key.set("ctrl", " ".join(map(_num, ctrl)))
    ET.indent(root)
    return Mjcf(ET.tostring(root, encoding="unicode") + "\n", cut, tuple(omitted))
