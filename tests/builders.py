"""Model builders shared by the dynamics tests: geometry in mm, inertia about the mass centre
in kg mm^2, converted to the SI models the library takes."""

from __future__ import annotations

import math

import numpy as np

from linkdyn.model import PRISMATIC, REVOLUTE, Body, Joint, Model

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


def parallelogram_chain(n, phi0=math.pi / 4, *, name="chain", cut=None, g=9.81):
    """n parallelogram windows in a row, in SI: n + 1 unit bars pinned to the ground 1 m apart
    (joints G0..Gn), their tips joined by n unit bars (A_k on the left, B_k on the right); 1 kg
    uniform bars, gravity -g along y, released with G0 at ``phi0`` (rad); ``cut`` the cut joints
    (default: chosen by the topology)."""
    def P(*xy):
        return np.array(xy, float)

    bodies = [Body("ground", {f"G{k}": P(k, 0) for k in range(n + 1)})]
    joints = []
    for k in range(n + 1):
        bodies.append(Body(f"V{k}", {"O": P(0, 0), "T": P(1, 0)}, 1.0, P(0.5, 0), 1 / 12))
        joints.append(Joint(f"G{k}", REVOLUTE, "ground", f"G{k}", f"V{k}", "O"))
    for k in range(1, n + 1):
        bodies.append(Body(f"H{k}", {"A": P(0, 0), "B": P(1, 0)}, 1.0, P(0.5, 0), 1 / 12))
        joints.append(Joint(f"A{k}", REVOLUTE, f"V{k - 1}", "T", f"H{k}", "A"))
        joints.append(Joint(f"B{k}", REVOLUTE, f"H{k}", "B", f"V{k}", "T"))
    phi = {f"V{k}": phi0 for k in range(n + 1)} | {f"H{k}": 0.0 for k in range(1, n + 1)}
    return Model(f"{name}{n}", tuple(bodies), tuple(joints), gravity=P(0, -g),
                 assembly_phi=phi, initial_q={"G0": phi0},
                 **({} if cut is None else {"cut": tuple(cut)}))
