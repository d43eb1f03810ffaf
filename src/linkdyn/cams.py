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

Oscillating followers (C6): an arm swinging about its pivot ``A = (a, 0)`` (``pivot``), its
swing ``s(theta)`` (rad) the lift. C1-C5 hold with the follower's geometry of the cam joints
(:mod:`linkdyn.joints.cam`, :mod:`linkdyn.joints.flat_cam`), whose steps compute them here
too: a knife edge or roller's centre at ``F(s) = A + L (cos(g0 - s), sin(g0 - s))`` (``arm``
L, ``g0`` putting F on the prime circle at s = 0), the pitch curve's normal ``N = F + J F_t``
(J the quarter turn, ``F_t = dF/dtheta``; ``(e - s', d + s)`` translating) and the pressure
angle from the follower point's direction of motion ``F' = dF/ds`` to N; a flat face at the
``offset`` f from the pivot, its normal at ``alpha(s) = alpha0 - s``, touching the profile at
``Q = H n + H_nu J n`` (H the cam's support function), the profile's radius ``H + H_nu_nu``,
the pressure angle from the face point's velocity ``-J (Q - A)`` (the arm turning clockwise as
s grows) to n.

Contact stress (C7, :func:`hertz_line`): a roller of width L on the profile is a Hertz line
contact of two cylinders, the profile's radius of curvature at the contact and the roller's:
the contact's half-width ``b = sqrt(4 F R / (pi L E*))`` and its peak pressure ``p_max = 2 F /
(pi b L)`` for the contact force F, ``1/R = 1/rho + 1/R_f``, ``1/E* = (1 - nu_1^2)/E_1 + (1 -
nu_2^2)/E_2``.

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
    """A disc cam and its follower, translating or (``pivot`` > 0) oscillating.

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
        ``e``, m: the follower's line from O (knife and roller; 0 for a flat face), or an
        oscillating flat face's distance ``f`` from its pivot towards O.
    speed : float
        ``w``, rad/s, counter-clockwise.
    length_unit, angle_unit : str
        The file's units, for what a person reads.
    table : tuple of two ndarray (n,), optional
        The lift by a table of points instead: cam angles (rad, increasing, within one turn)
        and lifts (m), through which a periodic cubic spline runs.
    formula : PeriodicFormula, optional
        The lift by a formula of the cam angle instead (its derivatives exact).
    pivot : float
        ``a``, m: an oscillating follower's pivot from O (0: a translating follower). Its
        lift is then the arm's swing, rad, and SVAJ its angle's (rad, rad/s, ...).
    arm : float
        ``L``, m: an oscillating knife edge's or roller's centre from the pivot.
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
    pivot: float = 0.0
    arm: float = 0.0

    @property
    def oscillating(self) -> bool:
        """Whether the follower swings about a pivot (its lift an angle)."""
        return self.pivot > 0

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
        The follower's lift (m), velocity (m/s), acceleration (m/s^2) and jerk (m/s^3); an
        oscillating follower's swing (rad) and its rates (rad/s, ...).
    pressure_angle : ndarray
        rad (C3; 0 for a translating flat face).
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


def follower_numbers(cam: Cam) -> tuple:
    """The follower's geometry as the cam joints' steps take it (their ``nums``,
    :data:`linkdyn.joints.WIDTH` floats, the lift's own numbers 0): a knife edge's or roller's
    point F(s) (:func:`linkdyn.joints.cam.follower_point`), or a flat face
    (:func:`linkdyn.joints.flat_cam.face_line`), translating or oscillating."""
    from .joints import cam as jc, rocker_cam, rocker_flat_cam
    rb, rf, e, a = cam.base_radius, cam.roller_radius, cam.offset, cam.pivot
    if cam.follower == "flat" and cam.oscillating:
        x = {"base_radius": rb, "offset": e, "pivot": a}
        head = (a, e, float(rocker_flat_cam.start_angle(x)), jc.OSCILLATING)
    elif cam.follower == "flat":
        head = (rb, 0.0, math.pi / 2, jc.TRANSLATING)
    elif cam.oscillating:
        x = {"base_radius": rb, "roller_radius": rf, "pivot": a, "arm": cam.arm}
        head = (a, cam.arm, float(rocker_cam.start_angle(x)), jc.OSCILLATING)
    else:
        head = (e, math.sqrt((rb + rf) ** 2 - e * e), 0.0, jc.TRANSLATING)
    return head[:3] + (0.0,) * 5 + (float(head[3]),)


def profile(cam: Cam, n: int = 721) -> CamProfile:
    """The cam's design quantities at ``n`` cam angles over one turn, both ends included."""
    from .joints import cam as jc, flat_cam as jf
    theta = np.linspace(0.0, 2 * math.pi, int(n))
    s = cam.motion.svaj(theta)
    w = cam.speed
    svaj = (s[0], w * s[1], w * w * s[2], w ** 3 * s[3])
    nums, rf, zero = follower_numbers(cam), cam.roller_radius, 0.0 * theta
    if cam.follower == "flat":
        # C5: the face's normal n at alpha(s), at H from O, touching the profile at Q = H n +
        # H_nu J n; the profile's radius H + H_nu_nu
        al, H, H_nu, H_nunu = jf.support(nums[8], nums, s[:3])[:4]
        nx, ny = np.cos(al) + zero, np.sin(al) + zero
        qx, qy = H * nx - H_nu * ny, H * ny + H_nu * nx
        rho = H + H_nunu
        # Q moving as s grows: along n, or turning clockwise about the pivot, -J (Q - A)
        vx, vy = (qy, cam.pivot - qx) if cam.oscillating else (nx, ny)
        phi = np.arctan2(vx * ny - vy * nx, vx * nx + vy * ny)
        return CamProfile(cam, theta, *svaj, phi, rho, rho, _turn(theta, H * nx, H * ny),
                          _turn(theta, qx, qy), rho <= 0)
    # C1-C4: F and F_t; the pitch curve's normal N = F + J F_t, away from O; C3: the pressure
    # angle from the follower point's direction of motion F' = dF/ds to N
    x, y, xt, yt = jc.pitch_point(nums[8], nums, s[:3])[:4]
    x, y = x + zero, y + zero
    p = jc.follower_point(nums[8], nums, s[0])
    nx, ny = x - yt, y + xt
    phi = np.arctan2(p[2] * ny - p[3] * nx, p[2] * nx + p[3] * ny)
    rho_p = jc.pitch_curve(nums, s[:3])[1]
    # the profile: the pitch curve moved R_f along the normal towards O
    size = np.hypot(nx, ny)
    return CamProfile(cam, theta, *svaj, phi, rho_p, rho_p - rf, _turn(theta, x, y),
                      _turn(theta, x - rf * nx / size, y - rf * ny / size),
                      (rho_p > 0) & (rho_p < rf))


def hertz_line(force, r_cam, r_roller, width, e_cam, nu_cam, e_roller, nu_roller):
    """Hertz line contact of a roller on a cam (two cylinders with parallel axes, C7): the
    contact's half-width ``b`` (m), its peak pressure ``p_max`` (Pa) and the effective radius
    ``R`` (m), each of the shape of ``force``.

    ``1/R = 1/r_cam + 1/r_roller`` (``r_cam`` the profile's radius of curvature at the contact,
    negative where it is concave), ``1/E* = (1 - nu_cam^2)/e_cam + (1 - nu_roller^2)/e_roller``,

        ``b = sqrt(4 F R / (pi L E*))``,  ``p_max = 2 F / (pi b L)``,

    with ``F`` the contact force (N) and ``L`` the ``width`` (m) of the roller in contact.
    Where the force is not positive (the follower would leave the cam) there is no contact: ``b``
    and ``p_max`` are 0."""
    force = np.asarray(force, float)
    with np.errstate(divide="ignore"):
        R = 1.0 / (1.0 / np.asarray(r_cam, float) + 1.0 / np.asarray(r_roller, float))
    e_star = 1.0 / ((1.0 - nu_cam ** 2) / e_cam + (1.0 - nu_roller ** 2) / e_roller)
    f = np.where(force > 0, force, 0.0)
    b = np.sqrt(4.0 * f * R / (math.pi * width * e_star))
    with np.errstate(divide="ignore", invalid="ignore"):
        p = np.where(f > 0, 2.0 * f / (math.pi * b * width), 0.0)
    return b, p, R + 0.0 * force


def joins(cam: Cam) -> tuple[np.ndarray, np.ndarray]:
    """The cam angles (J,) rad of the joins between its segments (the cycle's own at 0) and
    the jumps (4, J) of the follower's lift (m), velocity (m/s), acceleration (m/s^2) and
    jerk (m/s^3) across each, at the cam's speed: the n-th derivative's jump in the cam angle
    times ``w^n``."""
    theta, jump = cam.motion.jumps()
    return theta, jump * cam.speed ** np.arange(4)[:, None]


def columns(p: CamProfile) -> dict[str, np.ndarray]:
    """The profile's table: its header (SI units in it) -> values (n,); an oscillating
    follower's swing and its rates in rad (``s_rad``, ``v_rad_s``, ...)."""
    u = "rad" if p.cam.oscillating else "m"
    return {"theta_rad": p.theta, f"s_{u}": p.s, f"v_{u}_s": p.v, f"a_{u}_s2": p.a,
            f"j_{u}_s3": p.j,
            "pressure_angle_rad": p.pressure_angle, "rho_pitch_m": p.rho_pitch,
            "rho_m": p.rho, "pitch_x_m": p.pitch[0], "pitch_y_m": p.pitch[1],
            "profile_x_m": p.profile[0], "profile_y_m": p.profile[1],
            "undercut": p.undercut.astype(float)}
