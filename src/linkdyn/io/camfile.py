"""The cam file of ``linkdyn cam`` (``[units]`` and ``[cam]`` with its ``[[cam.segments]]``):
read it into a :class:`linkdyn.cams.Cam` (:func:`read`), and print a design's key numbers in the
file's units (:func:`text`). The formulas are in :mod:`linkdyn.cams`."""

from __future__ import annotations

import math

import numpy as np

from ..cams import FOLLOWERS, Cam, CamProfile, joins
from ..motion import PeriodicFormula, Segment


def _lift_unit(cam) -> tuple[float, str, str]:
    """The follower's motion in the file's units: SI per unit, the unit, and what it is (a
    translating follower's lift, a length; an oscillating one's swing, an angle)."""
    from .units import ANGLE_UNITS, LENGTH_UNITS
    if cam.oscillating:
        return ANGLE_UNITS[cam.angle_unit], cam.angle_unit, "swing"
    return LENGTH_UNITS[cam.length_unit], cam.length_unit, "lift"


def text(p: CamProfile) -> str:
    """The design's key numbers as the command line prints them, in the file's units."""
    from .units import ANGLE_UNITS, LENGTH_UNITS
    cam = p.cam
    L, Lu = LENGTH_UNITS[cam.length_unit], cam.length_unit
    A, Au = ANGLE_UNITS[cam.angle_unit], cam.angle_unit
    Q, Qu, what = _lift_unit(cam)
    rpm = cam.speed * 60 / (2 * math.pi)
    k = int(np.argmax(np.abs(p.pressure_angle)))
    lines = [f"{cam.name}: {'oscillating ' if cam.oscillating else ''}{cam.follower} follower, "
             f"base circle {cam.base_radius / L:.6g} {Lu}"
             + (f", roller {cam.roller_radius / L:.6g} {Lu}" if cam.follower == "roller" else "")
             + (f", pivot {cam.pivot / L:.6g} {Lu}" if cam.oscillating else "")
             + (f", arm {cam.arm / L:.6g} {Lu}" if cam.arm else "")
             + (f", offset {cam.offset / L:.6g} {Lu}" if cam.offset else "")
             + f", at {rpm:.6g} rpm",
             f"  {what} {np.max(p.s) / Q:.6g} {Qu}; peak velocity {np.max(np.abs(p.v)) / Q:.6g} "
             f"{Qu}/s, acceleration {np.max(np.abs(p.a)) / Q:.6g} {Qu}/s^2, jerk "
             f"{np.max(np.abs(p.j)) / Q:.6g} {Qu}/s^3",
             f"  max pressure angle {abs(p.pressure_angle[k]) / A:.4g} {Au} at cam angle "
             f"{p.theta[k] / A:.4g} {Au}"]
    convex = p.rho[p.rho > 0]
    lines.append(f"  smallest radius of curvature of the profile "
                 f"{(np.min(convex) if len(convex) else math.nan) / L:.6g} {Lu}"
                 + (f" (pitch curve {np.min(p.rho_pitch[p.rho_pitch > 0]) / L:.6g} {Lu})"
                    if cam.follower != "flat" else ""))
    if np.any(p.undercut):
        at = p.theta[p.undercut]
        lines.append(f"  UNDERCUT at cam angles {at[0] / A:.4g} .. {at[-1] / A:.4g} {Au}: "
                     + ("the profile's radius falls below the roller's" if cam.follower == "roller"
                        else "the profile has a cusp (R_b + s + s'' <= 0)")
                     + "; enlarge the base circle"
                     + (" or use a smaller roller" if cam.follower == "roller" else ""))
    else:
        lines.append("  no undercutting")
    lines.append(continuity(p))
    return "\n".join(lines)


ORDERS = ("displacement", "velocity", "acceleration", "jerk")


def continuity(p: CamProfile) -> str:
    """The line that says which of the follower's lift, velocity and acceleration are
    continuous at every join of the cam's segments, and where the first that is not jumps
    (a jump counts above 1e-9 of that quantity's peak over the turn)."""
    from .units import ANGLE_UNITS
    cam = p.cam
    L, Lu, _ = _lift_unit(cam)
    A, Au = ANGLE_UNITS[cam.angle_unit], cam.angle_unit
    theta, jump = joins(cam)
    peaks = [np.max(np.abs(x)) for x in (p.s, p.v, p.a, p.j)]
    jumps = [np.abs(jump[n]) > 1e-9 * max(peaks[n], 1e-300) for n in range(4)]

    def at(n):   # the cam angles where derivative n jumps, in order (a table's: how many)
        x = np.sort(theta[jumps[n]]) / A
        if len(x) > 8:
            return f"{len(x)} cam angles from {x[0]:.4g} to {x[-1]:.4g} {Au}"
        return "cam angles " + ", ".join(f"{v:.4g}" for v in x) + f" {Au}"

    first = next((n for n in range(3) if np.any(jumps[n])), None)
    if first is None:
        return ("  displacement, velocity and acceleration continuous at every join"
                + (f" (the jerk jumps at {at(3)})" if np.any(jumps[3]) else ""))
    unit = f"{Lu}" + ("", "/s", "/s^2")[first]
    return (f"  {ORDERS[first].upper()} JUMPS at {at(first)} (by up to "
            f"{np.max(np.abs(jump[first])) / L:.6g} {unit}): "
            + ("infinite jerk there, a shock at speed; next to a dwell use a law that starts "
               "and ends at zero acceleration (cycloidal, poly345, poly4567, modified_sine, "
               "modified_trapezoid)" if first == 2 else "the follower would be struck"))


# --- the cam file: [units] and [cam] with its [[cam.segments]] --------------------------------

CAM_KEYS = ("name", "base_radius", "follower", "roller_radius", "offset", "rpm", "samples",
            "segments", "table", "formula", "pivot", "arm")
SEGMENT_KEYS = ("law", "to", "angle")
TABLE_KEYS = ("angle", "lift")


def read(path) -> tuple[Cam, int]:
    """The cam of the file ``path`` (TOML: ``[units]`` and ``[cam]``) and its sample count.

    Raises
    ------
    ModelError
        One message naming the file, the field and the fix.
    """
    import os
    from pathlib import Path

    from .. import laws
    from . import read_model_data
    from .reader import _Reader
    from .units import _units

    file = os.fspath(path)
    data = read_model_data(file)
    r = _Reader(file, Path(file).parent)
    r.table(data, "", ("units", "cam"), required=("cam",), noun="section", what="sections")
    if "units" in data:
        _units(r, data["units"])
    c = r.table(data["cam"], "cam", CAM_KEYS, required=("base_radius",))
    if sum(k in c for k in ("segments", "table", "formula")) != 1:
        r.fail("cam.segments", "give the lift by segments, by a table or by a formula, one of "
               "them", "Keep [[cam.segments]], cam.table = { angle = [...], lift = [...] } or "
               "cam.formula = \"...\"")
    L, A = r.length, r.angle
    follower = r.choice(c.get("follower", "roller"), "cam.follower", FOLLOWERS, "follower")
    rb = r.number(c["base_radius"], "cam.base_radius", r.length_name, positive=True) * L
    rf = 0.0
    if follower == "roller":
        if "roller_radius" not in c:
            r.fail("cam.roller_radius", "missing required key 'roller_radius'",
                   f"Give the roller's radius in {r.length_name}, or follower = \"knife\"")
        rf = r.number(c["roller_radius"], "cam.roller_radius", r.length_name,
                      positive=True) * L
    elif "roller_radius" in c:
        r.fail("cam.roller_radius", f"a {follower} follower has no roller",
               'Remove roller_radius, or set follower = "roller"')
    e = r.number(c.get("offset", 0.0), "cam.offset", r.length_name) * L
    pivot, arm = swinging(r, c, follower, rb, rf, e)
    if follower == "flat" and e and not pivot:
        r.fail("cam.offset", "a flat face normal to its line does not depend on the offset",
               "Remove offset for a flat-faced follower")
    if abs(e) >= rb + rf and not pivot:
        r.fail("cam.offset", f"the offset {e / L:g} {r.length_name} reaches the prime circle "
               f"({(rb + rf) / L:g} {r.length_name})",
               "Give an offset smaller than the base circle plus the roller")
    # the lift: a length, or an oscillating follower's swing, an angle
    Q, Qn = (A, r.angle_name) if pivot else (L, r.length_name)
    rpm = r.number(c.get("rpm", 60.0), "cam.rpm", "rev/min", positive=True)
    samples = int(r.number(c.get("samples", 721), "cam.samples", positive=True))
    if samples < 3 or samples > 1_000_000:
        r.fail("cam.samples", f"must be from 3 to 1,000,000, got {samples}",
               "Give a number of cam angles, e.g. samples = 721")
    common = dict(name=str(c.get("name", Path(file).stem)), base_radius=rb,
                  follower=follower, roller_radius=rf, offset=e, speed=rpm * 2 * math.pi / 60,
                  length_unit=r.length_name, angle_unit=r.angle_name, pivot=pivot, arm=arm)
    if "table" in c:
        return swing_checked(r, Cam(segments=(), table=lift_table(r, c["table"], Q, Qn),
                                    **common), "cam.table.lift"), samples
    if "formula" in c:
        return swing_checked(r, Cam(segments=(), formula=lift_formula(r, c["formula"], Q, Qn),
                                    **common), "cam.formula"), samples
    items = r.entries(c["segments"], "cam.segments")
    if not items:
        r.fail("cam.segments", "no segments given", 'Add [[cam.segments]] tables')
    segs, lift, total = [], 0.0, 0.0
    for k, item in enumerate(items):
        f = f"cam.segments[{k}]"
        r.table(item, f, SEGMENT_KEYS, required=("law", "angle"))
        law = r.choice(item["law"], f"{f}.law", tuple(laws.LAWS), "motion law")
        span = r.number(item["angle"], f"{f}.angle", r.angle_name, positive=True) * A
        if law == "dwell":
            if "to" in item:
                r.fail(f"{f}.to", "a dwell holds its lift: it takes no 'to'",
                       "Remove to, or use a rise law")
        elif "to" not in item:
            r.fail(f"{f}.to", "missing required key 'to'",
                   f"Give the lift at the segment's end in {Qn}")
        else:
            lift = r.number(item["to"], f"{f}.to", Qn, nonnegative=True) * Q
        segs.append(Segment(law, lift, span))
        total += span
    if not math.isclose(total, 2 * math.pi, rel_tol=1e-9):
        r.fail("cam.segments", f"the segments span {total / A:.6g} {r.angle_name}, not one turn "
               f"({2 * math.pi / A:.6g} {r.angle_name})",
               "Make the segments' angles add up to one turn")
    if lift != 0.0:
        r.fail("cam.segments", f"the lift ends at {lift / Q:g} {Qn}, not 0",
               "End the last rise or return at to = 0")
    return swing_checked(r, Cam(segments=tuple(segs), **common), "cam.segments"), samples


def swinging(r, c, follower: str, rb: float, rf: float, e: float) -> tuple[float, float]:
    """``cam.pivot`` and ``cam.arm`` (m; 0, 0 for a translating follower), checked: the arm
    reaches the prime circle (``|a - L| < R_b + R_f < a + L``, a knife edge or roller), the
    face at the base circle is nearer than the pivot (``0 < R_b + f < a``, a flat face)."""
    L, Ln = r.length, r.length_name
    if "pivot" not in c:
        if "arm" in c:
            r.fail("cam.arm", "a translating follower has no arm",
                   "Remove arm, or give the oscillating follower's pivot")
        return 0.0, 0.0
    a = r.number(c["pivot"], "cam.pivot", Ln, positive=True) * L
    if follower == "flat":
        if "arm" in c:
            r.fail("cam.arm", "a flat face is placed by its offset from the pivot, not an arm",
                   "Remove arm; give offset, the face's distance from the pivot")
        if not 0 < rb + e < a:
            r.fail("cam.pivot", f"the pivot {a / L:g} {Ln} must be further from the cam's "
                   f"centre than the face at the base circle ({(rb + e) / L:g} {Ln}), and "
                   "that above 0", "Move the pivot further out, or change offset")
        return a, 0.0
    if "offset" in c:
        r.fail("cam.offset", "an oscillating follower's point is placed by pivot and arm",
               "Remove offset")
    if "arm" not in c:
        r.fail("cam.arm", "missing required key 'arm'",
               f"Give the follower point's distance from the pivot in {Ln}")
    arm = r.number(c["arm"], "cam.arm", Ln, positive=True) * L
    if not abs(a - arm) < rb + rf < a + arm:
        r.fail("cam.arm", f"the arm cannot reach the prime circle ({(rb + rf) / L:g} {Ln}) "
               f"from the pivot: |pivot - arm| < base_radius + roller_radius < pivot + arm",
               "Change arm or pivot")
    return a, arm


def swing_checked(r, cam: Cam, field: str) -> Cam:
    """``cam``, an oscillating follower's swing checked short of the line of centres (its
    arm's or face's angle from it at the bottom of the swing, :func:`linkdyn.cams.
    follower_numbers`' third number)."""
    from ..cams import follower_numbers
    if not cam.oscillating:
        return cam
    start = follower_numbers(cam)[2]
    top = float(np.max(cam.motion.svaj(np.linspace(0.0, 2 * math.pi, 3601))[0]))
    if not top < start:
        r.fail(field, f"the follower would swing {top / r.angle:.4g} {r.angle_name}, past the "
               f"line of centres ({start / r.angle:.4g} {r.angle_name} away at the bottom)",
               "Shorten the swing, or move the pivot further from the cam")
    return cam


def lift_table(r, value, scale: float, unit: str) -> tuple[np.ndarray, np.ndarray]:
    """``cam.table``'s cam angles (rad) and lifts (m, or rad: ``scale`` SI per ``unit``),
    checked: at least 4 points, the angles increasing within one turn from the first (the
    spline closes the turn)."""
    t = r.table(value, "cam.table", TABLE_KEYS, required=TABLE_KEYS)
    cols = {}
    for key, name in (("angle", r.angle_name), ("lift", unit)):
        if not isinstance(t[key], list):
            r.fail(f"cam.table.{key}", f"expected an array of numbers in {name}",
                   f"Write {key} = [..., ...]")
        cols[key] = np.array([r.number(x, f"cam.table.{key}[{k}]", name)
                              for k, x in enumerate(t[key])])
    angle, lift = cols["angle"] * r.angle, cols["lift"] * scale
    if len(angle) != len(lift) or len(angle) < 4:
        r.fail("cam.table", f"angle and lift need the same number of points, at least 4 "
               f"(got {len(angle)} and {len(lift)})", "Give one lift for each cam angle")
    if np.any(np.diff(angle) <= 0) or angle[-1] - angle[0] >= 2 * math.pi:
        r.fail("cam.table.angle", "the cam angles must increase within one turn",
               "List each angle once, in order, the last less than a turn after the first "
               "(the spline joins it to the first)")
    return angle, lift


def lift_formula(r, value, scale: float, name: str) -> PeriodicFormula:
    """``cam.formula``, the lift (``name``, ``scale`` SI per unit: the file's length unit, or
    its angle unit for a swing) as a formula of the cam angle ``theta`` (its angle unit), read
    by :func:`linkdyn.expr.parse` (never executed) and checked: finite and not below 0 over
    the turn (the base circle is where it is 0)."""
    from ..expr import ExpressionError
    field = "cam.formula"
    unit = f"theta in {r.angle_name}, the lift in {name}"
    if not isinstance(value, str):
        r.fail(field, f"expected a formula as text ({unit})",
               'Write formula = "20*(1 - cos(pi*theta/180))/2", say')
    try:
        f = PeriodicFormula(value, scale, r.angle)
    except ExpressionError as exc:
        r.fail(field, str(exc).rstrip("."), f"Write the lift as a formula of theta ({unit})")
    theta = np.linspace(0.0, 2 * math.pi, 3601)
    s = np.stack(f.svaj(theta))
    bad = ~np.all(np.isfinite(s), axis=0)
    if np.any(bad):
        r.fail(field, f"the lift or its derivatives are not finite at cam angle "
               f"{theta[bad][0] / r.angle:.6g} {r.angle_name}",
               "Keep every function inside its domain over the whole turn")
    low = int(np.argmin(s[0]))
    if s[0, low] < -1e-9 * max(np.max(np.abs(s[0])), 1e-300):
        r.fail(field, f"the lift falls below 0 ({s[0, low] / scale:.6g} {name} "
               f"at cam angle {theta[low] / r.angle:.6g} {r.angle_name})",
               "Measure the lift from its lowest point (the base circle is where it is 0)")
    return f
