"""Gear pair (spur gears): two pitch circles that roll on each other without slip.

``connect = ["A.p", "B.q"]``: the gear on body a has its centre at A's point p and the pitch
radius ``radius_a``, the gear on body b its centre at B's point q and ``radius_b``; ``internal
= 1`` for an internal pair (one of them a ring gear, the other inside it; default 0, external).
A gear pair leaves two relative freedoms of the plane's three, so it is always a cut joint with
one closure row: no slip at the pitch point. With ``d = C_b - C_a`` the line of centres,
``alpha = atan2(d)`` its direction and ``s = +1`` external, ``-1`` internal, the residual (m,
integrable) is

    ``radius_a (phi_a - alpha) + s radius_b (phi_b - alpha - phase) = 0``,

whose rate is the row on the relative twist ``x`` of b to a at ``C_b``:
``S x = s r_b x_w - (r_a + s r_b) (d x x_v) / |d|^2`` (exact, for any ``|d|``). On fixed centres
external gears turn opposite, ``w_b = -(r_a / r_b) w_a``, internal ones the same way,
``w_b = (r_a / r_b) w_a``. ``phase`` (angle) turns gear b's teeth relative to gear a's at the
assembly: ``phi_b`` where the residual vanishes.

The multiplier ``lam`` (N) is the tangential tooth force at the pitch point: its moment about
gear a's centre is ``r_a lam``, about gear b's ``s r_b lam`` (at the pitch centre distance).
The teeth push along the line of action, at the ``pressure_angle`` (default 20 deg) to the
common tangent, so the tooth force has the magnitude ``|lam| / cos(pressure_angle)``: besides
the tangential part ``S^T lam``, a radial part ``|lam| tan(pressure_angle)`` that separates
the gears (on b along ``s d / |d|``). The kind's ``wrench`` carries both, so the reaction of
the gear joint (``Fx``, ``Fy``, by a on b) is the whole tooth force, and the joints that hold
the gears' centres (their bearings) carry the separating force, as real bearings do. The
radial part does no work while the tree holds the centre distance (both centres on one body,
or pivoted on the ground, or on a carrier), so the reduced dynamics (``lam``, the efforts) do
not depend on it; a gear whose centre distance is not ``|r_a + s r_b|`` at the assembly is
refused (:meth:`Gear.fit`, exit 3 naming the joint).

``q`` = ``r_a (phi_a - alpha)``, the arc gear a has rolled relative to the line of centres
(m): its rate is the pitch-line speed. ``alpha`` is taken in (-pi, pi]: a line of centres that
turns through the -x direction (a planet carried round its sun) makes the residual jump, and is
not supported.
"""

from __future__ import annotations

import math

import numpy as np

from ..steps import atan2, step
from .base import JointKind, Number

RADIUS_A = Number("radius_a", (), "length", 0.0,
                  doc="pitch radius of the gear on the first body")
RADIUS_B = Number("radius_b", (), "length", 0.0,
                  doc="pitch radius of the gear on the second body")
INTERNAL = Number("internal", (), "", 0.0, design=False,
                  doc="1 for an internal pair (one gear a ring), 0 for an external one")
#: the teeth's pressure angle (a gear's and a rack's)
PRESSURE_ANGLE = Number("pressure_angle", (), "angle", math.radians(20.0),
                        doc="pressure angle of the teeth (the line of action to the tangent)")
PHASE = Number("phase", (), "angle", 0.0,
               doc="turn of the second gear's teeth relative to the first's at the assembly")


@step
def separating(pa, lam, u):
    """The radial part ``|lam| tan(pa)`` of a tooth force of tangential part ``lam`` at the
    pressure angle ``pa`` (rad), along the unit direction ``u``."""
    f = np.abs(lam) * np.sin(pa) / np.cos(pa)
    return (f * u[0], f * u[1])


class Gear(JointKind):
    name = "gear"
    freedoms = 2
    tree = False
    angular = False
    numbers = (RADIUS_A, RADIUS_B, INTERNAL, PRESSURE_ANGLE, PHASE)
    row_units = ("m",)
    reaction = ("Fx", "Fy")
    multipliers = (("tangential force", "N"),)
    effort = None
    dyad = None
    periodic = False   # a whole turn of one body turns the other by the ratio

    # nums = (radius_a, radius_b, internal, pressure_angle, phase);  s = 1 - 2 internal

    @staticmethod
    @step
    def residual(nums, f, phi_a, phi_b):
        # r_a (phi_a - alpha) + s r_b (phi_b - alpha - phase),  alpha = atan2(d)
        ra, rb, s = nums[0], nums[1], 1.0 - 2.0 * nums[2]
        d = f[1]
        alpha = atan2(d[1], d[0])
        return (ra * (phi_a - alpha) + s * rb * (phi_b - alpha - nums[4]), 0.0, 0.0)

    @staticmethod
    @step
    def selected(nums, f, x):
        # S x = s r_b x_w - (r_a + s r_b) (d x x_v) / |d|^2
        ra, rb, s = nums[0], nums[1], 1.0 - 2.0 * nums[2]
        d = f[1]
        k = (ra + s * rb) / (d[0] * d[0] + d[1] * d[1])
        return (s * rb * x[0] - k * (d[0] * x[2] - d[1] * x[1]), 0.0, 0.0)

    @staticmethod
    @step
    def selected_rate(nums, f, fd, x):
        # dS/dt x = -(r_a + s r_b) [(d' x x_v) / |d|^2 - 2 (d . d') (d x x_v) / |d|^4]
        ra, rb, s = nums[0], nums[1], 1.0 - 2.0 * nums[2]
        d, dd = f[1], fd[1]
        n2 = d[0] * d[0] + d[1] * d[1]
        c = d[0] * x[2] - d[1] * x[1]
        cd = dd[0] * x[2] - dd[1] * x[1]
        return (-(ra + s * rb) * (cd / n2 - 2.0 * (d[0] * dd[0] + d[1] * dd[1]) * c / (n2 * n2)),
                0.0, 0.0)

    @staticmethod
    @step
    def wrench(nums, f, lam):
        # S^T lam = [s r_b, (r_a + s r_b) (d_y, -d_x) / |d|^2] lam, plus the radial force
        # s |lam| tan(pressure angle) d / |d| on b (it separates the gears)
        ra, rb, s = nums[0], nums[1], 1.0 - 2.0 * nums[2]
        d = f[1]
        n2 = d[0] * d[0] + d[1] * d[1]
        k = (ra + s * rb) / n2 * lam[0]
        m = s / np.sqrt(n2)
        r = separating(nums[3], lam[0], (m * d[0], m * d[1]))
        return (s * rb * lam[0], k * d[1] + r[0], -k * d[0] + r[1])

    @staticmethod
    @step
    def coordinate(nums, f, a, b, dd, dd2):
        # q = r_a (phi_a - alpha);  alpha' = (d x d') / |d|^2,
        # alpha'' = (d x d'') / |d|^2 - 2 (d . d') (d x d') / |d|^4
        ra, d = nums[0], f[1]
        n2 = d[0] * d[0] + d[1] * d[1]
        c1 = d[0] * dd[1] - d[1] * dd[0]
        c2 = d[0] * dd2[1] - d[1] * dd2[0]
        ap = c1 / n2
        app = c2 / n2 - 2.0 * (d[0] * dd[0] + d[1] * dd[1]) * c1 / (n2 * n2)
        return ra * (a[0] - atan2(d[1], d[0])), ra * (a[1] - ap), ra * (a[2] - app)

    def fit(self, nums, f):
        """How far the assembled pair is from meshing at its pitch circles: ``|d| - |r_a + s
        r_b|`` (m, the batch shape of ``d``), what that distance should be (m) and what it is."""
        ra, rb, internal = nums[0], nums[1], nums[2]
        want = np.abs(ra + (1.0 - 2.0 * internal) * rb)
        return np.hypot(f[1][0], f[1][1]) - want, want, \
            "the centre distance (|radius_a + radius_b|, internal |radius_a - radius_b|)"

    def refuse(self, numbers: dict) -> str | None:
        """Why a gear's numbers are not a gear pair (None: they are)."""
        if not (numbers["radius_a"] > 0 and numbers["radius_b"] > 0):
            return "radius_a and radius_b must be positive (the pitch radii)"
        if numbers["internal"] not in (0.0, 1.0):
            return "internal must be 0 (external gears) or 1 (an internal pair)"
        if not 0 <= numbers["pressure_angle"] < math.pi / 2:
            return "pressure_angle must be from 0 to 90 deg"
        return None


KIND = Gear()
