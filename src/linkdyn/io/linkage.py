"""``[[bodies]]`` and ``[[joints]]``: the links with their named points and mass properties, and
the joints that connect two body points."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable

import numpy as np

from .. import joints as jk
from ..joints import coupling
from ..model import GROUND, Body, Joint, point_spread
from .reader import _quote, _Reader, _did_you_mean, _entry_field, _type_name

SHORT_LINK = 1e-9  # a link shorter than this fraction of the mechanism's size has zero length

BODY_KEYS = ("name", "points", "mass", "com", "inertia", "inertia_about", "bars", "free")
BAR_KEYS = ("between", "mass", "mass_per_length")
JOINT_KEYS = ("name", "type", "connect", "joints") + tuple(dict.fromkeys(
    x.name for kind in jk.REGISTRY.values() for x in kind.numbers if not x.derived))


@dataclass(frozen=True)
class BodyForm:
    """What a ``[[bodies]]`` entry holds in one space, beyond what every space shares (the
    name, the named points, a ground without mass properties, a moving body's mass and mass
    centre): read by :func:`read_bodies`."""

    keys: tuple[str, ...]            # the keys an entry may have
    example: str                     # a points table to show in a message
    ground_keys: tuple[str, ...]     # keys the ground may not have
    ground_why: str                  # why not
    inertia_fix: str                 # how to give the inertia ({unit}: kg length^2)
    body: Callable[..., Any]         # the space's Body class
    moving: Callable[..., Any]       # (r, field, name, points, entry) -> Body of a moving body


def read_bodies(r: _Reader, entries: Any, form: BodyForm) -> dict:
    """The bodies of ``[[bodies]]`` by name, SI: every entry's keys, a unique name and its
    points (``r.dim`` components, the file's length unit) checked here, a moving body's mass
    properties by ``form.moving``."""
    if entries is None:
        r.fail("bodies", "the model has no bodies",
               'Add [[bodies]] tables, one of them with name = "ground"')
    _check_ground(r, r.entries(entries, "bodies"))
    L, Lu = r.length, r.length_name
    bodies: dict = {}
    for i, entry in enumerate(entries):
        f = _entry_field("bodies", i, entry)
        r.table(entry, f, form.keys, required=("name",))
        name = r.name(entry["name"], f"{f}.name")
        if name in bodies:
            r.fail(f"bodies[{i}].name", f"duplicate body name '{name}'",
                   "Give every body a different name")
        pts = entry.get("points")
        if not isinstance(pts, dict) or not pts:
            r.fail(f"{f}.points", "a body needs at least one named point",
                   f"Add e.g. points = {form.example} in the body's frame")
        points = {r.name(p, f"{f}.points"): r.vector(xy, f"{f}.points.{p}", Lu) * L
                  for p, xy in pts.items()}
        if name == GROUND:
            for key in form.ground_keys:
                if key in entry:
                    r.fail(f"{f}.{key}", form.ground_why, f"Remove '{key}' from the ground body")
            bodies[name] = form.body(name, points)
        else:
            bodies[name] = form.moving(r, f, name, points, entry)
    return bodies


def mass_and_com(r: _Reader, f: str, name: str, points: dict, entry: dict,
                 form: BodyForm) -> tuple[float, np.ndarray]:
    """A moving body's mass (kg) and mass centre (body frame, m: a vector, or the name of one
    of its points), once its ``mass`` and ``inertia`` are known to be given."""
    Lu = r.length_name
    for key in ("mass", "inertia"):
        if key not in entry:
            r.fail(f"{f}.{key}", f"a moving body needs a {key}",
                   "Add mass = ... (kg)" if key == "mass"
                   else form.inertia_fix.format(unit=f"kg {Lu}^2"))
    mass = r.number(entry["mass"], f"{f}.mass", "kg", nonnegative=True,
                    fix="Give a mass in kg, 0 or more (0: a massless link)")
    com = entry.get("com", [0.0] * r.dim)
    if isinstance(com, str):  # the name of one of the body's points
        return mass, points[r.point(name, points, com, f"{f}.com")]
    return mass, r.vector(com, f"{f}.com", Lu) * r.length


def _moving(r: _Reader, f: str, name: str, points: dict, entry: dict) -> Body:
    """A moving planar body: its bars, or its mass, mass centre and inertia (about the mass
    centre, or about a named point by ``inertia_about``)."""
    if "bars" in entry:
        return _bars(r, f, name, points, entry)
    L, Lu = r.length, r.length_name
    mass, com = mass_and_com(r, f, name, points, entry, PLANAR)
    inertia = r.number(entry["inertia"], f"{f}.inertia", f"kg {Lu}^2", nonnegative=True,
                       fix=f"Give a moment of inertia in kg {Lu}^2, 0 or more (0: a point "
                           "mass, or a massless link)")
    if "inertia_about" in entry:
        about = r.point(name, points, entry["inertia_about"], f"{f}.inertia_about")
        d2 = float(np.sum((points[about] - com) ** 2)) / L**2  # |P - C|^2 in length unit^2
        # a point mass has exactly m d^2 about P: the rounding of a typed m d^2 is not
        # an error
        if inertia - mass * d2 < -1e-9 * mass * d2:
            r.fail(f"{f}.inertia",
                   f"inertia {inertia:g} kg {Lu}^2 about point '{about}' is less than "
                   f"m d^2 = {mass * d2:g} kg {Lu}^2 (mass centre {math.sqrt(d2):g} {Lu} away), "
                   f"so the inertia about the mass centre would be {inertia - mass * d2:g}",
                   "Check inertia, inertia_about, com and mass: by the parallel-axis theorem "
                   "the inertia about a point is the centroidal one plus m d^2")
        # parallel-axis theorem: I_C = I_P - m |P - C|^2
        inertia = max(inertia - mass * d2, 0.0)
    return Body(name, points, mass=mass, com=com, inertia=inertia * L**2)


PLANAR = BodyForm(
    keys=BODY_KEYS, example="{ O1 = [0, 0], O2 = [38.1, 0] }",
    ground_keys=("mass", "com", "inertia", "inertia_about", "bars"),
    ground_why="the ground is fixed and has no mass properties",
    inertia_fix="Add inertia = ... ({unit}, about the mass centre)", body=Body, moving=_moving)


def _bodies(r: _Reader, entries: Any) -> dict[str, Body]:
    """The planar bodies of ``[[bodies]]``."""
    return read_bodies(r, entries, PLANAR)


@dataclass(frozen=True)
class FreeChain:
    """How a space writes a free body (``free = "P"``) as joints: the global axes of its
    translations and of its turns, in order, each one joint named ``<body>_<suffix>``; read by
    :func:`free_bodies`."""

    slides: tuple[tuple[str, list], ...]          # (suffix, global axis) of each translation
    turns: tuple[tuple[str, list | None], ...]    # (suffix, global axis or None) of each turn
    carriage: Callable[..., dict]                 # (r, field, entry, point) -> a carriage's keys
    example: str                                  # the fix of a bad ``free``


def _planar_carriage(r: _Reader, f: str, entry: dict, point: str) -> dict:
    return {"points": {"O": [0.0, 0.0]}, "mass": 0.0, "inertia": 0.0}


PLANAR_FREE = FreeChain(
    slides=(("x", [1.0, 0.0]), ("y", [0.0, 1.0])), turns=(("phi", None),),
    carriage=_planar_carriage,
    example='Write e.g. free = "C": the point whose x and y are the free coordinates')


def free_bodies(r: _Reader, bodies: Any, joints: Any, chain: FreeChain = PLANAR_FREE
                ) -> tuple[Any, Any]:
    """The ``[[bodies]]`` and ``[[joints]]`` entries with each free body (``free = "P"``: joined
    to nothing but loads) on its freedoms, written as joints through massless carriages.

    Planar (``chain = PLANAR_FREE``): a free body ``B`` with ``free = "P"`` hangs from the
    ground by two massless carriages and three joints: the prismatic joint ``B_x`` (the ground's
    new point ``B_origin`` at the origin to the carriage ``B_x``, along the ground's x axis), the
    prismatic joint ``B_y`` (carriage ``B_x`` to carriage ``B_y``, along y) and the revolute
    joint ``B_phi`` (carriage ``B_y`` to ``B.P``). So ``q_B_x``, ``q_B_y`` are the global
    coordinates of P and ``q_B_phi`` the body's angle. Spatial (``spatial.reader.FREE``): the
    same with the prismatic joints ``B_x``, ``B_y``, ``B_z`` and the revolute joints ``B_rx``,
    ``B_ry``, ``B_rz`` about the carriages' x, y, z axes (five carriages, ``B_x`` ... ``B_ry``).
    Each joint but the last ends on the carriage of its own name; the last ends on ``B.P``. The
    carriages have no mass or inertia: they add no term to the equations of motion (the free
    coordinates' mass matrix is the body's own, regular when its mass and inertia are above
    zero). Written out (``linkdyn.io.writer``), the model holds the carriages as bodies and
    joints.
    """
    if not isinstance(bodies, list) or not any(isinstance(e, dict) and "free" in e
                                               for e in bodies):
        return bodies, joints
    names = {e.get("name") for e in bodies if isinstance(e, dict)}
    out, carriages, links, origins = [], [], [], {}
    steps = [(s, "prismatic", u) for s, u in chain.slides] + \
        [(s, "revolute", u) for s, u in chain.turns]
    for i, entry in enumerate(bodies):
        if not (isinstance(entry, dict) and "free" in entry):
            out.append(entry)
            continue
        f, name, point = _entry_field("bodies", i, entry), entry.get("name"), entry["free"]
        if name == GROUND:
            r.fail(f"{f}.free", "the ground is fixed: it cannot be free",
                   "Remove free from the ground body")
        pts = entry.get("points")
        if not (isinstance(point, str) and isinstance(pts, dict) and point in pts):
            r.fail(f"{f}.free", f"expected the name of one of the body's points, got "
                   f"{_quote(point) if isinstance(point, str) else _type_name(point)}",
                   chain.example)
        for taken in (f"{name}_{s}" for s, _, _ in steps[:-1]):
            if taken in names:
                r.fail(f"{f}.free", f"the free body's carriage would be named '{taken}', the name "
                       "of another body", f"Rename body '{taken}'")
        out.append({k: v for k, v in entry.items() if k != "free"})
        origins[f"{name}_origin"] = f"{f}.free"
        carriage = chain.carriage(r, f, entry, point)
        # ground -> B_x -> ... -> the last carriage -> B (at P)
        first = f"{GROUND}.{name}_origin"
        for k, (suffix, kind, axis) in enumerate(steps):
            last = k == len(steps) - 1
            end = f"{name}.{point}" if last else f"{name}_{suffix}.O"
            if not last:
                carriages.append({"name": f"{name}_{suffix}", **carriage})
            links.append({"name": f"{name}_{suffix}", "type": kind, "connect": [first, end],
                          **({"axis": axis} if axis is not None else {})})
            first = end
    for k, entry in enumerate(out):
        if isinstance(entry, dict) and entry.get("name") == GROUND \
                and isinstance(entry.get("points"), dict):
            for origin, field in origins.items():
                if origin in entry["points"]:
                    r.fail(field, f"the free body's origin would be the ground's point "
                           f"'{origin}', which the ground has", f"Rename the ground's point "
                           f"'{origin}'")
            out[k] = dict(entry, points={**entry["points"],
                                         **{o: [0.0] * r.dim for o in origins}})
    given = joints if joints is not None else []
    return out + carriages, (given + links if isinstance(given, list) else given)


def _bars(r: _Reader, f: str, name: str, points: dict, entry: dict) -> Body:
    """A body whose mass, mass centre and inertia are composed of uniform bars between its
    points (``bars = [{ between = ["A", "B"], mass = ... }]``; ``mass_per_length`` in kg per
    the file's length unit instead of ``mass``)."""
    from ..model import Bar, bar_mass
    for key in ("mass", "com", "inertia", "inertia_about"):
        if key in entry:
            r.fail(f"{f}.{key}", f"a body given by bars takes its {key} from them",
                   f"Remove '{key}', or remove bars and give mass, com and inertia")
    items = r.entries(entry["bars"], f"{f}.bars")
    if not items:
        r.fail(f"{f}.bars", "no bars given",
               'Give e.g. bars = [{ between = ["O2", "O3"], mass = 1.5 }]')
    bars = []
    for k, item in enumerate(items):
        g = f"{f}.bars[{k}]"
        r.table(item, g, BAR_KEYS, required=("between",))
        ends = item["between"]
        if not (isinstance(ends, list) and len(ends) == 2):
            r.fail(f"{g}.between", "expected two point names",
                   'Write between = ["A", "B"] with two of the body\'s points')
        a, b = (r.point(name, points, p, f"{g}.between[{j}]") for j, p in enumerate(ends))
        if ("mass" in item) == ("mass_per_length" in item):
            r.fail(g, "give exactly one of mass and mass_per_length",
                   f"Write mass = ... (kg) or mass_per_length = ... (kg/{r.length_name})")
        if "mass" in item:
            bars.append(Bar(a, b, mass=r.number(item["mass"], f"{g}.mass", "kg",
                                                nonnegative=True)))
        else:
            lam = r.number(item["mass_per_length"], f"{g}.mass_per_length",
                           f"kg/{r.length_name}", nonnegative=True)
            bars.append(Bar(a, b, mass_per_length=lam / r.length))
    mass, com, inertia = bar_mass(points, bars)
    return Body(name, points, mass=mass, com=com, inertia=inertia, bars=tuple(bars))


def _check_ground(r: _Reader, entries: list) -> None:
    """Exactly one body is the ground; say which body was probably meant if none is."""
    names = [e.get("name") for e in entries if isinstance(e, dict)]
    if GROUND in names:
        return
    fix = 'Add a [[bodies]] table with name = "ground" and the fixed pivots as its points'
    close = _did_you_mean(GROUND, [n for n in names if isinstance(n, str)], "")
    massless = [n for e, n in zip(entries, names) if isinstance(e, dict) and "mass" not in e]
    if close.startswith("Did you mean"):
        fix = f'{close.split("?")[0]}? Rename it "ground"'
    elif massless:
        fix = (f"If body {_quote(massless[0])} is the fixed frame, rename it \"ground\"; "
               f"otherwise a{fix[1:]}")
    r.fail("bodies", "no body is named 'ground'", fix)


def _reference(r: _Reader, value: Any, field: str, bodies: dict[str, Body]) -> tuple[str, str]:
    """Split ``"body.point"`` and check both names."""
    if not isinstance(value, str) or value.count(".") != 1:
        r.fail(field, f"expected \"body.point\", got {_type_name(value)}",
               'Write the body name and the point name joined by a dot, e.g. "crank.O2"')
    body, point = value.split(".")
    r.choice(body, field, bodies, "body", "bodies")
    return body, r.point(body, bodies[body].points, point, field)


def _joints(r: _Reader, entries: Any, bodies: dict[str, Body]) -> dict[str, Joint]:
    joints: dict[str, Joint] = {}
    later = []   # the couplings, read once the joints they name are
    for i, entry in enumerate(r.entries(entries, "joints")):
        f = _entry_field("joints", i, entry)
        couples = isinstance(entry, dict) and isinstance(entry.get("type"), str) \
            and entry["type"] in jk.REGISTRY and jk.get(entry["type"]).couples
        r.table(entry, f, JOINT_KEYS, required=("name", "type", "joints" if couples else "connect"))
        name = r.name(entry["name"], f"{f}.name")
        if name in joints or name in (n for _, n, _ in later):
            r.fail(f"joints[{i}].name", f"duplicate joint name '{name}'",
                   "Give every joint a different name")
        kind = r.choice(entry["type"], f"{f}.type", jk.names(), "joint type")
        for key in jk.NUMBERS:
            if key in entry and key not in jk.get(kind).keys:
                takes = [k for k, x in jk.REGISTRY.items() if key in x.keys]
                r.fail(f"{f}.{key}", f"a {kind} joint has no {key}",
                       f"Remove {key}, or set type = " + " or ".join(f'"{k}"' for k in takes))
        if couples:
            if "connect" in entry:
                r.fail(f"{f}.connect", f"a {kind} joint takes the joints it couples, not connect",
                       'Remove connect; write joints = ["J1", "J2"]')
            later.append((i, name, entry))
            continue
        if "joints" in entry:
            r.fail(f"{f}.joints", f"a {kind} joint has no joints",
                   'Remove joints (it names the joints of type = "coupling")')
        conn = entry["connect"]
        if not isinstance(conn, list) or len(conn) != 2:
            r.fail(f"{f}.connect", f"expected two \"body.point\" strings, got {_type_name(conn)}",
                   'Write connect = ["ground.O1", "crank.O1"]')
        a, pa = _reference(r, conn[0], f"{f}.connect[0]", bodies)
        b, pb = _reference(r, conn[1], f"{f}.connect[1]", bodies)
        if a == b:
            r.fail(f"{f}.connect", f"the joint connects body '{a}' to itself",
                   "A joint joins two different bodies; check the body names in connect")
        extra = _numbers_of(r, f, kind, name, entry, a)
        joints[name] = Joint(name, kind, a, pa, b, pb, **extra)
    for i, name, entry in later:
        joints[name] = _coupling(r, _entry_field("joints", i, entry), name, entry, joints, bodies)
    order = {name: k for k, name in enumerate(
        e.get("name") for e in entries if isinstance(e, dict))}
    return dict(sorted(joints.items(), key=lambda kv: order[kv[0]]))


def _numbers_of(r: _Reader, f: str, kind: str, name: str, entry: dict, body_a: str) -> dict:
    """A joint's numbers its kind declares (not the derived ones), read in SI and checked by the
    kind (:meth:`~linkdyn.joints.JointKind.refuse`)."""
    extra = {x.name: _number(r, x, entry.get(x.name), f"{f}.{x.name}", body_a)
             for x in jk.get(kind).numbers if not x.derived}
    why = jk.get(kind).refuse(extra)
    if why:
        r.fail(f, f"a {kind} joint: {why}", f"Correct the numbers of joint '{name}'")
    return extra


def _coupling(r: _Reader, f: str, name: str, entry: dict, joints: dict, bodies: dict) -> Joint:
    """A coupling from the two joints its ``joints`` names (:func:`coupling.couple`)."""
    pair = entry["joints"]
    fix = 'Write joints = ["J1", "J2"], two revolute joints of one common body'
    if not (isinstance(pair, list) and len(pair) == 2 and all(isinstance(x, str) for x in pair)):
        r.fail(f"{f}.joints", f"expected two joint names, got {_type_name(pair)}", fix)
    for k, x in enumerate(pair):
        r.choice(x, f"{f}.joints[{k}]", joints, "joint", "joints (not couplings)")
    if pair[0] == pair[1]:
        r.fail(f"{f}.joints", f"the coupling names joint '{pair[0]}' twice", fix)
    extra = _numbers_of(r, f, entry["type"], name, entry, "")
    try:
        return coupling.couple(name, joints[pair[0]], joints[pair[1]], bodies, **extra)
    except coupling.CouplingError as e:
        r.fail(f"{f}.joints", str(e), fix)


def _number(r: _Reader, x: jk.Number, value: Any, field: str, body_a: str):
    """A joint's number ``x`` (declared by its kind) from the file's ``value`` (None: its
    default), in SI: a length or an angle converted from the file's units, a direction made a
    unit vector."""
    scale, unit = {"angle": (r.angle, r.angle_name),
                   "length": (r.length, r.length_name),
                   "pressure": (1.0 / r.length ** 2, f"N/{r.length_name}^2")}.get(x.unit,
                                                                                  (1.0, ""))
    if value is None:
        return x.value()
    if x.choices:   # given by name: its place in the choices
        return float(x.choices.index(r.choice(value, field, x.choices, x.doc or x.name)))
    if not x.shape:
        return r.number(value, field, unit) * scale
    v = r.vector(value, field, unit) * scale
    if x.direction:
        if np.hypot(*v) == 0:
            r.fail(field, f"the {x.name} is zero",
                   f"Give the {x.doc or 'direction'} in the frame of body '{body_a}', "
                   f"e.g. {x.name} = [1, 0]")
        v = v / np.hypot(*v)
    return v


def link_pairs(bodies, joints) -> list[tuple[str, str, str, str, str]]:
    """The links of the mechanism: pairs of different named points of one body that two
    revolute joints attach to, as ``(body, point, other point, joint, other joint)`` (the first
    joint attaching at each point, in the joints' order). ``bodies`` and ``joints``: the
    :class:`~linkdyn.model.Body` and :class:`~linkdyn.model.Joint` entries."""
    at: dict[str, dict[str, str]] = {b.name: {} for b in bodies}
    for j in joints:
        if jk.get(j.kind).angular:
            at[j.body_a].setdefault(j.point_a, j.name)
            at[j.body_b].setdefault(j.point_b, j.name)
    return [(b, p, q, pins[p], pins[q]) for b, pins in at.items()
            for i, p in enumerate(pins) for q in list(pins)[i + 1:]]


def short_links(pairs, points, size):
    """Which of the links ``pairs`` (:func:`link_pairs`) have zero length: ``(pair, short)`` for
    each, ``short`` True where its two points lie within ``SHORT_LINK`` times the mechanism's
    ``size`` of each other. ``points``: ``(body, point) -> (2, ...)`` in the body's frame, m;
    ``size``: float or array of the batch shape (one design, or D designs)."""
    for pair in pairs:
        body, p, q = pair[:3]
        d = np.hypot(*(np.asarray(points[body, p]) - np.asarray(points[body, q])))
        yield pair, ~(d > SHORT_LINK * np.asarray(size))


def _check_links(r: _Reader, bodies: dict[str, Body], joints: dict[str, Joint]) -> None:
    """No link of zero length: two revolute joints of one body at different points must not be
    at the same place (the link between them could turn freely, or not at all)."""
    points = {(b.name, p): x for b in bodies.values() for p, x in b.points.items()}
    size = point_spread(list(points.values()))
    for (body, p, q, jp, jq), short in short_links(link_pairs(bodies.values(), joints.values()),
                                                   points, size):
        if short:
            xy = ", ".join(f"{c / r.length:g}" for c in points[body, q])
            field = next(f"bodies.{body}.points.{x}" for x in (q, p))
            r.fail(field, f"the link of body '{body}' between joints {jp} (point {p}) and {jq} "
                          f"(point {q}) has zero length: {p} and {q} are both at [{xy}] "
                          f"{r.length_name}",
                   f"Move {q} away from {p}; a pin that two joints share is one point that both "
                   "joints connect to")

