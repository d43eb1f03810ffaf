"""Distance constraint: two points of two bodies held at a fixed distance, as by a massless rod
pinned at both ends.

``connect = ["A.p", "B.q"]`` and ``length`` (> 0): the points p of A and q of B stay ``length``
apart, free to turn about each other and about either point. Three relative freedoms less one
leave two, so it is always a cut joint with one closure row. With ``d = r_q - r_p`` and
``u = d / |d|`` the residual (m) is ``|d| - length``; its rate is the row on the relative
twist ``x`` of b to a at q: ``S x = u . x_v`` (exact: the transport ``w_a k x d`` of the
relative velocity is normal to ``u``), and ``(dS/dt) x = u' . x_v`` with
``u' = (d' - u (u . d')) / |d|``.

The multiplier ``lam`` (N) is the rod's force on B along ``u``, positive pushing q away from p
(compression), its reaction ``[Fx, Fy] = lam u`` by A on B through q and minus that on A through
p: no moment about either point, as a two-force member. ``q`` = ``|d|``, the points' distance
(m).
"""

from __future__ import annotations

import numpy as np

from ..planar import dot
from ..steps import step
from .base import JointKind, Number

LENGTH = Number("length", (), "length", 0.0, doc="distance held between the two points")


class Distance(JointKind):
    name = "distance"
    freedoms = 2
    tree = False
    angular = False
    numbers = (LENGTH,)
    row_units = ("m",)
    reaction = ("Fx", "Fy")
    multipliers = (("rod force", "N"),)
    effort = None
    dyad = None

    # nums = (length,)

    def refuse(self, numbers: dict) -> str | None:
        if not numbers["length"] > 0:
            return "length: a distance constraint needs a length > 0"
        return None

    @staticmethod
    @step
    def residual(nums, f, phi_a, phi_b):
        # |d| - length
        d = f[1]
        return (np.sqrt(dot(d, d)) - nums[0], 0.0, 0.0)

    @staticmethod
    @step
    def selected(nums, f, x):
        # S x = u . x_v
        d = f[1]
        r = np.sqrt(dot(d, d))
        return ((d[0] * x[1] + d[1] * x[2]) / r, 0.0, 0.0)

    @staticmethod
    @step
    def selected_rate(nums, f, fd, x):
        # (dS/dt) x = u' . x_v,  u' = (d' - u (u . d')) / |d|
        d, dd = f[1], fd[1]
        r = np.sqrt(dot(d, d))
        ud = dot(d, dd) / r
        return (((dd[0] - d[0] / r * ud) * x[1] + (dd[1] - d[1] / r * ud) * x[2]) / r, 0.0, 0.0)

    @staticmethod
    @step
    def wrench(nums, f, lam):
        # S^T lam = [0, lam u]: the rod's force through q, no moment about it
        d = f[1]
        r = np.sqrt(dot(d, d))
        return (0.0, lam[0] * d[0] / r, lam[0] * d[1] / r)

    @staticmethod
    @step
    def coordinate(nums, f, a, b, dd, dd2):
        # q = |d|, qd = u . d', qdd = u . d'' + (|d'|^2 - (u . d')^2) / |d|
        d = f[1]
        r = np.sqrt(dot(d, d))
        qd = dot(d, dd) / r
        return r, qd, dot(d, dd2) / r + (dot(dd, dd) - qd * qd) / r


KIND = Distance()
