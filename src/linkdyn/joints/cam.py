"""Cam and follower: a disc cam turning with its body, a follower point (a roller's centre or a
knife edge) kept on the cam's pitch curve.

``connect = ["cam.C", "follower.F"]``: the cam turns about its point C (the cam's centre) with
the first body; the second body carries F, the roller's centre (``roller_radius`` > 0) or the
knife edge (``roller_radius = 0``, the default). The pitch curve is the one ``linkdyn cam``
designs (:mod:`linkdyn.cams`, C1): the path of F in the cam's frame when the cam turns by the
cam angle ``theta`` and F rises ``s(theta)`` along a line at the ``offset`` e from C,

    ``P(theta) = R(-theta) (e, d0 + s(theta))``,  ``d0 = sqrt((R_b + R_f)^2 - e^2)``,

drawn in the first body's frame: at cam angle 0 the follower's line is along the body's +y
axis, and the cam turning counter-clockwise by ``theta`` lifts F by ``s(theta)``. The lift is
a rise of ``lift`` over the cam angle ``rise`` by the motion ``law`` (:mod:`linkdyn.laws`), a
dwell ``dwell``, a return to 0 over ``fall`` by the same law, and a dwell for the rest of the
turn (cam angle 0: the rise starts).

The pair leaves two relative freedoms, so it is always a cut joint with one row. With ``d =
r_F - r_C`` at the polar angle ``psi`` in the cam's frame, the contact's cam angle
``theta(psi)`` solves ``beta(theta) = psi`` (``beta = atan2(d0 + s, e) - theta``, the pitch
point's polar angle) by Newton's method, and the residual (m) is

    ``|d| - rho(theta(psi))``,  ``rho = sqrt(e^2 + (d0 + s)^2)``,

whose rate is the row on the relative twist ``x`` of b to a at F: ``S x = c . x_v`` with ``c =
u + g perp'(d) / |d|^2``, ``u = d / |d|``, ``perp'(d) = (d_y, -d_x)`` and ``g = rho_theta /
beta_theta`` (``d rho / d psi`` along the curve); ``c`` is normal to the pitch curve, pointing
away from C. The multiplier ``lam`` (N) is the contact force's component along ``u``; the
contact force on the follower is ``lam c`` (its reaction ``Fx``, ``Fy``), along the common
normal, of magnitude ``lam |c|``. A cam can only push: ``lam < 0`` is where the follower
would leave the cam (:attr:`Cam.one_sided`; the run's summary reports those samples).

``q`` = ``s(theta(psi))``, the lift the cam gives F at the contact (m).
"""

from __future__ import annotations

import math

import numpy as np

from .. import laws
from ..steps import atan2, by_kind, select, settled, step
from .base import JointKind, Number

BASE_RADIUS = Number("base_radius", (), "length", 0.0,
                     doc="base circle's radius R_b (the profile's least distance from C)")
ROLLER_RADIUS = Number("roller_radius", (), "length", 0.0,
                       doc="roller's radius R_f (0: a knife edge)")
OFFSET = Number("offset", (), "length", 0.0, doc="follower's line from the cam's centre")
LIFT = Number("lift", (), "length", 0.0, doc="the rise's height")
RISE = Number("rise", (), "angle", 0.0, doc="cam angle of the rise (from cam angle 0)")
DWELL = Number("dwell", (), "angle", 0.0, doc="cam angle of the dwell at the top")
FALL = Number("fall", (), "angle", 0.0, doc="cam angle of the return")
LAW = Number("law", (), "", float(laws.CODES["cycloidal"]), design=False,
             choices=tuple(laws.LAWS), doc="motion law")
#: a roller's contact stress (Hertz line contact, :func:`linkdyn.cams.hertz_line`): the width
#: of the contact along the roller's axis and both bodies' elastic constants; a width of 0 (the
#: default) asks for no stress
ROLLER_WIDTH = Number("roller_width", (), "length", 0.0, design=False,
                      doc="the roller's width in contact with the cam, L (0: no contact stress)")
CAM_MODULUS = Number("cam_modulus", (), "pressure", 0.0, design=False,
                     doc="the cam's Young's modulus E_1")
CAM_POISSON = Number("cam_poisson", (), "", 0.3, design=False,
                     doc="the cam's Poisson ratio nu_1")
ROLLER_MODULUS = Number("roller_modulus", (), "pressure", 0.0, design=False,
                        doc="the roller's Young's modulus E_2")
ROLLER_POISSON = Number("roller_poisson", (), "", 0.3, design=False,
                        doc="the roller's Poisson ratio nu_2")
HERTZ = (ROLLER_WIDTH, CAM_MODULUS, CAM_POISSON, ROLLER_MODULUS, ROLLER_POISSON)

#: Newton's iterations for the contact's cam angle, at most. The polar angle's rate along the
#: pitch curve is ``beta_theta = e s' / rho^2 - 1``; a cam with ``|e s'| <= STEEP rho^2``
#: (refused otherwise) has it within [-3/2, -1/2], and from ``s = 0`` the iterations reached
#: rounding (5e-15 rad) by the fifth on 199 random such cams (every law, offsets to 0.95 of the
#: prime circle). They stop after a step below ``SETTLED`` (rad) on every sample: converging
#: quadratically, the error left is of its square, rounding (the fourth step, usually)
ITERATIONS = 6
SETTLED = 1e-9
#: a start guess for the contact (the frame's ``t`` given to :func:`locate`: the last sample's
#: contact, on the compiled backend) is kept if the pitch point's polar angle there misses by
#: at most this (rad); else the iterations start from ``s = 0`` (the cold start)
WARM = 0.05
STEEP = 0.5
TWO_PI = 2.0 * math.pi
#: the follower's motion, ``nums[8]``: along a line, or an arm swinging about a pivot
TRANSLATING, OSCILLATING = 0, 1


@step
def lift(nums, theta):
    """The lift ``(s, s', s'')`` (m, m/rad, m/rad^2) at the cam angle ``theta`` (rad, any
    turn): rise, dwell, return, dwell (``nums``: the cam's numbers)."""
    h, r, dw, fa, code = nums[3], nums[4], nums[5], nums[6], nums[7]
    t = theta - TWO_PI * np.floor(theta / TWO_PI)
    # the rise's side (to the top dwell's end) or the return's: u of its law, held to [0, 1]
    up = t < r + dw
    u = select(up, t / r, (t - r - dw) / fa)
    u = select(u < 0.0, 0.0, select(u > 1.0, 1.0, u))
    f = laws.law(code, u)
    # s = h f(u) rising, h (1 - f(u)) returning; s', s'' only while rising or returning
    moving = select(up, t < r, t < r + dw + fa)
    k = select(up, 1.0 / r, -1.0 / fa)
    return (h * select(up, f[0], 1.0 - f[0]), select(moving, h * k * f[1], 0.0),
            select(moving, h * k * k * f[2] * select(up, 1.0, -1.0), 0.0))


@step
def _translating(nums, s):
    # F = (e, d0 + s): nums[0] = e, nums[1] = d0
    return nums[0], nums[1] + s, 0.0, 1.0, 0.0, 0.0


@step
def _oscillating(nums, s):
    # F = (a + L cos g, L sin g), g = g0 - s: nums[0] = a, nums[1] = L, nums[2] = g0
    g = nums[2] - s
    c, sn = nums[1] * np.cos(g), nums[1] * np.sin(g)
    return nums[0] + c, sn, sn, -c, -c, -sn


#: The step ``follower_point(code, nums, s) -> (X, Y, X', Y', X'', Y'')``: the follower point
#: F in the cam's frame at cam angle 0 (m) when the follower has risen by ``s``, and its first
#: and second derivatives in ``s``; code 0 a translating follower, 1 an oscillating one
#: (``nums[8]``).
follower_point = by_kind([(TRANSLATING, _translating), (OSCILLATING, _oscillating)])


@step
def pitch_point(code, nums, s):
    """The follower point F in the cam's frame at cam angle 0 and its rates in the cam angle,
    ``(x, y, x_t, y_t, x_tt, y_tt)`` (m, m/rad, m/rad^2), at the lift ``s = (s, s', s'')``
    (code: :func:`follower_point`'s)."""
    p = follower_point(code, nums, s[0])
    # F_t = F' s',  F_tt = F'' s'^2 + F' s''
    return (p[0], p[1], p[2] * s[1], p[3] * s[1], p[4] * s[1] * s[1] + p[2] * s[2],
            p[5] * s[1] * s[1] + p[3] * s[2])


@step
def wrap(angle):
    """``angle`` (rad) less whole turns, into [-pi, pi) (by a floor: for the contact's
    iterations, whose misses are never near half a turn once they converge)."""
    return angle - TWO_PI * np.floor((angle + math.pi) / TWO_PI)


@step
def newton_start(g, miss, it):
    """The contact iterations' start rule: whether the start guess ``g`` (NaN: none) is
    dropped (:data:`WARM`) at iteration ``it`` with the polar miss ``miss`` there, and the
    iterations go back to the cold start; only the first iteration may drop it."""
    return (it == 0) & (g == g) & (np.abs(miss) > WARM)


@step
def locate(nums, f):
    """The contact's cam angle ``theta`` (rad) on the pitch curve of the follower point ``d``
    (``f[1]``) in the frame of the cam (axis ``f[0]``): where the pitch point's polar angle is
    ``d``'s. The cut's one search for it (:meth:`Cam.locate`, where its frame is made; ``f[3]``
    a start guess, NaN: none); the other steps read it as the frame's ``f[3]``
    (:func:`contact`)."""
    code = nums[8]
    ea, d, g = f[0], f[1], f[3]
    psi = atan2(ea[0] * d[1] - ea[1] * d[0], ea[0] * d[0] + ea[1] * d[1])
    # Newton on beta(theta) = atan2(F(s(theta))) - theta = psi (mod 2 pi), from the guess in
    # the cold start's turn, or from s = 0 (the cold start), with
    # beta_theta = (F x F') s' / |F|^2 - 1
    p = follower_point(code, nums, 0.0)
    cold = atan2(p[1], p[0]) - psi
    theta = select(g == g, cold + wrap(g - cold), cold)
    for it in range(ITERATIONS + 1):
        s = lift(nums, theta)
        p = follower_point(code, nums, s[0])
        miss = wrap(atan2(p[1], p[0]) - theta - psi)
        bt = (p[0] * p[3] - p[1] * p[2]) * s[1] / (p[0] * p[0] + p[1] * p[1]) - 1.0
        far = newton_start(g, miss, it)
        dt = select(far, theta - cold, miss / bt)
        theta = theta - dt
        if settled(select(far, 1.0, dt), SETTLED):
            break
    return theta


@step
def contact(nums, f):
    """The contact on the pitch curve at the cam angle ``theta`` = ``f[3]`` (:func:`locate`'s):
    ``theta``, the lift ``(s, s', s'')`` there, the pitch point's radius ``rho`` and
    ``rho_theta``, ``rho_theta_theta``, ``beta_theta``, ``beta_theta_theta`` (beta: its polar
    angle)."""
    code, theta = nums[8], f[3]
    s = lift(nums, theta)
    x, y, xt, yt, xtt, ytt = pitch_point(code, nums, s)
    r2 = x * x + y * y
    rho = np.sqrt(r2)
    # rho_t = F.F_t / rho,  beta_t = F x F_t / rho^2 - 1, and their rates in theta
    fd, fx = x * xt + y * yt, x * yt - y * xt
    rt = fd / rho
    rtt = (xt * xt + yt * yt + x * xtt + y * ytt) / rho - fd * fd / (rho * r2)
    bt = fx / r2 - 1.0
    btt = (x * ytt - y * xtt) / r2 - 2.0 * fx * fd / (r2 * r2)
    return theta, s, rho, rt, rtt, bt, btt


@step
def normal_row(nums, f):
    """``c = u + g perp'(d) / |d|^2`` (the row's force direction, normal to the pitch curve
    through F, pointing away from C; ``|c| >= 1``) and ``g = rho_theta / beta_theta``."""
    c = contact(nums, f)
    d = f[1]
    n2 = d[0] * d[0] + d[1] * d[1]
    n = np.sqrt(n2)
    g = c[3] / c[5]
    return (d[0] / n + g * d[1] / n2, d[1] / n - g * d[0] / n2), g


class Cam(JointKind):
    name = "cam"
    freedoms = 2
    tree = False
    angular = False
    numbers = (BASE_RADIUS, ROLLER_RADIUS, OFFSET, LIFT, RISE, DWELL, FALL, LAW) + HERTZ
    row_units = ("m",)
    reaction = ("Fx", "Fy")
    multipliers = (("radial contact force", "N"),)
    effort = None
    dyad = None
    #: the contact can only push (lam >= 0); where lam < 0 the follower would leave the cam
    one_sided = True
    #: the contact's cam angle, the frame's ``t`` (:func:`locate`)
    locate = staticmethod(locate)

    # nums = (base_radius, roller_radius, offset, lift, rise, dwell, fall, law)

    @staticmethod
    @step
    def residual(nums, f, phi_a, phi_b):
        # |d| - rho(theta(psi))
        d = f[1]
        return (np.sqrt(d[0] * d[0] + d[1] * d[1]) - contact(nums, f)[2], 0.0, 0.0)

    @staticmethod
    @step
    def selected(nums, f, x):
        # S x = c . x_v
        c = normal_row(nums, f)[0]
        return (c[0] * x[1] + c[1] * x[2], 0.0, 0.0)

    @staticmethod
    @step
    def selected_rate(nums, f, fd, x):
        # (dS/dt) x = c' . x_v:  c' = u' + g' perp'(d) / |d|^2 + g (perp'(d') / |d|^2
        #   - 2 (d . d') perp'(d) / |d|^4),  u' = (d' - u (u . d')) / |d|,
        #   g' = g_theta theta',  theta' = psi' / beta_theta,  psi' = (d x d') / |d|^2 - w_a
        k = contact(nums, f)
        d, dd = f[1], fd[1]
        n2 = d[0] * d[0] + d[1] * d[1]
        n = np.sqrt(n2)
        dot_ = d[0] * dd[0] + d[1] * dd[1]
        g = k[3] / k[5]
        gt = (k[4] * k[5] - k[3] * k[6]) / (k[5] * k[5])
        th1 = ((d[0] * dd[1] - d[1] * dd[0]) / n2 - fd[0]) / k[5]
        g1 = gt * th1
        ux = (dd[0] - d[0] * dot_ / n2) / n
        uy = (dd[1] - d[1] * dot_ / n2) / n
        cx = ux + g1 * d[1] / n2 + g * (dd[1] / n2 - 2.0 * dot_ * d[1] / (n2 * n2))
        cy = uy - g1 * d[0] / n2 + g * (-dd[0] / n2 + 2.0 * dot_ * d[0] / (n2 * n2))
        return (cx * x[1] + cy * x[2], 0.0, 0.0)

    @staticmethod
    @step
    def wrench(nums, f, lam):
        # S^T lam = [0, lam c]: the contact force through F, along the common normal
        c = normal_row(nums, f)[0]
        return (0.0, lam[0] * c[0], lam[0] * c[1])

    @staticmethod
    @step
    def coordinate(nums, f, a, b, dd, dd2):
        # q = s(theta);  theta' = psi' / beta_theta,
        # theta'' = (psi'' - beta_theta_theta theta'^2) / beta_theta,
        # psi'' = (d x d'') / |d|^2 - 2 (d . d') (d x d') / |d|^4 - al_a
        k = contact(nums, f)
        s = k[1]
        d = f[1]
        n2 = d[0] * d[0] + d[1] * d[1]
        c1 = d[0] * dd[1] - d[1] * dd[0]
        c2 = d[0] * dd2[1] - d[1] * dd2[0]
        p1 = c1 / n2 - a[1]
        p2 = c2 / n2 - 2.0 * (d[0] * dd[0] + d[1] * dd[1]) * c1 / (n2 * n2) - a[2]
        th1 = p1 / k[5]
        th2 = (p2 - k[6] * th1 * th1) / k[5]
        return s[0], s[1] * th1, s[2] * th1 * th1 + s[1] * th2

    def own(self, numbers: dict, zero=0.0) -> tuple:
        """The cut steps' numbers: ``(e, d0, 0, lift, rise, dwell, fall, law, 0)``,
        ``d0 = sqrt((R_b + R_f)^2 - e^2)`` (the follower point's height at s = 0)."""
        x = numbers
        rp, e = x["base_radius"] + x["roller_radius"], x["offset"]
        return (e, np.sqrt(rp * rp - e * e), zero, x["lift"], x["rise"], x["dwell"], x["fall"],
                x["law"], zero + TRANSLATING)

    def refuse(self, numbers: dict) -> str | None:
        """Why a cam's numbers make no cam (None: they do)."""
        rb, rf, e = numbers["base_radius"], numbers["roller_radius"], numbers["offset"]
        if not rb > 0:
            return "base_radius must be positive"
        if not rf >= 0:
            return "roller_radius must be 0 (a knife edge) or positive"
        if not abs(e) < rb + rf:
            return "the offset must be less than base_radius + roller_radius"
        if not numbers["lift"] > 0:
            return "lift must be positive"
        return (self.refuse_hertz(numbers) or self.refuse_lift(numbers)
                or self.refuse_curve(numbers))

    def refuse_hertz(self, numbers: dict) -> str | None:
        """Why the contact stress's numbers make no Hertz line contact (None: they do, or no
        ``roller_width`` asks for it)."""
        width = numbers.get("roller_width", 0.0)
        if width == 0:
            return None
        if not width > 0:
            return "roller_width must be positive (or 0: no contact stress)"
        if not numbers["roller_radius"] > 0:
            return "a contact stress needs a roller: give roller_radius > 0 with roller_width"
        for body in ("cam", "roller"):
            if not numbers[f"{body}_modulus"] > 0:
                return (f"{body}_modulus must be positive with roller_width (e.g. steel's "
                        "206000 N/mm^2 in a mm file)")
            if not -1.0 < numbers[f"{body}_poisson"] < 0.5:
                return f"{body}_poisson must be above -1 and below 0.5 (steel's is 0.3)"
        return None

    def cam_angle(self, numbers: dict, f):
        """The contact's cam angle (rad, within one turn) for the cut's frame ``f`` (arrays
        of the batch shape): where on the cam the follower touches."""
        return np.mod(contact(self.own(numbers), f)[0], TWO_PI)

    def stressed(self, numbers: dict) -> bool:
        """Whether the joint's numbers ask for its contact stress (a roller with a width)."""
        return numbers.get("roller_width", 0.0) > 0

    def contact_radii(self, numbers: dict, f):
        """Where the roller touches the cam, for the follower point ``f[1]`` in the cut's
        frame ``f`` (arrays of the batch shape): the contact's cam angle (rad, within one
        turn) and the radii of curvature there of the cam's profile (m, positive convex, C4 of
        :mod:`linkdyn.cams`: the pitch curve's radius less the roller's) and of the roller."""
        nums = self.own(numbers)
        theta, s = contact(nums, f)[:2]
        rho_p = pitch_curve(nums, s)[1]
        rf = numbers["roller_radius"]
        return np.mod(theta, TWO_PI), rho_p - rf, rf + 0.0 * rho_p

    def refuse_lift(self, numbers: dict) -> str | None:
        """Why the rise, dwell, fall and law make no lift (None: they do)."""
        if not (numbers["rise"] > 0 and numbers["fall"] > 0 and numbers["dwell"] >= 0):
            return "rise and fall must be positive angles, dwell 0 or more"
        if numbers["rise"] + numbers["dwell"] + numbers["fall"] > TWO_PI * (1 + 1e-12):
            return "rise + dwell + fall must be at most one turn"
        if laws_name(numbers["law"]) == "dwell":
            return "law must be a rise law (harmonic, cycloidal, poly345, ...), not dwell"
        return None

    def refuse_swing(self, numbers: dict, start: float, part: str, fix: str) -> str | None:
        """Why an oscillating follower's ``swing`` is no swing (None: it is one): positive, and
        short of the line of centres, ``start`` (rad) away at the bottom of the swing; ``part``
        names what swings, ``fix`` what to change."""
        if not numbers["swing"] > 0:
            return "swing must be a positive angle"
        if not numbers["swing"] < start:
            return (f"the {part} would swing past the line of centres (swing at most "
                    f"{math.degrees(start):.4g} deg here); {fix}")
        return None

    def refuse_curve(self, numbers: dict) -> str | None:
        """Why the pitch curve cannot be followed (None: it can): its polar angle must fall
        evenly for the contact's Newton iterations, and it must not bend tighter than the
        roller (undercutting, C4 of :mod:`linkdyn.cams`), over a turn."""
        nums = self.own({k: float(v) for k, v in numbers.items()})
        steep, rho = pitch_curve(nums, lift(nums, np.linspace(0.0, TWO_PI, 1441)))
        if np.max(steep) > STEEP:
            return (f"the pitch curve's polar angle must fall evenly along it, |F x F_theta| "
                    f"<= rho^2 / 2 (here up to {np.max(steep):.3g} rho^2), for its contact to "
                    "be found; " + self.steep_fix)
        under = (rho > 0) & (rho < numbers["roller_radius"])
        if np.any(under):
            at = np.degrees(np.linspace(0.0, TWO_PI, 1441)[under])
            return (f"the cam is undercut at cam angles {at[0]:.4g} .. {at[-1]:.4g} deg (the "
                    "pitch curve bends tighter than the roller); enlarge base_radius or use a "
                    "smaller roller")
        return None

    #: what to change where the pitch curve's polar angle falls unevenly
    steep_fix = "reduce the offset or enlarge base_radius"


def pitch_curve(nums, s):
    """The pitch curve's steepness ``|F x F_theta| / |F|^2`` and radius of curvature
    ``|P'|^3 / (P'' x P')`` (m, positive convex, C4 of :mod:`linkdyn.cams`) at the lifts ``s =
    (s, s', s'')`` (each (n,)) of a follower with the cut numbers ``nums`` (floats). In the
    cam's frame ``P = R(-theta) F``: ``P' = R(-theta) (F_t - J F)``, ``P'' = R(-theta) (F_tt
    - 2 J F_t - F)``, J the quarter turn."""
    x, y, xt, yt, xtt, ytt = pitch_point(nums[8], nums, s)
    x, y = x + 0.0 * s[0], y + 0.0 * s[0]
    # J (x, y) = (-y, x)
    ux, uy = xt + y, yt - x
    vx, vy = xtt + 2.0 * yt - x, ytt - 2.0 * xt - y
    return (np.abs(x * yt - y * xt) / (x * x + y * y),
            np.hypot(ux, uy) ** 3 / (vx * uy - vy * ux))


def laws_name(code) -> str:
    """The motion law's name of the code a cam joint holds."""
    return tuple(laws.LAWS)[int(code)]


KIND = Cam()
