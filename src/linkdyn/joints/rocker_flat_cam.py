"""Cam and oscillating flat-faced follower: a disc cam turning with its body, the flat face of
an arm swinging about its pivot kept tangent to the cam's profile.

``connect = ["cam.C", "arm.F"]``: the cam turns about its point C with the first body; the
second body (the arm) carries the face, a straight line through its point F normal to its +y
axis (the face's normal ``n``, pointing away from the cam). The follower's designed motion is
the arm's angle: at cam angle 0 the pivot is at ``A = (a, 0)`` in the cam body's frame (``a``
= ``pivot``), the face at the ``offset`` f from the pivot towards the cam, its normal at the
angle ``alpha0`` that puts it at ``R_b`` from C; the cam turning counter-clockwise by
``theta`` swings the arm clockwise by ``s(theta)``, moving the face away from C:

    ``alpha(s) = alpha0 - s``,  ``h(s) = a cos(alpha(s)) - f``,  ``cos alpha0 = (R_b + f) / a``,

``h`` the face's distance from C. The steps are the translating face's
(:mod:`linkdyn.joints.flat_cam`) with this ``alpha`` and ``h``; ``q`` is the arm's swing
``s(theta)`` at the contact (rad).
"""

from __future__ import annotations

import numpy as np

from .cam import BASE_RADIUS, DWELL, FALL, LAW, OFFSET, OSCILLATING, RISE
from .flat_cam import FlatCam
from .rocker_cam import PIVOT, SWING


def start_angle(numbers: dict):
    """``alpha0`` (rad): the face's normal's angle from the line of centres at the bottom of
    the swing."""
    return np.arccos((numbers["base_radius"] + numbers["offset"]) / numbers["pivot"])


class RockerFlatCam(FlatCam):
    name = "rocker_flat_cam"
    angular = True
    numbers = (BASE_RADIUS, PIVOT, OFFSET, SWING, RISE, DWELL, FALL, LAW)

    def own(self, numbers: dict, zero=0.0) -> tuple:
        """The cut steps' numbers: ``(a, f, alpha0, swing, rise, dwell, fall, law, 1)``."""
        x = numbers
        return (x["pivot"], x["offset"], start_angle(x), x["swing"], x["rise"], x["dwell"],
                x["fall"], x["law"], zero + OSCILLATING)

    def refuse(self, numbers: dict) -> str | None:
        """Why an oscillating flat-faced cam's numbers make no cam (None: they do)."""
        rb, a, f = numbers["base_radius"], numbers["pivot"], numbers["offset"]
        if not rb > 0:
            return "base_radius must be positive"
        if not 0 < rb + f < a:
            return ("the pivot must be further from the cam's centre than the face at the "
                    "base circle: 0 < base_radius + offset < pivot")
        return (self.refuse_swing(numbers, start_angle(numbers), "face",
                                  "shorten the swing or move the pivot further from the cam")
                or self.refuse_lift(numbers) or self.refuse_curve(numbers))

    steep_fix = "shorten the swing or lengthen the rise and the return"


KIND = RockerFlatCam()
