"""Prismatic joint (slider): the second body's point slides along an axis fixed in the first.

``q`` = displacement of the second body's point from the first's along ``axis`` (m); the
second body's frame keeps the fixed ``angle`` to the first's. Cut, it keeps the relative
rotation and the relative velocity normal to the axis (2 rows: rad, m); its reaction is a
force normal to the axis and a moment.
"""

from __future__ import annotations

import numpy as np

from ..planar import dot, normal, rotate, turned, wrapped
from ..steps import step
from .base import ANGLE, AXIS, JointKind, line_motion


class Prismatic(JointKind):
    name = "prismatic"
    freedoms = 1
    tree = True
    angular = False
    numbers = (AXIS, ANGLE)
    row_units = ("rad", "m")
    reaction = ("Fx", "Fy", "M")
    multipliers = (("moment", "N m"), ("normal force", "N"))
    effort = "force"
    dyad = "P"

    def tree_numbers(self, values: dict, sign: int) -> dict:
        # the axis is fixed in the joint's first body; the tree row holds it in the parent's
        # frame: a parent that is the second body sees it turned by -angle
        if sign > 0:
            return values
        return dict(values, axis=rotate(np.asarray(-values["angle"]), values["axis"]))

    @staticmethod
    @step
    def place(s, q, turn, angle, axis_p, phi_p, cos_p, sin_p, r_joint):
        # phi_i = phi_p + s angle;  O_i = joint point + s q e, e fixed in the joint's first body
        ca, sa = np.cos(s * angle), np.sin(s * angle)
        e = turned(cos_p, sin_p, axis_p)
        return (phi_p + s * angle, ca * cos_p - sa * sin_p, sa * cos_p + ca * sin_p,
                (r_joint[0] + (s * q) * e[0], r_joint[1] + (s * q) * e[1]), e)

    @staticmethod
    @step
    def motion(s, e):
        # p_i = [0, s e]
        return (0.0, s * e[0], s * e[1])

    @staticmethod
    @step
    def plus_motion(s, e, x, rate):
        return (x[0], x[1] + (s * rate) * e[0], x[2] + (s * rate) * e[1])

    @staticmethod
    @step
    def plus_motion_rate(s, e, w_axis, x, rate):
        # pd_i = [0, s w perp(e)], w of the body carrying the axis
        f = s * rate * w_axis
        return (x[0], x[1] - f * e[1], x[2] + f * e[0])

    @staticmethod
    @step
    def residual(nums, f, phi_a, phi_b):
        # [phi_b - phi_a - angle (wrapped), d . n],  d = r_Pb - r_Pa,  n = perp(e);
        # nums = (angle, ...)
        return (wrapped(phi_b - phi_a - nums[0]), dot(f[1], normal(f[0])), 0.0)

    @staticmethod
    @step
    def selected(nums, f, x):
        # S = [[1, 0, 0], [0, n_x, n_y]]
        return (x[0], dot((x[1], x[2]), normal(f[0])), 0.0)

    @staticmethod
    @step
    def selected_rate(nums, f, fd, x):
        # dS/dt x = [0, n_dot . x_v],  n_dot = -w_a e
        return (0.0, -fd[0] * dot((x[1], x[2]), f[0]), 0.0)

    @staticmethod
    @step
    def wrench(nums, f, lam):
        # S^T lam = [lam_0, lam_1 n]
        n = normal(f[0])
        return (lam[0], lam[1] * n[0], lam[1] * n[1])

    @staticmethod
    @step
    def coordinate(nums, f, a, b, dd, dd2):
        # q = d . e along the axis turning with the first body
        return line_motion(f[0], a[1], a[2], f[1], dd, dd2)


KIND = Prismatic()
