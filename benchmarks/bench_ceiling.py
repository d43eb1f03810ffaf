"""How fast can Hoeken's kinematics go at all on this machine, on one core?

The throughput target of ``make bench`` (5e6 samples/s for the kinematics of every joint and
body) is measured against a general solver. This script measures a ceiling for it: the same
kinematics written out by hand for this one four-bar as a compiled (numba) kernel, with none of
the general solver's machinery (no layout, no continuation nodes, no dyad dispatch, the branch
fixed once), storing per sample only the numbers that are not redundant:

- q, qd, qdd of the four joints (12);
- for each of the three moving bodies: angle, its cosine and sine, origin x and y; angular
  velocity, origin velocity x, y; angular acceleration, origin acceleration x, y (33);
- the closure residual and the relative pivot of the rate system (2).

47 numbers per sample, where the general kernel stores 75 (its ground rows, the zero slider
axes of revolute joints and the closure Jacobian besides). The outputs are staged through a
small block buffer so that they are written row by row, the fastest order measured here.
Every output is checked against linkdyn's kinematics before timing.

It prints the ceiling's samples per second into fresh outputs (as a user's call gets them)
and into outputs already touched, beside linkdyn's compiled kinematics measured in the same run.

Usage: python benchmarks/bench_ceiling.py [--samples N]   (needs numba: pip install 'linkdyn[fast]')
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402

import numba  # noqa: E402
import numpy as np  # noqa: E402

import linkdyn  # noqa: E402
from linkdyn import kinematics  # noqa: E402
from linkdyn.kinematics import compile_layout  # noqa: E402

TARGET_KINEMATICS = 5e6   # samples/s, issue 2
BUF = 64                  # samples staged before the row-by-row write
# output rows: q, qd, qdd of J1..J4; per body (crank, coupler, rocker) phi, c, s, x, y,
# omega, vx, vy, alpha, ax, ay; then residual, pivot
ROWS = 12 + 33 + 2


@numba.njit(inline="always")
def body(buf, m, k, phi, c, s, x, y, w, vx, vy, al, ax, ay):
    """A body's 11 rows from row m: angle, cosine, sine, origin, twist, twist rate."""
    buf[m, k], buf[m + 1, k], buf[m + 2, k], buf[m + 3, k], buf[m + 4, k] = phi, c, s, x, y
    buf[m + 5, k], buf[m + 6, k], buf[m + 7, k] = w, vx, vy
    buf[m + 8, k], buf[m + 9, k], buf[m + 10, k] = al, ax, ay


@numba.njit(error_model="numpy")
def hoeken(t, w, u, v, pa, pb, side, size, out):
    """Hoeken's kinematics at the times ``t`` (T,), crank at constant speed ``w`` from 0.

    ``u``: the coupler pin on the crank, ``v``: the rocker pin on the coupler, ``pb``: the
    ground pin on the rocker (each in its body's frame, the body's origin at its pin on the
    previous body); ``pa``: the ground pin. ``side``: +1 or -1, the assembly branch of the
    rocker pin left or right of the line from the coupler pin to ``pa``. ``out`` (ROWS, T).
    """
    b, c = math.sqrt(v[0] ** 2 + v[1] ** 2), math.sqrt(pb[0] ** 2 + pb[1] ** 2)
    vxh, vyh, pbxh, pbyh = v[0] / b, v[1] / b, pb[0] / c, pb[1] / c
    phi_v, phi_pb = math.atan2(v[1], v[0]), math.atan2(pb[1], pb[0])
    buf = np.empty((ROWS, BUF))
    T = t.shape[0]
    for t0 in range(0, T, BUF):
        nb = min(BUF, T - t0)
        for k in range(nb):
            # crank: phi1 = w t; the coupler pin R2 = R(phi1) u
            p1 = w * t[t0 + k]
            c1, s1 = math.cos(p1), math.sin(p1)
            r2x, r2y = c1 * u[0] - s1 * u[1], s1 * u[0] + c1 * u[1]
            # rocker pin R3: |R3 - R2| = b, |pa - R3| = c (circle intersection)
            dx, dy = pa[0] - r2x, pa[1] - r2y
            d = math.sqrt(dx * dx + dy * dy)
            kk = (b * b - c * c + d * d) / (2 * d)
            h = math.sqrt(b * b - kk * kk)
            r3x, r3y = r2x + (kk * dx - side * h * dy) / d, r2y + (kk * dy + side * h * dx) / d
            # coupler and rocker angles from the directions of their pins
            e2x, e2y, e3x, e3y = r3x - r2x, r3y - r2y, pa[0] - r3x, pa[1] - r3y
            c2, s2 = (e2x * vxh + e2y * vyh) / b, (e2y * vxh - e2x * vyh) / b
            c3, s3 = (e3x * pbxh + e3y * pbyh) / c, (e3y * pbxh - e3x * pbyh) / c
            p2, p3 = math.atan2(e2y, e2x) - phi_v, math.atan2(e3y, e3x) - phi_pb
            # rates: w2 perp(e2) + w3 perp(e3) = -w perp(R2)
            det = e2x * e3y - e2y * e3x
            w2 = w * (r2y * e3x - r2x * e3y) / det
            w3 = w * (r2x * e2y - r2y * e2x) / det
            # accelerations: al2 perp(e2) + al3 perp(e3) = w^2 R2 + w2^2 e2 + w3^2 e3
            fx = w * w * r2x + w2 * w2 * e2x + w3 * w3 * e3x
            fy = w * w * r2y + w2 * w2 * e2y + w3 * w3 * e3y
            al2 = (fx * e3x + fy * e3y) / det
            al3 = -(fx * e2x + fy * e2y) / det
            # origin velocities and accelerations (crank origin fixed)
            v2x, v2y = -w * r2y, w * r2x
            v3x, v3y = v2x - w2 * e2y, v2y + w2 * e2x
            a2x, a2y = -w * w * r2x, -w * w * r2y
            a3x, a3y = a2x - al2 * e2y - w2 * w2 * e2x, a2y + al2 * e2x - w2 * w2 * e2y
            # closure residual and the relative pivot of [perp(e2) perp(e3)], pivoting rows
            res = max(abs(r3x + c3 * pb[0] - s3 * pb[1] - pa[0]),
                      abs(r3y + s3 * pb[0] + c3 * pb[1] - pa[1])) / size
            first = max(abs(e2x), abs(e2y))
            piv = min(first, abs(det) / first) / max(first, abs(e3x), abs(e3y))
            # stored one by one (a tuple indexed in a loop is 2-3 times slower)
            buf[0, k], buf[1, k], buf[2, k], buf[3, k] = p1, p2 - p1, p3 - p2, p3
            buf[4, k], buf[5, k], buf[6, k], buf[7, k] = w, w2 - w, w3 - w2, w3
            buf[8, k], buf[9, k], buf[10, k], buf[11, k] = 0.0, al2, al3 - al2, al3
            body(buf, 12, k, p1, c1, s1, 0.0, 0.0, w, 0.0, 0.0, 0.0, 0.0, 0.0)
            body(buf, 23, k, p2, c2, s2, r2x, r2y, w2, v2x, v2y, al2, a2x, a2y)
            body(buf, 34, k, p3, c3, s3, r3x, r3y, w3, v3x, v3y, al3, a3x, a3y)
            buf[45, k], buf[46, k] = res, piv
        for m in range(ROWS):
            for k in range(nb):
                out[m, t0 + k] = buf[m, k]


def check(out, mech, t):
    """Every output row against linkdyn's kinematics (angles modulo 2 pi)."""
    sol = kinematics.solve(mech, t, backend="numpy")
    n = 3
    ref = [x for rows in sol.joint_motion for x in rows]
    for i in range(1, n + 1):
        ref += [sol.pose.phi[i], sol.pose.c[i], sol.pose.s[i], *sol.pose.r[i], *sol.twists[i],
                *sol.rates[i]]
    for m, x in enumerate(ref):
        x = np.broadcast_to(x, t.shape)
        diff = out[m] - x
        if m in (0, 1, 2, 3, 12, 23, 34):   # angles: modulo 2 pi
            diff = (diff + np.pi) % (2 * np.pi) - np.pi
        scale = max(np.abs(x).max(), 1.0 if m in (0, 1, 2, 3, 12, 23, 34) else 1e-300)
        assert np.abs(diff).max() <= 1e-9 * scale, f"row {m}: {np.abs(diff).max()}"
    assert np.all(out[45] < 1e-12) and np.all(out[46] > 1e-3), "residual, pivot"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})
    mech = linkdyn.load(linkdyn.example_path("hoeken"))
    lay = compile_layout(mech)
    (cut,) = lay.cuts
    u, v, pa, pb = lay.joint_point[2], lay.joint_point[3], cut.pa, cut.pb
    assert not np.any(lay.joint_point[1]), "the kernel takes the crank pivot at the origin"
    w = mech.drivers[0].motion.speed
    # the branch of the assembled mechanism at t = 0
    s0 = kinematics.solve(mech, np.zeros(1), backend="numpy")
    r2, r3 = s0.pose.r[2][:, 0], s0.pose.r[3][:, 0]
    (dx, dy), (ex, ey) = pa - r2, r3 - r2
    side = float(np.sign(dx * ey - dy * ex))
    T = args.samples
    t = np.linspace(0.0, mech.drivers[0].period, T)

    def run(out):
        hoeken(t, w, u, v, pa, pb, side, float(lay.size), out)
        return out
    tc = np.linspace(-0.3, 1.2, 2001) * mech.drivers[0].period
    hoeken(tc, w, u, v, pa, pb, side, float(lay.size), small := np.empty((ROWS, len(tc))))
    check(small, mech, tc)

    def best(fn):
        times = []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            fn()
            times.append(time.perf_counter() - t0)
        return min(times)
    touched = run(np.zeros((ROWS, T)))
    fresh = best(lambda: run(np.empty((ROWS, T))))
    warm = best(lambda: run(touched))
    kinematics.solve(mech, t[:1000], backend="compiled")   # compile once
    general = best(lambda: kinematics.solve(mech, t, backend="compiled"))
    print(f"Hoeken four-bar, {T} samples, one core, best of {args.repeat}")
    print(f"ceiling: hand-written compiled kernel for this one four-bar, {ROWS} numbers per sample")
    print(f"  into fresh outputs       {T / fresh:12.4g} samples/s  ({fresh / T * 1e9:5.0f} ns/sample)"
          f"   target {TARGET_KINEMATICS:.0e} {'met' if T / fresh >= TARGET_KINEMATICS else 'NOT met'}")
    print(f"  into outputs touched     {T / warm:12.4g} samples/s  ({warm / T * 1e9:5.0f} ns/sample)")
    print(f"linkdyn compiled kinematics {T / general:11.4g} samples/s  ({general / T * 1e9:5.0f} ns/sample),"
          f" {fresh / general:.0%} of the ceiling")


if __name__ == "__main__":
    main()
