"""Throughput of linkdyn on the bundled Hoeken four-bar, on one core.

Prints samples per second for
  1. kinematics (positions, rates, accelerations of every joint, body and named point),
  2. the full analysis (kinematics, driver torque, cut-joint multipliers, every joint reaction),
on each backend (the numpy reference and, with numba installed, the compiled kernels; their
one-time compilation is done before timing and reported), each beside a baseline measured in
the same run on the same machine:
  - kinematics: a per-sample loop with scipy.optimize.fsolve for the loop closure and
    numpy.linalg.solve for the rates and accelerations;
    and, as a ceiling, the same kinematics written out by hand for this one four-bar in numpy;
  - full analysis: a per-sample loop forming the simultaneous Newton-Euler system (all joint
    reactions and the torque as unknowns, 9 x 9) and solving it with numpy.linalg.solve.

Usage: python benchmarks/bench_hoeken.py [--samples N] [--repeat R] [--clock wall|cpu]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from scipy.optimize import fsolve  # noqa: E402

import linkdyn  # noqa: E402
from linkdyn import compiled, kinematics  # noqa: E402

TARGET_KINEMATICS = 5e6   # samples/s, issue 2
TARGET_ANALYSIS = 3e6     # samples/s, issue 3
CLOCK = time.perf_counter  # --clock cpu: time.process_time (a shared machine's other jobs excluded)


def best_time(fn, repeat):
    """The shortest of ``repeat`` runs of ``fn``, s, by :data:`CLOCK` (the other benchmarks use
    it too)."""
    times = []
    for _ in range(repeat):
        t0 = CLOCK()
        fn()
        times.append(CLOCK() - t0)
    return min(times)


def one_core():
    """Pin this process to one core (where the system allows)."""
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {sorted(os.sched_getaffinity(0))[0]})


def baseline_kinematics(mech, t):
    """Per-sample loop: fsolve for the coupler and rocker angles, then 2x2 solves."""
    g = mech.body("ground").points["O4"]
    a = np.linalg.norm(mech.body("crank").points["O2"])
    b = np.linalg.norm(mech.body("coupler").points["O3"])
    c = np.linalg.norm(mech.body("rocker").points["O4"])
    w = mech.drivers[0].motion.speed
    x = np.array([np.radians(77.0), np.radians(-77.0)])
    out = np.empty((len(t), 6))
    for k, tk in enumerate(t):
        th = w * tk

        def closure(y):
            return [a * np.cos(th) + b * np.cos(y[0]) - c * np.cos(y[1]) - g[0],
                    a * np.sin(th) + b * np.sin(y[0]) - c * np.sin(y[1]) - g[1]]
        x = fsolve(closure, x, xtol=1e-12)
        K = np.array([[-b * np.sin(x[0]), c * np.sin(x[1])], [b * np.cos(x[0]), -c * np.cos(x[1])]])
        rhs = np.array([a * np.sin(th), -a * np.cos(th)]) * w
        xd = np.linalg.solve(K, rhs)
        acc = np.array([a * np.cos(th) * w**2 + b * np.cos(x[0]) * xd[0]**2 - c * np.cos(x[1]) * xd[1]**2,
                        a * np.sin(th) * w**2 + b * np.sin(x[0]) * xd[0]**2 - c * np.sin(x[1]) * xd[1]**2])
        out[k] = (*x, *xd, *np.linalg.solve(K, acc))
    return out


def specialised_kinematics(mech, t):
    """Reference ceiling: Hoeken's kinematics written out by hand for this one four-bar in
    numpy (circle intersection, 2x2 rate and acceleration solves by dot products). No
    generality at all; it shows what numpy can do at best on this machine."""
    g = mech.body("ground").points["O4"][0]
    a = np.linalg.norm(mech.body("crank").points["O2"])
    b = np.linalg.norm(mech.body("coupler").points["O3"])
    c = np.linalg.norm(mech.body("rocker").points["O4"])
    w = mech.drivers[0].motion.speed
    th = w * t
    u1x, u1y = np.cos(th), np.sin(th)
    ax, ay = a * u1x, a * u1y
    dx, dy = g - ax, -ay
    d = np.sqrt(dx * dx + dy * dy)
    k = (b * b - c * c + d * d) / (2 * d)
    h = np.sqrt(b * b - k * k)
    bx, by = ax + (k * dx - h * dy) / d, ay + (k * dy + h * dx) / d   # coupler-rocker pin
    u2x, u2y, u3x, u3y = (bx - ax) / b, (by - ay) / b, (bx - g) / c, by / c
    phi2, phi3 = np.arctan2(u2y, u2x), np.arctan2(u3y, u3x)
    vax, vay = -a * w * u1y, a * w * u1x
    den2, den3 = b * (u2x * u3y - u2y * u3x), c * (u3x * u2y - u3y * u2x)
    w2 = -(vax * u3x + vay * u3y) / den2
    w3 = (vax * u2x + vay * u2y) / den3
    rx = a * w * w * u1x + b * w2 * w2 * u2x - c * w3 * w3 * u3x
    ry = a * w * w * u1y + b * w2 * w2 * u2y - c * w3 * w3 * u3y
    return phi2, phi3, w2, w3, (rx * u3x + ry * u3y) / den2, -(rx * u2x + ry * u2y) / den3


def baseline_analysis(sol):
    """Per-sample loop: the simultaneous Newton-Euler system of the three links (9 x 9)."""
    m = sol.model
    names = ["crank", "coupler", "rocker"]
    pins = {"crank": ("J1", "J2"), "coupler": ("J2", "J3"), "rocker": ("J3", "J4")}
    joint_pts = {("J1", "crank"): "O1", ("J2", "crank"): "O2", ("J2", "coupler"): "O2",
                 ("J3", "coupler"): "O3", ("J3", "rocker"): "O3", ("J4", "rocker"): "O4"}
    jidx = {"J1": 0, "J2": 1, "J3": 2, "J4": 3}
    mass = {n: m.body(n).mass for n in names}
    inertia = {n: m.body(n).inertia for n in names}
    kin = sol.kin
    com = {}
    acc_c = {}
    pts = {}
    for n in names:
        b = m.body(n)
        i = kin.layout.topo.bodies.index(n)
        rel = np.asarray(b.com) - kin.layout.origin[i]  # mass centre relative to O_i
        c = kinematics.last(kin.pose.point(i, rel))
        ac = kinematics.last(kinematics.point_acceleration(kin.twists[i], kin.rates[i], kin.pose.rotate(i, rel)))
        com[n], acc_c[n] = c, ac
        for j in pins[n]:
            pts[(j, n)] = sol.point(n, joint_pts[(j, n)])
    alpha = {n: sol.alpha(n) for n in names}
    out = np.empty((len(sol.t), 9))
    for k in range(len(sol.t)):
        A = np.zeros((9, 9))
        rhs = np.zeros(9)
        for r, n in enumerate(names):
            # unknowns: F_j (force by first body on second) for J1..J4, then tau
            for j in pins[n]:
                sgn = 1.0 if m.joint(j).body_b == n else -1.0
                col = 2 * jidx[j]
                arm = pts[(j, n)][k] - com[n][k]
                A[3 * r + 0, col], A[3 * r + 0, col + 1] = sgn, 0.0
                A[3 * r + 1, col], A[3 * r + 1, col + 1] = 0.0, sgn
                A[3 * r + 2, col], A[3 * r + 2, col + 1] = -sgn * arm[1], sgn * arm[0]
            if n == "crank":
                A[3 * r + 2, 8] = 1.0
            rhs[3 * r:3 * r + 2] = mass[n] * acc_c[n][k]
            rhs[3 * r + 2] = inertia[n] * alpha[n][k]
        out[k] = np.linalg.solve(A, rhs)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--samples", type=int, default=1_000_000)
    ap.add_argument("--baseline-samples", type=int, default=2000)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                    help="time by the wall clock, or by this process's CPU time (on a shared "
                         "machine, without the other jobs' share)")
    args = ap.parse_args()
    global CLOCK
    CLOCK = time.process_time if args.clock == "cpu" else time.perf_counter
    one_core()

    mech = linkdyn.load(linkdyn.example_path("hoeken"))
    period = mech.drivers[0].period
    t = np.linspace(0.0, period, args.samples)
    tb = np.linspace(0.0, period, args.baseline_samples)

    backends = ["numpy"] + (["compiled"] if compiled.numba is not None else [])
    tk, ta = {}, {}
    for be in backends:
        t0 = time.perf_counter()
        linkdyn.analyze(mech, t[:1000], backend=be)  # warm-up (compiles the kernels once)
        warm = time.perf_counter() - t0
        if be == "compiled":
            print(f"(compiled kernels: first use {warm:.1f} s, then cached on disk)")
        tk[be] = best_time(lambda: kinematics.solve(mech, t, backend=be), args.repeat)
        ta[be] = best_time(lambda: linkdyn.analyze(mech, t, backend=be), args.repeat)
    ts = best_time(lambda: specialised_kinematics(mech, t), args.repeat)
    tkb = best_time(lambda: baseline_kinematics(mech, tb), 1)
    sol_b = linkdyn.analyze(mech, tb, backend="numpy")
    tab = best_time(lambda: baseline_analysis(sol_b), 1)

    # the references solve the same problem: check they agree, so the comparison is fair
    _, _, w2, w3, al2, al3 = specialised_kinematics(mech, tb)
    for ref_x, name in ((w2, "omega_coupler"), (w3, "omega_rocker"), (al2, "alpha_coupler"),
                        (al3, "alpha_rocker")):
        got = sol_b.columns[name]
        assert np.allclose(ref_x, got, rtol=0, atol=1e-9 * np.abs(got).max()), name
    ref = baseline_analysis(sol_b)
    tau = sol_b.effort("J1")
    assert np.allclose(ref[:, 8], tau, rtol=0, atol=1e-9 * np.abs(tau).max()), "baseline mismatch"

    rs = args.samples / ts
    rkb = args.baseline_samples / tkb
    rab = args.baseline_samples / (tab + tkb)  # the baseline needs its kinematics too
    print(f"Hoeken four-bar, {args.samples} samples, one core, best of {args.repeat} "
          f"({args.clock} clock)")
    for be in backends:
        rk, ra = args.samples / tk[be], args.samples / ta[be]
        print(f"[{be}]")
        print(f"kinematics     {rk:12.4g} samples/s   baseline (per-sample fsolve) {rkb:10.4g}/s"
              f"   ratio {rk / rkb:8.1f}x   target {TARGET_KINEMATICS:.0e}"
              f" {'met' if rk >= TARGET_KINEMATICS else 'NOT met'}")
        print(f"               (hand-written closed form for this one four-bar in numpy: {rs:.4g}/s;"
              f" the general solver runs at {rk / rs:.0%} of it)")
        print(f"full analysis  {ra:12.4g} samples/s   baseline (per-sample 9x9 NE)  {rab:10.4g}/s"
              f"   ratio {ra / rab:8.1f}x   target {TARGET_ANALYSIS:.0e}"
              f" {'met' if ra >= TARGET_ANALYSIS else 'NOT met'}")

if __name__ == "__main__":
    main()
