"""Cam and oscillating follower: a disc cam turning with its body, the point of a follower arm
(a roller's centre or a knife edge) kept on the cam's pitch curve while the arm swings about
its pivot.

``connect = ["cam.C", "arm.F"]``: the cam turns about its point C with the first body; the
second body (the arm) carries F, the roller's centre (``roller_radius`` > 0) or the knife edge
(``roller_radius = 0``). The follower's designed motion is its arm's angle: at cam angle 0 the
arm's pivot is at ``A = (a, 0)`` in the cam body's frame (``a`` = ``pivot``, from C), F at the
``arm`` length L from it, at the angle ``g0`` with ``|F| = R_b + R_f`` (the prime circle);
the cam turning counter-clockwise by ``theta`` swings the arm clockwise by ``s(theta)``,
moving F away from C:

    ``F(s) = A + L (cos(g0 - s), sin(g0 - s))``,  ``cos g0 = (R_p^2 - a^2 - L^2) / (2 a L)``,
    ``0 < g0 < pi``,

and the pitch curve is ``P(theta) = R(-theta) F(s(theta))``. The swing ``s`` is the
dwell-rise-dwell-return of :mod:`linkdyn.joints.cam` (a rise of ``swing`` over ``rise``, the
dwell ``dwell``, the return over ``fall``, the bottom dwell for the rest of the turn).

Everything else is the translating cam's (:mod:`linkdyn.joints.cam`, the same steps: the
contact's cam angle by Newton's method on the pitch point's polar angle, the residual ``|d| -
rho``, the row along the pitch curve's normal, the contact force along the common normal),
with its follower point ``F(s)`` in place of ``(e, d0 + s)``. ``q`` is the arm's swing
``s(theta)`` at the contact (rad).
"""

from __future__ import annotations

import numpy as np

from .base import Number
from .cam import (BASE_RADIUS, DWELL, FALL, HERTZ, LAW, OSCILLATING, RISE, ROLLER_RADIUS, Cam)

PIVOT = Number("pivot", (), "length", 0.0,
               doc="the follower's pivot from the cam's centre, a (rocker_cam)")
ARM = Number("arm", (), "length", 0.0,
             doc="the follower point from its pivot, L (rocker_cam)")
SWING = Number("swing", (), "angle", 0.0, doc="the arm's swing over the rise (rocker_cam)")


def start_angle(numbers: dict):
    """``g0`` (rad): the arm's angle from the line of centres at the bottom of the swing."""
    rp = numbers["base_radius"] + numbers["roller_radius"]
    a, arm = numbers["pivot"], numbers["arm"]
    return np.arccos((rp * rp - a * a - arm * arm) / (2.0 * a * arm))


class RockerCam(Cam):
    name = "rocker_cam"
    angular = True
    numbers = (BASE_RADIUS, ROLLER_RADIUS, PIVOT, ARM, SWING, RISE, DWELL, FALL, LAW) + HERTZ

    def own(self, numbers: dict, zero=0.0) -> tuple:
        """The cut steps' numbers: ``(a, L, g0, swing, rise, dwell, fall, law, 1)``."""
        x = numbers
        return (x["pivot"], x["arm"], start_angle(x), x["swing"], x["rise"], x["dwell"],
                x["fall"], x["law"], zero + OSCILLATING)

    def refuse(self, numbers: dict) -> str | None:
        """Why a rocker cam's numbers make no cam (None: they do)."""
        rb, rf = numbers["base_radius"], numbers["roller_radius"]
        a, arm = numbers["pivot"], numbers["arm"]
        if not rb > 0:
            return "base_radius must be positive"
        if not rf >= 0:
            return "roller_radius must be 0 (a knife edge) or positive"
        if not (a > 0 and arm > 0):
            return "pivot and arm must be positive lengths"
        if not abs(a - arm) < rb + rf < a + arm:
            return ("the arm must reach the prime circle: |pivot - arm| < base_radius + "
                    "roller_radius < pivot + arm")
        return (self.refuse_swing(numbers, start_angle(numbers), "arm",
                                  "shorten the swing or lengthen the arm")
                or self.refuse_hertz(numbers) or self.refuse_lift(numbers)
                or self.refuse_curve(numbers))

    steep_fix = "shorten the swing, or move the pivot further from the cam"


KIND = RockerCam()
