"""Revolute joint (pin): the two bodies share a point and turn freely about it.

``q`` = phi of the second body minus phi of the first (rad). Cut, it keeps the two in-plane
components of the relative velocity at the pin (2 rows, m); its reaction is a force.
"""

from __future__ import annotations

import numpy as np

from ..planar import twist
from .base import JointKind


class Revolute(JointKind):
    name = "revolute"
    freedoms = 1
    tree = True
    angular = True
    keys = ()
    row_units = ("m", "m")
    reaction = ("Fx", "Fy")
    multipliers = (("x", "N"), ("y", "N"))
    effort = "tau"
    dyad = "R"

    def place_child(self, s, q, angle, axis_p, phi_p, cos_p, sin_p, r_joint):
        # phi_i = phi_p + s q;  O_i coincides with the parent's joint point
        phi = phi_p + s * q
        return phi, np.cos(phi), np.sin(phi), r_joint, None

    def motion_vector(self, s, e, ndim):
        # p_i = [s, 0, 0], constant
        return np.array([float(s), 0.0, 0.0]).reshape((3,) + (1,) * ndim)

    def add_motion(self, s, e, x, rate):
        x[0] += s * rate
        return x

    def add_motion_rate(self, s, e, w_axis, x, rate):
        return x  # p_i is constant

    def cut_residual(self, angle, phi_a, phi_b, e_a, r_pa, r_pb):
        # the two pin points coincide: r_Pb - r_Pa = 0
        return r_pb - r_pa

    def cut_rows(self, e_a, x):
        # S = [[0, 1, 0], [0, 0, 1]]: the relative velocity at the pin
        return x[1:]

    def cut_rows_rate(self, e_a, w_a, x):
        return 0.0

    def cut_wrench(self, e_a, lam):
        # S^T lam = [0, lam_x, lam_y]: a force through the pin
        return twist(0.0, lam)

    def joint_motion(self, e_a, a, b, points):
        # q = phi_b - phi_a and its rates
        return b[0] - a[0], b[1] - a[1], b[2] - a[2]


KIND = Revolute()
