"""Disc cams designed from a follower motion: the profile, SVAJ, pressure angle, curvature.

A disc cam turns about its centre O at the constant speed ``w`` (counter-clockwise); a
translating follower moves along a line parallel to y at the offset ``e`` from O. Over the cam
angle ``theta`` the follower's lift is ``s(theta)``, segment after segment by the motion laws of
:mod:`linkdyn.laws` (a dwell; a rise or return by a law), one full turn in all. With
``s' = ds/dtheta`` (m/rad) and so on, the follower's velocity, acceleration and jerk are
``w s'``, ``w^2 s''``, ``w^3 s'''`` (SVAJ).

Knife edge and roller (C1-C4; the knife edge is a roller of radius 0). The roller's centre
moves on the *pitch curve*; in the fixed frame it is at ``F = (e, d + s)``, with the prime
circle ``R_p = R_b + R_f`` (base circle plus roller) and ``d = sqrt(R_p^2 - e^2)``.

- C1, the pitch curve in the cam's frame: ``P(theta) = R(-theta) F``.
- C2, its derivatives: ``P' = R(-theta) (d + s, s' - e)``,
  ``P'' = R(-theta) (2 s' - e, s'' - d - s)``.
- C3, the pressure angle (between the follower's line and the common normal):
  ``tan(phi) = (s' - e) / (d + s)``.
- C4, radius of curvature of the pitch curve ``rho_p = |P'|^3 / (P'' x P')`` (positive convex:
  the cam's frame sees the curve run clockwise); the profile is the
  pitch curve moved ``R_f`` along the normal towards O, its radius ``rho_p - R_f``. Where
  ``0 < rho_p < R_f`` the roller cannot follow a convex profile: the cam is undercut.

Flat-faced follower (C5), its face normal to its line: contact at the distance ``s'`` from the
line, ``(s', R_b + s)`` in the fixed frame; the profile's radius ``rho = R_b + s + s''``, which
must stay positive (a cusp otherwise); the pressure angle is 0.

Everything is SI (m, rad, s); :func:`text` prints in the file's units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .motion import Segment, SegmentMotion

FOLLOWERS = ("knife", "roller", "flat")


@dataclass(frozen=True)
class Cam:
    """A disc cam and its translating follower.

    Attributes
    ----------
    name : str
    segments : tuple[Segment, ...]
        The lift over the cam angle: each segment's ``to`` (m) and ``time`` its span of cam
        angle (rad); the spans add up to one turn and the lift returns to 0.
    base_radius : float
        ``R_b``, m: the smallest distance from O to the profile.
    follower : str
        ``'knife'``, ``'roller'`` or ``'flat'``.
    roller_radius : float
        ``R_f``, m (a roller's; 0 otherwise).
    offset : float
        ``e``, m: the follower's line from O (knife and roller; 0 for a flat face).
    speed : float
        ``w``, rad/s, counter-clockwise.
    length_unit, angle_unit : str
        The file's units, for what a person reads.
    """

    name: str
    segments: tuple
    base_radius: float
    follower: str = "roller"
    roller_radius: float = 0.0
    offset: float = 0.0
    speed: float = 2 * math.pi
    length_unit: str = "m"
    angle_unit: str = "rad"

    @property
    def motion(self) -> SegmentMotion:
        """The lift as a function of the cam angle (the segments' ``time`` is their angle)."""
        return SegmentMotion(0.0, self.segments, repeat=True)


@dataclass(frozen=True)
class CamProfile:
    """A cam's design quantities at the cam angles ``theta`` (n,), rad, each (n,) (points (2, n)).

    Attributes
    ----------
    theta : ndarray
    s, v, a, j : ndarray
        The follower's lift (m), velocity (m/s), acceleration (m/s^2) and jerk (m/s^3).
    pressure_angle : ndarray
        rad (C3; 0 for a flat face).
    rho_pitch : ndarray
        Radius of curvature of the pitch curve, m (C4; the profile's for a flat face).
    rho : ndarray
        Radius of curvature of the cam's profile, m (positive convex).
    pitch : ndarray (2, n)
        The roller centre's (or knife edge's) path in the cam's frame, m.
    profile : ndarray (2, n)
        The cam's surface in the cam's frame, m (the points to cut it by).
    undercut : ndarray bool
        Where the follower cannot follow the profile: ``0 < rho_pitch < R_f`` (roller), or
        ``rho <= 0`` (a flat face's cusp).
    """

    cam: Cam
    theta: np.ndarray
    s: np.ndarray
    v: np.ndarray
    a: np.ndarray
    j: np.ndarray
    pressure_angle: np.ndarray
    rho_pitch: np.ndarray
    rho: np.ndarray
    pitch: np.ndarray
    profile: np.ndarray
    undercut: np.ndarray

    def __repr__(self) -> str:
        return (f"<CamProfile of {self.cam.name!r}: {len(self.theta)} angles, max pressure "
                f"angle {math.degrees(np.max(np.abs(self.pressure_angle))):.4g} deg>")


def _turn(theta, x, y):
    """``R(-theta) (x, y)``: a vector of the fixed frame in the cam's frame."""
    c, sn = np.cos(theta), np.sin(theta)
    return np.stack((c * x + sn * y, -sn * x + c * y))


def profile(cam: Cam, n: int = 721) -> CamProfile:
    """The cam's design quantities at ``n`` cam angles over one turn, both ends included."""
    theta = np.linspace(0.0, 2 * math.pi, int(n))
    s, s1, s2, s3 = cam.motion.svaj(theta)
    w = cam.speed
    rb, rf, e = cam.base_radius, cam.roller_radius, cam.offset
    if cam.follower == "flat":
        # C5: contact (s', R_b + s) in the fixed frame; rho = R_b + s + s''
        y = rb + s
        pitch = _turn(theta, np.full_like(s, 0.0), y)
        prof = _turn(theta, s1, y)
        rho = rb + s + s2
        return CamProfile(cam, theta, s, w * s1, w * w * s2, w ** 3 * s3, np.zeros_like(s),
                          rho, rho, pitch, prof, rho <= 0)
    rp = rb + rf
    d = math.sqrt(rp * rp - e * e)
    y = d + s
    # C1-C2: the pitch curve and its derivatives (in the fixed frame's axes, rotated)
    x1, y1 = y, s1 - e
    x2, y2 = 2 * s1 - e, s2 - y
    # C3: tan(phi) = (s' - e) / (d + s)
    phi = np.arctan2(s1 - e, y)
    # C4: rho_p = |P'|^3 / (P'' x P') (the cam turning counter-clockwise, its frame sees the
    # pitch curve run clockwise: positive where it is convex); the profile rho_p - R_f
    speed = np.hypot(x1, y1)
    rho_p = speed ** 3 / (y1 * x2 - x1 * y2)
    # outward normal of the pitch curve in the fixed frame: (-(s' - e), d + s) / |P'|
    nx, ny = -y1 / speed, x1 / speed
    pitch = _turn(theta, np.full_like(s, e), y)
    prof = _turn(theta, e - rf * nx, y - rf * ny)
    return CamProfile(cam, theta, s, w * s1, w * w * s2, w ** 3 * s3, phi, rho_p, rho_p - rf,
                      pitch, prof, (rho_p > 0) & (rho_p < rf))


def columns(p: CamProfile) -> dict[str, np.ndarray]:
    """The profile's table: its header (SI units in it) -> values (n,)."""
    return {"theta_rad": p.theta, "s_m": p.s, "v_m_s": p.v, "a_m_s2": p.a, "j_m_s3": p.j,
            "pressure_angle_rad": p.pressure_angle, "rho_pitch_m": p.rho_pitch,
            "rho_m": p.rho, "pitch_x_m": p.pitch[0], "pitch_y_m": p.pitch[1],
            "profile_x_m": p.profile[0], "profile_y_m": p.profile[1],
            "undercut": p.undercut.astype(float)}


def text(p: CamProfile) -> str:
    """The design's key numbers as the command line prints them, in the file's units."""
    from .io.units import ANGLE_UNITS, LENGTH_UNITS
    cam = p.cam
    L, Lu = LENGTH_UNITS[cam.length_unit], cam.length_unit
    A, Au = ANGLE_UNITS[cam.angle_unit], cam.angle_unit
    rpm = cam.speed * 60 / (2 * math.pi)
    k = int(np.argmax(np.abs(p.pressure_angle)))
    lines = [f"{cam.name}: {cam.follower} follower, base circle {cam.base_radius / L:.6g} {Lu}"
             + (f", roller {cam.roller_radius / L:.6g} {Lu}" if cam.follower == "roller" else "")
             + (f", offset {cam.offset / L:.6g} {Lu}" if cam.offset else "")
             + f", at {rpm:.6g} rpm",
             f"  lift {np.max(p.s) / L:.6g} {Lu}; peak velocity {np.max(np.abs(p.v)) / L:.6g} "
             f"{Lu}/s, acceleration {np.max(np.abs(p.a)) / L:.6g} {Lu}/s^2, jerk "
             f"{np.max(np.abs(p.j)) / L:.6g} {Lu}/s^3",
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
    return "\n".join(lines)


# --- the cam file: [units] and [cam] with its [[cam.segments]] --------------------------------

CAM_KEYS = ("name", "base_radius", "follower", "roller_radius", "offset", "rpm", "samples",
            "segments")
SEGMENT_KEYS = ("law", "to", "angle")


def read(path) -> tuple[Cam, int]:
    """The cam of the file ``path`` (TOML: ``[units]`` and ``[cam]``) and its sample count.

    Raises
    ------
    ModelError
        One message naming the file, the field and the fix.
    """
    import os
    from pathlib import Path

    from . import laws
    from .io import read_model_data
    from .io.reader import _Reader
    from .io.units import _units

    file = os.fspath(path)
    data = read_model_data(file)
    r = _Reader(file, Path(file).parent)
    r.table(data, "", ("units", "cam"), required=("cam",), noun="section", what="sections")
    if "units" in data:
        _units(r, data["units"])
    c = r.table(data["cam"], "cam", CAM_KEYS, required=("base_radius", "segments"))
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
    if follower == "flat" and e:
        r.fail("cam.offset", "a flat face normal to its line does not depend on the offset",
               "Remove offset for a flat-faced follower")
    if abs(e) >= rb + rf:
        r.fail("cam.offset", f"the offset {e / L:g} {r.length_name} reaches the prime circle "
               f"({(rb + rf) / L:g} {r.length_name})",
               "Give an offset smaller than the base circle plus the roller")
    rpm = r.number(c.get("rpm", 60.0), "cam.rpm", "rev/min", positive=True)
    samples = int(r.number(c.get("samples", 721), "cam.samples", positive=True))
    if samples < 3 or samples > 1_000_000:
        r.fail("cam.samples", f"must be from 3 to 1,000,000, got {samples}",
               "Give a number of cam angles, e.g. samples = 721")
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
                   f"Give the lift at the segment's end in {r.length_name}")
        else:
            lift = r.number(item["to"], f"{f}.to", r.length_name, nonnegative=True) * L
        segs.append(Segment(law, lift, span))
        total += span
    if not math.isclose(total, 2 * math.pi, rel_tol=1e-9):
        r.fail("cam.segments", f"the segments span {total / A:.6g} {r.angle_name}, not one turn "
               f"({2 * math.pi / A:.6g} {r.angle_name})",
               "Make the segments' angles add up to one turn")
    if lift != 0.0:
        r.fail("cam.segments", f"the lift ends at {lift / L:g} {r.length_name}, not 0",
               "End the last rise or return at to = 0")
    cam = Cam(name=str(c.get("name", Path(file).stem)), segments=tuple(segs), base_radius=rb,
              follower=follower, roller_radius=rf, offset=e, speed=rpm * 2 * math.pi / 60,
              length_unit=r.length_name, angle_unit=r.angle_name)
    return cam, samples
