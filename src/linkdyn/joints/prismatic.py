"""Prismatic joint (slider): the second body's point slides along an axis fixed in the first.

``q`` = displacement of the second body's point from the first's along ``axis`` (m); the
second body's frame keeps the fixed ``angle`` to the first's. Cut, it keeps the relative
rotation and the relative velocity normal to the axis (2 rows: rad, m); its reaction is a
force normal to the axis and a moment.
"""

from __future__ import annotations

import numpy as np

from ..planar import dot, perp, rotate_cs, twist, wrap
from .base import JointKind, line_motion


class Prismatic(JointKind):
    name = "prismatic"
    freedoms = 1
    tree = True
    angular = False
    keys = ("axis", "angle")
    row_units = ("rad", "m")
    reaction = ("Fx", "Fy", "M")
    multipliers = (("moment", "N m"), ("normal force", "N"))
    effort = "force"
    dyad = "P"

    def place_child(self, s, q, angle, axis_p, phi_p, cos_p, sin_p, r_joint):
        # phi_i = phi_p + s angle;  O_i = joint point + s q e, e fixed in the joint's first body
        ca, sa = np.cos(s * angle), np.sin(s * angle)
        e = rotate_cs(cos_p, sin_p, axis_p)
        return (phi_p + s * angle, ca * cos_p - sa * sin_p, sa * cos_p + ca * sin_p,
                r_joint + (s * q) * e, e)

    def motion_vector(self, s, e, ndim):
        # p_i = [0, s e]
        return twist(0.0, s * e)

    def add_motion(self, s, e, x, rate):
        x[1:] += (s * rate) * e
        return x

    def add_motion_rate(self, s, e, w_axis, x, rate):
        # pd_i = [0, s w perp(e)], w of the body carrying the axis
        x[1:] += (s * rate * w_axis) * perp(e)
        return x

    def cut_residual(self, angle, phi_a, phi_b, e_a, r_pa, r_pb):
        # [phi_b - phi_a - angle (wrapped), (r_Pb - r_Pa) . n],  n = perp(e)
        return np.stack((wrap(phi_b - phi_a - angle), dot(r_pb - r_pa, perp(e_a))))

    def cut_rows(self, e_a, x):
        # S = [[1, 0, 0], [0, n_x, n_y]]
        return np.stack(np.broadcast_arrays(x[0], dot(x[1:], perp(e_a))))

    def cut_rows_rate(self, e_a, w_a, x):
        # dS/dt x = [0, n_dot . x_v],  n_dot = -w_a e
        ndot_x = -w_a * dot(x[1:], e_a)
        return np.stack((np.zeros_like(ndot_x), ndot_x))

    def cut_wrench(self, e_a, lam):
        # S^T lam = [lam_0, lam_1 n]
        return twist(lam[0], lam[1] * perp(e_a))

    def joint_motion(self, e_a, a, b, points):
        # q = d . e along the axis turning with the first body
        return line_motion(e_a, a[1], a[2], points)


KIND = Prismatic()
