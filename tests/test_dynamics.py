"""Inverse dynamics and joint reactions against independent computations.

Every check compares linkdyn's recursive DeNOC results (``linkdyn.analysis.analyze``) with a
computation that shares none of its recursions:

a. the slow explicit-matrix reference ``linkdyn.dynamics.dense`` (eq. 27 with N_l, N_d, M, J
   formed as matrices; reactions from a stacked wrench balance);
b. a simultaneous Newton–Euler solve written here: every joint reaction and driver effort
   unknown at once, three equations per moving body about its mass centre, mass-centre
   accelerations computed here from the body's angle, angular velocity and acceleration and the
   acceleration of one point; applied loads computed here too;
c. power balance: driver power + power of the non-conservative loads = d(KE + PE)/dt by a
   five-point (Richardson) finite difference in time;
d. statics by virtual work, virtual displacements by finite differences of positions;
e. action = reaction (every joint's connect order reversed) and each body's wrench balance with
   the reported reactions and efforts;
f. property-based random Grashof crank-rockers;
g. batch equals loop.

Tolerances are relative to each quantity's peak over the samples (scale-aware).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from linkdyn.analysis import analyze
from linkdyn.dynamics import dense
from linkdyn.model import PRISMATIC, REVOLUTE, Body, Driver, Joint, Load, Model
from linkdyn.motion import ConstantSpeed, ExpressionMotion

from linkdyn import laws
from linkdyn.cams import Cam
from linkdyn.joints.cam import laws_name
from linkdyn.joints.coupling import couple
from linkdyn.motion import Segment

from builders import DEG, MM, RPM, body, pri, rev, slot

RTOL = 1e-9

# ----------------------------------------------------------------------------------------------
# model builders (SI); geometry in mm, inertia about the mass centre in kg mm^2


def force(body_, point, fx, fy, wx=0.0):
    """Force (N, global) ``[fx + 0.3 fx sin(wx t), fy]`` at ``body.point``."""
    return Load("force", body_, point,
                value=lambda t: np.stack(np.broadcast_arrays(fx + 0.3 * fx * np.sin(wx * t), fy),
                                         axis=-1))


def torque(body_, value, wt=0.0):
    return Load("torque", body_, value=lambda t: value * (1.0 + 0.5 * np.sin(wt * np.asarray(t))))


def spring(b1, p1, b2, p2, k, l0):
    return Load("spring", b1, p1, body2=b2, point2=p2, stiffness=k, free_length=l0)


def damper(b1, p1, b2, p2, c):
    return Load("damper", b1, p1, body2=b2, point2=p2, damping=c)


GRAVITY = np.array([0.7, -9.81])


def hoeken(loaded=False):
    """The seed paper's Hoeken four-bar (Table 1; table inertias are about O_i), cut at J4."""
    bodies = (
        body("ground", {"O1": (0, 0), "O4": (89.5, 0), "S": (200, 150)}),
        body("crank", {"O1": (0, 0), "O2": (38.1, 0)}, 1.5, (19.05, 0), 725.80 - 1.5 * 19.05**2),
        body("coupler", {"O2": (0, 0), "O3": (115.2, 0), "P": (230.4, 0)}, 5.0, (115.2, 0),
             88473.60 - 5.0 * 115.2**2),
        body("rocker", {"O3": (0, 0), "O4": (115.2, 0)}, 3.0, (57.6, 0),
             13271.76 - 3.0 * 57.6**2),
    )
    joints = (rev("J1", "ground.O1", "crank.O1"), rev("J2", "crank.O2", "coupler.O2"),
              rev("J3", "coupler.O3", "rocker.O3"), rev("J4", "ground.O4", "rocker.O4"))
    loads = ()
    if loaded:
        loads = (force("coupler", "P", -20.0, 35.0, 2.0), torque("rocker", 0.5, 3.0),
                 spring("coupler", "P", "ground", "S", 400.0, 0.1),
                 damper("crank", "O2", "ground", "O4", 2.0))
    return Model("hoeken" + ("-loaded" if loaded else ""), bodies, joints,
                 (Driver("J1", ConstantSpeed(45 * RPM)),), loads,
                 GRAVITY if loaded else np.zeros(2),
                 assembly_phi={"crank": 0.0, "coupler": 77.12 * DEG, "rocker": -77.12 * DEG},
                 cut=("J4",))


def slider_crank(cut=None):
    """Offset slider-crank (prismatic to the ground), gas load, damper, gravity."""
    bodies = (
        body("ground", {"O": (0, 0), "G": (0, 20)}),
        body("crank", {"O": (0, 0), "A": (50, 0)}, 0.3, (25, 3), 62.5),
        body("rod", {"A": (0, 0), "B": (180, 0)}, 0.6, (90, -4), 1620.0),
        body("slider", {"B": (0, 0), "F": (20, 0)}, 0.8, (5, 3), 133.33),
    )
    joints = (rev("J1", "ground.O", "crank.O"), rev("J2", "crank.A", "rod.A"),
              rev("J3", "rod.B", "slider.B"), pri("J4", "ground.G", "slider.B"))
    loads = (force("slider", "F", -200.0, 0.0, 31.4), damper("slider", "B", "ground", "O", 5.0))
    return Model("slider-crank", bodies, joints, (Driver("J1", ConstantSpeed(300 * RPM)),),
                 loads, GRAVITY, assembly_phi={"crank": 0.0, "rod": 6.38 * DEG, "slider": 0.0},
                 assembly_q={"J4": 0.2289}, cut=cut)


def inverted_slider_crank(cut=None):
    """Crank and slotted lever; the block slides along a slot offset 10 mm from the lever's
    pivot line and sits at 0.2 rad to the lever (prismatic joint between two moving bodies)."""
    bodies = (
        body("ground", {"O2": (0, 0), "O4": (0, -150)}),
        body("crank", {"O2": (0, 0), "A": (75, 0)}, 0.4, (37.5, 2), 187.5),
        body("block", {"A": (0, 0)}, 0.2, (3, -2), 18.75),
        body("lever", {"O4": (0, 0), "S": (0, 10), "T": (300, 0)}, 1.2, (150, 5), 9000.0),
    )
    joints = (rev("J1", "ground.O2", "crank.O2"), rev("J2", "crank.A", "block.A"),
              pri("J3", "lever.S", "block.A", (1.0, 0.0), 0.2),
              rev("J4", "ground.O4", "lever.O4"))
    loads = (force("lever", "T", -30.0, 10.0, 5.0), torque("lever", -2.0, 2.0))
    return Model("inverted slider-crank", bodies, joints,
                 (Driver("J1", ConstantSpeed(60 * RPM, 0.3)),), loads, GRAVITY,
                 assembly_phi={"crank": 0.3, "block": 1.2, "lever": 1.0},
                 assembly_q={"J3": 0.17}, cut=cut)


def boom(offset=0.0):
    """Hydraulic-cylinder-driven boom: the driven joint is a prismatic joint between two moving
    bodies (barrel and rod); ``offset`` (mm) moves the rod's line off the barrel's pivot. The
    cylinder's length 0.52..0.68 m swings the 0.3 m boom arm between about 66 and 103 deg, far
    from the dead centres at 0.2 and 0.8 m."""
    bodies = (
        body("ground", {"C0": (0, 0), "B0": (500, 0)}),
        body("barrel", {"C0": (0, 0), "Y": (0, offset)}, 2.0, (150, 0), 15000.0),
        body("rod", {"R": (0, 0)}, 1.0, (-120, 2), 5000.0),
        body("boom", {"B0": (0, 0), "R": (300, 0), "tip": (800, 0)}, 6.0, (350, 20), 3.0e5),
    )
    joints = (rev("J1", "ground.C0", "barrel.C0"), pri("J2", "barrel.Y", "rod.R"),
              rev("J3", "rod.R", "boom.R"), rev("J4", "ground.B0", "boom.B0"))
    loads = (force("boom", "tip", 5.0, -50.0, 1.0),)
    return Model("boom", bodies, joints,
                 (Driver("J2", ExpressionMotion("0.6 + 0.08*sin(2*t)")),), loads, GRAVITY,
                 assembly_phi={"barrel": 30 * DEG, "rod": 30 * DEG, "boom": 86 * DEG},
                 assembly_q={"J2": 0.6})


def stephenson():
    """Stephenson-III six-bar (two loops), loads on the output."""
    bodies = (
        body("ground", {"O2": (0, 0), "O4": (90, 0), "O6": (40, -60)}),
        body("crank", {"O2": (0, 0), "A": (25, 0)}, 0.15, (12.5, 0), 7.81),
        body("coupler", {"A": (0, 0), "B": (80, 0), "E": (40, 40)}, 0.6, (40, 10), 420.0),
        body("rocker", {"O4": (0, 0), "B": (80, 0)}, 0.35, (40, 0), 186.67),
        body("link5", {"E": (0, 0), "F": (120, 0)}, 0.45, (60, 0), 540.0),
        body("output", {"O6": (0, 0), "F": (40, 0), "T": (70, 0)}, 0.3, (35, 0), 122.5),
    )
    joints = (rev("J1", "ground.O2", "crank.O2"), rev("J2", "crank.A", "coupler.A"),
              rev("J3", "coupler.B", "rocker.B"), rev("J4", "ground.O4", "rocker.O4"),
              rev("J5", "coupler.E", "link5.E"), rev("J6", "link5.F", "output.F"),
              rev("J7", "ground.O6", "output.O6"))
    loads = (force("output", "T", 3.0, -4.0, 6.0), torque("rocker", 0.2, 4.0),
             spring("link5", "F", "ground", "O2", 50.0, 0.05))
    return Model("stephenson", bodies, joints, (Driver("J1", ConstantSpeed(60 * RPM)),), loads,
                 GRAVITY,
                 assembly_phi={"crank": 0.0, "coupler": 66.03 * DEG, "rocker": 113.97 * DEG,
                               "link5": -91.94 * DEG, "output": -169.73 * DEG})


def watt2():
    """Watt-II six-bar (two four-bar loops in series)."""
    bodies = (
        body("ground", {"O2": (0, 0), "O4": (100, 0), "O6": (160, -20)}),
        body("crank", {"O2": (0, 0), "A": (30, 0)}, 0.2, (15, 0), 15.0),
        body("coupler1", {"A": (0, 0), "B": (90, 0)}, 0.4, (45, 0), 270.0),
        body("rocker1", {"O4": (0, 0), "B": (80, 0), "C": (45, -53.62)}, 0.5, (31.25, -13.41),
             363.6),
        body("coupler2", {"C": (0, 0), "D": (80, 0)}, 0.35, (40, 0), 186.67),
        body("output", {"O6": (0, 0), "D": (40, 0), "T": (100, 0)}, 0.3, (50, 0), 250.0),
    )
    joints = (rev("J1", "ground.O2", "crank.O2"), rev("J2", "crank.A", "coupler1.A"),
              rev("J3", "coupler1.B", "rocker1.B"), rev("J4", "ground.O4", "rocker1.O4"),
              rev("J5", "rocker1.C", "coupler2.C"), rev("J6", "coupler2.D", "output.D"),
              rev("J7", "ground.O6", "output.O6"))
    loads = (force("output", "T", 0.0, -6.0, 0.0), damper("output", "T", "ground", "O4", 0.5))
    return Model("watt2", bodies, joints, (Driver("J1", ConstantSpeed(60 * RPM)),), loads,
                 GRAVITY,
                 assembly_phi={"crank": 0.0, "coupler1": 58.41 * DEG, "rocker1": 106.60 * DEG,
                               "coupler2": -46.00 * DEG, "output": 31.49 * DEG})


def five_bar():
    """Two-driver five-bar; the second driven joint and the distal pin are declared with the
    child body first (``connect = [child, parent]``)."""
    bodies = (
        body("ground", {"A": (0, 0), "E": (200, 0)}),
        body("link1", {"A": (0, 0), "B": (100, 0)}, 0.3, (50, 5), 250.0),
        body("link2", {"B": (0, 0), "C": (150, 0)}, 0.4, (75, 0), 750.0),
        body("link3", {"D": (0, 0), "C": (150, 0)}, 0.4, (70, -3), 750.0),
        body("link4", {"E": (0, 0), "D": (100, 0)}, 0.3, (50, 0), 250.0),
    )
    joints = (rev("J1", "ground.A", "link1.A"), rev("J2", "link1.B", "link2.B"),
              rev("J3", "link3.C", "link2.C"), rev("J4", "link4.D", "link3.D"),
              rev("J5", "link4.E", "ground.E"))
    loads = (force("link2", "C", 4.0, -10.0, 3.0),
             spring("link1", "B", "link4", "D", 200.0, 0.08))
    drivers = (Driver("J1", ExpressionMotion("1.2 + 0.3*sin(3*t)")),
               Driver("J5", ExpressionMotion("-(1.9 + 0.3*sin(2*t + 0.5))")))
    return Model("five-bar", bodies, joints, drivers, loads, GRAVITY,
                 assembly_phi={"link1": 1.2, "link2": 67 * DEG, "link3": 113 * DEG,
                               "link4": 2.04})


def scotch_yoke():
    """Crank pin in the vertical slot of a yoke sliding on the ground (a slot joint whose slot
    translates), working load, damper, gravity."""
    bodies = (
        body("ground", {"O": (0, 0), "G": (0, 0)}),
        body("crank", {"O": (0, 0), "A": (60, 0)}, 0.4, (30, 4), 120.0),
        body("yoke", {"C": (0, 0), "P": (200, 0)}, 1.5, (80, 10), 9000.0),
    )
    joints = (rev("J1", "ground.O", "crank.O"), pri("J2", "ground.G", "yoke.C"),
              slot("J3", "yoke.C", "crank.A", (0.0, 1.0)))
    loads = (force("yoke", "P", -150.0, 0.0, 20.0), damper("yoke", "P", "ground", "O", 3.0))
    return Model("scotch-yoke", bodies, joints, (Driver("J1", ConstantSpeed(120 * RPM, 0.2)),),
                 loads, GRAVITY, assembly_phi={"crank": 0.2, "yoke": 0.0},
                 assembly_q={"J2": 0.0588})


def slotted_lever():
    """Quick-return crank and slotted lever: the crank pin slides and turns in a slot of the
    lever, offset 10 mm from its pivot line (a slot joint whose slot turns)."""
    bodies = (
        body("ground", {"O2": (0, 0), "O4": (0, -150)}),
        body("crank", {"O2": (0, 0), "A": (75, 0)}, 0.4, (37.5, 2), 187.5),
        body("lever", {"O4": (0, 0), "S": (0, 10), "T": (300, 0)}, 1.2, (150, 5), 9000.0),
    )
    joints = (rev("J1", "ground.O2", "crank.O2"), slot("J3", "lever.S", "crank.A", (1.0, 0.0)),
              rev("J4", "ground.O4", "lever.O4"))
    loads = (force("lever", "T", -30.0, 10.0, 5.0), torque("lever", -2.0, 2.0))
    return Model("slotted lever", bodies, joints, (Driver("J1", ConstantSpeed(60 * RPM, 0.3)),),
                 loads, GRAVITY, assembly_phi={"crank": 0.3, "lever": 1.0})


def massless(model, names, point=False):
    """``model`` with the bodies ``names`` massless (mass and inertia 0), or point masses
    (``point``: their inertia 0, their mass kept)."""
    bodies = tuple(dataclasses.replace(b, inertia=0.0, mass=b.mass if point else 0.0)
                   if b.name in names else b for b in model.bodies)
    return dataclasses.replace(model, name=model.name + "-massless", bodies=bodies)


def hoeken_rod():
    """The loaded Hoeken with its rocker a massless rod: a distance constraint between the
    ground's O4 and the coupler's O3."""
    m = hoeken(True)
    bodies = tuple(b for b in m.bodies if b.name != "rocker")
    joints = tuple(j for j in m.joints if j.name not in ("J3", "J4")) + (
        Joint("R", "distance", "ground", "O4", "coupler", "O3", length=0.1152),)
    loads = tuple(x for x in m.loads if x.body != "rocker")
    return dataclasses.replace(m, name="hoeken-rod", bodies=bodies, joints=joints, loads=loads,
                               cut=None, assembly_phi={"crank": 0.0, "coupler": 77.12 * DEG})


def cam_follower(speed=300 * RPM, offset=5.0, law="cycloidal"):
    """A disc cam turning on the ground (offset 5 mm, base circle 40 mm, roller 10 mm; a
    cycloidal rise of 20 mm over 100 deg, dwell 80 deg, return over 100 deg) and a translating
    roller follower on a vertical guide at the offset, pressed on the cam by a compression
    spring (2 kN/m, preload 20 N at the bottom), gravity and a damper."""
    e, rb, rf = offset, 40.0, 10.0
    d0 = math.sqrt((rb + rf) ** 2 - e ** 2)
    bodies = (body("ground", {"C": (0, 0), "G": (e, 0), "S": (e, 200)}),
              body("cam", {"C": (0, 0)}, 2.0, (3, 1), 3000.0),
              body("follower", {"F": (0, 0), "T": (0, 30)}, 0.5, (1, 15), 100.0))
    joints = (rev("J1", "ground.C", "cam.C"), pri("J2", "ground.G", "follower.F", (0, 1)),
              Joint("K", "cam", "cam", "C", "follower", "F", base_radius=rb * MM,
                    roller_radius=rf * MM, offset=e * MM, lift=20 * MM, rise=100 * DEG,
                    dwell=80 * DEG, fall=100 * DEG, law=float(laws.CODES[law])))
    loads = (spring("ground", "S", "follower", "F", 2000.0, (200 - d0) * MM + 0.01),
             damper("follower", "T", "ground", "S", 1.5))
    return Model("cam-follower", bodies, joints, (Driver("J1", ConstantSpeed(speed)),), loads,
                 GRAVITY, assembly_phi={"cam": 0.0, "follower": 0.0},
                 assembly_q={"J2": d0 * MM})


def rocker_cam(speed=300 * RPM, law="cycloidal"):
    """A disc cam turning on the ground (base circle 40 mm, roller 10 mm) and an oscillating
    roller follower: an arm pivoted on the ground at A = (120, 0) mm, its roller's centre F
    90 mm from A, swung 15 deg by a cycloidal rise over 100 deg, a dwell of 80 deg and a
    return over 100 deg; a tension spring from the ground pulls the roller on the cam, with
    gravity and a damper."""
    a, arm = 120.0, 90.0
    g0 = math.acos((50.0 ** 2 - a ** 2 - arm ** 2) / (2 * a * arm))
    bodies = (body("ground", {"C": (0, 0), "A": (a, 0), "S": (-10, -60)}),
              body("cam", {"C": (0, 0)}, 2.0, (2, -1), 3000.0),
              body("arm", {"A": (0, 0), "F": (arm, 0), "T": (40, 0)}, 0.4, (50, 6), 900.0))
    joints = (rev("J1", "ground.C", "cam.C"), rev("J2", "ground.A", "arm.A"),
              Joint("K", "rocker_cam", "cam", "C", "arm", "F", base_radius=40 * MM,
                    roller_radius=10 * MM, pivot=a * MM, arm=arm * MM, swing=15 * DEG,
                    rise=100 * DEG, dwell=80 * DEG, fall=100 * DEG, law=float(laws.CODES[law])))
    loads = (spring("ground", "S", "arm", "F", 1000.0, 0.06),
             damper("arm", "T", "ground", "S", 1.5))
    return Model("rocker-cam", bodies, joints, (Driver("J1", ConstantSpeed(speed)),), loads,
                 GRAVITY, assembly_phi={"cam": 0.0, "arm": g0})


def flat_follower(speed=300 * RPM):
    """A disc cam turning on the ground (base circle 40 mm; a cycloidal rise of 20 mm over 100
    deg, dwell 80 deg, return over 100 deg) and a translating flat-faced follower on a vertical
    guide 5 mm right of the cam's centre (its face normal to the guide, through F), pressed on
    the cam by a compression spring, with gravity and a damper."""
    e, rb = 5.0, 40.0
    bodies = (body("ground", {"C": (0, 0), "G": (e, 0), "S": (e, 200)}),
              body("cam", {"C": (0, 0)}, 2.0, (3, 1), 3000.0),
              body("follower", {"F": (0, 0), "T": (0, 30)}, 0.5, (1, 15), 100.0))
    joints = (rev("J1", "ground.C", "cam.C"), pri("J2", "ground.G", "follower.F", (0, 1)),
              Joint("K", "flat_cam", "cam", "C", "follower", "F", base_radius=rb * MM,
                    lift=20 * MM, rise=100 * DEG, dwell=80 * DEG, fall=100 * DEG,
                    law=float(laws.CODES["cycloidal"])))
    loads = (spring("ground", "S", "follower", "F", 2000.0, (200 - rb) * MM + 0.01),
             damper("follower", "T", "ground", "S", 1.5))
    return Model("flat-follower", bodies, joints, (Driver("J1", ConstantSpeed(speed)),), loads,
                 GRAVITY, assembly_phi={"cam": 0.0, "follower": 0.0},
                 assembly_q={"J2": rb * MM})


def rocker_flat(speed=300 * RPM):
    """A disc cam turning on the ground (base circle 40 mm) and an oscillating flat-faced
    follower: an arm pivoted on the ground at A = (100, 0) mm, its face 10 mm from the pivot
    towards the cam (the arm's frame: origin at the pivot, the face y = -10 mm, its normal +y),
    swung 10 deg by a cycloidal rise over 100 deg, a dwell of 80 deg and a return over 100 deg;
    a tension spring pulls the face on the cam, with gravity and a damper."""
    a, f, rb = 100.0, 10.0, 40.0
    alpha0 = math.acos((rb + f) / a)
    bodies = (body("ground", {"C": (0, 0), "A": (a, 0), "S": (-20, -35)}),
              body("cam", {"C": (0, 0)}, 2.0, (2, -1), 3000.0),
              body("arm", {"A": (0, 0), "F": (-87, -f), "T": (-40, -f)}, 0.4, (-50, -4), 900.0))
    joints = (rev("J1", "ground.C", "cam.C"), rev("J2", "ground.A", "arm.A"),
              Joint("K", "rocker_flat_cam", "cam", "C", "arm", "F", base_radius=rb * MM,
                    pivot=a * MM, offset=f * MM, swing=10 * DEG, rise=100 * DEG,
                    dwell=80 * DEG, fall=100 * DEG, law=float(laws.CODES["cycloidal"])))
    loads = (spring("ground", "S", "arm", "F", 1000.0, 0.04),
             damper("arm", "T", "ground", "S", 1.5))
    return Model("rocker-flat", bodies, joints, (Driver("J1", ConstantSpeed(speed)),), loads,
                 GRAVITY, assembly_phi={"cam": 0.0, "arm": alpha0 - math.pi / 2})


def coupled_five_bar():
    """The geared five-bar with its gear pair replaced by a coordinate coupling of the two
    ground pivots, ``q_J1 = 0.8 q_J2 + 0.2 rad``, J2 declared ground second (its q = -phi)."""
    bodies = (
        body("ground", {"O1": (0, 0), "O2": (80, 0)}),
        body("gear1", {"O1": (0, 0), "A": (25, 0)}, 0.5, (2, 1), 400.0),
        body("gear2", {"O2": (0, 0), "B": (25, 0)}, 0.5, (0, -3), 400.0),
        body("link1", {"A": (0, 0), "P": (90, 0)}, 0.2, (45, 0), 135.0),
        body("link2", {"P": (0, 0), "B": (90, 0)}, 0.2, (45, 2), 135.0),
    )
    j1, j2 = rev("J1", "ground.O1", "gear1.O1"), rev("J2", "gear2.O2", "ground.O2")
    joints = (j1, j2, couple("K", j1, j2, {b.name: b for b in bodies}, 0.8, 0.2),
              rev("J3", "gear1.A", "link1.A"), rev("J4", "gear2.B", "link2.B"),
              rev("J5", "link1.P", "link2.P"))
    loads = (force("link1", "P", 3.0, -20.0, 2.0),)
    return Model("coupled-five-bar", bodies, joints, (Driver("J1", ConstantSpeed(60 * RPM)),),
                 loads, GRAVITY, assembly_phi={"gear1": 0.0, "gear2": 0.25, "link1": 1.1,
                                               "link2": -1.1})


def coupled_carrier():
    """Two arms pinned at two points of a swinging carrier, their pins coupled:
    ``q_J1 = 2 q_J2 + 0.3 rad`` (J2 declared arm first); the carrier and J1 driven."""
    bodies = (
        body("ground", {"O": (0, 0)}),
        body("carrier", {"O": (0, 0), "P1": (60, 0), "P2": (-40, 30)}, 0.8, (10, 5), 900.0),
        body("armA", {"P1": (0, 0), "T": (50, 0)}, 0.2, (25, 0), 45.0),
        body("armB", {"P2": (0, 0), "T": (40, 0)}, 0.15, (20, 2), 25.0),
    )
    j1, j2 = rev("J1", "carrier.P1", "armA.P1"), rev("J2", "armB.P2", "carrier.P2")
    joints = (rev("J0", "ground.O", "carrier.O"), j1, j2,
              couple("K", j1, j2, {b.name: b for b in bodies}, 2.0, 0.3))
    loads = (spring("armB", "T", "ground", "O", 300.0, 0.03), force("armA", "T", 2.0, -1.0, 3.0))
    drivers = (Driver("J0", ExpressionMotion("0.6*sin(2*t)")),
               Driver("J1", ExpressionMotion("0.5 + 0.8*sin(3*t)")))
    return Model("coupled-carrier", bodies, joints, drivers, loads, GRAVITY,
                 assembly_phi={"carrier": 0.0, "armA": 0.5, "armB": -0.1})


MODELS = {
    "hoeken": hoeken,
    "hoeken-rod": hoeken_rod,
    "hoeken-massless-coupler": lambda: massless(hoeken(True), ("coupler",)),
    "slider-crank-point-masses": lambda: massless(slider_crank(), ("rod", "slider"), point=True),
    "hoeken-loaded": lambda: hoeken(True),
    "slider-crank": slider_crank,
    "slider-crank-cut-J3": lambda: slider_crank(("J3",)),
    "inverted-slider-crank": inverted_slider_crank,
    "inverted-slider-crank-cut-prismatic": lambda: inverted_slider_crank(("J3",)),
    "boom": boom,
    "boom-offset": lambda: boom(20.0),
    "stephenson": stephenson,
    "watt2": watt2,
    "five-bar": five_bar,
    "scotch-yoke": scotch_yoke,
    "slotted-lever": slotted_lever,
    "cam-follower": cam_follower,
    "rocker-cam": rocker_cam,
    "flat-follower": flat_follower,
    "rocker-flat": rocker_flat,
    "coupled-five-bar": coupled_five_bar,
    "coupled-carrier": coupled_carrier,
}


def times(model, n=17):
    """n samples over a cycle of the (first) driver, or 1.3 s for expression drivers."""
    m = model.drivers[0].motion
    span = 2 * math.pi / abs(m.speed) if isinstance(m, ConstantSpeed) and m.speed else 1.3
    return np.linspace(0.0, span, n)


_SOLUTIONS: dict = {}


def solution(name):
    """Cached solution of a named model over ``times``."""
    if name not in _SOLUTIONS:
        model = MODELS[name]()
        _SOLUTIONS[name] = analyze(model, times(model))
    return _SOLUTIONS[name]


# ----------------------------------------------------------------------------------------------
# helpers: relative differences, planar algebra


def perp(a):
    return np.stack((-a[..., 1], a[..., 0]), axis=-1)


def cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def rot(phi, v):
    """Rotate local vector(s) v (2,) by angles phi (...) -> (..., 2)."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack((c * v[0] - s * v[1], s * v[0] + c * v[1]), axis=-1)


def rel_diff(actual, expected, scale=None):
    """max |actual - expected| / peak |expected| (or ``scale``)."""
    actual, expected = np.asarray(actual, float), np.asarray(expected, float)
    assert actual.shape == expected.shape, (actual.shape, expected.shape)
    assert np.all(np.isfinite(actual)) and np.all(np.isfinite(expected))
    peak = float(np.max(np.abs(expected))) if scale is None else float(scale)
    err = float(np.max(np.abs(actual - expected))) if actual.size else 0.0
    return err / peak if peak > 0 else err


def check(actual, expected, rtol=RTOL, scale=None, what=""):
    r = rel_diff(actual, expected, scale)
    assert r <= rtol, f"{what}: relative difference {r:.3e} > {rtol:.1e}"
    return r


def force_scale(reactions_force):
    """A model-wide force scale: the largest reaction over all joints and samples, N."""
    return float(np.max(np.abs(reactions_force)))


def check_reactions(force_a, moment_a, force_b, moment_b, model, size, rtol=RTOL, what=""):
    """Per joint: force relative to that joint's peak (floored at 1e-6 of the model's largest
    reaction); prismatic moment relative to its peak (floored at that force scale x size);
    revolute moments are ~0 in both and compared on the force-scale x size."""
    fs = force_scale(force_b)
    worst = 0.0
    for k, jt in enumerate(model.joints):
        peak = max(np.max(np.abs(force_b[..., k, :])), 1e-6 * fs)
        worst = max(worst, check(force_a[..., k, :], force_b[..., k, :], rtol, peak,
                                 f"{what} force {jt.name}"))
        mpeak = np.max(np.abs(moment_b[..., k])) if jt.kind in (PRISMATIC, "coupling") else 0.0
        worst = max(worst, check(moment_a[..., k], moment_b[..., k], rtol,
                                 max(mpeak, fs * size), f"{what} moment {jt.name}"))
    return worst


def size_of(model):
    pts = np.array([p for b in model.bodies for p in b.points.values()])
    return float(np.max(np.ptp(pts, axis=0)))


# ----------------------------------------------------------------------------------------------
# independent mechanics: body states, applied loads, energies, Newton–Euler solve


@dataclasses.dataclass
class BodyState:
    phi: np.ndarray      # (T,)
    w: np.ndarray        # (T,)
    al: np.ndarray       # (T,)
    rC: np.ndarray       # (T, 2) mass centre
    vC: np.ndarray
    aC: np.ndarray
    rO: np.ndarray       # reference point (the body's tree joint point) and its velocity
    vO: np.ndarray


def body_states(sol):
    """Mass-centre position/velocity/acceleration of every moving body, computed here from the
    body's angle, angular velocity and acceleration and the motion of one point (its O_i)."""
    kin, model = sol.kin, sol.model
    out = {}
    for b in model.moving_bodies:
        i = sol.body_index(b.name)
        phi, w, al = sol.phi(b.name), sol.omega(b.name), sol.alpha(b.name)
        pname, plocal = next(iter(b.points.items()))
        rC = sol.point(b.name, pname) + rot(phi, np.asarray(b.com) - plocal)
        rO, vO, aO = kin.r[..., i, :], kin.tw[..., i, 1:], kin.twd[..., i, 1:]
        d = rC - rO
        vC = vO + w[..., None] * perp(d)
        aC = aO + al[..., None] * perp(d) - (w**2)[..., None] * d
        out[b.name] = BodyState(phi, w, al, rC, vC, aC, rO, vO)
    return out


def point_vel(st_, r):
    return st_.vO + st_.w[..., None] * perp(r - st_.rO)


def applied(sol, states):
    """Applied loads computed here: per moving body (force (T,2), moment about C (T,)), the
    potential energy (T,) and the power of the non-conservative loads (T,)."""
    model, t = sol.model, sol.t
    T = t.shape
    F = {b: np.zeros(T + (2,)) for b in states}
    Mc = {b: np.zeros(T) for b in states}
    pe, power = np.zeros(T), np.zeros(T)
    g = np.asarray(model.gravity, float)

    def add(b, f, r):
        if b in states:
            F[b] += f
            Mc[b] += cross(r - states[b].rC, f)

    for b in model.moving_bodies:
        s = states[b.name]
        F[b.name] += b.mass * g
        pe -= b.mass * (s.rC @ g)
    for ld in model.loads:
        if ld.kind == "force":
            r = sol.point(ld.body, ld.point)
            f = np.broadcast_to(ld.value(t), T + (2,))
            add(ld.body, f, r)
            if ld.body in states:
                power += np.sum(f * point_vel(states[ld.body], r), -1)
        elif ld.kind == "torque":
            tq = np.broadcast_to(ld.value(t), T)
            if ld.body in states:
                Mc[ld.body] += tq
                power += tq * states[ld.body].w
        else:
            r1, r2 = sol.point(ld.body, ld.point), sol.point(ld.body2, ld.point2)
            v1 = point_vel(states[ld.body], r1) if ld.body in states else np.zeros(T + (2,))
            v2 = point_vel(states[ld.body2], r2) if ld.body2 in states else np.zeros(T + (2,))
            d = r2 - r1
            length = np.linalg.norm(d, axis=-1)
            u = d / length[..., None]
            if ld.kind == "spring":
                tension = ld.stiffness * (length - ld.free_length)
                pe += 0.5 * ld.stiffness * (length - ld.free_length) ** 2
            else:
                rate = np.sum(u * (v2 - v1), -1)
                tension = ld.damping * rate
                power -= ld.damping * rate**2
            add(ld.body, tension[..., None] * u, r1)
            add(ld.body2, -tension[..., None] * u, r2)
    return F, Mc, pe, power


def kinetic_energy(sol, states):
    return sum(0.5 * b.mass * np.sum(states[b.name].vC ** 2, -1)
               + 0.5 * b.inertia * states[b.name].w ** 2 for b in sol.model.moving_bodies)


FACES = ("flat_cam", "rocker_flat_cam")
CAMS = ("cam", "rocker_cam") + FACES
UNKNOWNS = {REVOLUTE: 2, PRISMATIC: 2, "slot": 1, "distance": 1,
            "coupling": 1, **{k: 1 for k in CAMS}}  # per joint


def cam_of(jt):
    """The cam of ``linkdyn cam`` (:class:`linkdyn.cams.Cam`) a cam joint's numbers describe:
    rise, dwell, return, dwell (a rocker cam's lift is its arm's swing, rad)."""
    x = jt.numbers
    law = laws_name(x["law"])
    h = x["swing"] if "swing" in x else x["lift"]
    rest = 2 * math.pi - x["rise"] - x["dwell"] - x["fall"]
    segs = tuple(s for s in (Segment(law, h, x["rise"]), Segment("dwell", 0.0, x["dwell"]),
                             Segment(law, 0.0, x["fall"]), Segment("dwell", 0.0, rest))
                 if s.time > 0)
    return Cam("joint", segs, x["base_radius"], "roller", x.get("roller_radius", 0.0),
               x.get("offset", 0.0))


def follower_point(jt, s, s1=0.0):
    """The follower point F (..., 2) of a cam joint in the cam's frame at cam angle 0 when it
    has risen by ``s``, and F_theta = dF/ds s' (..., 2): ``(e, d0 + s)`` translating, ``A + L
    (cos(g0 - s), sin(g0 - s))`` oscillating (A = (pivot, 0), |F(0)| = R_b + R_f)."""
    x = jt.numbers
    rp = x["base_radius"] + x["roller_radius"]
    s, s1 = np.asarray(s, float), np.asarray(s1, float)
    if jt.kind == "cam":
        e = x["offset"]
        F = np.stack(np.broadcast_arrays(e, math.sqrt(rp * rp - e * e) + s), -1)
        return F, np.stack(np.broadcast_arrays(0.0 * s1, s1), -1)
    a, arm = x["pivot"], x["arm"]
    g = math.acos((rp * rp - a * a - arm * arm) / (2 * a * arm)) - s
    F = np.stack((a + arm * np.cos(g), arm * np.sin(g)), -1)
    return F, np.stack((arm * np.sin(g) * s1, -arm * np.cos(g) * s1), -1)


def cam_contact(jt, psi):
    """The cam angles (shape of ``psi``) of the pitch points of a cam joint at the polar angles
    ``psi`` in the cam's frame, found here by bracketing the pitch point's polar angle
    ``atan2(F(s(theta))) - theta`` (C1 of linkdyn.cams, the lift by the cam's SegmentMotion)."""
    from scipy.optimize import brentq

    cam = cam_of(jt)

    def beta(th, p):   # the pitch point's polar angle minus psi, wrapped to (-pi, pi]
        F = follower_point(jt, cam.motion.svaj(np.array([th % (2 * math.pi)]))[0][0])[0]
        return math.remainder(math.atan2(F[1], F[0]) - th - p, 2 * math.pi)

    out = np.zeros(np.shape(psi))
    F0 = follower_point(jt, 0.0)[0]
    for k, p in enumerate(np.ravel(psi)):
        th0 = math.atan2(F0[1], F0[0]) - p   # beta falls by about one turn over a turn
        out.reshape(-1)[k] = brentq(beta, th0 - 1.0, th0 + 1.0, args=(p,), xtol=1e-15,
                                    rtol=1e-15) % (2 * math.pi)
    return out


def cam_polar(phi, d):
    """The polar angle (T,) and radius (T,) of ``d`` (T, 2, global) in the frame of a cam body
    at the angle ``phi`` (T,)."""
    c, s = np.cos(phi), np.sin(phi)
    return (np.arctan2(-s * d[..., 0] + c * d[..., 1], c * d[..., 0] + s * d[..., 1]),
            np.linalg.norm(d, axis=-1))


def pitch_normal(jt, th):
    """The unit normal (..., 2) of a cam joint's pitch curve at the cam angle ``th``, pointing
    away from the cam's centre, in the cam's frame turned back by ``th`` (the frame of F):
    across the tangent C2, ``P' = R(-th) (F_theta - J F)``, so ``perp(F_theta - J F) = F + J
    F_theta`` (J the quarter turn)."""
    s0, s1 = cam_of(jt).motion.svaj(np.mod(th, 2 * math.pi))[:2]
    F, Ft = follower_point(jt, s0, s1)
    n = np.stack((F[..., 0] - Ft[..., 1], F[..., 1] + Ft[..., 0]), -1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def cam_normal(sol, jt):
    """The unit normal (T, 2) of a cam joint's pitch curve at its follower point, pointing away
    from the cam's centre, at the contact's cam angle (cam_contact), turned with the cam."""
    phi = sol.phi(jt.body_a) if jt.body_a != "ground" else np.zeros(sol.t.shape)
    psi, _ = cam_polar(phi, sol.point(jt.body_b, jt.point_b) - sol.point(jt.body_a, jt.point_a))
    th = cam_contact(jt, psi)
    n = pitch_normal(jt, th)
    c, s = np.cos(phi - th), np.sin(phi - th)
    return np.stack((c * n[..., 0] - s * n[..., 1], s * n[..., 0] + c * n[..., 1]), -1)


def face_line(jt, s):
    """A flat face's normal angle ``alpha`` and distance ``h`` from the cam's centre at the lift
    ``s``, in the cam's frame at cam angle 0: ``pi/2`` and ``R_b + s`` translating (C5 of
    linkdyn.cams); ``alpha0 - s`` and ``a cos(alpha) - f`` oscillating (pivot (a, 0), the face
    f from it), ``cos alpha0 = (R_b + f) / a``."""
    x = jt.numbers
    if jt.kind == "flat_cam":
        return math.pi / 2 + 0.0 * s, x["base_radius"] + s
    al = math.acos((x["base_radius"] + x["offset"]) / x["pivot"]) - s
    return al, x["pivot"] * np.cos(al) - x["offset"]


def support(jt, nu):
    """The cam's support function ``H(nu)`` (float), the distance from its centre of the face
    whose normal is at the angle ``nu`` in the cam's frame: the face's ``h`` at the cam angle
    where ``alpha(s(theta)) - theta = nu``, found by bracketing."""
    from scipy.optimize import brentq

    motion = cam_of(jt).motion

    def s_of(th):
        return motion.svaj(np.array([th % (2 * math.pi)]))[0][0]

    def miss(th):
        return math.remainder(face_line(jt, s_of(th))[0] - th - nu, 2 * math.pi)

    th0 = face_line(jt, 0.0)[0] - nu
    th = brentq(miss, th0 - 1.0, th0 + 1.0, xtol=1e-15, rtol=1e-15)
    return float(face_line(jt, s_of(th))[1])


def face_contact(sol, jt):
    """The face's normal n (T, 2, global: the follower's +y axis) and the contact point (T, 2,
    global) of a flat-faced cam joint: ``C + R(phi_cam) (H u + H_nu perp(u))``, u at the
    normal's angle nu in the cam's frame, ``H_nu`` by a five-point difference of
    :func:`support` (the envelope's point of tangency)."""
    phi = sol.phi(jt.body_a) if jt.body_a != "ground" else np.zeros(sol.t.shape)
    pb = sol.phi(jt.body_b)
    n = np.stack((-np.sin(pb), np.cos(pb)), -1)
    nu = pb + math.pi / 2 - phi
    h = 1e-3
    X = np.zeros(sol.t.shape + (2,))
    for k, v in enumerate(nu):
        H = [support(jt, v + j * h) for j in (-2, -1, 0, 1, 2)]
        Hn = (H[0] - 8 * H[1] + 8 * H[3] - H[4]) / (12 * h)
        u, w = np.array([math.cos(v), math.sin(v)]), np.array([-math.sin(v), math.cos(v)])
        X[k] = rot(phi[k], H[2] * u + Hn * w)
    return n, X + sol.point(jt.body_a, jt.point_a)


def joint_columns(model):
    """First column of each joint's reaction unknowns, and the number of them all."""
    start = np.cumsum([0] + [UNKNOWNS[j.kind] for j in model.joints])
    return [int(x) for x in start[:-1]], int(start[-1])


def coupling_wrench(sol, jt):
    """A coupling's wrench per unit torque on its second body about its point (the second
    coupled pin): force (T, 2) ``(sigma_1 - ratio sigma_2) (d_y, -d_x) / |d|^2`` with ``d`` the
    second pin from the first, and moment ``-ratio sigma_2``; the signs from the joints here."""
    model = sol.model
    j1, j2 = (model.joint(n) for n in jt.coupled)
    s1 = 1.0 if j1.body_b == jt.body_a else -1.0
    s2 = 1.0 if j2.body_b == jt.body_b else -1.0
    d = sol.point(jt.body_b, jt.point_b) - sol.point(jt.body_a, jt.point_a)
    k = (s1 - jt.ratio * s2) / np.sum(d * d, -1)
    f = k[..., None] * np.stack((d[..., 1], -d[..., 0]), -1)
    return f, np.broadcast_to(-jt.ratio * s2, sol.t.shape)


def ne_system(sol):
    """The simultaneous Newton–Euler equations ``K x = rhs`` of all moving bodies.

    Unknowns x: per joint (model order) — revolute ``[Fx, Fy]`` by the first body on the
    second; prismatic ``[F_n, M]`` (normal force along n = perp(axis), moment by the first on
    the second about the second body's point); slot ``[F_n]`` (normal force through the pin) —
    then one effort per driver (revolute: a moment on the second body; prismatic: a force along
    the axis through the second body's point).
    Rows per moving body: ``sum F = m a_C`` (x, y) and ``sum M_C = I_C alpha``.
    Returns K (T, 3 nb, n_unknowns + nd), rhs (T, 3 nb), the axis normals, the body states.
    """
    model = sol.model
    states = body_states(sol)
    names = [b.name for b in model.moving_bodies]
    row = {b: 3 * k for k, b in enumerate(names)}
    T = sol.t.shape
    nd = len(model.drivers)
    col, nj = joint_columns(model)
    K = np.zeros(T + (3 * len(names), nj + nd))
    rhs = np.zeros(T + (3 * len(names),))

    def put(b, col, f, x, mz=0.0):
        if b not in row:
            return
        r0 = row[b]
        K[..., r0, col] += f[..., 0]
        K[..., r0 + 1, col] += f[..., 1]
        K[..., r0 + 2, col] += cross(x - states[b].rC, f) + mz

    zero = np.zeros(T + (2,))
    normals = {}
    for k, jt in enumerate(model.joints):
        x = sol.point(jt.body_b, jt.point_b)
        c0 = col[k]
        if jt.kind == REVOLUTE:
            for c, f in ((c0, np.array([1.0, 0.0])), (c0 + 1, np.array([0.0, 1.0]))):
                f = np.broadcast_to(f, T + (2,))
                put(jt.body_b, c, f, x)
                put(jt.body_a, c, -f, x)
        elif jt.kind in FACES:
            # the contact force along the face's normal through the point of tangency
            n, X = face_contact(sol, jt)
            normals[jt.name] = (n, n, X)
            put(jt.body_b, c0, n, X)
            put(jt.body_a, c0, -n, X)
        elif jt.kind in CAMS:
            # the contact force along the pitch curve's normal through the follower point
            n = cam_normal(sol, jt)
            normals[jt.name] = (n, n)
            put(jt.body_b, c0, n, x)
            put(jt.body_a, c0, -n, x)
        elif jt.kind == "coupling":
            # the coupling torque lam on the coupled pins' bodies A and B: about B's pin, the
            # moment -ratio sigma_2 lam and the force (sigma_1 - ratio sigma_2) lam perp(d)^T / |d|^2
            # routing the shared body's reaction torque through the two pins (minus both on A)
            f, mz = coupling_wrench(sol, jt)
            normals[jt.name] = (f, f)
            put(jt.body_b, c0, f, x, mz)
            put(jt.body_a, c0, -f, x, -mz)
        elif jt.kind == "distance":
            # a rod's force along the line of its two points (applied anywhere on that line)
            d = x - sol.point(jt.body_a, jt.point_a)
            u = d / np.linalg.norm(d, axis=-1, keepdims=True)
            normals[jt.name] = (u, u)
            put(jt.body_b, c0, u, x)
            put(jt.body_a, c0, -u, x)
        else:
            phi_a = sol.phi(jt.body_a) if jt.body_a != "ground" else np.zeros(T)
            e = rot(phi_a, np.asarray(jt.axis, float) / np.linalg.norm(jt.axis))
            n = perp(e)
            normals[jt.name] = (e, n)
            put(jt.body_b, c0, n, x)
            put(jt.body_a, c0, -n, x)
            if jt.kind == PRISMATIC:
                put(jt.body_b, c0 + 1, zero, x, 1.0)
                put(jt.body_a, c0 + 1, zero, x, -1.0)
    for d, drv in enumerate(model.drivers):
        jt = model.joint(drv.joint)
        c = nj + d
        x = sol.point(jt.body_b, jt.point_b)
        if jt.kind == REVOLUTE:
            put(jt.body_b, c, zero, x, 1.0)
            put(jt.body_a, c, zero, x, -1.0)
        else:
            e = normals[jt.name][0]
            put(jt.body_b, c, e, x)
            put(jt.body_a, c, -e, x)
    F, Mc, _, _ = applied(sol, states)
    for b in model.moving_bodies:
        s, r0 = states[b.name], row[b.name]
        rhs[..., r0:r0 + 2] = b.mass * s.aC - F[b.name]
        rhs[..., r0 + 2] = b.inertia * s.al - Mc[b.name]
    return K, rhs, normals, states


def ne_solve(sol):
    """Reactions (T, nj, 2), moments (T, nj) and efforts (T, nd) from the simultaneous solve."""
    model = sol.model
    K, rhs, normals, _ = ne_system(sol)
    assert K.shape[-1] == K.shape[-2], "mobility != drivers"
    x = np.linalg.solve(K, rhs[..., None])[..., 0]
    col, n_unknowns = joint_columns(model)
    nj = len(model.joints)
    force = np.zeros(sol.t.shape + (nj, 2))
    moment = np.zeros(sol.t.shape + (nj,))
    for k, jt in enumerate(model.joints):
        c = col[k]
        if jt.kind == REVOLUTE:
            force[..., k, :] = x[..., c:c + 2]
        elif jt.kind == "coupling":
            f, mz = coupling_wrench(sol, jt)
            force[..., k, :] = x[..., c, None] * f
            moment[..., k] = x[..., c] * mz
        else:
            force[..., k, :] = x[..., c, None] * normals[jt.name][1]
            if jt.kind == PRISMATIC:
                moment[..., k] = x[..., c + 1]
            if jt.kind in FACES:   # about the follower's point: the contact's offset from it
                moment[..., k] = cross(normals[jt.name][2] - sol.point(jt.body_b, jt.point_b),
                                       force[..., k, :])
    return force, moment, x[..., n_unknowns:]


def reported_unknowns(sol):
    """The NE unknown vector assembled from linkdyn's reported reactions and efforts."""
    model = sol.model
    _, _, normals, _ = ne_system(sol)
    parts = []
    for k, jt in enumerate(model.joints):
        f = sol.reactions.force[..., k, :]
        if jt.kind == REVOLUTE:
            parts.append(f)
        elif jt.kind == PRISMATIC:
            n = normals[jt.name][1]
            parts.append(np.stack((np.sum(f * n, -1), sol.reactions.moment[..., k]), -1))
        elif jt.kind == "coupling":   # its torque, the multiplier's column
            parts.append(sol.columns[f"torque_{jt.name}"][..., None])
        else:  # a slot: the normal force only; a distance: the rod's force
            parts.append(np.sum(f * normals[jt.name][1], -1)[..., None])
    parts.append(sol.dyn.tau)
    return np.concatenate(parts, axis=-1)


# ----------------------------------------------------------------------------------------------
# a. recursive vs dense explicit matrices


@pytest.mark.parametrize("name", list(MODELS))
def test_recursive_matches_dense(name):
    sol = solution(name)
    model, kin = sol.model, sol.kin
    assert np.all(sol.valid)
    d = dense.solve(model, kin, sol.loads.w_ext)
    # N qd reproduces the twists and G^T N the closure Jacobian of the kinematics (eqs. 8, 20-24)
    check(d.twist, kin.tw, what="N qd vs twists")
    check(d.J, kin.J, 1e-12, scale=max(np.max(np.abs(kin.J)), 1.0), what="J")
    for k, drv in enumerate(model.drivers):
        check(sol.dyn.tau[..., k], d.tau[..., k], what=f"tau {drv.joint}")
    fs = force_scale(d.force)
    for k, c in enumerate(kin.layout.topo.cut):
        # a prismatic cut's moment multiplier is a moment: scale it by the force scale x size
        rows = kin.layout.topo.row_slice(k)
        check(sol.dyn.lam[..., rows], d.lam[..., rows],
              scale=max(np.max(np.abs(d.lam[..., rows])), fs * size_of(model)),
              what=f"lambda at {model.joints[c].name}")
    check_reactions(sol.reactions.force, sol.reactions.moment, d.force, d.moment, model,
                    size_of(model), what="recursive vs dense")


def test_hoeken_seed_example_is_the_paper_setup():
    """The Hoeken model really is the seed example: 1 DOF, cut at J4, no gravity, 45 rpm."""
    sol = solution("hoeken")
    topo = sol.kin.layout.topo
    assert [sol.model.joints[j].name for j in topo.cut] == ["J4"]
    assert topo.mobility == 1
    np.testing.assert_allclose(sol.kin.qd[:, 0], 4.71238898, rtol=1e-8)
    # rocker joint angle at t = 0 is -154.24 deg relative to the coupler (Table 1)
    np.testing.assert_allclose(sol.kin.q[0, 2], -154.24 * DEG, atol=2e-3)


EXAMPLES = sorted((Path(__file__).parents[1] / "src" / "linkdyn" / "examples").glob("*.toml"))


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_bundled_examples_recursive_matches_dense(path):
    from linkdyn.io import load_model

    model = load_model(path)
    sol = analyze(model, times(model, 9))
    d = dense.solve(model, sol.kin, sol.loads.w_ext)
    check(sol.dyn.tau, d.tau, what="tau")
    check_reactions(sol.reactions.force, sol.reactions.moment, d.force, d.moment, model,
                    size_of(model), what=path.stem)


# ----------------------------------------------------------------------------------------------
# b. simultaneous Newton–Euler solve


@pytest.mark.parametrize("name", list(MODELS))
def test_recursive_matches_simultaneous_newton_euler(name):
    sol = solution(name)
    model = sol.model
    force, moment, tau = ne_solve(sol)
    for k, drv in enumerate(model.drivers):
        check(sol.dyn.tau[..., k], tau[..., k], what=f"tau {drv.joint}")
    check_reactions(sol.reactions.force, sol.reactions.moment, force, moment, model,
                    size_of(model), what="recursive vs Newton–Euler")


def test_newton_euler_reference_is_not_trivially_satisfied():
    """Guard: a wrong effort (here 1 % off) must fail the Newton–Euler comparison."""
    sol = solution("hoeken-loaded")
    _, _, tau = ne_solve(sol)
    assert rel_diff(1.01 * sol.dyn.tau, tau) > 1e-3


# ----------------------------------------------------------------------------------------------
# c. power balance


def five_point_derivative(f, h):
    """d/dt at the centre of samples (..., 5) at offsets -2h, -h, 0, h, 2h (O(h^4))."""
    return (f[..., 0] - 8 * f[..., 1] + 8 * f[..., 3] - f[..., 4]) / (12 * h)


@pytest.mark.parametrize("name", list(MODELS))
def test_power_balance(name):
    model = MODELS[name]()
    centres = times(model, 9)[:-1] + 0.0123
    m0 = model.drivers[0].motion
    speed = max(abs(m0.speed) if isinstance(m0, ConstantSpeed) else 3.0, 1.0)
    h = 2e-3 / speed
    offsets = np.arange(-2, 3) * h
    t = (centres[:, None] + offsets).reshape(-1)
    sol = analyze(model, t)
    states = body_states(sol)
    _, _, pe, p_nc = applied(sol, states)
    ke = kinetic_energy(sol, states)
    # the solver's own energy terms agree with the ones computed here
    check(sol.dyn.kinetic_energy, ke, 1e-12, what="kinetic energy")
    if sol.loads.has_potential:
        check(sol.loads.potential_energy - pe, np.zeros_like(pe), 1e-12,
              scale=np.ptp(pe) + np.max(ke), what="potential energy (up to a constant)")
    check(sol.loads.power, p_nc, 1e-12, scale=np.max(np.abs(p_nc)) + 1e-300, what="load power")
    qd = sol.kin.qd[:, [[j.name for j in model.joints].index(d.joint) for d in model.drivers]]
    p_drv = np.sum(sol.dyn.tau * qd, -1)
    check(sol.driver_power, p_drv, 1e-13, what="driver power")
    energy = (ke + pe).reshape(len(centres), 5)
    dEdt = five_point_derivative(energy, h)
    mid = (slice(None), 2)
    lhs = (p_drv + p_nc).reshape(len(centres), 5)[mid]
    scale = max(np.max(np.abs(p_drv)), np.max(np.abs(p_nc)), np.max(np.abs(dEdt)))
    check(lhs, dEdt, 1e-7, scale=scale, what="driver + load power vs dE/dt")


# ----------------------------------------------------------------------------------------------
# d. statics by virtual work


def static_model(model, sol, k, shift=None):
    """``model`` held at rest at sample k (drivers constant), optionally with one driver
    displaced: ``shift = (driver index, dq)``; the sample's pose is the assembly guess."""
    jnames = [j.name for j in model.joints]
    drivers = []
    for d, drv in enumerate(model.drivers):
        q = float(sol.kin.q[k, jnames.index(drv.joint)])
        if shift is not None and shift[0] == d:
            q += shift[1]
        drivers.append(Driver(drv.joint, ExpressionMotion(repr(q))))
    return dataclasses.replace(
        model, drivers=tuple(drivers),
        assembly_phi={b.name: float(sol.phi(b.name)[k]) for b in model.moving_bodies},
        assembly_q={j.name: float(sol.kin.q[k, n]) for n, j in enumerate(model.joints)})


def load_geometry(sol):
    """Application points (T, K, 2) with their forces (T, K, 2), torqued bodies' angles (T, L)
    with torques (T, L), and the spring potential (T,), at rest (dampers exert nothing)."""
    model, t = sol.model, sol.t
    pts, fs, angs, tqs = [], [], [], []
    pe_spring = np.zeros(t.shape)
    g = np.asarray(model.gravity, float)
    for b in model.moving_bodies:
        pname, plocal = next(iter(b.points.items()))
        pts.append(sol.point(b.name, pname) + rot(sol.phi(b.name), np.asarray(b.com) - plocal))
        fs.append(np.broadcast_to(b.mass * g, t.shape + (2,)))
    for ld in model.loads:
        if ld.kind == "force" and ld.body != "ground":
            pts.append(sol.point(ld.body, ld.point))
            fs.append(np.broadcast_to(ld.value(t), t.shape + (2,)))
        elif ld.kind == "torque" and ld.body != "ground":
            angs.append(sol.phi(ld.body))
            tqs.append(np.broadcast_to(ld.value(t), t.shape))
        elif ld.kind == "spring":
            d = sol.point(ld.body2, ld.point2) - sol.point(ld.body, ld.point)
            pe_spring += 0.5 * ld.stiffness * (np.linalg.norm(d, axis=-1) - ld.free_length) ** 2
    stack = lambda xs, tail: np.stack(xs, axis=-2 if tail else -1) if xs else np.zeros(
        t.shape + ((0, 2) if tail else (0,)))
    return stack(pts, True), stack(fs, True), stack(angs, False), stack(tqs, False), pe_spring


@pytest.mark.parametrize("name", ["hoeken-loaded", "slider-crank", "inverted-slider-crank",
                                  "boom", "stephenson", "watt2", "five-bar", "slotted-lever"])
def test_statics_by_virtual_work(name):
    model = MODELS[name]()
    dyn_sol = solution(name)
    for k in (3, 10):
        t = dyn_sol.t[k:k + 1]
        rest = analyze(static_model(model, dyn_sol, k), t)
        assert np.all(rest.kin.qd == 0) and np.all(rest.kin.qdd == 0)
        np.testing.assert_allclose(rest.kin.q, dyn_sol.kin.q[k:k + 1], atol=1e-9)
        _, F, _, T_, _ = load_geometry(rest)
        for d, drv in enumerate(model.drivers):
            h = 1e-3 if model.joint(drv.joint).kind == REVOLUTE else 1e-4 * size_of(model)
            geo = [load_geometry(analyze(static_model(model, dyn_sol, k, (d, s * h)), t))
                   for s in (-2, -1, 0, 1, 2)]
            dX = five_point_derivative(np.stack([g[0] for g in geo], -1), h)      # (1, K, 2)
            dA = five_point_derivative(np.stack([g[2] for g in geo], -1), h)      # (1, L)
            dV = five_point_derivative(np.stack([g[4] for g in geo], -1), h)      # (1,)
            # principle of virtual work: tau dq + sum F . dr + sum T dphi - dV = 0
            terms = np.concatenate((np.sum(F * dX, -1), T_ * dA, -dV[..., None]), -1)
            expected = -np.sum(terms, -1)
            scale = max(np.sum(np.abs(terms)), abs(rest.dyn.tau[0, d]))
            check(rest.dyn.tau[..., d], expected, 1e-8, scale=scale,
                  what=f"static effort {drv.joint} at sample {k}")


# ----------------------------------------------------------------------------------------------
# e. action = reaction, wrench balance with the reported values


def reversed_model(model):
    """Every joint's connect order reversed (prismatic axes re-expressed in the new first body);
    drivers' motions negated, since q changes sign."""
    joints = []
    for jt in model.joints:
        if jt.kind == REVOLUTE:
            joints.append(Joint(jt.name, REVOLUTE, jt.body_b, jt.point_b, jt.body_a, jt.point_a))
        else:
            axis = rot(np.asarray(-jt.angle), np.asarray(jt.axis, float))
            joints.append(Joint(jt.name, PRISMATIC, jt.body_b, jt.point_b, jt.body_a,
                                jt.point_a, axis, -jt.angle))
    drivers = []
    for drv in model.drivers:
        m = drv.motion
        neg = (ConstantSpeed(-m.speed, -m.start) if isinstance(m, ConstantSpeed)
               else ExpressionMotion(f"-({m.text})"))
        drivers.append(Driver(drv.joint, neg))
    return dataclasses.replace(model, joints=tuple(joints), drivers=tuple(drivers),
                               assembly_q={k: -v for k, v in model.assembly_q.items()})


REVERSIBLE = ["hoeken-loaded", "slider-crank", "slider-crank-cut-J3", "inverted-slider-crank",
              "inverted-slider-crank-cut-prismatic", "boom", "boom-offset", "stephenson",
              "five-bar"]


@pytest.mark.parametrize("name", REVERSIBLE)
def test_action_equals_reaction(name):
    """Reversing a joint's connect order reports what B exerts on A: the opposite force, and for
    a prismatic joint the opposite moment carried to A's point; efforts change sign.

    A driven prismatic joint's actuator force acts along the axis through the second body's
    point, which the reversal moves to the old first body's point: the reported moment then
    also changes by the actuator's moment ``-(r_Pb - r_Pa) x tau e``."""
    sol = solution(name)
    model = sol.model
    rev_sol = analyze(reversed_model(model), sol.t)
    np.testing.assert_allclose(rev_sol.kin.q, -sol.kin.q, atol=1e-9)
    check(rev_sol.dyn.tau, -sol.dyn.tau, what="efforts")
    expected_moment = -sol.reactions.moment.copy()
    _, _, normals, _ = ne_system(sol)
    efforts = {drv.joint: sol.dyn.tau[..., d] for d, drv in enumerate(model.drivers)}
    for k, jt in enumerate(model.joints):
        if jt.kind == PRISMATIC:
            arm = sol.point(jt.body_b, jt.point_b) - sol.point(jt.body_a, jt.point_a)
            total = sol.reactions.force[..., k, :]
            if jt.name in efforts:
                total = total + efforts[jt.name][..., None] * normals[jt.name][0]
            expected_moment[..., k] -= cross(arm, total)
    check_reactions(rev_sol.reactions.force, rev_sol.reactions.moment,
                    -sol.reactions.force, expected_moment, model, size_of(model),
                    what="reversed connect")


@pytest.mark.parametrize("name", list(MODELS))
def test_body_wrench_balance_with_reported_reactions(name):
    """Every moving body: sum of reported joint reactions, driver efforts and applied loads
    equals m a_C and I_C alpha; revolute joints report no moment; prismatic reactions are
    normal to the axis."""
    sol = solution(name)
    model = sol.model
    K, rhs, normals, _ = ne_system(sol)
    x = reported_unknowns(sol)
    residual = np.einsum("...ij,...j->...i", K, x) - rhs
    # each row relative to the peak of the magnitudes of its terms
    terms = np.einsum("...ij,...j->...i", np.abs(K), np.abs(x)) + np.abs(rhs)
    rel = np.max(np.abs(residual), axis=0) / np.max(terms, axis=0)
    assert np.max(rel) <= RTOL, f"wrench balance residual {np.max(rel):.3e}"
    fs = force_scale(sol.reactions.force)
    for k, jt in enumerate(model.joints):
        if jt.kind in FACES:  # a face's: the contact force's about the follower's point
            X = normals[jt.name][2] - sol.point(jt.body_b, jt.point_b)
            assert np.max(np.abs(sol.reactions.moment[..., k] - cross(
                X, sol.reactions.force[..., k, :]))) <= RTOL * fs * size_of(model)
        elif jt.kind not in (PRISMATIC, "coupling"):  # revolute and slot joints carry none
            assert np.max(np.abs(sol.reactions.moment[..., k])) <= RTOL * fs * size_of(model)
        if jt.kind in ("distance", "coupling") + CAMS:
            # a rod's reaction along the rod, a cam's along the normal, a coupling's across the
            # line of its pins
            u = normals[jt.name][0]
            u = u / np.linalg.norm(u, axis=-1, keepdims=True)
            across = cross(u, sol.reactions.force[..., k, :])
            assert np.max(np.abs(across)) <= RTOL * fs
        elif jt.kind != REVOLUTE:  # prismatic and slot reactions are normal to the axis
            e = normals[jt.name][0]
            along = np.sum(sol.reactions.force[..., k, :] * e, -1)
            assert np.max(np.abs(along)) <= RTOL * fs


# ----------------------------------------------------------------------------------------------
# f. property-based: random Grashof crank-rockers


def _circle_intersection(c1, r1, c2, r2, up):
    d = c2 - c1
    L = np.linalg.norm(d)
    a = (r1**2 - r2**2 + L**2) / (2 * L)
    h = math.sqrt(max(r1**2 - a**2, 0.0))
    u = d / L
    return c1 + a * u + (1 if up else -1) * h * np.array([-u[1], u[0]])


def _floats(draw):
    """``f(lo, hi)``: a finite float drawn in [lo, hi]."""
    return lambda lo, hi: draw(st.floats(lo, hi, allow_nan=False, allow_infinity=False))


def _placed_bodies(f, ground, links):
    """The ground with its points, and each link of ``links`` (name, {point: global position},
    length) with its points expressed in a randomly placed body frame and random mass, mass
    centre and inertia. Returns the bodies and each link's frame angle (the assembly guess)."""
    bodies, angles = [Body("ground", ground)], {}
    for name, pts, length in links:
        phi, o = f(-math.pi, math.pi), np.array([f(-0.3, 0.3), f(-0.3, 0.3)])
        m = f(0.1, 5.0)
        com = np.array([f(-1, 1), f(-1, 1)]) * length   # the frame origin is at o
        bodies.append(Body(name, {k: rot(np.asarray(-phi), v - o) for k, v in pts.items()}, m,
                           com, m * length**2 * f(0.01, 0.5)))
        angles[name] = phi
    return bodies, angles


@st.composite
def crank_rockers(draw):
    """A random crank-rocker (Grashof, crank shortest and adjacent to the ground) assembled at
    t = 0 by construction: the joint positions are computed first, then each body's points are
    expressed in a randomly placed body frame."""
    f = _floats(draw)
    a = f(0.02, 0.2)                                   # crank
    d = a * f(2.0, 4.0)                                # ground
    # coupler b, rocker c: b + c >= 1.15 (d + a) and |b - c| <= 0.8 (d - a) keep both
    # dead-centre positions (coupler and rocker collinear) away from the crank's turn
    s = (d + a) * f(1.15, 1.9)
    diff = (d - a) * 0.8 * f(-1.0, 1.0)
    b, c = (s + diff) / 2, (s - diff) / 2
    O1 = np.array([f(-0.5, 0.5), f(-0.5, 0.5)])
    beta = f(-math.pi, math.pi)
    O4 = O1 + d * np.array([math.cos(beta), math.sin(beta)])
    gamma = f(-math.pi, math.pi)
    A = O1 + a * np.array([math.cos(gamma), math.sin(gamma)])
    B = _circle_intersection(A, b, O4, c, draw(st.booleans()))
    bodies, frames = _placed_bodies(f, {"O1": O1, "O4": O4}, (
        ("crank", {"O1": O1, "A": A}, a), ("coupler", {"A": A, "B": B}, b),
        ("rocker", {"B": B, "O4": O4}, c)))
    specs = [("J1", "ground.O1", "crank.O1"), ("J2", "crank.A", "coupler.A"),
             ("J3", "coupler.B", "rocker.B"), ("J4", "ground.O4", "rocker.O4")]
    joints = []
    for k, (name, p, q) in enumerate(specs):
        if k > 0 and draw(st.booleans()):
            p, q = q, p                                 # child-first connect order
        joints.append(rev(name, p, q))
    speed = f(1.0, 20.0) * draw(st.sampled_from([-1.0, 1.0]))
    gravity = np.array([f(-20, 20), f(-20, 20)])
    # q_J1 = phi_crank - phi_ground (or its opposite if the connect order was reversed)
    q1 = frames["crank"] if joints[0].body_b == "crank" else -frames["crank"]
    s1 = 1.0 if joints[0].body_b == "crank" else -1.0
    model = Model("random crank-rocker", tuple(bodies), tuple(joints),
                  (Driver("J1", ConstantSpeed(s1 * speed, q1)),), (), gravity,
                  assembly_phi=frames,
                  cut=(draw(st.sampled_from(["J2", "J3", "J4"])),))
    return model, {"A": A, "B": B}, abs(speed)


def check_against_references(sol, size):
    """The recursive efforts and reactions of ``sol`` against the dense explicit-matrix form and
    the simultaneous Newton–Euler solve."""
    model = sol.model
    d = dense.solve(model, sol.kin, sol.loads.w_ext)
    force, moment, tau = ne_solve(sol)
    check(sol.dyn.tau, d.tau, what="tau recursive vs dense")
    check(sol.dyn.tau, tau, what="tau recursive vs Newton–Euler")
    check_reactions(sol.reactions.force, sol.reactions.moment, d.force, d.moment, model, size,
                    what="recursive vs dense")
    check_reactions(sol.reactions.force, sol.reactions.moment, force, moment, model, size,
                    what="recursive vs Newton–Euler")


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(crank_rockers())
def test_random_crank_rockers(case):
    model, assembled, speed = case
    t = np.linspace(0.0, 2 * math.pi / speed, 7)
    sol = analyze(model, t)
    # the solver assembled the mechanism where it was built
    size = size_of(model)
    for body_, p in (("coupler", "A"), ("coupler", "B")):
        np.testing.assert_allclose(sol.point(body_, p)[0], assembled[p], atol=1e-9 * size)
    check_against_references(sol, size)


@st.composite
def slider_cranks(draw):
    """A random offset slider-crank on a slide of random direction, its slider at a random fixed
    angle to the slide, the prismatic joint written in either order, cut at a random joint (the
    slider or a pin), assembled at t = 0 by construction, with gravity and a load on the slider."""
    f = _floats(draw)
    a = f(0.02, 0.2)                                   # crank
    rod = a * f(2.5, 5.0)                              # connecting rod
    off = (rod - a) * 0.6 * f(-1.0, 1.0)               # slide offset: the crank never toggles
    O = np.array([f(-0.5, 0.5), f(-0.5, 0.5)])
    beta = f(-math.pi, math.pi)
    u = np.array([math.cos(beta), math.sin(beta)])
    n = np.array([-u[1], u[0]])
    G = O + off * n                                    # a point of the slide line
    gamma = f(-math.pi, math.pi)
    A = O + a * np.array([math.cos(gamma), math.sin(gamma)])
    foot = G + np.dot(A - G, u) * u
    B = foot + (1 if draw(st.booleans()) else -1) * math.sqrt(rod**2 - np.dot(A - foot, A - foot)) * u
    bodies, frames = _placed_bodies(f, {"O": O, "G": G}, (
        ("crank", {"O": O, "A": A}, a), ("rod", {"A": A, "B": B}, rod),
        ("slider", {"B": B, "F": B + 0.05 * u}, 0.05)))
    phi_s = frames["slider"]
    if draw(st.booleans()):     # line fixed in the ground: q = (B - G) . u
        slide = pri("J4", "ground.G", "slider.B", u, phi_s)
        q4 = float(np.dot(B - G, u))
    else:                       # line fixed in the slider: q = (G - B) . u
        slide = pri("J4", "slider.B", "ground.G", rot(np.asarray(-phi_s), u), -phi_s)
        q4 = float(np.dot(G - B, u))
    joints = (rev("J1", "ground.O", "crank.O"), rev("J2", "crank.A", "rod.A"),
              rev("J3", "rod.B", "slider.B"), slide)
    speed = f(1.0, 20.0) * draw(st.sampled_from([-1.0, 1.0]))
    loads = (force("slider", "F", f(-50, 50), f(-50, 50), 3.0),)
    model = Model("random slider-crank", tuple(bodies), joints,
                  (Driver("J1", ConstantSpeed(speed, frames["crank"])),), loads,
                  np.array([f(-20, 20), f(-20, 20)]),
                  assembly_phi=frames, assembly_q={"J4": q4},
                  cut=(draw(st.sampled_from(["J2", "J3", "J4"])),))
    return model, {"A": A, "B": B}, abs(speed)


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(slider_cranks())
def test_random_slider_cranks(case):
    model, assembled, speed = case
    t = np.linspace(0.0, 2 * math.pi / speed, 7)
    sol = analyze(model, t)
    size = size_of(model)
    for p in ("A", "B"):
        np.testing.assert_allclose(sol.point("rod", p)[0], assembled[p], atol=1e-9 * size)
    check_against_references(sol, size)


# ----------------------------------------------------------------------------------------------
# g. batch equals loop


@pytest.mark.parametrize("name", ["hoeken-loaded", "inverted-slider-crank", "five-bar",
                                  "stephenson", "slotted-lever"])
def test_batch_equals_loop(name):
    model = MODELS[name]()
    t = times(model, 5)[:4] * 0.25                     # a quarter of the cycle, 4 samples
    batch = analyze(model, t)
    fields = lambda s: {"q": s.kin.q, "qd": s.kin.qd, "qdd": s.kin.qdd, "tau": s.dyn.tau,
                        "lam": s.dyn.lam, "force": s.reactions.force,
                        "moment": s.reactions.moment, "ke": s.dyn.kinetic_energy}
    whole = fields(batch)
    singles = [fields(analyze(model, t[k:k + 1])) for k in range(len(t))]
    for key, value in whole.items():
        loop = np.concatenate([s[key] for s in singles], axis=0)
        scale = max(np.max(np.abs(value)), 1e-300)
        if key == "moment":
            scale = max(scale, force_scale(whole["force"]) * size_of(model))
        # the closure is solved to a residual of 1e-12 of the mechanism's size along two different
        # Newton paths (continuation vs. assembly), so positions, and with them everything else,
        # may differ by a few 1e-12
        check(loop, value, 1e-11, scale=scale, what=f"batch vs loop {key}")
