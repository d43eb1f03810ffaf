"""Revolute joint: B turns about the axis e fixed in A through the joint's point; q the angle
of B from its design orientation relative to A (right hand about e), rad."""

from __future__ import annotations

import numpy as np

from .. import algebra as sa
from . import base


class Revolute(base.SpatialKind):
    name = "revolute"
    freedoms = 1
    effort = "tau"
    cut_rank = 0
    row_labels = ("Fx", "Fy", "Fz", "M1", "M2")

    def relative(self, g, q):
        # R_rel = Rot(e, q) R0, no travel
        return sa.rotation(g.e, q[..., 0]) @ g.R0, np.zeros(q.shape[:-1] + (3,))

    def screws(self, g, RA, RB, c, q):
        # s = [e; c x e], e fixed in A
        return sa.line_screw(sa.matvec(RA, g.e), c)[..., None, :]

    def coordinates(self, g, R_rel, d):
        return sa.angle_about(R_rel @ sa.transpose(g.R0), g.e)[..., None]

    def _couples(self, g, pose):
        return np.stack([sa.matvec(pose.RA, g.t1), sa.matvec(pose.RA, g.t2)], -2)

    def closure(self, g, pose):
        # coincident points; B's copy of the axis on A's: t_k . (e_A x e_B) = 0
        r1, p1 = base.coincident(pose)
        r2, p2 = base.aligned(sa.matvec(pose.RA, g.e), sa.matvec(pose.RB, sa.matvec(sa.transpose(g.R0), g.e)), self._couples(g, pose))
        return np.concatenate([r1, r2], -1), np.concatenate([p1, p2], -2)

    def closure_rate(self, g, pose, m):
        return np.concatenate([base.coincident_rate(pose, m),
                               base.aligned_rate(m, self._couples(g, pose))], -2)


KIND = Revolute()
