"""Model builders shared by the dynamics tests: geometry in mm, inertia about the mass centre
in kg mm^2, converted to the SI models the library takes."""

from __future__ import annotations

import math

import numpy as np

from linkdyn.model import PRISMATIC, REVOLUTE, Body, Joint

MM = 1e-3
DEG = math.pi / 180
RPM = 2 * math.pi / 60


def body(name, points, mass=0.0, com=(0.0, 0.0), inertia=0.0):
    """A body with points and mass centre in mm, inertia about the mass centre in kg mm^2."""
    return Body(name, {k: np.array(v, float) * MM for k, v in points.items()}, float(mass),
                np.array(com, float) * MM, inertia * 1e-6)


def rev(name, a, b):
    """Revolute joint ``connect = [a, b]``, each ``'body.point'``."""
    (ba, pa), (bb, pb) = a.split("."), b.split(".")
    return Joint(name, REVOLUTE, ba, pa, bb, pb)


def slot(name, a, b, axis=(1.0, 0.0)):
    """Slot joint ``connect = [a, b]``: b's pin on the line through a's point along ``axis``
    (a's frame)."""
    (ba, pa), (bb, pb) = a.split("."), b.split(".")
    return Joint(name, "slot", ba, pa, bb, pb, np.array(axis, float))


def pri(name, a, b, axis=(1.0, 0.0), angle=0.0):
    """Prismatic joint ``connect = [a, b]``, axis in the first body's frame, angle in rad."""
    (ba, pa), (bb, pb) = a.split("."), b.split(".")
    return Joint(name, PRISMATIC, ba, pa, bb, pb, np.array(axis, float), float(angle))
