"""Model files: read TOML or JSON, validate every field, convert to SI, build a :class:`Model`.

The format is documented key by key in ``docs/model-format.md``. Every problem raises
:class:`~linkdyn.errors.ModelError` naming the file, the field (a dotted path such as
``bodies.crank.mass`` or ``drivers[0].motion.q``) and how to fix it; misspelt keys and names get
the closest valid spelling. Checks that need the topology (mobility, loops) live in
:mod:`linkdyn.topology`, not here.
"""

from __future__ import annotations

import difflib
import json
import math
import os
import re
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from . import expr as _expr
from . import motion as _motion
from .errors import ModelError
from .model import GROUND, JOINT_KINDS, REVOLUTE, Body, Driver, Joint, Load, Model

__all__ = ["load_model", "model_from_dict", "LENGTH_UNITS", "ANGLE_UNITS"]

LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "in": 0.0254}  # metres per unit
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}  # radians per unit

SECTIONS = ("mechanism", "units", "bodies", "joints", "drivers", "loads", "assembly", "topology",
            "analysis")
BODY_KEYS = ("name", "points", "mass", "com", "inertia", "inertia_about")
JOINT_KEYS = ("name", "type", "connect", "axis", "angle")
MOTION_KEYS = {"constant_speed": ("kind", "speed", "rpm", "start"),
               "expression": ("kind", "q"), "table": ("kind", "file")}
LOAD_KEYS = {"force": ("kind", "name", "body", "point", "value"),
             "torque": ("kind", "name", "body", "value"),
             "spring": ("kind", "name", "body", "point", "body2", "point2", "stiffness",
                        "free_length"),
             "damper": ("kind", "name", "body", "point", "body2", "point2", "damping")}
_NAME = re.compile(r"[A-Za-z0-9_][A-Za-z0-9_\-]*\Z")


def load_model(path: str | os.PathLike) -> Model:
    """Read a model file (``.toml`` or ``.json``), validate it and return it in SI units.

    Parameters
    ----------
    path : str or os.PathLike
        The model file. Files it refers to (motion tables) are looked up relative to its directory.

    Returns
    -------
    Model

    Raises
    ------
    ModelError
        For any invalid content, naming the file, the field and the fix.
    """
    file = os.fspath(path)
    suffix = Path(file).suffix.lower()
    if suffix not in (".toml", ".json"):
        raise ModelError(f"unknown model file type '{suffix or '(none)'}'", file=file,
                         fix="Name the file *.toml (TOML) or *.json (JSON)")
    try:
        text = Path(file).read_bytes().decode("utf-8-sig")
    except FileNotFoundError:
        raise ModelError("file not found", file=file,
                         fix="Check the path and the current directory") from None
    except (OSError, UnicodeDecodeError) as e:
        raise ModelError(f"cannot read the file ({e})", file=file,
                         fix="Give a readable UTF-8 text file") from None
    data = _parse_toml(text, file) if suffix == ".toml" else _parse_json(text, file)
    return model_from_dict(data, source=file, base_dir=Path(file).parent)


def model_from_dict(data: dict, *, source: str = "", base_dir: str | os.PathLike = ".") -> Model:
    """Validate a parsed model (the structure of a model file) and return it in SI units.

    Parameters
    ----------
    data : dict
        The model, as ``tomllib.load`` or ``json.load`` would return it.
    source : str
        File name used in error messages and stored as ``Model.source``.
    base_dir : str or os.PathLike
        Directory that relative ``file`` paths (motion tables) are resolved against.
    """
    r = _Reader(source, Path(base_dir))
    if not isinstance(data, dict):
        r.fail("", f"expected a table of sections, got {_type_name(data)}",
               "Give the model as a dict such as {'bodies': [...], 'joints': [...]}")
    r.table(data, "", SECTIONS, noun="section", what="sections")
    mech = r.table(data.get("mechanism", {}), "mechanism", ("name", "gravity", "description"))
    name = r.string(mech["name"], "mechanism.name") if "name" in mech else (
        Path(source).stem if source else "mechanism")
    gravity = r.vector(mech.get("gravity", [0.0, 0.0]), "mechanism.gravity", "m/s^2")
    description = r.string(mech.get("description", ""), "mechanism.description", empty=True)
    _units(r, data.get("units", {}))
    bodies = _bodies(r, data.get("bodies"))
    joints = _joints(r, data.get("joints", []), bodies)
    drivers = _drivers(r, data.get("drivers", []), joints)
    loads = _loads(r, data.get("loads", []), bodies)
    phi, q = _assembly(r, data.get("assembly", {}), bodies, joints)
    cut = _topology(r, data.get("topology", {}), joints, drivers)
    duration, cycles, samples, path_point, path_range = _analysis(
        r, data.get("analysis", {}), drivers, bodies, joints)
    return Model(name=name, bodies=tuple(bodies.values()), joints=tuple(joints.values()),
                 drivers=tuple(d for _, d in drivers.values()), loads=tuple(loads), gravity=gravity,
                 assembly_phi=phi, assembly_q=q, cut=cut, duration=duration, cycles=cycles,
                 samples=samples, source=source, description=description,
                 path_point=path_point, path_range=path_range)


# ---------------------------------------------------------------- parsing

def _parse_toml(text: str, file: str) -> dict:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        msg = str(e)
        m = re.search(r"\s*\(at line (\d+), column (\d+)\)", msg)
        if m is None:
            raise ModelError(f"invalid TOML: {msg}", file=file, field="",
                             fix="Check the end of the file (unclosed brackets or quotes)") from None
        line = int(m.group(1))
        src = text.splitlines()[line - 1].strip() if line <= len(text.splitlines()) else ""
        raise ModelError(f"invalid TOML: {msg[:m.start()]} (column {m.group(2)}: {src!r})",
                         file=file, field=f"line {line}",
                         fix="Write key = value with quoted strings, [table] and [[array of tables]] "
                             "headers, and each table declared once") from None


def _parse_json(text: str, file: str) -> dict:
    def no_duplicates(pairs):
        keys = [k for k, _ in pairs]
        dup = next((k for k in keys if keys.count(k) > 1), None)
        if dup is not None:
            raise ModelError(f"key '{dup}' appears twice in one JSON object", file=file,
                             fix="Keep one of the two")
        return dict(pairs)

    try:
        data = json.loads(text, object_pairs_hook=no_duplicates)
    except json.JSONDecodeError as e:
        src = text.splitlines()[e.lineno - 1].strip() if e.lineno <= len(text.splitlines()) else ""
        raise ModelError(f"invalid JSON: {e.msg} (column {e.colno}: {src!r})", file=file,
                         field=f"line {e.lineno}",
                         fix="Check commas, brackets and double quotes near that line") from None
    if not isinstance(data, dict):
        raise ModelError("the top level must be a JSON object", file=file,
                         fix='Write {"bodies": [...], "joints": [...], ...}')
    return data


# ---------------------------------------------------------------- validation helpers

def _did_you_mean(word: Any, choices, what: str) -> str:
    """'Did you mean ...? Valid <what>: ...' for an unknown name."""
    choices = list(choices)
    if not choices:
        return f"There are no {what} to choose from"
    text = ""
    if isinstance(word, str):
        lower = {c.lower(): c for c in choices}
        close = ([lower[word.lower()]] if word.lower() in lower
                 else difflib.get_close_matches(word, choices, n=1, cutoff=0.5))
        text = f"Did you mean '{close[0]}'? " if close else ""
    if len(choices) <= 16:
        text += f"Valid {what}: {', '.join(choices)}"
    return text.strip()


def _type_name(value: Any) -> str:
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, str):
        return f"the string {value!r}"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return f"a list of {_count(len(value))}"
    return f"{value!r}"


@dataclass
class _Reader:
    """Validation context: the file read, the directory it is in and its declared units."""

    file: str
    base_dir: Path
    length: float = 1.0
    angle: float = 1.0
    length_name: str = "m"
    angle_name: str = "rad"

    def fail(self, field: str, message: str, fix: str) -> NoReturn:
        raise ModelError(message, file=self.file, field=field, fix=fix)

    def table(self, value: Any, field: str, keys, required=(), *, noun="key", what="keys",
              note="") -> dict:
        """Check that ``value`` is a table with known keys only and the ``required`` ones."""
        if not isinstance(value, dict):
            self.fail(field, f"expected a table, got {_type_name(value)}",
                      f"Write it as [{field}] or {{ key = value, ... }}")
        for key in value:
            if key not in keys:
                self.fail(field, f"unknown {noun} '{key}'", _did_you_mean(key, keys, what) + (
                    f". {note}" if note else ""))
        for key in required:
            if key not in value:
                self.fail(f"{field}.{key}" if field else key, f"missing required key '{key}'",
                          f"Add {key} = ...")
        return value

    def entries(self, value: Any, field: str) -> list[dict]:
        """An array of tables such as [[bodies]]."""
        fix = f"Write each entry under its own [[{field}]] header"
        if not isinstance(value, list):
            self.fail(field, f"expected an array of tables, got {_type_name(value)}", fix)
        for i, entry in enumerate(value):
            if not isinstance(entry, dict):
                self.fail(f"{field}[{i}]", f"expected a table, got {_type_name(entry)}", fix)
        return value

    def number(self, value: Any, field: str, unit: str = "", *, positive=False,
               nonnegative=False, fix: str = "") -> float:
        u = f" {unit}" if unit else ""
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            hint = " without quotes" if isinstance(value, str) and _is_float(value) else ""
            self.fail(field, f"expected a number{' in' + u if u else ''}, got {_type_name(value)}",
                      f"Write a plain number{hint}, e.g. {_key(field)} = 1.5")
        x = float(value)
        if not math.isfinite(x):
            self.fail(field, f"must be a finite number, got {x}", fix or "Give a finite value")
        if positive and x <= 0:
            self.fail(field, f"must be positive, got {x:g}{u}", fix or f"Give a value > 0{u}")
        if nonnegative and x < 0:
            self.fail(field, f"must not be negative, got {x:g}{u}", fix or f"Give a value >= 0{u}")
        return x

    def vector(self, value: Any, field: str, unit: str = "") -> np.ndarray:
        if not isinstance(value, list) or len(value) != 2:
            got = _count(len(value)) if isinstance(value, list) else _type_name(value)
            u = f" in {unit}" if unit else ""
            self.fail(field, f"expected a vector [x, y] of 2 numbers{u}, got {got}",
                      f"Write e.g. {_key(field)} = [1.0, 0.0]")
        return np.array([self.number(c, f"{field}[{i}]", unit) for i, c in enumerate(value)])

    def string(self, value: Any, field: str, *, empty=False) -> str:
        if not isinstance(value, str) or (not value and not empty):
            self.fail(field, f"expected a non-empty string, got {_type_name(value)}",
                      f'Write it in double quotes, e.g. {_key(field)} = "..."')
        return value

    def name(self, value: Any, field: str) -> str:
        self.string(value, field)
        if not _NAME.match(value):
            self.fail(field, f"invalid name {value!r}",
                      "Use letters, digits, '_' and '-' only (no dots or spaces)")
        return value

    def choice(self, value: Any, field: str, choices, what: str, plural: str = "") -> str:
        if not isinstance(value, str) or value not in choices:
            self.fail(field, f"unknown {what} {value!r}" if isinstance(value, str)
                      else f"expected the name of a {what}, got {_type_name(value)}",
                      _did_you_mean(value, choices, plural or f"{what}s"))
        return value

    def point(self, body: str, points: dict, value: Any, field: str) -> str:
        if not isinstance(value, str) or value not in points:
            self.fail(field, f"body '{body}' has no point {value!r}",
                      _did_you_mean(value, points, f"points of '{body}'"))
        return value

    def expression(self, text: str, field: str, unit: str):
        try:
            return _expr.parse(text, variables=("t",))
        except _expr.ExpressionError as e:
            self.fail(field, str(e).rstrip("."), _expr_fix(unit))


def _expr_fix(unit: str) -> str:
    return f"Write a formula of time t (s) giving {unit}; see docs/model-format.md"


def _count(n: int) -> str:
    return f"{n} value" if n == 1 else f"{n} values"


def _key(field: str) -> str:
    """The last key of a dotted field path, for examples: ``bodies.crank.com`` -> ``com``."""
    return re.sub(r"\[\d+\]$", "", field.rsplit(".", 1)[-1])


def _is_float(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return False


def _entry_field(section: str, i: int, entry: Any) -> str:
    """``bodies.crank`` for an entry with a valid name, else ``bodies[1]`` (0-based)."""
    name = entry.get("name") if isinstance(entry, dict) else None
    return f"{section}.{name}" if isinstance(name, str) and _NAME.match(name) else f"{section}[{i}]"


# ---------------------------------------------------------------- sections

def _units(r: _Reader, units: Any) -> None:
    units = r.table(units, "units", ("length", "angle"),
                    note="Mass is always kg, time s, force N; inertia is kg * length^2")
    if "length" in units:
        r.length_name = r.choice(units["length"], "units.length", LENGTH_UNITS, "length unit")
    if "angle" in units:
        r.angle_name = r.choice(units["angle"], "units.angle", ANGLE_UNITS, "angle unit")
    r.length, r.angle = LENGTH_UNITS[r.length_name], ANGLE_UNITS[r.angle_name]


def _bodies(r: _Reader, entries: Any) -> dict[str, Body]:
    if entries is None:
        r.fail("bodies", "the model has no bodies",
               'Add [[bodies]] tables, one of them with name = "ground"')
    _check_ground(r, r.entries(entries, "bodies"))
    L, Lu = r.length, r.length_name
    bodies: dict[str, Body] = {}
    for i, entry in enumerate(entries):
        f = _entry_field("bodies", i, entry)
        r.table(entry, f, BODY_KEYS, required=("name",))
        name = r.name(entry["name"], f"{f}.name")
        if name in bodies:
            r.fail(f"bodies[{i}].name", f"duplicate body name '{name}'",
                   "Give every body a different name")
        pts = entry.get("points")
        if not isinstance(pts, dict) or not pts:
            r.fail(f"{f}.points", "a body needs at least one named point",
                   "Add e.g. points = { O1 = [0, 0], O2 = [38.1, 0] } in the body's frame")
        points = {r.name(p, f"{f}.points"): r.vector(xy, f"{f}.points.{p}", Lu) * L
                  for p, xy in pts.items()}
        if name == GROUND:
            for key in ("mass", "com", "inertia", "inertia_about"):
                if key in entry:
                    r.fail(f"{f}.{key}", "the ground is fixed and has no mass properties",
                           f"Remove '{key}' from the ground body")
            bodies[name] = Body(name, points)
            continue
        for key in ("mass", "inertia"):
            if key not in entry:
                r.fail(f"{f}.{key}", f"a moving body needs a {key}",
                       "Add mass = ... (kg)" if key == "mass"
                       else f"Add inertia = ... (kg {Lu}^2, about the mass centre)")
        mass = r.number(entry["mass"], f"{f}.mass", "kg", positive=True,
                        fix="Give a positive mass in kg (only the ground is massless)")
        com = entry.get("com", [0.0, 0.0])
        if isinstance(com, str):  # the name of one of the body's points
            com = points[r.point(name, points, com, f"{f}.com")]
        else:
            com = r.vector(com, f"{f}.com", Lu) * L
        inertia = r.number(entry["inertia"], f"{f}.inertia", f"kg {Lu}^2", positive=True,
                           fix=f"Give a positive moment of inertia in kg {Lu}^2")
        if "inertia_about" in entry:
            about = r.point(name, points, entry["inertia_about"], f"{f}.inertia_about")
            d2 = float(np.sum((points[about] - com) ** 2)) / L**2  # |P - C|^2 in length unit^2
            if inertia - mass * d2 <= 0:
                r.fail(f"{f}.inertia",
                       f"inertia {inertia:g} kg {Lu}^2 about point '{about}' is not more than "
                       f"m d^2 = {mass * d2:g} kg {Lu}^2 (mass centre {math.sqrt(d2):g} {Lu} away), "
                       f"so the inertia about the mass centre would be {inertia - mass * d2:g}",
                       "Check inertia, inertia_about, com and mass: by the parallel-axis theorem "
                       "the inertia about a point exceeds the centroidal one by m d^2")
            inertia -= mass * d2  # parallel-axis theorem: I_C = I_P - m |P - C|^2
        bodies[name] = Body(name, points, mass=mass, com=com, inertia=inertia * L**2)
    return bodies


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
        fix = (f"If body '{massless[0]}' is the fixed frame, rename it \"ground\"; "
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
    for i, entry in enumerate(r.entries(entries, "joints")):
        f = _entry_field("joints", i, entry)
        r.table(entry, f, JOINT_KEYS, required=("name", "type", "connect"))
        name = r.name(entry["name"], f"{f}.name")
        if name in joints:
            r.fail(f"joints[{i}].name", f"duplicate joint name '{name}'",
                   "Give every joint a different name")
        kind = r.choice(entry["type"], f"{f}.type", JOINT_KINDS, "joint type")
        conn = entry["connect"]
        if not isinstance(conn, list) or len(conn) != 2:
            r.fail(f"{f}.connect", f"expected two \"body.point\" strings, got {_type_name(conn)}",
                   'Write connect = ["ground.O1", "crank.O1"]')
        a, pa = _reference(r, conn[0], f"{f}.connect[0]", bodies)
        b, pb = _reference(r, conn[1], f"{f}.connect[1]", bodies)
        if a == b:
            r.fail(f"{f}.connect", f"the joint connects body '{a}' to itself",
                   "A joint joins two different bodies; check the body names in connect")
        if kind == REVOLUTE:
            for key in ("axis", "angle"):
                if key in entry:
                    r.fail(f"{f}.{key}", f"a revolute joint has no {key}",
                           f'Remove {key}, or set type = "prismatic" for a slider')
            joints[name] = Joint(name, kind, a, pa, b, pb)
            continue
        axis = r.vector(entry.get("axis", [1.0, 0.0]), f"{f}.axis")
        if np.hypot(*axis) == 0:
            r.fail(f"{f}.axis", "the sliding axis is zero",
                   f"Give the sliding direction in the frame of body '{a}', e.g. axis = [1, 0]")
        angle = r.number(entry.get("angle", 0.0), f"{f}.angle", r.angle_name) * r.angle
        joints[name] = Joint(name, kind, a, pa, b, pb, axis=axis / np.hypot(*axis), angle=angle)
    return joints


def _drivers(r: _Reader, entries: Any, joints: dict[str, Joint]) -> dict[str, tuple[str, Driver]]:
    """Drivers keyed by joint name, each with the field that declared it."""
    drivers: dict[str, tuple[str, Driver]] = {}
    for i, entry in enumerate(r.entries(entries, "drivers")):
        f = f"drivers[{i}]"
        r.table(entry, f, ("joint", "motion"), required=("joint", "motion"))
        joint = r.choice(entry["joint"], f"{f}.joint", joints, "joint")
        if joint in drivers:
            r.fail(f"{f}.joint", f"joint '{joint}' is already driven by {drivers[joint][0]}",
                   "Give each joint at most one driver; remove one of them")
        revolute = joints[joint].kind == REVOLUTE
        motion, period = _motion_of(r, entry["motion"], f"{f}.motion", revolute)
        description = motion.describe("rad" if revolute else "m")
        drivers[joint] = (f, Driver(joint, motion, description=description, period=period))
    return drivers


def _motion_of(r: _Reader, spec: Any, f: str, revolute: bool):
    """Build the Motion of a driver; q in rad (revolute) or m (prismatic)."""
    kinds = tuple(MOTION_KEYS)
    if not isinstance(spec, dict):
        r.fail(f, f"expected a table, got {_type_name(spec)}",
               'Write e.g. motion = { kind = "constant_speed", rpm = 45.0 }')
    if "kind" not in spec:
        r.fail(f"{f}.kind", "missing required key 'kind'", f"Add kind = one of {', '.join(kinds)}")
    kind = r.choice(spec["kind"], f"{f}.kind", kinds, "motion kind")
    r.table(spec, f, MOTION_KEYS[kind], what=f'keys for kind = "{kind}"')
    scale, unit = (r.angle, r.angle_name) if revolute else (r.length, r.length_name)
    if kind == "constant_speed":
        if ("speed" in spec) == ("rpm" in spec):
            r.fail(f, "give exactly one of speed and rpm",
                   f"Write speed = ... ({unit}/s) or rpm = ... (revolutions per minute)")
        if "rpm" in spec and not revolute:
            r.fail(f"{f}.rpm", "rpm is for a revolute joint; this driver's joint is prismatic",
                   f"Write speed = ... in {unit}/s")
        speed = (r.number(spec["rpm"], f"{f}.rpm", "rev/min") * 2 * math.pi / 60 if "rpm" in spec
                 else r.number(spec["speed"], f"{f}.speed", f"{unit}/s") * scale)
        start = r.number(spec.get("start", 0.0), f"{f}.start", unit) * scale
        period = 2 * math.pi / abs(speed) if revolute and speed != 0 else None
        return _motion.ConstantSpeed(speed, start=start), period
    if kind == "expression":
        if "q" not in spec:
            r.fail(f"{f}.q", "missing required key 'q'",
                   f'Add q = "..." (a formula of t giving {unit})')
        text = r.string(spec["q"], f"{f}.q")
        try:
            motion = _motion.ExpressionMotion(text, scale=scale)
            with np.errstate(all="ignore"):
                q = motion.evaluate(np.zeros(1))
        except _expr.ExpressionError as e:
            r.fail(f"{f}.q", str(e).rstrip("."), _expr_fix(unit))
        if not all(np.all(np.isfinite(v)) for v in q):
            r.fail(f"{f}.q", f"q = {text!r} or its derivatives are not finite at t = 0",
                   "The analysis starts at t = 0; give a formula defined there")
        return motion, None
    if "file" not in spec:
        r.fail(f"{f}.file", "missing required key 'file'", 'Add file = "profile.csv" (columns t, q)')
    path = r.base_dir / r.string(spec["file"], f"{f}.file")
    if not path.is_file():
        r.fail(f"{f}.file", f"table file not found: looked for '{path}'",
               "Give the path of a CSV file relative to the model file's directory")
    try:
        return _motion.TableMotion.from_csv(path, scale=scale), None
    except (OSError, ValueError) as e:
        r.fail(f"{f}.file", f"invalid motion table: {str(e).rstrip('.')}",
               f"Give a CSV file with columns t (s, increasing) and q ({unit})")


@dataclass(frozen=True)
class _TimeFunction:
    """A load value: each component a constant or an expression of t; shape ``t.shape + shape``."""

    components: tuple  # floats or linkdyn.expr.Expr
    vector: bool

    def __call__(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        out = np.stack([np.broadcast_to(c(t) if callable(c) else c, t.shape).astype(float)
                        for c in self.components], axis=-1)
        return out if self.vector else out[..., 0]


def _load_value(r: _Reader, value: Any, f: str, vector: bool) -> _TimeFunction:
    def component(c: Any, field: str, unit: str):
        return r.expression(c, field, unit) if isinstance(c, str) else r.number(c, field, unit)

    if vector:
        if not isinstance(value, list) or len(value) != 2:
            got = _count(len(value)) if isinstance(value, list) else _type_name(value)
            r.fail(f, f"expected [fx, fy] (2 numbers or formulas of t), got {got}",
                   'Write value = [-20.0, 35.0] (N, global frame) or value = ["10*sin(t)", "0"]')
        return _TimeFunction(tuple(component(c, f"{f}[{k}]", "N") for k, c in enumerate(value)),
                             vector=True)
    return _TimeFunction((component(value, f, "N m"),), False)


def _loads(r: _Reader, entries: Any, bodies: dict[str, Body]) -> list[Load]:
    loads: list[Load] = []
    L, Lu = r.length, r.length_name
    for i, entry in enumerate(r.entries(entries, "loads")):
        f = _entry_field("loads", i, entry)
        if "kind" not in entry:
            r.fail(f"{f}.kind", "missing required key 'kind'",
                   f"Add kind = one of {', '.join(LOAD_KEYS)}")
        kind = r.choice(entry["kind"], f"{f}.kind", LOAD_KEYS, "load kind")
        need = tuple(k for k in LOAD_KEYS[kind] if k != "name")
        r.table(entry, f, LOAD_KEYS[kind], required=need, what=f'keys for kind = "{kind}"')
        name = r.name(entry["name"], f"{f}.name") if "name" in entry else ""
        body = r.choice(entry["body"], f"{f}.body", bodies, "body", "bodies")
        point = (r.point(body, bodies[body].points, entry["point"], f"{f}.point")
                 if "point" in entry else None)
        if kind in ("force", "torque"):
            if body == GROUND:
                r.fail(f"{f}.body", f"a {kind} on the ground has no effect",
                       "Apply it to a moving body")
            value = _load_value(r, entry["value"], f"{f}.value", vector=kind == "force")
            loads.append(Load(kind, body, point, value, name=name))
            continue
        body2 = r.choice(entry["body2"], f"{f}.body2", bodies, "body", "bodies")
        point2 = r.point(body2, bodies[body2].points, entry["point2"], f"{f}.point2")
        if body2 == body:
            r.fail(f"{f}.body2", f"both ends of the {kind} are on body '{body}'",
                   f"Attach the {kind} between two different bodies")
        if kind == "spring":
            k = r.number(entry["stiffness"], f"{f}.stiffness", f"N/{Lu}", nonnegative=True)
            l0 = r.number(entry["free_length"], f"{f}.free_length", Lu, nonnegative=True)
            loads.append(Load(kind, body, point, None, body2, point2, stiffness=k / L,
                              free_length=l0 * L, name=name))
        else:
            c = r.number(entry["damping"], f"{f}.damping", f"N s/{Lu}", nonnegative=True)
            loads.append(Load(kind, body, point, None, body2, point2, damping=c / L, name=name))
    return loads


def _assembly(r: _Reader, section: Any, bodies, joints) -> tuple[dict, dict]:
    """Guesses: absolute angles ``phi`` (rad) of moving bodies, joint coordinates ``q`` (rad or m)."""
    section = r.table(section, "assembly", ("phi", "q"))
    moving = [b for b in bodies if b != GROUND]
    phi: dict[str, float] = {}
    for b, v in r.table(section.get("phi", {}), "assembly.phi", moving, noun="moving body",
                        what="moving bodies", note="The ground's angle is always 0").items():
        phi[b] = r.number(v, f"assembly.phi.{b}", r.angle_name) * r.angle
    q: dict[str, float] = {}
    for j, v in r.table(section.get("q", {}), "assembly.q", joints, noun="joint",
                        what="joints").items():
        scale, unit = ((r.angle, r.angle_name) if joints[j].kind == REVOLUTE
                       else (r.length, r.length_name))
        q[j] = r.number(v, f"assembly.q.{j}", unit) * scale
    return phi, q


def _topology(r: _Reader, section: Any, joints, drivers) -> tuple[str, ...] | None:
    section = r.table(section, "topology", ("cut",))
    if "cut" not in section:
        return None
    cut = section["cut"]
    if not isinstance(cut, list):
        r.fail("topology.cut", f"expected a list of joint names, got {_type_name(cut)}",
               'Write cut = ["J4"]')
    for k, j in enumerate(cut):
        r.choice(j, f"topology.cut[{k}]", joints, "joint")
        if j in cut[:k]:
            r.fail(f"topology.cut[{k}]", f"joint '{j}' is listed twice", "List each cut joint once")
        if j in drivers:
            r.fail(f"topology.cut[{k}]", f"joint '{j}' is driven ({drivers[j][0]}) and cannot be cut",
                   "Cut another joint of the same loop, or remove cut to choose automatically")
    return tuple(cut)


def _analysis(r: _Reader, section: Any, drivers, bodies, joints) -> tuple:
    """Optional CLI defaults: ``(duration s, cycles, samples, path_point, path_range)``, each
    None when absent; ``path_range`` is a range of the first driver's coordinate, SI."""
    section = r.table(section, "analysis", ("duration", "cycles", "samples", "path_point",
                                            "path_range"))
    if "duration" in section and "cycles" in section:
        r.fail("analysis", "give either duration or cycles, not both", "Remove one of them")
    duration = (r.number(section["duration"], "analysis.duration", "s", positive=True)
                if "duration" in section else None)
    cycles = (r.number(section["cycles"], "analysis.cycles", positive=True)
              if "cycles" in section else None)
    if cycles is not None and not any(d.period for _, d in drivers.values()):
        r.fail("analysis.cycles", "cycles needs a revolute driver turning at constant speed",
               "Give duration = ... (s) instead")
    samples = None
    if "samples" in section:
        s = section["samples"]
        if (isinstance(s, bool) or not isinstance(s, (int, float)) or not float(s).is_integer()
                or s < 2):
            r.fail("analysis.samples", f"expected a whole number >= 2, got {_type_name(s)}",
                   "Write e.g. samples = 361")
        samples = int(s)
    path_point = None
    if "path_point" in section:
        path_point = r.string(section["path_point"], "analysis.path_point")
        body, _, point = path_point.partition(".")
        if body not in bodies or point not in bodies[body].points:
            r.fail("analysis.path_point", f"'{path_point}' is not a named point of a body",
                   "Write it as BODY.POINT, e.g. path_point = \"coupler.P\"")
    path_range = None
    if "path_range" in section:
        first = next(iter(drivers.values()), None)
        # without drivers the mobility check reports the real problem
        revolute = first is None or joints[first[1].joint].kind == REVOLUTE
        lo, hi = r.vector(section["path_range"], "analysis.path_range",
                          "rad or deg" if revolute else "length unit")
        scale = r.angle if revolute else r.length
        path_range = (float(lo * scale), float(hi * scale))
    return duration, cycles, samples, path_point, path_range
