"""Rack and pinion: a pinion's pitch circle rolls without slip on a rack's pitch line.

``connect = ["A.p", "B.q"]``: the rack on body a, its pitch line through A's point p along
``axis`` (a's frame, fixed in a); the pinion on body b, its centre at B's point q and the pitch
radius ``radius``, on the left of the axis (the side ``n = perp(e)``, e the axis turned a
quarter turn counter-clockwise), at the distance ``radius`` from the pitch line. Two relative
freedoms leave one closure row, so it is always a cut joint. With ``d = C_b - P_a`` the
residual (m) is

    ``d . e + radius (phi_b - phi_a) - offset = 0``,

the pinion's travel along the rack equal to the arc it has rolled back (``offset``, a length,
places the pinion's teeth on the rack's at the assembly). Its rate is the row on the relative
twist ``x`` of b to a at ``C_b``: ``S x = x_v . e + radius x_w`` (exact: ``d . e'`` cancels
the transport of ``x_v``). On a fixed rack a pinion moving along ``+e`` turns clockwise,
``w_b = -v / radius``.

The multiplier ``lam`` (N) is the tangential tooth force on the pinion at the pitch point,
along ``e`` (its moment about the pinion's centre ``radius lam``). The tooth force lies on the
line of action, at the ``pressure_angle`` (default 20 deg) to the pitch line: magnitude
``|lam| / cos(pressure_angle)``, its radial part ``|lam| tan(pressure_angle)`` pushing the
pinion away from the rack (along ``n``). The kind's ``wrench`` carries both (the reaction
``Fx``, ``Fy`` by the rack on the pinion is the whole tooth force; the bearings carry the
separating force). The radial part does no work while the tree holds the pinion's distance from
the pitch line, so the reduced dynamics do not depend on it; a pinion whose centre is not at
``radius`` from the pitch line at the assembly is refused (:meth:`Rack.fit`, exit 3).

``q`` = ``d . e``, the pinion centre's travel along the rack from ``p`` (m).
"""

from __future__ import annotations

import math

from ..planar import dot, normal
from ..steps import step
from .base import AXIS, JointKind, Number, line_motion
from .gear import PRESSURE_ANGLE, separating

RADIUS = Number("radius", (), "length", 0.0, doc="pitch radius of the pinion")
OFFSET = Number("offset", (), "length", 0.0,
                doc="the pinion's travel along the rack where its turn relative to the rack is 0")


class Rack(JointKind):
    name = "rack"
    freedoms = 2
    tree = False
    angular = False
    numbers = (AXIS, RADIUS, OFFSET, PRESSURE_ANGLE)
    row_units = ("m",)
    reaction = ("Fx", "Fy")
    multipliers = (("tangential force", "N"),)
    effort = None
    dyad = None
    periodic = False   # a whole turn of one body turns the other by the ratio

    # nums = (radius, offset, pressure_angle)

    @staticmethod
    @step
    def residual(nums, f, phi_a, phi_b):
        # d . e + radius (phi_b - phi_a) - offset
        return (dot(f[1], f[0]) + nums[0] * (phi_b - phi_a) - nums[1], 0.0, 0.0)

    @staticmethod
    @step
    def selected(nums, f, x):
        # S x = x_v . e + radius x_w
        return (dot((x[1], x[2]), f[0]) + nums[0] * x[0], 0.0, 0.0)

    @staticmethod
    @step
    def selected_rate(nums, f, fd, x):
        # dS/dt x = x_v . e',  e' = w_a n (the rack turns with its body)
        return (fd[0] * dot((x[1], x[2]), normal(f[0])), 0.0, 0.0)

    @staticmethod
    @step
    def wrench(nums, f, lam):
        # S^T lam = [radius lam, lam e], plus the radial force |lam| tan(pressure angle) n
        e = f[0]
        r = separating(nums[2], lam[0], normal(e))
        return (nums[0] * lam[0], lam[0] * e[0] + r[0], lam[0] * e[1] + r[1])

    @staticmethod
    @step
    def coordinate(nums, f, a, b, dd, dd2):
        # q = d . e along the rack turning with the first body
        return line_motion(f[0], a[1], a[2], f[1], dd, dd2)

    def fit(self, nums, f):
        """How far the assembled pinion is from meshing: its centre's distance from the pitch
        line, ``d . n - radius`` (m), what it should be (m) and what it is."""
        n = (-f[0][1], f[0][0])
        return f[1][0] * n[0] + f[1][1] * n[1] - nums[0], nums[0], \
            "the pinion centre's distance from the pitch line (radius, on the left of the axis)"

    def refuse(self, numbers: dict) -> str | None:
        """Why a rack's numbers are not a rack and pinion (None: they are)."""
        if not numbers["radius"] > 0:
            return "radius must be positive (the pinion's pitch radius)"
        if not 0 <= numbers["pressure_angle"] < math.pi / 2:
            return "pressure_angle must be from 0 to 90 deg"
        return None


KIND = Rack()
