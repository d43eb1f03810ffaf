"""The model file of a spatial mechanism (``[mechanism] space = "spatial"``): bodies posed at
a design pose with 3-D points and inertia tensors, the spatial joint kinds with their axes,
3-vector loads and gravity. Drivers, loads, ``[topology]`` and ``[analysis]`` are read by the
planar reader's functions with a 3-component reader (``_Reader.dim = 3``) and the spatial
joint registry; every message names the file, the field and the fix."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..io.drivers import _drivers
from ..io.linkage import BodyForm, FreeChain, _reference, free_bodies, mass_and_com, read_bodies
from ..io.loads import _loads
from ..io.options import _analysis, _topology
from ..io.reader import _Reader, _entry_field
from ..io.units import _units
from ..model import Model
from . import algebra as sa
from . import joints as sj
from .model import Body, Joint

SECTIONS = ("mechanism", "units", "bodies", "joints", "drivers", "loads", "topology", "analysis",
            "initial")
BODY_KEYS = ("name", "points", "mass", "com", "inertia", "origin", "rotation", "free")
JOINT_KEYS = ("name", "type", "connect", "axis", "axis2")
PERPENDICULAR = 1e-6   # |axis . axis2| of a universal joint's unit axes at the design pose


def read(r: _Reader, data: dict, mech: dict, source: str) -> Model:
    """The spatial model of the parsed file ``data`` (its ``[mechanism]`` table ``mech``
    already checked for its keys), SI."""
    r.dim, r.kinds = 3, sj
    if "assembly" in data:
        r.fail("assembly", "[assembly] is not read for spatial models",
               "Remove it: the design pose (each body's origin and rotation) is the "
               "assembly guess")
    r.table(data, "", SECTIONS, noun="section", what="sections of a spatial model")
    name = r.string(mech["name"], "mechanism.name") if "name" in mech else (
        Path(source).stem if source else "mechanism")
    gravity = r.vector(mech.get("gravity", [0.0, 0.0, 0.0]), "mechanism.gravity", "m/s^2")
    description = r.string(mech.get("description", ""), "mechanism.description", empty=True)
    _units(r, data.get("units", {}))
    body_entries, joint_entries = free_bodies(r, data.get("bodies"), data.get("joints", []),
                                              FREE)
    bodies = read_bodies(r, body_entries, FORM)
    joints = _joints(r, joint_entries, bodies)
    drivers = _drivers(r, data.get("drivers", []), joints)
    for entry in data.get("loads", []) if isinstance(data.get("loads"), list) else []:
        if isinstance(entry, dict) and entry.get("kind") == "friction":
            r.fail("loads", "friction is not yet for spatial models",
                   "Remove the friction load, or model it as a joint_torque formula of qd_<joint>")
    loads = _loads(r, data.get("loads", []), bodies, joints)
    analysis = data.get("analysis", {})
    for key in ("path_point", "path_range", "output"):
        if isinstance(analysis, dict) and key in analysis:
            r.fail(f"analysis.{key}", f"{key} is not yet for spatial models",
                   f"Remove {key} (the summary of a spatial run has no "
                   + ("efficiency curve)" if key == "output" else "path straightness)"))
    initial_q, initial_qd = _initial(r, data.get("initial", {}), joints, drivers)
    cut = _topology(r, data.get("topology", {}), joints, drivers)
    duration, cycles, samples, path_point, path_range, _ = _analysis(
        r, data.get("analysis", {}), drivers, bodies, joints)
    return Model(name=name, bodies=tuple(bodies.values()), joints=tuple(joints.values()),
                 drivers=tuple(d for _, d in drivers.values()), loads=tuple(loads),
                 gravity=gravity, cut=cut, duration=duration, cycles=cycles, samples=samples,
                 source=source, description=description, path_point=path_point,
                 path_range=path_range, length_unit=r.length_name, angle_unit=r.angle_name,
                 initial_q=initial_q, initial_qd=initial_qd, space="spatial")


def _moving(r: _Reader, f: str, name: str, points: dict, entry: dict) -> Body:
    """A moving spatial body: mass, mass centre, its frame's origin and rotation at the design
    pose, and the inertia tensor about the mass centre in the body frame."""
    mass, com = mass_and_com(r, f, name, points, entry, FORM)
    origin = r.vector(entry.get("origin", [0.0, 0.0, 0.0]), f"{f}.origin", r.length_name)
    rot = r.vector(entry.get("rotation", [0.0, 0.0, 0.0]), f"{f}.rotation",
                   r.angle_name) * r.angle
    return Body(name, points, mass=mass, com=com,
                inertia=_inertia(r, entry["inertia"], f"{f}.inertia") * r.length**2,
                origin=origin * r.length, rotation=sa.rotation_vector(rot))


FORM = BodyForm(
    keys=BODY_KEYS, example="{ A = [0, 0, 0], B = [0, 30, 0] }",
    ground_keys=("mass", "com", "inertia", "origin", "rotation"),
    ground_why="the ground is fixed: its frame is the global frame and it has no mass "
               "properties",
    inertia_fix="Add inertia = [Ixx, Iyy, Izz] ({unit}, about the mass centre, body frame) "
                "or the full tensor",
    body=Body, moving=_moving)


def _carriage(r: _Reader, f: str, entry: dict, point: str) -> dict:
    """A free body's massless carriage, posed at the design pose with its origin at the body's
    point ``point`` and the global frame's axes (so the free coordinates are P's global
    coordinates and the turns about the global axes, from the design pose)."""
    L = r.length_name
    at = r.vector(entry.get("origin", [0.0, 0.0, 0.0]), f"{f}.origin", L)
    rot = r.vector(entry.get("rotation", [0.0, 0.0, 0.0]), f"{f}.rotation", r.angle_name)
    local = r.vector(entry["points"][point], f"{f}.points.{point}", L)
    where = at + sa.rotation_vector(rot * r.angle) @ local      # file's length unit
    return {"points": {"O": [0.0, 0.0, 0.0]}, "mass": 0.0, "inertia": [0.0, 0.0, 0.0],
            "origin": [float(x) for x in where]}


FREE = FreeChain(
    slides=(("x", [1.0, 0.0, 0.0]), ("y", [0.0, 1.0, 0.0]), ("z", [0.0, 0.0, 1.0])),
    turns=(("rx", [1.0, 0.0, 0.0]), ("ry", [0.0, 1.0, 0.0]), ("rz", [0.0, 0.0, 1.0])),
    carriage=_carriage,
    example='Write e.g. free = "C": the point whose x, y and z are the free coordinates')


def _inertia(r: _Reader, value: Any, field: str) -> np.ndarray:
    """The centroidal inertia tensor (3, 3) in the file's units: principal ``[Ixx, Iyy, Izz]``
    or the full symmetric tensor; refused unless positive semi-definite with the triangle
    inequalities of a rigid body (``Ixx + Iyy >= Izz``, ...)."""
    unit = f"kg {r.length_name}^2"
    fix = ("Give [Ixx, Iyy, Izz] (principal, body frame) or [[Ixx, Ixy, Ixz], [Ixy, Iyy, Iyz], "
           "[Ixz, Iyz, Izz]]")
    if isinstance(value, list) and len(value) == 3 and all(isinstance(v, list) for v in value):
        rows = []
        for k, row in enumerate(value):
            if len(row) != 3:
                r.fail(f"{field}[{k}]", f"expected 3 numbers, got {len(row)}", fix)
            rows.append([r.number(c, f"{field}[{k}][{j}]", unit) for j, c in enumerate(row)])
        tensor = np.array(rows)
        if not np.allclose(tensor, tensor.T, rtol=0, atol=1e-12 * max(np.abs(tensor).max(), 1e-300)):
            r.fail(field, "the inertia tensor is not symmetric", "Give Ixy, Ixz, Iyz once each "
                   "in both places (tensor entries, Ixy = -integral of x y dm)")
    elif isinstance(value, list) and len(value) == 3:
        tensor = np.diag([r.number(c, f"{field}[{k}]", unit, nonnegative=True)
                          for k, c in enumerate(value)])
    else:
        r.fail(field, "expected 3 principal moments or a 3 x 3 tensor", fix)
    w = np.linalg.eigvalsh(tensor)
    scale = max(float(w.max()), 1e-300)
    if w.min() < -1e-12 * scale or 2 * w.max() > w.sum() * (1 + 1e-9) + 1e-300:
        r.fail(field, f"no rigid body has these moments (principal values "
               f"{', '.join(f'{x:g}' for x in w)} {unit}): they must be >= 0 and each at most "
               "the sum of the other two", "Check the moments and the products of inertia")
    return tensor


def _unit(r: _Reader, value: Any, field: str, body: str) -> np.ndarray:
    v = r.vector(value, field)
    n = float(np.linalg.norm(v))
    if n == 0:
        r.fail(field, "the axis is zero", f"Give a direction in the frame of body '{body}', "
               "e.g. [0, 0, 1]")
    return v / n


def _joints(r: _Reader, entries: Any, bodies: dict[str, Body]) -> dict[str, Joint]:
    joints: dict[str, Joint] = {}
    for i, entry in enumerate(r.entries(entries, "joints")):
        f = _entry_field("joints", i, entry)
        r.table(entry, f, JOINT_KEYS, required=("name", "type", "connect"))
        name = r.name(entry["name"], f"{f}.name")
        if name in joints:
            r.fail(f"joints[{i}].name", f"duplicate joint name '{name}'",
                   "Give every joint a different name")
        kind = sj.get(r.choice(entry["type"], f"{f}.type", sj.names(), "spatial joint type"))
        conn = entry["connect"]
        if not isinstance(conn, list) or len(conn) != 2:
            r.fail(f"{f}.connect", "expected two \"body.point\" strings",
                   'Write connect = ["ground.A", "crank.A"]')
        a, pa = _reference(r, conn[0], f"{f}.connect[0]", bodies)
        b, pb = _reference(r, conn[1], f"{f}.connect[1]", bodies)
        if a == b:
            r.fail(f"{f}.connect", f"the joint connects body '{a}' to itself",
                   "A joint joins two different bodies; check the body names in connect")
        for key in ("axis", "axis2"):
            if key in entry and key not in kind.keys:
                takes = [k for k, x in sj.REGISTRY.items() if key in x.keys]
                r.fail(f"{f}.{key}", f"a {kind.name} joint has no {key}",
                       f"Remove {key}, or set type = " + " or ".join(f'"{k}"' for k in takes))
            if key not in entry and key in kind.keys:
                r.fail(f"{f}.{key}", f"a {kind.name} joint needs its {key}",
                       f"Add {key} = [x, y, z] (in the frame of body "
                       f"'{a if key == 'axis' else b}')")
        axis = _unit(r, entry["axis"], f"{f}.axis", a) if "axis" in entry else np.zeros(3)
        axis2 = _unit(r, entry["axis2"], f"{f}.axis2", b) if "axis2" in entry else np.zeros(3)
        if "axis2" in entry:
            # both axes in global components at the design pose
            ea, eb = bodies[a].rotation @ axis, bodies[b].rotation @ axis2
            if abs(float(ea @ eb)) > PERPENDICULAR:
                r.fail(f"{f}.axis2", f"axis2 is not perpendicular to axis at the design pose "
                       f"(cosine {float(ea @ eb):.3g})",
                       "Give a universal joint's two axes at right angles (axis in the first "
                       "body's frame, axis2 in the second's)")
        joints[name] = Joint(name, kind.name, a, pa, b, pb, axis=axis, axis2=axis2)
    return joints


def coordinate_names(joints) -> dict:
    """Every joint coordinate's name, ``<joint><suffix>`` as in results.csv's ``q_`` columns
    (``J1``, ``J3.s``, ``J2.1``), -> ``(joint, index in its kind's coordinates, angular)``; a
    spherical joint has no such columns (its Cardan angles depend on the tree)."""
    return {f"{j.name}{suffix}": (j.name, k, angular) for j in joints
            for k, (suffix, angular) in enumerate(sj.get(j.kind).coordinates_named)
            if sj.get(j.kind).tree and j.kind != "spherical"}


def _initial(r: _Reader, section: Any, joints: dict, drivers: dict) -> tuple[dict, dict]:
    """``[initial]`` of a spatial model: ``q`` (angle or length unit) and ``qd`` (per s) of the
    free joint coordinates at t = 0 by their results.csv names (``J1``; ``"J3.s"``, ``"J2.1"``
    quoted, or ``J3 = { s = ... }``), SI. Rotations count from the design pose; a prismatic
    travel is ``(r_Bq - r_Ap) . e``. Their number is checked against the mobility by
    :func:`linkdyn.spatial.forward.partition`."""
    names = coordinate_names(joints.values())
    section = r.table(section, "initial", ("q", "qd"))
    out: list[dict] = []
    for key, per in (("q", ""), ("qd", "/s")):
        given = section.get(key, {})
        if not isinstance(given, dict):
            r.fail(f"initial.{key}", "expected a table of joint coordinates",
                   f'Write {key} = {{ J1 = 10.0, "J3.s" = 5.0 }}')
        flat = {}
        for name, v in given.items():     # J3 = { s = ... } is "J3.s"
            if isinstance(v, dict):
                flat.update({f"{name}.{sub}": x for sub, x in v.items()})
            else:
                flat[name] = v
        values: dict[str, float] = {}
        for name, v in flat.items():
            f = f"initial.{key}.{name}"
            if name not in names:
                joint = name.split(".")[0]
                why = (f"joint '{joint}' is a {joints[joint].kind} joint, which has no "
                       "coordinates in results.csv" if joint in joints
                       and joints[joint].kind == "spherical" else
                       f"unknown joint coordinate '{name}'")
                r.fail(f, why, "Name a coordinate of a revolute, prismatic, cylindrical or "
                       f"universal joint: {', '.join(names) or 'none'}")
            joint, _, angular = names[name]
            if joint in drivers:
                r.fail(f, f"joint '{joint}' is driven ({drivers[joint][0]}): its motion is "
                       "prescribed, not free", "Name only the free degrees of freedom")
            scale, unit = (r.angle, r.angle_name) if angular else (r.length, r.length_name)
            values[name] = r.number(v, f, unit + per) * scale
        out.append(values)
    return out[0], out[1]
