"""Cam and flat-faced follower: a disc cam turning with its body, a flat face on the follower
kept tangent to the cam's profile.

``connect = ["cam.C", "follower.F"]``: the cam turns about its point C with the first body; the
second body carries the face, a straight line through its point F normal to its +y axis (the
face's normal ``n``, pointing away from the cam). The follower's design is ``linkdyn cam``'s
flat face (:mod:`linkdyn.cams`, C5): at cam angle 0 the face's normal is the cam body's +y
axis and the face is at ``R_b + s`` from C; the cam turning counter-clockwise by ``theta``
lifts it by ``s(theta)`` (the lift of :mod:`linkdyn.joints.cam`: rise, dwell, return, dwell).

In general (this module's steps serve the oscillating face too, :mod:`.rocker_flat_cam`) the
face's normal has the angle ``alpha(s) = alpha0 - k s`` and the face is at the distance
``h(s)`` from C, in the cam's frame at cam angle 0 (translating: ``alpha = pi/2``, ``h = R_b +
s``, ``k = 0``). At the cam angle ``theta`` the normal's angle in the cam's frame is ``nu =
alpha(s(theta)) - theta``, and the cam's profile is the envelope of those faces: its support
function ``H(nu) = h(s(theta(nu)))``. With ``d = r_F - r_C`` and the face's normal ``n`` (the
second body's +y axis), the contact's cam angle solves ``alpha(s(theta)) - theta = nu`` (Newton's
method from ``s = 0``; exact at once for a translating face) and the residual (m) is

    ``n . d - H(nu)``.

Its rate on the relative twist ``x`` of b to a at F is the row ``S x = (n x d - H_nu) x_w + n .
x_v`` (``H_nu = h_theta / nu_theta``, ``nu_theta = -k s' - 1``): the multiplier ``lam`` (N) is
the contact force along ``n`` through the contact point ``C + H n + H_nu perp(n)`` (where the
face touches the profile, ``H_nu`` along the face from the foot of the normal through C); its
reaction on the follower about F is ``lam [n x d - H_nu, n]`` (``Fx``, ``Fy`` and the moment
``M`` of the force's offset along the face). A cam can only push: ``lam < 0`` is where the face
would leave the cam. ``q`` = ``s(theta)`` (m).
"""

from __future__ import annotations

import math

import numpy as np

from ..steps import atan2, by_kind, select, settled, step
from .cam import (BASE_RADIUS, DWELL, FALL, ITERATIONS, LAW, LIFT, OSCILLATING, RISE, SETTLED,
                  STEEP, TRANSLATING, TWO_PI, Cam, lift, newton_start, wrap)


@step
def _translating(nums, s):
    # alpha = pi / 2, h = R_b + s: nums[0] = R_b, nums[2] = pi / 2
    return nums[2], nums[0] + s, 1.0, 0.0, 0.0


@step
def _oscillating(nums, s):
    # alpha = alpha0 - s, h = a cos(alpha) - f: nums[0] = a, nums[1] = f, nums[2] = alpha0
    al = nums[2] - s
    c, sn = nums[0] * np.cos(al), nums[0] * np.sin(al)
    return al, c - nums[1], sn, -c, 1.0


#: The step ``face_line(code, nums, s) -> (alpha, h, h', h'', k)``: the face's normal angle and
#: distance from C at the lift ``s`` (cam angle 0), h's derivatives in ``s`` and ``k =
#: -d alpha / ds``; code 0 a translating face, 1 an oscillating one (``nums[8]``).
face_line = by_kind([(TRANSLATING, _translating), (OSCILLATING, _oscillating)])


@step
def support(code, nums, s):
    """The face at the lift ``s = (s, s', s'')``: its normal's angle ``alpha`` (rad, the cam's
    frame at cam angle 0), the support function ``H`` (m) and its rates ``H_nu``, ``H_nu_nu``
    in the normal's angle nu, ``nu_theta``, ``nu_theta_theta`` and ``k`` (code:
    :func:`face_line`'s)."""
    p = face_line(code, nums, s[0])
    # h_t = h' s',  h_tt = h'' s'^2 + h' s'';  nu_t = -k s' - 1,  nu_tt = -k s'';
    # H_nu = h_t / nu_t,  H_nu_nu = (h_tt nu_t - h_t nu_tt) / nu_t^3
    ht, htt = p[2] * s[1], p[3] * s[1] * s[1] + p[2] * s[2]
    bt, btt = -p[4] * s[1] - 1.0, -p[4] * s[2]
    return p[0], p[1], ht / bt, (htt * bt - ht * btt) / (bt * bt * bt), bt, btt, p[4]


@step
def locate(nums, f):
    """The contact's cam angle ``theta`` (rad) of the face (normal ``n``: the second body's +y
    axis, ``f[2]`` turned a quarter turn) with the cam (axis ``f[0]``): where the face's
    normal has the angle ``n`` has in the cam's frame. The cut's one search for it
    (:meth:`FlatCam.locate`; ``f[3]`` a start guess, NaN: none, kept as the translating cam's,
    :func:`linkdyn.joints.cam.locate`); the other steps read it as the frame's ``f[3]``
    (:func:`contact`)."""
    code, g = nums[8], f[3]
    ea, eb = f[0], f[2]
    n = (-eb[1], eb[0])
    nu = atan2(ea[0] * n[1] - ea[1] * n[0], ea[0] * n[0] + ea[1] * n[1])
    # Newton on alpha(s(theta)) - theta = nu (mod 2 pi), from the guess or from s = 0:
    # nu_theta = -k s' - 1
    p = face_line(code, nums, 0.0)
    cold = p[0] - nu
    theta = select(g == g, cold + wrap(g - cold), cold)
    for it in range(ITERATIONS + 1):
        s = lift(nums, theta)
        p = face_line(code, nums, s[0])
        miss = wrap(p[0] - theta - nu)
        far = newton_start(g, miss, it)
        dt = select(far, theta - cold, miss / (-p[4] * s[1] - 1.0))
        theta = theta - dt
        if settled(select(far, 1.0, dt), SETTLED):
            break
    return theta


@step
def contact(nums, f):
    """The contact of the face with the cam at the cam angle ``theta`` = ``f[3]``
    (:func:`locate`'s): ``theta``, the lift ``(s, s', s'')`` there, ``H``, ``H_nu``,
    ``H_nu_nu`` (the support function and its rates in the normal's angle nu), ``nu_theta``
    and the face's normal ``n``."""
    code, theta, eb = nums[8], f[3], f[2]
    n = (-eb[1], eb[0])
    s = lift(nums, theta)
    u = support(code, nums, s)
    return theta, s, u[1], u[2], u[3], u[4], u[5], n


@step
def _moment_arm(k, d):
    """``n x d - H_nu`` of a contact ``k`` (:func:`contact`): the row's rotation part."""
    n = k[7]
    return n[0] * d[1] - n[1] * d[0] - k[3]


class FlatCam(Cam):
    name = "flat_cam"
    numbers = (BASE_RADIUS, LIFT, RISE, DWELL, FALL, LAW)
    reaction = ("Fx", "Fy", "M")
    multipliers = (("contact force", "N"),)
    #: the contact's cam angle, the frame's ``t`` (:func:`locate`)
    locate = staticmethod(locate)

    @staticmethod
    @step
    def residual(nums, f, phi_a, phi_b):
        # n . d - H(nu)
        k, d = contact(nums, f), f[1]
        return (k[7][0] * d[0] + k[7][1] * d[1] - k[2], 0.0, 0.0)

    @staticmethod
    @step
    def selected(nums, f, x):
        # S x = (n x d - H_nu) x_w + n . x_v
        k = contact(nums, f)
        return (_moment_arm(k, f[1]) * x[0] + k[7][0] * x[1] + k[7][1] * x[2], 0.0, 0.0)

    @staticmethod
    @step
    def selected_rate(nums, f, fd, x):
        # (dS/dt) x = (-w_b n . d + n x d' - H_nu_nu (w_b - w_a)) x_w + w_b perp(n) . x_v
        k = contact(nums, f)
        n, d, dd = k[7], f[1], fd[1]
        rot = (-fd[2] * (n[0] * d[0] + n[1] * d[1]) + n[0] * dd[1] - n[1] * dd[0]
               - k[4] * (fd[2] - fd[0]))
        return (rot * x[0] + fd[2] * (-n[1] * x[1] + n[0] * x[2]), 0.0, 0.0)

    @staticmethod
    @step
    def wrench(nums, f, lam):
        # S^T lam: the contact force lam n through the contact point, about F
        k = contact(nums, f)
        return (lam[0] * _moment_arm(k, f[1]), lam[0] * k[7][0], lam[0] * k[7][1])

    @staticmethod
    @step
    def coordinate(nums, f, a, b, dd, dd2):
        # q = s(theta);  theta' = nu' / nu_theta,  theta'' = (nu'' - nu_tt theta'^2) / nu_theta,
        # nu' = w_b - w_a,  nu'' = al_b - al_a
        k = contact(nums, f)
        s = k[1]
        th1 = (b[1] - a[1]) / k[5]
        th2 = (b[2] - a[2] - k[6] * th1 * th1) / k[5]
        return s[0], s[1] * th1, s[2] * th1 * th1 + s[1] * th2

    def own(self, numbers: dict, zero=0.0) -> tuple:
        """The cut steps' numbers: ``(R_b, 0, pi/2, lift, rise, dwell, fall, law, 0)``."""
        x = numbers
        return (x["base_radius"], zero, zero + math.pi / 2, x["lift"], x["rise"], x["dwell"],
                x["fall"], x["law"], zero + TRANSLATING)

    def cam_angle(self, numbers: dict, f):
        """The contact's cam angle (rad, within one turn) for the cut's frame ``f``."""
        return np.mod(contact(self.own(numbers), f)[0], TWO_PI)

    def refuse(self, numbers: dict) -> str | None:
        """Why a flat-faced cam's numbers make no cam (None: they do)."""
        if not numbers["base_radius"] > 0:
            return "base_radius must be positive"
        if not numbers["lift"] > 0:
            return "lift must be positive"
        return self.refuse_lift(numbers) or self.refuse_curve(numbers)

    def refuse_curve(self, numbers: dict) -> str | None:
        """Why the face cannot follow the profile (None: it can): the face's turn must be slow
        enough for the contact's Newton iterations (``k |s'| <= 1/2``), and the profile's
        radius of curvature ``H + H_nu_nu`` (C5 of :mod:`linkdyn.cams`) positive over a turn
        (a cusp otherwise)."""
        nums = self.own({k: float(v) for k, v in numbers.items()})
        steep, rho = face_curve(nums, lift(nums, np.linspace(0.0, TWO_PI, 1441)))
        if np.max(steep) > STEEP:
            return (f"the face turns too fast for its contact to be found, |s'| <= 1/2 (here "
                    f"up to {np.max(steep):.3g}); " + self.steep_fix)
        if np.any(rho <= 0):
            at = np.degrees(np.linspace(0.0, TWO_PI, 1441)[rho <= 0])
            return (f"the profile would have a cusp at cam angles {at[0]:.4g} .. {at[-1]:.4g} "
                    "deg (its radius of curvature R_b + s + s'' below zero); enlarge "
                    "base_radius or lengthen the rise and the return")
        return None

    steep_fix = "lengthen the rise and the return"


def face_curve(nums, s):
    """The face's turning rate ``k |s'|`` and the profile's radius of curvature ``H +
    H_nu_nu`` (m, C5 of :mod:`linkdyn.cams` for a translating face) at the lifts ``s = (s,
    s', s'')`` (each (n,)) of a flat-faced follower with the cut numbers ``nums`` (floats)."""
    u = support(nums[8], nums, s)
    return np.abs(u[6] * s[1]), u[1] + u[3]


KIND = FlatCam()
