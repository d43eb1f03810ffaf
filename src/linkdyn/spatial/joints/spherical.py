"""Spherical (ball) joint: points coincide, B turns freely. As a tree joint: three Cardan
rotations about A's design x, y, z axes (singular where the middle one is +-90 deg, so
loops are cut at spherical joints first); no coordinate columns."""

from __future__ import annotations

import numpy as np

from .. import algebra as sa
from . import base

_X, _Y, _Z = np.eye(3)


class Spherical(base.SpatialKind):
    name = "spherical"
    freedoms = 3
    coordinates_named = ((".1", True), (".2", True), (".3", True))
    keys = ()
    cut_rank = 4
    row_labels = ("Fx", "Fy", "Fz")
    couple_free = True

    def relative(self, g, q):
        r1, r2, r3 = (sa.rotation(a, q[..., k]) for k, a in enumerate((_X, _Y, _Z)))
        return r1 @ r2 @ r3 @ g.R0, np.zeros(q.shape[:-1] + (3,))

    def screws(self, g, RA, RB, c, q):
        r1 = RA @ sa.rotation(_X, q[..., 0])
        r2 = r1 @ sa.rotation(_Y, q[..., 1])
        return np.stack([sa.line_screw(RA @ _X, c), sa.line_screw(r1 @ _Y, c),
                         sa.line_screw(r2 @ _Z, c)], -2)

    def coordinates(self, g, R_rel, d):
        # Rx Ry Rz: [0,2] = s2, [1,2] = -s1 c2, [2,2] = c1 c2, [0,1] = -c2 s3, [0,0] = c2 c3
        n = R_rel @ sa.transpose(g.R0)
        return np.stack([np.arctan2(-n[..., 1, 2], n[..., 2, 2]),
                         np.arcsin(np.clip(n[..., 0, 2], -1, 1)),
                         np.arctan2(-n[..., 0, 1], n[..., 0, 0])], -1)

    def closure(self, g, pose):
        return base.coincident(pose)

    def closure_rate(self, g, pose, m):
        return base.coincident_rate(pose, m)


KIND = Spherical()
