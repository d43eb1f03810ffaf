"""Coordinate coupling: the coordinate of one revolute joint held to a linear function of another's,
``q_1 = ratio q_2 + offset_angle`` (MuJoCo's joint equality, Pinocchio's mimic joint).

``joints = ["J1", "J2"]`` names the two coupled revolute joints; they must share one body ``c``
(the ground, a frame, a carrier) and sit at two different points of it. With ``A`` the other
body of J1 and ``B`` the other body of J2, the coupling is a cut joint between A and B
(``connect`` is J1's point on A and J2's point on B, resolved by :func:`couple`), one closure
row: three relative freedoms less one. ``sigma_1 = +1`` when A is J1's second body (``q_1 =
phi_A - phi_c``), ``-1`` when it is its first; ``sigma_2`` likewise for B and J2.

The relative twist ``x`` of B to A at J2's point tells the two joints' rates apart because the
two points are held apart on c: with ``d = r_2 - r_1`` (fixed in c, so it turns with c), the
transport ``x_v = (w_c - w_A) k x d`` gives ``w_A - w_c = -(d x x_v) / |d|^2`` and ``w_B - w_c
= x_w + (w_A - w_c)``. So the row (rad/s)

    ``S x = qd_1 - ratio qd_2 = -ratio sigma_2 x_w - (sigma_1 - ratio sigma_2) (d x x_v) / |d|^2``

(exact for any ``|d|``: a gear pair's row with the pitch radii ``sigma_1`` and ``-ratio
sigma_2``, :mod:`.gear`). The residual (rad) takes c's angle from the line of the two points,
``phi_c = angle(d) - beta`` with ``beta`` the direction of ``r_2 - r_1`` in c's frame (measured
from it, in (-pi, pi], so the shared body may not turn half a turn from its drawing, as a gear's
line of centres):

    ``sigma_1 (phi_A - phi_c) - ratio sigma_2 (phi_B - phi_c) - offset_angle = 0``.

The multiplier ``lam`` (N m) is a generalized effort: the coupling's work rate is
``lam (qd_1 - ratio qd_2)``, so it acts as the torque ``lam`` in J1 and ``-ratio lam`` in J2 (in
each joint's sense, on its second body). Its wrench ``S^T lam`` on B about J2's point (on A
minus that) is the moment ``-ratio sigma_2 lam`` with the force ``(sigma_1 - ratio sigma_2) lam
(d_y, -d_x) / |d|^2``, as a gear's tooth force, which is the reaction the coupling reports;
its moment about c's points does the joint torques' work. ``q`` is ``q_1`` (rad).

Not coupled here: sliding joints, and two revolute joints at one point of c (coaxial), whose
relative motion does not tell the two coordinates apart; :func:`couple` refuses them.
"""

from __future__ import annotations

import math

import numpy as np

from ..steps import atan2, step
from .base import JointKind, Number

RATIO = Number("ratio", (), "", 1.0,
               doc="q of the first coupled joint per q of the second (rad/rad)")
OFFSET = Number("offset_angle", (), "angle", 0.0,
                doc="q of the first coupled joint when the second's is zero")
SIGN_1 = Number("sign_1", (), "", 1.0, design=False, derived=True,
                doc="+1 if the first coupled joint's q is phi_A - phi_c, -1 if phi_c - phi_A")
SIGN_2 = Number("sign_2", (), "", 1.0, design=False, derived=True,
                doc="+1 if the second coupled joint's q is phi_B - phi_c, -1 if phi_c - phi_B")
BETA = Number("beta", (), "angle", 0.0, design=False, derived=True,
              doc="direction of the second coupled joint's point from the first's, in the "
                  "shared body's frame")


class Coupling(JointKind):
    name = "coupling"
    freedoms = 2
    tree = False
    angular = True
    numbers = (RATIO, OFFSET, SIGN_1, SIGN_2, BETA)
    row_units = ("rad",)
    reaction = ("Fx", "Fy", "M")
    multipliers = (("coupling torque", "N m"),)
    column = "torque"  # results.csv's torque_<coupling>: lam
    effort = None
    dyad = None
    periodic = False   # a whole turn of one joint turns the other by the ratio
    couples = True     # its connect comes from the two joints it couples (:func:`couple`)

    # nums = (ratio, offset_angle, sign_1, sign_2, beta); k1 = sign_1, k2 = -ratio sign_2

    @staticmethod
    @step
    def residual(nums, f, phi_a, phi_b):
        # sigma_1 (phi_A - phi_c) - ratio sigma_2 (phi_B - phi_c) - offset, phi_c = angle(d) - beta
        d, cb, sb = f[1], np.cos(nums[4]), np.sin(nums[4])
        phi_c = atan2(cb * d[1] - sb * d[0], cb * d[0] + sb * d[1])
        return (nums[2] * (phi_a - phi_c) - nums[0] * nums[3] * (phi_b - phi_c) - nums[1],
                0.0, 0.0)

    @staticmethod
    @step
    def selected(nums, f, x):
        # S x = k2 x_w - (k1 + k2) (d x x_v) / |d|^2
        k1, k2, d = nums[2], -nums[0] * nums[3], f[1]
        k = (k1 + k2) / (d[0] * d[0] + d[1] * d[1])
        return (k2 * x[0] - k * (d[0] * x[2] - d[1] * x[1]), 0.0, 0.0)

    @staticmethod
    @step
    def selected_rate(nums, f, fd, x):
        # dS/dt x = -(k1 + k2) [(d' x x_v) / |d|^2 - 2 (d . d') (d x x_v) / |d|^4]
        k1, k2, d, dd = nums[2], -nums[0] * nums[3], f[1], fd[1]
        n2 = d[0] * d[0] + d[1] * d[1]
        c = d[0] * x[2] - d[1] * x[1]
        cd = dd[0] * x[2] - dd[1] * x[1]
        return (-(k1 + k2) * (cd / n2 - 2.0 * (d[0] * dd[0] + d[1] * dd[1]) * c / (n2 * n2)),
                0.0, 0.0)

    @staticmethod
    @step
    def wrench(nums, f, lam):
        # S^T lam = [k2, (k1 + k2) (d_y, -d_x) / |d|^2] lam
        k1, k2, d = nums[2], -nums[0] * nums[3], f[1]
        k = (k1 + k2) / (d[0] * d[0] + d[1] * d[1]) * lam[0]
        return (k2 * lam[0], k * d[1], -k * d[0])

    @staticmethod
    @step
    def coordinate(nums, f, a, b, dd, dd2):
        # q_1 = sigma_1 (phi_A - phi_c); phi_c' = (d x d') / |d|^2,
        # phi_c'' = (d x d'') / |d|^2 - 2 (d . d') (d x d') / |d|^4
        d, cb, sb = f[1], np.cos(nums[4]), np.sin(nums[4])
        n2 = d[0] * d[0] + d[1] * d[1]
        c1 = d[0] * dd[1] - d[1] * dd[0]
        c2 = d[0] * dd2[1] - d[1] * dd2[0]
        w = c1 / n2
        al = c2 / n2 - 2.0 * (d[0] * dd[0] + d[1] * dd[1]) * c1 / (n2 * n2)
        phi_c = atan2(cb * d[1] - sb * d[0], cb * d[0] + sb * d[1])
        return nums[2] * (a[0] - phi_c), nums[2] * (a[1] - w), nums[2] * (a[2] - al)


KIND = Coupling()


class CouplingError(ValueError):
    """Two joints a coupling cannot couple; the message names them and says why."""


def couple(name: str, first, second, bodies: dict, ratio: float = 1.0,
           offset_angle: float = 0.0):
    """The coupling joint ``name`` holding ``q_first = ratio q_second + offset_angle``.

    Parameters
    ----------
    name : str
    first, second : linkdyn.model.Joint
        The two coupled joints: revolute, sharing exactly one body c, at two different points of
        it.
    bodies : dict[str, linkdyn.model.Body]
        The model's bodies by name (c's points give ``beta``).
    ratio : float
        rad per rad.
    offset_angle : float
        rad.

    Returns
    -------
    linkdyn.model.Joint
        A ``coupling`` joint from A (``first``'s other body, at its point) to B (``second``'s),
        its numbers the ratio, offset and the derived ``sign_1``, ``sign_2``, ``beta``, and
        ``coupled = (first.name, second.name)``.

    Raises
    ------
    CouplingError
        Naming the joint that cannot be coupled and why.
    """
    for j in (first, second):
        if j.kind != "revolute":
            raise CouplingError(f"joint {j.name!r} is {j.kind}: a coupling couples two "
                                "revolute joints")
    shared = {first.body_a, first.body_b} & {second.body_a, second.body_b}
    if len(shared) != 1:
        raise CouplingError(f"joints {first.name!r} and {second.name!r} share "
                            f"{'no body' if not shared else 'both bodies'}: a coupling couples "
                            "two joints of one common body (the ground, a frame or a carrier)")
    (c,) = shared

    def other(j):
        # the joint's other body and point, its sign (+1: q = phi_other - phi_c), c's point
        if j.body_a == c:
            return j.body_b, j.point_b, 1.0, j.point_a
        return j.body_a, j.point_a, -1.0, j.point_b

    a, pa, s1, c1 = other(first)
    b, pb, s2, c2 = other(second)
    d = np.asarray(bodies[c].points[c2], float) - np.asarray(bodies[c].points[c1], float)
    size = max(float(np.max(np.abs(np.asarray(v, float)))) for v in bodies[c].points.values())
    if not np.hypot(*d) > 1e-9 * max(size, 1e-300):
        raise CouplingError(f"joints {first.name!r} and {second.name!r} are at one point of body "
                            f"{c!r}: a coupling needs its two joints at different points (two "
                            "coaxial joints' relative motion does not tell them apart)")
    # the coupled joints' own class (linkdyn.model.Joint), which this module may not import
    return type(first)(name, KIND.name, a, pa, b, pb, ratio=float(ratio),
                       offset_angle=float(offset_angle), sign_1=s1, sign_2=s2,
                       beta=float(math.atan2(d[1], d[0])), coupled=(first.name, second.name))
