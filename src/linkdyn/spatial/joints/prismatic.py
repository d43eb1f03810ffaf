"""Prismatic joint: B slides along the axis e fixed in A, its orientation relative to A held
at the design pose's; q = (r_Bq - r_Ap) . e, m."""

from __future__ import annotations

import numpy as np

from .. import algebra as sa
from . import base


class Prismatic(base.SpatialKind):
    name = "prismatic"
    freedoms = 1
    angular = False
    coordinates_named = (("", False),)
    effort = "force"
    cut_rank = 1
    row_labels = ("F1", "F2", "Mx", "My", "Mz")

    def relative(self, g, q):
        # R_rel = R0, d = q e
        return np.broadcast_to(g.R0, q.shape[:-1] + (3, 3)), q[..., :1] * g.e

    def screws(self, g, RA, RB, c, q):
        # s = [0; e], e fixed in A
        return sa.free_vector(sa.matvec(RA, g.e), False)[..., None, :]

    def coordinates(self, g, R_rel, d):
        return (sa.dot(d, g.e))[..., None]

    def _forces(self, g, pose):
        return np.stack([sa.matvec(pose.RA, g.t1), sa.matvec(pose.RA, g.t2)], -2)

    def closure(self, g, pose):
        # no travel across e; no relative rotation
        r1, p1 = base.sliding(pose, self._forces(g, pose))
        r2, p2 = base.locked(pose, g.R0)
        return np.concatenate([r1, r2], -1), np.concatenate([p1, p2], -2)

    def closure_rate(self, g, pose, m):
        return np.concatenate([base.sliding_rate(pose, m, self._forces(g, pose)),
                               base.locked_rate(pose)], -2)


KIND = Prismatic()
