"""Cylindrical joint: B slides along and turns about the axis e fixed in A; ``q.s`` the
travel (as prismatic, m), ``q.r`` the rotation (as revolute, rad). As a tree joint: the
travel first, then the rotation about e through B's point."""

from __future__ import annotations

import numpy as np

from .. import algebra as sa
from . import base


class Cylindrical(base.SpatialKind):
    name = "cylindrical"
    freedoms = 2
    coordinates_named = ((".s", False), (".r", True))
    cut_rank = 2
    row_labels = ("F1", "F2", "M1", "M2")

    def relative(self, g, q):
        return sa.rotation(g.e, q[..., 1]) @ g.R0, q[..., :1] * g.e

    def screws(self, g, RA, RB, c, q):
        e = sa.matvec(RA, g.e)
        return np.stack([sa.free_vector(e, False), sa.line_screw(e, c)], -2)

    def coordinates(self, g, R_rel, d):
        return np.stack([sa.dot(d, g.e), sa.angle_about(R_rel @ sa.transpose(g.R0), g.e)], -1)

    def _perp(self, g, pose):
        return np.stack([sa.matvec(pose.RA, g.t1), sa.matvec(pose.RA, g.t2)], -2)

    def closure(self, g, pose):
        # no travel across e; B's copy of the axis on A's
        t = self._perp(g, pose)
        r1, p1 = base.sliding(pose, t)
        r2, p2 = base.aligned(sa.matvec(pose.RA, g.e), sa.matvec(pose.RB, sa.matvec(sa.transpose(g.R0), g.e)), t)
        return np.concatenate([r1, r2], -1), np.concatenate([p1, p2], -2)

    def closure_rate(self, g, pose, m):
        t = self._perp(g, pose)
        return np.concatenate([base.sliding_rate(pose, m, t), base.aligned_rate(m, t)], -2)


KIND = Cylindrical()
