"""Universal (Hooke) joint: points coincide; B turns by ``q.1`` about ``axis`` e (fixed in A),
then by ``q.2`` about ``axis2`` e2 (fixed in B, perpendicular to e at the design pose), rad."""

from __future__ import annotations

import numpy as np

from .. import algebra as sa
from . import base


class Universal(base.SpatialKind):
    name = "universal"
    freedoms = 2
    coordinates_named = ((".1", True), (".2", True))
    keys = ("axis", "axis2")
    cut_rank = 3
    row_labels = ("Fx", "Fy", "Fz", "M")

    def relative(self, g, q):
        # R_rel = Rot(e, q1) R0 Rot(e2, q2)
        return (sa.rotation(g.e, q[..., 0]) @ g.R0 @ sa.rotation(g.e2, q[..., 1]),
                np.zeros(q.shape[:-1] + (3,)))

    def screws(self, g, RA, RB, c, q):
        return np.stack([sa.line_screw(sa.matvec(RA, g.e), c), sa.line_screw(sa.matvec(RB, g.e2), c)], -2)

    def coordinates(self, g, R_rel, d):
        # R_rel R0^T = Rot(e, q1) Rot(e2a, q2) with e2a = R0 e2: in the frame (e, e2a, e x e2a)
        # it is Rx(q1) Ry(q2) = [[c2, 0, s2], [s1 s2, c1, -s1 c2], [-c1 s2, s1, c1 c2]]
        e2a = sa.matvec(g.R0, g.e2)
        F = np.stack([g.e, e2a, sa.cross(g.e, e2a)], -1)
        n = sa.transpose(F) @ R_rel @ sa.transpose(g.R0) @ F
        return np.stack([np.arctan2(n[..., 2, 1], n[..., 1, 1]),
                         np.arctan2(n[..., 0, 2], n[..., 0, 0])], -1)

    def closure(self, g, pose):
        # coincident points; e_A . e2_B = 0 held by the couple e2_B x e_A
        r1, p1 = base.coincident(pose)
        eA, e2 = sa.matvec(pose.RA, g.e), sa.matvec(pose.RB, g.e2)
        u = sa.cross(e2, eA)
        return (np.concatenate([r1, np.sum(eA * e2, -1)[..., None]], -1),
                np.concatenate([p1, sa.free_vector(u, True)[..., None, :]], -2))

    def closure_rate(self, g, pose, m):
        eA, e2 = sa.matvec(pose.RA, g.e), sa.matvec(pose.RB, g.e2)
        ud = (sa.cross(sa.cross(m.VB[..., :3], e2), eA)
              + sa.cross(e2, sa.cross(m.VA[..., :3], eA)))
        return np.concatenate([base.coincident_rate(pose, m),
                               sa.free_vector(ud, True)[..., None, :]], -2)


KIND = Universal()
