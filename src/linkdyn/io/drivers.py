"""``[[drivers]]``: the driven joints and their motion (constant speed, a formula of t or a table
of samples), in rad for a revolute joint and m for a prismatic one."""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import numpy as np

from .. import expr as _expr
from .. import motion as _motion
from .. import joints as jk
from ..model import Driver, Joint
from .reader import _quote, _Reader, _expr_fix, _shorten, _type_name

MOTION_KEYS = {"constant_speed": ("kind", "speed", "rpm", "start"),
               "expression": ("kind", "q"), "table": ("kind", "file"),
               "segments": ("kind", "start", "segments", "repeat")}
SEGMENT_KEYS = ("law", "to", "time")


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
        kind = r.kind(joints[joint].kind)
        if kind.effort is None:
            r.fail(f"{f}.joint", f"joint '{joint}' is a {kind.name} joint, which cannot be driven",
                   "Drive one of the mechanism's revolute or prismatic joints instead")
        revolute = kind.angular
        motion, period = _motion_of(r, entry["motion"], f"{f}.motion", revolute)
        # in the file's unit of the joint's coordinate, as a person typed it
        description = motion.describe(*((r.angle_name, r.angle) if revolute
                                        else (r.length_name, r.length)))
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
        return _motion.ConstantSpeed(speed, start=start, rpm="rpm" in spec), period
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
            r.fail(f"{f}.q", f"q = {_quote(text)} or its derivatives are not finite at t = 0",
                   "The analysis starts at t = 0; give a formula defined there")
        return motion, None
    if kind == "segments":
        return _segments(r, spec, f, scale, unit)
    if "file" not in spec:
        r.fail(f"{f}.file", "missing required key 'file'", 'Add file = "profile.csv" (columns t, q)')
    name = r.string(spec["file"], f"{f}.file")
    if "\0" in name:
        r.fail(f"{f}.file", f"table file name {_quote(name)} contains a NUL character",
               "Give the path of a CSV file relative to the model file's directory")
    path = r.base_dir / name
    if not r.allow_outside and not _inside(path, r.base_dir):
        r.fail(f"{f}.file", f"table file {_quote(name)} is outside the model file's folder",
               "A motion table must lie in the model file's folder or below it (symbolic links "
               "resolved); move it there, or allow tables elsewhere explicitly (Python: "
               "load_model(..., allow_outside=True); command line: --allow-outside-tables)")
    if not os.path.lexists(path):
        r.fail(f"{f}.file", f"table file not found: looked for {_quote(str(path), 120)}",
               "Give the path of a CSV file relative to the model file's directory")
    try:
        table = _motion.TableMotion.from_csv(path, scale=scale, model=r.file,
                                             field=f"{f}.file", origin=name)
    except (OSError, ValueError) as e:
        r.fail(f"{f}.file", f"invalid motion table {_quote(name)}: "
               f"{_shorten(str(e).rstrip('.'), 300)}",
               f"Give a CSV file with columns t (s, increasing) and q ({unit})")
    return table, None


def _segments(r: _Reader, spec: dict, f: str, scale: float, unit: str):
    """A :class:`~linkdyn.motion.SegmentMotion` from ``kind = "segments"``: ``start`` and each
    segment's ``to`` in the joint's unit, ``time`` in s."""
    from .. import laws
    if "segments" not in spec:
        r.fail(f"{f}.segments", "missing required key 'segments'",
               'Add segments = [{ law = "cycloidal", to = ..., time = ... }, { law = "dwell", '
               'time = ... }, ...]')
    start = r.number(spec.get("start", 0.0), f"{f}.start", unit) * scale
    repeat = spec.get("repeat", True)
    if not isinstance(repeat, bool):
        r.fail(f"{f}.repeat", f"expected true or false, got {_type_name(repeat)}",
               "Write repeat = true (periodic) or repeat = false (hold the last value)")
    items = r.entries(spec["segments"], f"{f}.segments")
    if not items:
        r.fail(f"{f}.segments", "no segments given",
               'Give at least one, e.g. { law = "cycloidal", to = 60.0, time = 0.5 }')
    segs, at = [], start
    for k, item in enumerate(items):
        g = f"{f}.segments[{k}]"
        r.table(item, g, SEGMENT_KEYS, required=("law", "time"))
        law = r.choice(item["law"], f"{g}.law", tuple(laws.LAWS), "motion law")
        time = r.number(item["time"], f"{g}.time", "s", positive=True)
        if law == "dwell":
            if "to" in item:
                r.fail(f"{g}.to", "a dwell holds its start: it takes no 'to'",
                       "Remove to, or use a rise law (cycloidal, harmonic, poly345, poly4567)")
            to = at
        else:
            if "to" not in item:
                r.fail(f"{g}.to", "missing required key 'to'",
                       f"Give the coordinate at the segment's end, in {unit}")
            to = r.number(item["to"], f"{g}.to", unit) * scale
        segs.append(_motion.Segment(law, to, time))
        at = to
    if repeat and not math.isclose(at, start, rel_tol=1e-12, abs_tol=1e-15):
        r.fail(f"{f}.segments", f"the segments end at {at / scale:.6g} {unit}, not at the start "
               f"{start / scale:.6g} {unit}: repeated, the joint would jump at each repeat",
               "End the last segment at the start, or set repeat = false")
    motion = _motion.SegmentMotion(start, tuple(segs), repeat)
    return motion, motion.period


def _inside(path: Path, folder: Path) -> bool:
    """Whether ``path`` lies in ``folder`` or below it once symbolic links are resolved."""
    try:
        return path.resolve().is_relative_to(folder.resolve())
    except (OSError, RuntimeError, ValueError):          # a link loop, an invalid name
        return False
