"""``linkdyn import``: a mechanism drawn in Pyslvs (its expression or YAML project) as a linkdyn
model.

Pyslvs writes a mechanism as an expression, ``M[J[R, color[Green], P[x, y], L[ground, L1]],
...]``: joint ``i`` (counted from 0) of type ``R`` (revolute), ``P`` or ``RP`` (sliders, with
an angle ``A[deg]``), at ``P[x, y]`` in the saved pose, joining the links ``L[...]`` (``ground``
the frame). Each link is rigid: its joints keep their saved distances. The mechanism moves by
its input pairs ``(base, drive)``: the angle of the line from joint ``base`` to joint ``drive``
(absolute, degrees). A project file (``*.pyslvs``, YAML) holds the expression under
``mechanism`` and the input pairs under ``input``.

The import puts the mechanism in pylinkage's structure and reads it as
:func:`linkdyn.io.pylinkage.from_pylinkage` does (one reader of links and joints):

- joint ``i`` is the pylinkage joint ``P<i>`` at its saved position, a ground joint if it
  joins the link ``ground``; a slider (``RP``: a pin that slides along a line of its first
  link, the slot link, through its saved position at ``A`` degrees, and turns) is pylinkage's
  prismatic joint, so a ``slot`` joint from that line to the first other link, the others
  pinned to it; a ``P`` slider (the other links slide without turning on the slot link) a
  ``prismatic`` joint instead, at their saved angle to it. A slot on a moving link is that
  link's line as saved (its point ``P<i>_line``), turning with it: Pyslvs's solver keeps the
  slot at its saved angle to the link and the slot's base point on it;
- each other link is a link holding its joints in the expression's order; the input pair's link
  (the one holding both joints) is the driver, its motor joint the base (a ground joint);
- so each moving link is a body with its frame at its first joint, +x towards the next, each
  joint held by several links a revolute joint between the first and each other one (named
  ``P<i>``, or ``P<i>_<link>`` when it makes several), a joint of one link a point of it;
- the driver turns the crank at one turn per second (``2 pi`` rad/s) from its saved angle
  (Pyslvs has no time), so the model's first sample is the saved pose; the assembly follows
  the crank from there, as Pyslvs keeps each triangle on its saved side;
- masses are placeholders (1 kg uniform bars per link), gravity zero, lengths the file's
  numbers in the unit the caller names (Pyslvs has none).

Refused, naming the joint by its number and type or the input pair: a slider with no link but
its slot link, more or fewer than one input pair, an input pair no one moving link holds,
whose base is not a revolute ground joint or that drives a slider (base and drive one joint),
an expression that does not parse, and what pylinkage's reader refuses (a link pinned twice to the ground, a joint
no link holds, a mobility other than one).
"""

from __future__ import annotations

import math
import os
import re

from ..errors import ModelError, wrong_type
from . import read_input
from .pylinkage import Imported, from_pylinkage

__all__ = ["parse_expression", "read_pyslvs", "from_pyslvs", "import_pyslvs", "is_pyslvs"]

#: Suffixes of Pyslvs's project files (YAML).
PROJECT_SUFFIXES = (".pyslvs", ".yaml", ".yml")
_FIX = "Copy the expression from Pyslvs (Mechanism > Copy expression) or save the project as YAML"
_NUMBER = r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?"
_JOINT = re.compile(
    r"J\[(?P<type>RP|R|P)"
    rf"(?:,A\[(?P<angle>{_NUMBER})\])?"
    r"(?:,color\[(?:\([0-9,]*\)|[A-Za-z-]+)\])?"
    rf",P\[(?P<x>{_NUMBER}),(?P<y>{_NUMBER})\]"
    r",L\[(?P<links>[A-Za-z_0-9,]*)\]\]")


def is_pyslvs(file: str, text: str) -> bool:
    """Whether ``file`` (its ``text``) is Pyslvs's: a project file's suffix, or an expression."""
    return (os.path.splitext(file)[1].lower() in PROJECT_SUFFIXES
            or _strip(text).startswith("M["))


def _strip(text: str) -> str:
    """The expression without Pyslvs's comments (``#[ ... #]`` and ``# ...``) and spaces."""
    text = re.sub(r"#\[[\s\S]*?#\][^\n]*", "", text)
    return re.sub(r"\s+", "", re.sub(r"#[^\n]*", "", text))


def parse_expression(expression: str, *, source: str = "") -> list[dict]:
    """The joints of a Pyslvs expression.

    Returns
    -------
    list of dict
        Per joint, in order: ``type`` (``"R"``, ``"P"``, ``"RP"``), ``angle`` (deg, sliders),
        ``position`` (2,) in the file's length unit, ``links`` (tuple of link names).

    Raises
    ------
    ModelError
        Naming the joint (by its number) whose text is not Pyslvs's.
    """
    text = _strip(expression)
    if not (text.startswith("M[") and text.endswith("]")):
        raise ModelError("not a Pyslvs expression: expected M[J[...], ...]", file=source,
                         field="mechanism", fix=_FIX)
    body, joints, at = text[2:-1], [], 0
    while at < len(body):
        m = _JOINT.match(body, at)
        if m is None:
            raise ModelError(f"joint {len(joints)} is not a Pyslvs joint: {body[at:at + 60]!r}",
                             file=source, field=f"mechanism joint {len(joints)}",
                             fix="Write it J[R, P[x, y], L[link, ...]] (or copy it from Pyslvs)")
        joints.append({"type": m["type"], "angle": float(m["angle"] or 0.0),
                       "position": [float(m["x"]), float(m["y"])],
                       "links": tuple(x for x in m["links"].split(",") if x)})
        at = m.end() + (1 if body[m.end():m.end() + 1] == "," else 0)
    return joints


def read_pyslvs(path: str | os.PathLike) -> tuple[str, list]:
    """The expression and input pairs of a Pyslvs file: a project (YAML: ``mechanism``,
    ``input``) or an expression alone (no input pairs)."""
    if not isinstance(path, (str, os.PathLike)):
        raise wrong_type("read_pyslvs", "path", path, "a str or os.PathLike")
    file = os.fspath(path)
    text = read_input(file, "Pyslvs file")
    if _strip(text).startswith("M["):
        return text, []
    try:
        import yaml
    except ImportError:
        raise ModelError("reading a Pyslvs project needs PyYAML", file=file,
                         fix="pip install 'linkdyn[pyslvs]', or give the expression alone") \
            from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as e:
        raise ModelError(f"not YAML: {str(e).splitlines()[0]}", file=file, fix=_FIX) from None
    if not isinstance(data, dict) or not isinstance(data.get("mechanism"), str):
        raise ModelError("not a Pyslvs project: no expression under 'mechanism'", file=file,
                         field="mechanism", fix=_FIX)
    return data["mechanism"], data.get("input") or []


def import_pyslvs(path: str | os.PathLike, *, length_unit: str = "m",
                  inputs=None) -> Imported:
    """Read a Pyslvs file as a linkdyn model (:func:`from_pyslvs`); ``inputs`` (pairs of joint
    numbers) replace the file's input pairs."""
    expression, saved = read_pyslvs(path)
    return from_pyslvs(expression, saved if inputs is None else inputs,
                       source=os.fspath(path), length_unit=length_unit)


def from_pyslvs(expression: str, inputs, *, source: str = "", length_unit: str = "m",
                name: str = "") -> Imported:
    """A Pyslvs mechanism as a linkdyn model.

    Parameters
    ----------
    expression : str
        ``M[J[...], ...]``.
    inputs : sequence of (int, int)
        Pyslvs's input pairs ``(base, drive)``: one, the crank's ground joint and the joint it
        carries.
    source : str
        The file, for messages.
    length_unit : str
        The unit of the expression's numbers.
    name : str
        The mechanism's name (default: the file's stem).

    Returns
    -------
    Imported
        Its ``points`` map ``P<i>`` to (body, point).
    """
    def fail(field, message, fix):
        raise ModelError(message, file=source, field=field, fix=fix)

    joints = parse_expression(expression, source=source)
    for i, j in enumerate(joints):
        # R; RP (or P): a pin sliding (and turning) on the line at A of its first link
        if j["type"] != "R" and len(j["links"]) < 2:
            where = f" on link '{j['links'][0]}'" if j["links"] else ""
            fail(f"mechanism joint {i}", f"joint {i} is of type {j['type']}{where} and joins no "
                 "other link: a slider needs its slot link first and the sliding links after it",
                 "List the slot link and the links that slide on it in the joint's L[...]")
    pairs = [tuple(p) for p in inputs] if isinstance(inputs, (list, tuple)) else None
    if not pairs or len(pairs) != 1 or len(pairs[0]) != 2 or not all(
            isinstance(k, int) and not isinstance(k, bool) and 0 <= k < len(joints)
            for k in pairs[0]):
        fail("input", f"the mechanism needs one input pair of joint numbers (0 to "
             f"{len(joints) - 1}), got {inputs!r}: linkdyn imports mechanisms driven by one "
             "crank", "Give --input BASE,DRIVE: the crank's ground joint and the joint it carries")
    base, drive = pairs[0]
    crank = [lk for lk in dict.fromkeys(joints[base]["links"])
             if lk != "ground" and lk in joints[drive]["links"]]
    if "ground" not in joints[base]["links"] or len(crank) != 1 or base == drive \
            or joints[base]["type"] != "R":
        fail("input", f"input pair ({base}, {drive}): joint {base} must join the ground and one "
             f"moving link that also holds joint {drive}", "Give the crank's ground joint first")
    links: dict[str, list[str]] = {}
    for i, j in enumerate(joints):
        for lk in dict.fromkeys(j["links"][1:] if j["type"] != "R" else j["links"]):
            links.setdefault(lk, []).append(f"P{i}")
    (x0, y0), (x1, y1) = joints[base]["position"], joints[drive]["position"]
    data = {
        "name": name or os.path.splitext(os.path.basename(source))[0] or "mechanism",
        "joints": [_joint(i, j) for i, j in enumerate(joints)],
        "links": [{"id": lk, "type": "ground" if lk == "ground" else
                   "driver" if lk == crank[0] else "link", "joints": ids,
                   **({"motor_joint": f"P{base}", "angular_velocity": math.tau,
                       "initial_angle": math.atan2(y1 - y0, x1 - x0)} if lk == crank[0] else {})}
                  for lk, ids in links.items()],
    }
    return from_pylinkage(data, source=source, length_unit=length_unit, tool="Pyslvs")


def _joint(i: int, j: dict) -> dict:
    """Pyslvs's joint ``i`` as a pylinkage joint: ``P<i>``, a ground joint if it joins the
    ground, a slider as pylinkage's prismatic joint on the line through its saved position at
    ``A`` degrees (a P slider's link does not turn: ``"turns": False``), the line its slot
    link's (``"line_link"``) unless that is the ground."""
    if j["type"] != "R":
        a = math.radians(j["angle"])
        return {"id": f"P{i}", "type": "prismatic", "position": j["position"],
                "axis": [math.cos(a), math.sin(a)], "line_point": j["position"],
                **({"turns": False} if j["type"] == "P" else {}),
                **({"line_link": j["links"][0]} if j["links"][0] != "ground" else {})}
    return {"id": f"P{i}", "type": "ground" if "ground" in j["links"] else "revolute",
            "position": j["position"]}
