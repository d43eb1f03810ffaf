"""``linkdyn import``: a mechanism saved by pylinkage (its JSON serialization) as a linkdyn model.

pylinkage (``pylinkage.mechanism.mechanism_to_json``) writes a mechanism as ``joints`` (each an
``id``, a ``type`` -- ``ground``, ``revolute``, ``prismatic`` or ``tracker`` -- and a
``position``) and ``links`` (each an ``id``, a ``type`` -- ``ground``, ``driver`` or ``link`` --
and the ``joints`` it holds, rigidly, at the distances of the saved pose). It simulates by steps:
at step ``k`` the driver link (the crank) stands at ``initial_angle + k angular_velocity`` (rad,
the speed in rad per step) and every other joint is placed by circle-circle or circle-line
intersections nearest to where it was.

The linkdyn model says the same thing with bodies and joints:

- the ground link and every ground joint are the body ``ground``; every other link is a body whose
  frame has its origin at the link's first joint (the crank's: its motor joint) and its +x axis
  towards the next joint, as they stand in the saved pose; its points are the link's joints;
- a joint that two or more bodies hold is a revolute joint between the first of them (the ground
  for a ground joint) and each other one, named after the pylinkage joint (and, where it makes
  several, the second body: ``A_crank``); names keep letters, digits, ``_`` and ``-``;
- a prismatic joint (a pin that slides on the fixed line through ``line_point`` along ``axis``)
  is a ``slot`` joint: the line is the ground's, the pin the first link's that holds it (the
  ground's point if a ground link holds it). With ``line_link`` (Pyslvs's sliders on a moving
  link) the line is that link's instead: through ``line_point`` along ``axis`` as saved, a point
  ``<joint>_line`` of its body that also counts for its frame and its placeholder mass;
- a tracker (a point at ``distance`` and ``angle`` from the line of two reference joints) is a
  point of the body that holds both reference joints;
- the driver link's motor joint is a constant-speed revolute driver: ``q = initial_angle +
  angular_velocity t``, one pylinkage step read as one second (speed in rad/s);
- lengths are the file's numbers, in the length unit the caller names (pylinkage has none);
  angles are written in rad;
- masses: pylinkage has none. Each moving body gets a placeholder of 1 kg
  (:data:`BAR_MASS`) spread uniformly along the bars between its joints (for a link of two
  joints the bar between them, for more the closed outline through them in file order), with the
  mass centre and inertia about it of those uniform bars. Replace them with the real ones.

What linkdyn cannot represent is refused, naming the joint or link and its type: an oscillating
driver (``arc_driver``), more or fewer than one driver, a tracker without reference joints or
whose reference joints no one link holds, a moving link pinned to the ground at two joints, a
joint that no link holds.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ModelError, wrong_type
from ..model import GROUND, Model
from . import read_input
from .reader import MAX_NAME, _NAME, _quote, _type_name
from .syntax import _parse_json
from .units import LENGTH_UNITS

__all__ = ["Imported", "read_pylinkage", "from_pylinkage", "import_pylinkage", "BAR_MASS"]

#: The placeholder mass, kg, of each moving body (uniform bars along its joints).
BAR_MASS = 1.0
JOINT_TYPES = ("ground", "revolute", "prismatic", "tracker")
LINK_TYPES = ("ground", "driver", "link")
_DESCRIPTION = ("Imported from {tool} by linkdyn import: masses are placeholders (1 kg "
                "uniform bars per link); {time}")
#: How each tool's crank speed becomes time: the description's words and the printed note's.
_TIME = {"pylinkage": ("one pylinkage step is 1 s",
                       "one pylinkage step is read as 1 s: the driver {joint} turns the crank "
                       "{crank} at {speed!r} rad/s (pylinkage's {speed!r} rad per step)"),
         "Pyslvs": ("the crank turns once a second",
                    "Pyslvs has no time: the driver {joint} turns the crank {crank} once a "
                    "second ({speed!r} rad/s) from its saved angle")}
_FIX = "Save the mechanism with pylinkage.mechanism.mechanism_to_json"


@dataclass(frozen=True)
class Imported:
    """A pylinkage mechanism as a linkdyn model.

    Attributes
    ----------
    data : dict
        The model-file structure (what :func:`linkdyn.model_from_dict` reads), lengths in
        ``data["units"]["length"]``, angles in rad.
    model : Model
        ``data`` read and checked (SI).
    points : dict
        ``{pylinkage joint id: (body, point)}``: where each pylinkage joint (and tracker) is in
        the model (the crank's motor joint: on the crank).
    notes : tuple of str
        What a user should read: the placeholder masses and the time scale.
    tool : str
        The tool the mechanism comes from: ``"pylinkage"`` or ``"Pyslvs"``
        (:mod:`linkdyn.io.pyslvs`).
    """

    data: dict
    model: Model
    points: dict
    notes: tuple[str, ...]
    tool: str = "pylinkage"


def read_pylinkage(path: str | os.PathLike) -> dict:
    """The parsed JSON of a pylinkage file (not yet checked); a ModelError naming the file if
    it cannot be read or is not JSON."""
    if not isinstance(path, (str, os.PathLike)):
        raise wrong_type("read_pylinkage", "path", path, "a str or os.PathLike")
    file = os.fspath(path)
    return _parse_json(read_input(file, "pylinkage file"), file)


def import_pylinkage(path: str | os.PathLike, *, length_unit: str = "m") -> Imported:
    """Read a pylinkage JSON file as a linkdyn model (:func:`from_pylinkage` of its content)."""
    data = read_pylinkage(path)
    return from_pylinkage(data, source=os.fspath(path), length_unit=length_unit)


class _Names:
    """Valid, unique linkdyn names made from pylinkage ids (which may hold spaces, dots...)."""

    def __init__(self, reserved=()):
        self.used = set(reserved)

    def __call__(self, raw: str) -> str:
        base = "".join(c if c.isascii() and (c.isalnum() or c in "_-") else "_" for c in raw)
        base = "_".join(x for x in base.split("_") if x)[:MAX_NAME - 4] or "x"
        if not _NAME.match(base):
            base = "j" + base
        name, k = base, 2
        while name in self.used:
            name, k = f"{base}_{k}", k + 1
        self.used.add(name)
        return name


def _bars(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Mass centre (2,) and inertia about it, kg length^2, of :data:`BAR_MASS` spread uniformly
    along the bars through ``points`` (n, 2): the one bar for n = 2, the closed outline for more.
    """
    ends = points[[1]] if len(points) == 2 else np.roll(points, -1, axis=0)
    starts = points[:1] if len(points) == 2 else points
    length = np.hypot(*(ends - starts).T)                       # (bars,)
    mid = 0.5 * (starts + ends)
    m = BAR_MASS * length / length.sum()                        # m_i = M l_i / sum l
    com = (m[:, None] * mid).sum(axis=0) / BAR_MASS             # c = sum m_i mid_i / M
    # I_c = sum m_i (l_i^2 / 12 + |mid_i - c|^2): each uniform bar about its middle, shifted
    inertia = float((m * (length ** 2 / 12 + ((mid - com) ** 2).sum(axis=1))).sum())
    return com, inertia


def from_pylinkage(data: dict, *, source: str = "", length_unit: str = "m",
                   tool: str = "pylinkage") -> Imported:
    """A pylinkage mechanism (the structure ``mechanism_to_dict`` returns) as a linkdyn model.

    Parameters
    ----------
    data : dict
        pylinkage's ``{"name", "joints", "links", "ground"}``.
    source : str
        The file, for messages.
    length_unit : str
        The length unit the file's numbers are in (a key of ``LENGTH_UNITS``); pylinkage has none.
    tool : str
        The tool named in the model's description and notes (a key of ``_TIME``): Pyslvs's
        mechanisms are read by putting them in this structure (:mod:`linkdyn.io.pyslvs`).

    Returns
    -------
    Imported

    Raises
    ------
    ModelError
        What linkdyn cannot represent or the file does not say, naming the joint or link (its
        id and type) as the field.
    """
    def fail(field, message, fix=_FIX):
        raise ModelError(message, file=source, field=field, fix=fix)

    if length_unit not in LENGTH_UNITS:
        fail("--length-unit", f"unknown length unit {_quote(length_unit)}",
             "Give one of " + ", ".join(LENGTH_UNITS))
    if not isinstance(data, dict) or not isinstance(data.get("joints"), list) \
            or not isinstance(data.get("links"), list):
        fail("", "not a pylinkage mechanism: expected an object with the lists 'joints' and "
             "'links'")

    # --- joints: positions by id; ground joints as pylinkage's loader decides them
    links_in = data["links"]
    for i, ld in enumerate(links_in):
        if not isinstance(ld, dict) or not isinstance(ld.get("id"), str):
            fail(f"links[{i}]", "a link must be an object with a text 'id'")
        if ld.get("type", "link") not in LINK_TYPES:
            kind = ld.get("type")
            what = (" (an oscillating crank: linkdyn has no constant-speed back-and-forth "
                    "driver)" if kind == "arc_driver" else "")
            fail(f"links[{i}]", f"link {_quote(ld['id'])} of type {_quote(kind)} cannot be "
                 f"imported{what}", "Drive the mechanism with a 'driver' link (a crank that "
                 "turns) or write the linkdyn model by hand")
        ids = ld.get("joints", [])
        if not isinstance(ids, list) or not all(isinstance(j, str) for j in ids) or not \
                isinstance(ld.get("motor_joint", ""), (str, type(None))):
            fail(f"links[{i}]", f"link {_quote(ld['id'])}: 'joints' must be a list of joint ids "
                 "and 'motor_joint' a joint id")
    grounded = {j for ld in links_in if ld.get("type") == "driver" and ld.get("motor_joint")
                for j in [ld["motor_joint"]]}
    grounded |= {j for ld in links_in if ld.get("type") == "ground" for j in ld.get("joints", [])}
    joints: dict[str, dict] = {}
    for i, jd in enumerate(data["joints"]):
        if not isinstance(jd, dict) or not isinstance(jd.get("id"), str):
            fail(f"joints[{i}]", "a joint must be an object with a text 'id'")
        jid, kind = jd["id"], jd.get("type", "revolute")
        if kind not in JOINT_TYPES:
            fail(f"joints[{i}]", f"joint {_quote(jid)} of type {_quote(kind)} cannot be imported: "
                 "the types of pylinkage's mechanism files are " + ", ".join(JOINT_TYPES),
                 "Load the file in pylinkage and save it with mechanism_to_json")
        if jid in joints:
            fail(f"joints[{i}]", f"two joints have the id {_quote(jid)}", "Give each joint its own id")
        jd = dict(jd, type="ground" if jid in grounded and kind not in ("tracker", "prismatic")
                  else kind)
        if kind != "tracker":
            pos = jd.get("position")
            ok = isinstance(pos, list) and len(pos) == 2 and all(
                isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
                for x in pos)
            if not ok:
                fail(f"joints[{i}]", f"joint {_quote(jid)} of type {_quote(kind)} has no position "
                     "(two finite numbers)", "Save the mechanism in an assembled pose")
        joints[jid] = jd

    def pos(jid) -> np.ndarray:
        return np.array(joints[jid]["position"], float)

    # --- sliders on a moving link: the links that carry a prismatic joint's line
    link_ids = {ld["id"]: ld.get("type", "link") for ld in links_in}
    lines: dict[str, list[str]] = {}                 # link id -> the joints whose line it is
    for i, (jid, jd) in enumerate(joints.items()):
        carrier = jd.get("line_link") if jd["type"] == "prismatic" else None
        if carrier is None or link_ids.get(carrier) == "ground":
            continue
        if carrier not in link_ids:
            fail(f"joints[{i}]", f"joint {_quote(jid)} of type 'prismatic' slides on the link "
                 f"{_quote(carrier)}, which the file does not define",
                 "Give line_link the id of a link")
        try:
            ok = all(np.isfinite(np.array(jd.get(k, [0.0, 0.0]), float).reshape(2)).all()
                     for k in ("axis", "line_point"))
        except (TypeError, ValueError):
            ok = False
        if not ok:
            fail(f"joints[{i}]", f"joint {_quote(jid)} of type 'prismatic': axis and "
                 "line_point must be two finite numbers each")
        lines.setdefault(carrier, []).append(jid)

    # --- links: the ground (all ground links and ground joints) and the moving links
    moving: list[dict] = []
    drivers: list[dict] = []
    for i, ld in enumerate(links_in):
        ids = ld.get("joints", [])
        for jid in ids:
            if jid not in joints:
                fail(f"links[{i}]", f"link {_quote(ld['id'])} holds the joint {_quote(jid)}, "
                     "which the file does not define", "Add the joint or remove it from the link")
            if joints[jid]["type"] == "tracker":
                fail(f"links[{i}]", f"link {_quote(ld['id'])} holds the tracker "
                     f"{_quote(jid)}: a tracker observes, it does not join links",
                     "Join the link at a revolute joint")
        if ld.get("type") == "ground":
            continue
        if len(ids) + len(lines.get(ld["id"], [])) < 2 or len(set(ids)) != len(ids):
            fail(f"links[{i}]", f"link {_quote(ld['id'])} of type {_quote(ld.get('type', 'link'))}"
                 " must hold two or more different joints", "Give the link its joints")
        pinned = [j for j in ids if joints[j]["type"] == "ground"]
        if len(pinned) > 1:
            fail(f"links[{i}]", f"link {_quote(ld['id'])} of type {_quote(ld.get('type', 'link'))}"
                 f" is pinned to the ground at {len(pinned)} joints ({', '.join(pinned)}): it "
                 "cannot move", "Make it part of the ground link or free one of its joints")
        if ld.get("type") == "driver":
            drivers.append(ld)
        moving.append(ld)
    if len(drivers) != 1:
        fail("links", f"the mechanism has {len(drivers)} driver links "
             f"({', '.join(d['id'] for d in drivers) or 'none'}): linkdyn imports mechanisms "
             "driven by one crank", "Keep one 'driver' link")
    drv = drivers[0]
    motor = drv.get("motor_joint")
    if motor not in drv["joints"]:     # pylinkage's crank holds two, Pyslvs's may hold more
        fail(f"links[{links_in.index(drv)}]", f"driver link {_quote(drv['id'])} of type 'driver' "
             "must hold its motor_joint", "Give it motor_joint and one output joint")
    speed, start = drv.get("angular_velocity", math.tau / 360), drv.get("initial_angle", 0.0)
    for key, v in (("angular_velocity", speed), ("initial_angle", start)):
        if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
            fail(f"links[{links_in.index(drv)}].{key}", f"driver link {_quote(drv['id'])}: "
                 f"{key} must be a finite number in rad, got {_type_name(v)}")

    # --- bodies: the frame of each moving link at its first joint, +x towards the next
    names = _Names({GROUND})
    ground_points = _Names()
    ground: dict = {"name": GROUND, "points": {}}
    where: dict[str, tuple[str, str]] = {}
    held: dict[str, list[tuple[str, str]]] = {}       # joint id -> [(body, point)]
    for jid, jd in joints.items():
        if jd["type"] == "ground" or (jd["type"] == "prismatic" and jid in grounded):
            p = ground_points(jid)
            ground["points"][p] = [float(x) for x in pos(jid)]
            held[jid] = [(GROUND, p)]
            where[jid] = (GROUND, p)
    bodies, frames, phi = [ground], {}, {}
    line_at: dict[str, tuple[str, str, np.ndarray]] = {}   # joint -> (body, point, axis in it)
    for ld in moving:
        ids = list(ld["joints"])
        if ld is drv:
            ids.sort(key=lambda j: j != motor)         # the motor joint first: q is the angle
        # its joints, then the lines of the sliders it carries (their saved points)
        spots = [(j, pos(j)) for j in ids] + [
            (f"{j}_line", np.array(joints[j].get("line_point", joints[j]["position"]), float))
            for j in lines.get(ld["id"], [])]
        origin = spots[0][1]
        ahead = next((x - origin for _, x in spots[1:] if np.hypot(*(x - origin)) > 0), None)
        if ahead is None:
            fail(f"links[{links_in.index(ld)}]", f"link {_quote(ld['id'])} has all its joints at "
                 "one place", "Save the mechanism in an assembled pose")
        theta = math.atan2(ahead[1], ahead[0])
        c, s = math.cos(theta), math.sin(theta)
        rot = np.array([[c, s], [-s, c]])               # global -> body: R(-theta)
        name = names(ld["id"])
        pts = _Names()
        local = {}
        for jid, x in spots:
            p = pts(jid)
            local[p] = rot @ (x - origin)
            if np.array_equal(x - origin, ahead):   # on the +x axis by construction
                local[p] = np.array([math.hypot(*ahead), 0.0])
            if jid in joints:
                held.setdefault(jid, []).append((name, p))
                where.setdefault(jid, (name, p))
            else:                                   # a slider's line: axis R(-theta) axis
                slider = jid[:-len("_line")]
                axis = np.array(joints[slider].get("axis", [1.0, 0.0]), float)
                line_at[slider] = (name, p, rot @ axis)
        com, inertia = _bars(np.array(list(local.values())))
        bodies.append({"name": name, "points": {p: [float(x) for x in v] for p, v in local.items()},
                       "mass": BAR_MASS, "com": [float(x) for x in com], "inertia": inertia})
        frames[ld["id"]] = (name, origin, rot, pts)
        phi[name] = theta

    # --- trackers: a point of the body that holds both reference joints
    for i, (jid, jd) in enumerate(joints.items()):
        if jd["type"] != "tracker":
            continue
        r1, r2 = jd.get("ref_joint1_id"), jd.get("ref_joint2_id")
        if r1 not in joints or r2 not in joints:
            fail(f"joints[{i}]", f"joint {_quote(jid)} of type 'tracker' has no reference joints "
                 "(a free tracker is a fixed point of no link)",
                 "Give it ref_joint1_id and ref_joint2_id, two joints of one link")
        dist, ang = jd.get("distance", 0.0), jd.get("angle", 0.0)
        if not all(isinstance(v, (int, float)) and math.isfinite(v) for v in (dist, ang)):
            fail(f"joints[{i}]", f"joint {_quote(jid)} of type 'tracker': distance and angle must "
                 "be finite numbers")
        a, b = pos(r1), pos(r2)
        base = math.atan2(b[1] - a[1], b[0] - a[0]) + ang   # pylinkage's TrackerJoint
        p = a + dist * np.array([math.cos(base), math.sin(base)])
        both = {n for n, _ in held.get(r1, [])} & {n for n, _ in held.get(r2, [])}
        body = next((bd for bd in bodies if bd["name"] in both), None)
        if body is None:
            fail(f"joints[{i}]", f"joint {_quote(jid)} of type 'tracker': no one link holds both "
                 f"its reference joints {_quote(r1)} and {_quote(r2)}",
                 "Give it two reference joints of one link")
        if body["name"] == GROUND:
            pname = ground_points(jid)
            body["points"][pname] = [float(x) for x in p]
        else:
            _, origin, rot, pts = next(f for f in frames.values() if f[0] == body["name"])
            pname = pts(jid)
            body["points"][pname] = [float(x) for x in rot @ (p - origin)]
        where[jid] = (body["name"], pname)

    # --- joints: revolute between the first holder and every other; a prismatic as a slot
    jnames = _Names()
    model_joints, assembly_q = [], {}
    drive_joint = None
    for i, (jid, jd) in enumerate(joints.items()):
        if jd["type"] == "tracker":
            continue
        hold = held.get(jid, [])
        if jd["type"] == "prismatic":
            if not hold:
                fail(f"joints[{i}]", f"joint {_quote(jid)} of type 'prismatic' belongs to no link",
                     "Add it to the link that slides")
            axis, lp = jd.get("axis", [1.0, 0.0]), jd.get("line_point", [0.0, 0.0])
            try:
                axis, lp = np.array(axis, float).reshape(2), np.array(lp, float).reshape(2)
            except (TypeError, ValueError):
                fail(f"joints[{i}]", f"joint {_quote(jid)} of type 'prismatic': axis and "
                     "line_point must be two numbers each")
            if not (np.isfinite(axis).all() and np.isfinite(lp).all()) or np.hypot(*axis) < 1e-10:
                fail(f"joints[{i}]", f"joint {_quote(jid)} of type 'prismatic': axis must be a "
                     "finite direction, line_point a finite point")
            if jid in line_at:        # the line of a moving link, its axis in that body
                carrier, line, along = line_at[jid]
            else:
                carrier, line, along = GROUND, ground_points(f"{jid}_line"), axis
                ground["points"][line] = [float(x) for x in lp]
            name = jnames(jid)
            # a pin that turns (pylinkage's) is a slot joint; one that does not (Pyslvs's P
            # slider, "turns": false) a prismatic joint, the pin's link kept at its saved angle
            # to the line's
            still = {"type": "prismatic", "angle": phi.get(hold[0][0], 0.0)
                     - phi.get(carrier, 0.0)} \
                if jd.get("turns", True) is False else {"type": "slot"}
            model_joints.append({"name": name, **still, "axis": [float(x) for x in along],
                                 "connect": [f"{carrier}.{line}", "{}.{}".format(*hold[0])]})
            u = axis / np.hypot(*axis)
            assembly_q[name] = float((pos(jid) - lp) @ u)  # the pin's travel along the line
        elif not hold:
            fail(f"joints[{i}]", f"joint {_quote(jid)} of type {_quote(jd['type'])} belongs to "
                 "no link", "Add it to a link or remove it")
        first = hold[0]
        for other in hold[1:]:       # one joint: its id; several: the id and the second body
            name = jnames(jid if len(hold) == 2 else f"{jid}_{other[0]}")
            model_joints.append({"name": name, "type": "revolute",
                                 "connect": ["{}.{}".format(*first), "{}.{}".format(*other)]})
            if jid == motor and other[0] == frames[drv["id"]][0]:
                drive_joint = name
    crank = frames[drv["id"]][0]
    if drive_joint is None:    # the motor joint is a ground joint, so held by ground and crank
        raise AssertionError("the motor joint's revolute joint was not made")

    notes = (
        f"masses are placeholders: each moving body {BAR_MASS:g} kg as uniform bars along its "
        "joints (mass centre and inertia of those bars); replace them with the real ones",
        _TIME[tool][1].format(joint=drive_joint, crank=crank, speed=float(speed)),
        f"lengths are the file's numbers in {length_unit}; gravity is zero",
    )
    out: dict = {
        "mechanism": {"name": str(data.get("name") or Path(source).stem or "mechanism"),
                      "description": _DESCRIPTION.format(tool=tool, time=_TIME[tool][0]),
                      "gravity": [0.0, 0.0]},
        "units": {"length": length_unit, "angle": "rad"},
        "bodies": bodies,
        "joints": model_joints,
        "drivers": [{"joint": drive_joint, "motion": {"kind": "constant_speed",
                                                      "speed": float(speed),
                                                      "start": float(start)}}],
        "assembly": {"phi": phi, **({"q": assembly_q} if assembly_q else {})},
    }
    if speed != 0:
        out["analysis"] = {"cycles": 1}
    from . import model_from_dict
    from .. import topology

    def build(d):
        try:
            model = model_from_dict(json.loads(json.dumps(d)), source="")
            topology.build(model)  # one freedom, one driver: else a ModelError naming the count
        except ModelError as err:
            fail("", f"the mechanism cannot be a linkdyn model: {err.message}"
                 + (f" (in the model made of it: {err.field})" if err.field else ""),
                 f"Check that the {tool} mechanism has one degree of freedom, driven by its "
                 "crank")
        return model

    model = build(out)
    # The saved pose may have the crank elsewhere than at initial_angle (where t = 0 puts it):
    # carry the pose there by continuation, so the assembly starts on the saved pose's branch.
    gap = math.remainder(float(start) - phi[crank], math.tau)
    if abs(gap) > 1e-12:
        notes += (f"the saved pose has the crank at {phi[crank]!r} rad, its initial_angle is "
                  f"{float(start)!r} rad: the assembly guesses are the saved pose carried there",)
        out["assembly"] = _carried(build, out, drive_joint, phi[crank], gap, frames, joints)
        model = build(out)
    return Imported(out, model, where, notes, tool)


def _carried(build, out: dict, drive_joint: str, angle: float, gap: float, frames: dict,
             joints: dict) -> dict:
    """``out``'s assembly guesses carried from the saved pose (crank at ``angle``, rad) by
    ``gap`` rad of crank turn: linkdyn's own continuation over 64 steps from the pose."""
    from ..analysis import analyze
    from ..errors import AssemblyError

    moved = dict(out, drivers=[{"joint": drive_joint, "motion": {
        "kind": "constant_speed", "speed": gap, "start": angle}}])   # q = angle + gap t
    moved.pop("analysis", None)
    try:
        sol = analyze(build(moved), np.linspace(0.0, 1.0, 65))
    except AssemblyError:
        return out["assembly"]           # no continuation: the saved pose's own guesses
    guess = {"phi": {b: float(sol.phi(b)[-1]) for b in out["assembly"]["phi"]}}
    if "q" in out["assembly"]:
        guess["q"] = {name: float(sol.columns[f"q_{name}"][-1] / LENGTH_UNITS[out["units"]["length"]])
                      for name in out["assembly"]["q"]}
    return guess


def model_text(imported: Imported, suffix: str = ".toml") -> str:
    """The model file's text: TOML (the writer's :func:`~linkdyn.io.writer.dumps_toml`, under a
    comment on the placeholder masses) for ``.toml``, JSON for ``.json``."""
    if suffix.lower() == ".json":
        return json.dumps(imported.data, indent=2, allow_nan=False) + "\n"
    from .writer import dumps_toml

    head = "".join(f"# {n}\n" for n in (f"Imported from {imported.tool} by linkdyn import.",)
                   + imported.notes)
    return head + "\n" + dumps_toml(imported.data)
