"""Cost of a cam in ``analyze``: the bundled cam-driven four-bar (``cam_fourbar``: a disc cam
swinging a roller follower's arm, the arm the input of a four-bar) against the same four-bar
driven at its input by the same motion (a segments driver: the arm's designed swing in time),
on one backend, in the same run (a ratio: the machine's speed cancels out).

Prints samples per second of each, their ratio (issue 26's target: at least 0.5 on the
compiled backend), and the kinematics' share of each run (where a cam's contact is solved:
the closure's Newton iterations, each finding the contact's cam angle once per pose by the
cam's ``locate``, its own Newton iterations, for the cam's steps that read it).

Usage: python benchmarks/bench_cam.py [--samples N] [--repeat R] [--backend B]
       [--clock wall|cpu]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import dataclasses  # noqa: E402
import math  # noqa: E402

import numpy as np  # noqa: E402

import linkdyn  # noqa: E402
from linkdyn import kinematics  # noqa: E402
from linkdyn.joints.cam import laws_name  # noqa: E402
from linkdyn.joints.rocker_cam import start_angle  # noqa: E402
from linkdyn.model import Driver  # noqa: E402
from linkdyn.motion import Segment, SegmentMotion  # noqa: E402
from ratio import best_time, options, verdict  # noqa: E402

TARGET_RATIO = 0.5   # issue 26: a cam-driven four-bar at least half the plain four-bar's speed


def plain_fourbar(cam):
    """The four-bar of ``cam`` (the ``cam_fourbar`` example) without its cam: the arm driven
    by a segments driver through the swing the cam gives it (from the arm's angle at the
    bottom of the swing), in the cam's time at its speed."""
    k = cam.joint("K")
    x, w = k.numbers, cam.drivers[0].motion.speed
    g0 = float(start_angle(x))
    rest = 2 * math.pi - x["rise"] - x["dwell"] - x["fall"]
    law = laws_name(x["law"])
    segs = (Segment(law, g0 - x["swing"], x["rise"] / w), Segment("dwell", 0.0, x["dwell"] / w),
            Segment(law, g0, x["fall"] / w), Segment("dwell", 0.0, rest / w))
    return dataclasses.replace(
        cam, name="plain four-bar", bodies=tuple(b for b in cam.bodies if b.name != "cam"),
        joints=tuple(j for j in cam.joints if j.name not in ("J1", "K")),
        drivers=(Driver("J2", SegmentMotion(g0, segs)),), cut=None,
        assembly_phi={**{n: v for n, v in cam.assembly_phi.items() if n != "cam"}, "arm": g0})



def main():
    args = options(__doc__)
    clock = args.time
    cam = linkdyn.load(linkdyn.example_path("cam_fourbar"))
    plain = plain_fourbar(cam)
    t = np.linspace(0.0, 2 * math.pi / cam.drivers[0].motion.speed, args.samples)
    # the reference is the same four-bar: the arm's angle of both runs agrees (checked before
    # anything is timed; the cam starts at 7.5 deg, the plain drive at the rise's start)
    t0 = math.radians(7.5) / cam.drivers[0].motion.speed
    a = linkdyn.analyze(cam, t[:200], backend=args.backend)
    b = linkdyn.analyze(plain, t[:200] + t0, backend=args.backend)
    worst = float(np.max(np.abs(a.columns["phi_arm"] - b.columns["phi_arm"])))
    assert worst < 1e-9, f"the plain four-bar does not follow the cam's arm: {worst:.3g} rad"
    print(f"cam-driven four-bar against the same four-bar driven at its input, {args.samples} "
          f"samples, backend {args.backend}, {args.clock} clock")
    speed = {}
    for name, m in (("plain four-bar", plain), ("cam-driven four-bar", cam)):
        full = best_time(lambda: linkdyn.analyze(m, t, backend=args.backend), args.repeat, clock)
        kin = best_time(lambda: kinematics.solve(m, t, backend=args.backend), args.repeat,
                        clock)
        speed[name] = args.samples / full
        print(f"  {name:22s} {speed[name]:12.4g} samples/s   (kinematics "
              f"{100 * kin / full:4.0f} % of it)")
    ratio = speed["cam-driven four-bar"] / speed["plain four-bar"]
    print(verdict(ratio, TARGET_RATIO))


if __name__ == "__main__":
    main()
