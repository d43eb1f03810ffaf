"""How fast can Hoeken's analysis go at all on this machine, on one core?

The throughput targets of ``make bench`` (5e6 samples/s for the kinematics of every joint and
body, 3e6 samples/s for the full analysis) are measured on a general solver. This script
measures a ceiling for each: the same work written out by hand for this one four-bar as a
compiled (numba) kernel, with none of the general solver's machinery (no layout, no
continuation nodes, no dyad dispatch, the branch fixed once), storing per sample only the
numbers that are not redundant. Kinematics:

- q, qd, qdd of the four joints (12);
- for each of the three moving bodies: angle, its cosine and sine, origin x and y; angular
  velocity, origin velocity x, y; angular acceleration, origin acceleration x, y (33);
- the closure residual and the relative pivot of the rate system (2).

47 numbers per sample, where the general kernel stores 54 (the ground's cosine and the closure
Jacobian besides). The full analysis adds the Newton-Euler equations of the three links solved
for the driving torque and the four pin forces, and the kinetic energy: 12 numbers more (the
cut pin's force stored twice, standing in for the two multipliers), where the general kernel
stores 16 (the pivot and the three tree joints' moments besides). The outputs are staged
through a small block buffer so that they are written row by row, the fastest order measured
here. Every output is checked against linkdyn's results before timing.

It prints the ceilings' samples per second into fresh outputs (as a user's call gets them)
and into outputs already touched, beside linkdyn's compiled backend measured in the same run.

Usage: python benchmarks/bench_ceiling.py [--samples N] [--clock wall|cpu]   (needs numba: pip install 'linkdyn[fast]')
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import math  # noqa: E402

import numba  # noqa: E402
import numpy as np  # noqa: E402

import linkdyn  # noqa: E402
from linkdyn import kinematics  # noqa: E402
from linkdyn.kinematics import compile_layout  # noqa: E402

from bench_hoeken import TARGET_ANALYSIS, TARGET_KINEMATICS, best_time, one_core  # noqa: E402

BUF = 64                  # samples staged before the row-by-row write
# output rows: q, qd, qdd of J1..J4; per body (crank, coupler, rocker) phi, c, s, x, y,
# omega, vx, vy, alpha, ax, ay; residual, pivot; then, for the full analysis, tau,
# Fx, Fy of J1..J4, the cut pin's force again, kinetic energy
ROWS_KIN = 12 + 33 + 2
ROWS_ALL = ROWS_KIN + 1 + 8 + 2 + 1


@numba.njit(inline="always")
def body(buf, m, k, phi, c, s, x, y, w, vx, vy, al, ax, ay):
    """A body's 11 rows from row m: angle, cosine, sine, origin, twist, twist rate."""
    buf[m, k], buf[m + 1, k], buf[m + 2, k], buf[m + 3, k], buf[m + 4, k] = phi, c, s, x, y
    buf[m + 5, k], buf[m + 6, k], buf[m + 7, k] = w, vx, vy
    buf[m + 8, k], buf[m + 9, k], buf[m + 10, k] = al, ax, ay


@numba.njit(inline="always")
def newton_euler(m, i_o, dx, dy, w, al, ax, ay):
    """A link's net force and its net moment about its origin O, from O's acceleration (ax, ay),
    the mass centre at d = (dx, dy) from O and the inertia ``i_o`` about O:
    F = m (a + al perp(d) - w^2 d),  N = I_O al + m d x a."""
    fx, fy = m * (ax - al * dy - w * w * dx), m * (ay + al * dx - w * w * dy)
    return fx, fy, i_o * al + m * (dx * ay - dy * ax)


def kernel(full):
    """The compiled kernel of the kinematics alone or with the inverse dynamics (``full``, a
    constant of the compiled code: numba drops the branch it does not take)."""
    rows = ROWS_ALL if full else ROWS_KIN

    @numba.njit(error_model="numpy")
    def hoeken(t, w, u, v, pa, pb, side, size, mass, i_o, com, out):
        """Hoeken's kinematics (and inverse dynamics) at the times ``t`` (T,), crank at
        constant speed ``w`` from 0.

        ``u``: the coupler pin on the crank, ``v``: the rocker pin on the coupler, ``pb``: the
        ground pin on the rocker (each in its body's frame, the body's origin at its pin on the
        previous body); ``pa``: the ground pin. ``side``: +1 or -1, the assembly branch of the
        rocker pin left or right of the line from the coupler pin to ``pa``. ``mass``, ``i_o``
        (inertia about the origin), ``com`` (4, 2): per body, ground first. ``out`` (rows, T).
        """
        b, c = math.sqrt(v[0] ** 2 + v[1] ** 2), math.sqrt(pb[0] ** 2 + pb[1] ** 2)
        vxh, vyh, pbxh, pbyh = v[0] / b, v[1] / b, pb[0] / c, pb[1] / c
        phi_v, phi_pb = math.atan2(v[1], v[0]), math.atan2(pb[1], pb[0])
        buf = np.empty((rows, BUF))   # a constant shape: the stores compile to fixed offsets
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
                # stored one by one: a tuple indexed in a runtime loop compiles to slower code
                buf[0, k], buf[1, k], buf[2, k], buf[3, k] = p1, p2 - p1, p3 - p2, p3
                buf[4, k], buf[5, k], buf[6, k], buf[7, k] = w, w2 - w, w3 - w2, w3
                buf[8, k], buf[9, k], buf[10, k], buf[11, k] = 0.0, al2, al3 - al2, al3
                body(buf, 12, k, p1, c1, s1, 0.0, 0.0, w, 0.0, 0.0, 0.0, 0.0, 0.0)
                body(buf, 23, k, p2, c2, s2, r2x, r2y, w2, v2x, v2y, al2, a2x, a2y)
                body(buf, 34, k, p3, c3, s3, r3x, r3y, w3, v3x, v3y, al3, a3x, a3y)
                buf[45, k], buf[46, k] = res, piv
                if not full:
                    continue
                # Newton-Euler of each link about its origin, d = R(phi) com
                f1x, f1y, n1 = newton_euler(mass[1], i_o[1], c1 * com[1, 0] - s1 * com[1, 1],
                                            s1 * com[1, 0] + c1 * com[1, 1], w, 0.0, 0.0, 0.0)
                f2x, f2y, n2 = newton_euler(mass[2], i_o[2], c2 * com[2, 0] - s2 * com[2, 1],
                                            s2 * com[2, 0] + c2 * com[2, 1], w2, al2, a2x, a2y)
                f3x, f3y, n3 = newton_euler(mass[3], i_o[3], c3 * com[3, 0] - s3 * com[3, 1],
                                            s3 * com[3, 0] + c3 * com[3, 1], w3, al3, a3x, a3y)
                # pin forces F_J (by the joint's first body on its second); the coupler's and the
                # rocker's moments about their origins give F_J3:
                #   e2 x F_J3 = -N2,  e3 x F_J3 = e3 x F3 - N3
                m1, m2 = -n2, e3x * f3y - e3y * f3x - n3
                j3x = (m1 * e3x - e2x * m2) / det
                j3y = (-e2y * m2 + e3y * m1) / det
                j4x, j4y = f3x - j3x, f3y - j3y            # rocker: F_J3 + F_J4 = F3
                j2x, j2y = f2x + j3x, f2y + j3y            # coupler: F_J2 - F_J3 = F2
                j1x, j1y = f1x + j2x, f1y + j2y            # crank: F_J1 - F_J2 = F1
                tau = n1 + r2x * j2y - r2y * j2x           # crank moment about O1
                # kinetic energy: 1/2 m |v|^2 + m w v . perp(d) + 1/2 I_O w^2 per link
                ke = 0.5 * i_o[1] * w * w
                ke += (0.5 * mass[2] * (v2x * v2x + v2y * v2y) + 0.5 * i_o[2] * w2 * w2
                       + mass[2] * w2 * (v2y * (c2 * com[2, 0] - s2 * com[2, 1])
                                         - v2x * (s2 * com[2, 0] + c2 * com[2, 1])))
                ke += (0.5 * mass[3] * (v3x * v3x + v3y * v3y) + 0.5 * i_o[3] * w3 * w3
                       + mass[3] * w3 * (v3y * (c3 * com[3, 0] - s3 * com[3, 1])
                                         - v3x * (s3 * com[3, 0] + c3 * com[3, 1])))
                buf[47, k], buf[48, k], buf[49, k], buf[50, k], buf[51, k] = tau, j1x, j1y, j2x, j2y
                buf[52, k], buf[53, k], buf[54, k], buf[55, k] = j3x, j3y, j4x, j4y
                buf[56, k], buf[57, k], buf[58, k] = j4x, j4y, ke
            for m in range(rows):
                for k in range(nb):
                    out[m, t0 + k] = buf[m, k]


    return hoeken


HOEKEN = {False: kernel(False), True: kernel(True)}

def check(out, mech, t):
    """Every output row against linkdyn's numpy backend (angles modulo 2 pi; each dynamic
    column to 1e-9 of its family's peak)."""
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
    if len(out) == ROWS_ALL:
        cols = linkdyn.analyze(mech, t, backend="numpy").columns
        forces = [f"F{x}_J{j}" for j in (1, 2, 3, 4) for x in "xy"]
        peak = max(np.abs(cols[k]).max() for k in forces)
        for m, key in enumerate(["tau_J1"] + forces + ["Fx_J4", "Fy_J4", "kinetic_energy"]):
            scale = peak if key in forces else np.abs(cols[key]).max()
            err = np.abs(out[ROWS_KIN + m] - cols[key]).max()
            assert err <= 1e-9 * scale, f"{key}: {err}"


def numbers(mech) -> dict:
    """Hoeken's numbers as the hand-written kernels take them (SI): the crank speed ``w``; the
    pins ``u`` (coupler on the crank), ``v`` (rocker on the coupler), ``pb`` (ground on the
    rocker), each in its body's frame, and ``pa`` (the ground pin); ``side``, the assembly
    branch at t = 0; ``size``; per body, ground first, ``mass``, ``com`` (4, 2) and ``i_o``,
    the inertia about the body's origin. ``layout``: the compiled layout they come from."""
    lay = compile_layout(mech)
    (cut,) = lay.cuts
    u, v, pa, pb = lay.joint_point[2], lay.joint_point[3], cut.pa, cut.pb
    assert not np.any(lay.joint_point[1]), "the kernel takes the crank pivot at the origin"
    mass = np.asarray(lay.mass, float)
    com = np.array([np.asarray(x, float) for x in lay.com])
    # the branch of the assembled mechanism at t = 0
    s0 = kinematics.solve(mech, np.zeros(1), backend="numpy")
    r2, r3 = s0.pose.r[2][:, 0], s0.pose.r[3][:, 0]
    (dx, dy), (ex, ey) = pa - r2, r3 - r2
    return {"w": mech.drivers[0].motion.speed, "u": u, "v": v, "pa": pa, "pb": pb,
            "side": float(np.sign(dx * ey - dy * ex)), "size": float(lay.size), "mass": mass,
            "com": com, "i_o": np.asarray(lay.inertia, float) + mass * np.sum(com**2, axis=1),
            "layout": lay}


def setup(mech):
    """The hand-written kernel bound to Hoeken's numbers: ``run(t, out)`` fills ``out``
    ((ROWS_KIN or ROWS_ALL, T)) at the times ``t`` and returns it."""
    p = numbers(mech)

    def run(t, out):
        HOEKEN[len(out) == ROWS_ALL](t, p["w"], p["u"], p["v"], p["pa"], p["pb"], p["side"],
                                    p["size"], p["mass"], p["i_o"], p["com"], out)
        return out

    return run


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                    help="cpu: this process's CPU time (a shared machine's other jobs excluded)")
    args = ap.parse_args()
    import time

    import bench_hoeken   # best_time reads its clock
    bench_hoeken.CLOCK = time.process_time if args.clock == "cpu" else time.perf_counter
    one_core()
    mech = linkdyn.load(linkdyn.example_path("hoeken"))
    run = setup(mech)
    T = args.samples
    t = np.linspace(0.0, mech.drivers[0].period, T)

    def best(fn):
        return best_time(fn, args.repeat)
    tc = np.linspace(-0.3, 1.2, 2001) * mech.drivers[0].period
    general = {"kinematics": lambda: kinematics.solve(mech, t, backend="compiled"),
               "full analysis": lambda: linkdyn.analyze(mech, t, backend="compiled")}
    general["full analysis"]()   # compile once
    print(f"Hoeken four-bar, {T} samples, one core, best of {args.repeat} ({args.clock} clock)")
    for (name, fn), rows, target in zip(general.items(), (ROWS_KIN, ROWS_ALL),
                                        (TARGET_KINEMATICS, TARGET_ANALYSIS)):
        check(run(tc, np.empty((rows, len(tc)))), mech, tc)
        touched = run(t, np.zeros((rows, T)))
        fresh = best(lambda: run(t, np.empty((rows, T))))
        warm = best(lambda: run(t, touched))
        ours = best(fn)
        print(f"{name}: ceiling, hand-written compiled kernel for this one four-bar,"
              f" {rows} numbers per sample")
        print(f"  into fresh outputs        {T / fresh:10.4g} samples/s"
              f"  ({fresh / T * 1e9:4.0f} ns)   target {target:.0e}"
              f" {'met' if T / fresh >= target else 'NOT met'}")
        print(f"  into outputs touched      {T / warm:10.4g} samples/s  ({warm / T * 1e9:4.0f} ns)")
        print(f"  linkdyn, compiled backend {T / ours:10.4g} samples/s  ({ours / T * 1e9:4.0f} ns),"
              f" {fresh / ours:.0%} of the ceiling")


if __name__ == "__main__":
    main()
