"""Slot joint (pin in slot): a pin point of the second body slides along a straight slot of the
first, and turns freely in it.

``connect = ["A.p", "B.q"]``, ``axis`` in A's frame: the pin q of B stays on the line through
A's point p along the axis. Two relative freedoms (slide and turn) leave one constraint: the
pin's velocity relative to A, normal to the slot, vanishes. So a slot is always a cut joint
(no single coordinate places B from A) with one closure row; its multiplier is the normal
force, and its reaction ``[Fx, Fy]`` (by A on B, through the pin) is normal to the slot.
``q`` = the pin's displacement from p along the axis (m), as for a slider.
"""

from __future__ import annotations

from ..planar import dot, normal
from ..steps import step
from .base import AXIS, JointKind, line_motion


class Slot(JointKind):
    name = "slot"
    freedoms = 2
    tree = False
    angular = False
    numbers = (AXIS,)
    row_units = ("m",)
    reaction = ("Fx", "Fy")
    multipliers = (("normal force", "N"),)
    effort = None
    dyad = None

    @staticmethod
    @step
    def residual(nums, f, phi_a, phi_b):
        # the pin on the slot's line: d . n = 0,  d = r_Pb - r_Pa,  n = perp(e)
        return (dot(f[1], normal(f[0])), 0.0, 0.0)

    @staticmethod
    @step
    def selected(nums, f, x):
        # S = [[0, n_x, n_y]]: the pin's relative velocity normal to the slot
        return (dot((x[1], x[2]), normal(f[0])), 0.0, 0.0)

    @staticmethod
    @step
    def selected_rate(nums, f, fd, x):
        # dS/dt x = n_dot . x_v,  n_dot = -w_a e (the slot turns with its body)
        return (-fd[0] * dot((x[1], x[2]), f[0]), 0.0, 0.0)

    @staticmethod
    @step
    def wrench(nums, f, lam):
        # S^T lam = [0, lam n]: the normal force through the pin, no moment about it
        n = normal(f[0])
        return (0.0, lam[0] * n[0], lam[0] * n[1])

    @staticmethod
    @step
    def coordinate(nums, f, a, b, dd, dd2):
        # q = d . e, the pin's displacement along the slot turning with the first body
        return line_motion(f[0], a[1], a[2], f[1], dd, dd2)


KIND = Slot()
