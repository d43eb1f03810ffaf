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

Everything is SI (m, rad, s); :func:`linkdyn.io.camfile.text` prints in the file's units, and
:func:`linkdyn.io.camfile.read` reads a cam file (this module imports no reader: the cam joint,
:mod:`linkdyn.joints.cam`, checks its design by :func:`profile`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .motion import PeriodicFormula, PeriodicTable, Segment, SegmentMotion

FOLLOWERS = ("knife", "roller", "flat")


@dataclass(frozen=True)
class Cam:
    """A disc cam and its translating follower.

    Attributes
    ----------
    name : str
    segments : tuple[Segment, ...]
        The lift over the cam angle: each segment's ``to`` (m) and ``time`` its span of cam
        angle (rad); the spans add up to one turn and the lift returns to 0 (empty with a
        ``table``).
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
    table : tuple of two ndarray (n,), optional
        The lift by a table of points instead: cam angles (rad, increasing, within one turn)
        and lifts (m), through which a periodic cubic spline runs.
    formula : PeriodicFormula, optional
        The lift by a formula of the cam angle instead (its derivatives exact).
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
    table: tuple | None = None
    formula: PeriodicFormula | None = None

    @property
    def motion(self) -> SegmentMotion | PeriodicTable | PeriodicFormula:
        """The lift as a function of the cam angle: by its segments (their ``time`` is their
        angle), or, given a ``table`` ``(angles (n,) rad, lifts (n,) m)``, the periodic cubic
        spline through its points, or its ``formula``."""
        if self.formula is not None:
            return self.formula
        if self.table is not None:
            return PeriodicTable(self.table[0], self.table[1], 2 * math.pi)
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


def joins(cam: Cam) -> tuple[np.ndarray, np.ndarray]:
    """The cam angles (J,) rad of the joins between its segments (the cycle's own at 0) and
    the jumps (4, J) of the follower's lift (m), velocity (m/s), acceleration (m/s^2) and
    jerk (m/s^3) across each, at the cam's speed: the n-th derivative's jump in the cam angle
    times ``w^n``."""
    theta, jump = cam.motion.jumps()
    return theta, jump * cam.speed ** np.arange(4)[:, None]


def columns(p: CamProfile) -> dict[str, np.ndarray]:
    """The profile's table: its header (SI units in it) -> values (n,)."""
    return {"theta_rad": p.theta, "s_m": p.s, "v_m_s": p.v, "a_m_s2": p.a, "j_m_s3": p.j,
            "pressure_angle_rad": p.pressure_angle, "rho_pitch_m": p.rho_pitch,
            "rho_m": p.rho, "pitch_x_m": p.pitch[0], "pitch_y_m": p.pitch[1],
            "profile_x_m": p.profile[0], "profile_y_m": p.profile[1],
            "undercut": p.undercut.astype(float)}
