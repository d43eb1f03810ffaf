"""Revolute joint (pin): the two bodies share a point and turn freely about it.

``q`` = phi of the second body minus phi of the first (rad). Cut, it keeps the two in-plane
components of the relative velocity at the pin (2 rows, m); its reaction is a force.
"""

from __future__ import annotations

from ..planar import turned
from ..steps import step
from .base import JointKind


class Revolute(JointKind):
    name = "revolute"
    freedoms = 1
    tree = True
    angular = True
    numbers = ()
    row_units = ("m", "m")
    reaction = ("Fx", "Fy")
    multipliers = (("x", "N"), ("y", "N"))
    effort = "tau"
    dyad = "R"

    @staticmethod
    @step
    def place(s, q, turn, angle, axis_p, phi_p, cos_p, sin_p, r_joint):
        # phi_i = phi_p + s q, its cosine and sine by R(phi_p) turned by s q;  O_i coincides
        # with the parent's joint point
        c, sn = turned(cos_p, sin_p, turn)
        return phi_p + s * q, c, sn, (r_joint[0], r_joint[1]), (0.0, 0.0)

    @staticmethod
    @step
    def motion(s, e):
        # p_i = [s, 0, 0], constant
        return (s, 0.0, 0.0)

    @staticmethod
    @step
    def plus_motion(s, e, x, rate):
        return (x[0] + s * rate, x[1], x[2])

    @staticmethod
    @step
    def plus_motion_rate(s, e, w_axis, x, rate):
        return (x[0], x[1], x[2])  # p_i is constant

    @staticmethod
    @step
    def residual(nums, f, phi_a, phi_b):
        # the two pin points coincide: d = r_Pb - r_Pa = 0
        d = f[1]
        return (d[0], d[1], 0.0)

    @staticmethod
    @step
    def selected(nums, f, x):
        # S = [[0, 1, 0], [0, 0, 1]]: the relative velocity at the pin
        return (x[1], x[2], 0.0)

    @staticmethod
    @step
    def selected_rate(nums, f, fd, x):
        return (0.0, 0.0, 0.0)

    @staticmethod
    @step
    def wrench(nums, f, lam):
        # S^T lam = [0, lam_x, lam_y]: a force through the pin
        return (0.0, lam[0], lam[1])

    @staticmethod
    @step
    def coordinate(nums, f, a, b, dd, dd2):
        # q = phi_b - phi_a and its rates
        return b[0] - a[0], b[1] - a[1], b[2] - a[2]


KIND = Revolute()
