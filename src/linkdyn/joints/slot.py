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
    def residual(angle, phi_a, phi_b, e_a, r_pa, r_pb):
        # the pin on the slot's line: (r_Pb - r_Pa) . n = 0,  n = perp(e)
        return (dot((r_pb[0] - r_pa[0], r_pb[1] - r_pa[1]), normal(e_a)), 0.0, 0.0)

    @staticmethod
    @step
    def selected(e_a, x):
        # S = [[0, n_x, n_y]]: the pin's relative velocity normal to the slot
        return (dot((x[1], x[2]), normal(e_a)), 0.0, 0.0)

    @staticmethod
    @step
    def selected_rate(e_a, w_a, x):
        # dS/dt x = n_dot . x_v,  n_dot = -w_a e (the slot turns with its body)
        return (-w_a * dot((x[1], x[2]), e_a), 0.0, 0.0)

    @staticmethod
    @step
    def wrench(e_a, lam):
        # S^T lam = [0, lam n]: the normal force through the pin, no moment about it
        n = normal(e_a)
        return (0.0, lam[0] * n[0], lam[0] * n[1])

    @staticmethod
    @step
    def coordinate(e_a, a, b, d, dd, dd2):
        # q = d . e, the pin's displacement along the slot turning with the first body
        return line_motion(e_a, a[1], a[2], d, dd, dd2)


KIND = Slot()
