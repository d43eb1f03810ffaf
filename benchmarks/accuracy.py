"""Accuracy of linkdyn on every bundled example, by means that do not share its code path.

For each example, over one cycle (or its duration) at 181 samples, prints the largest relative
difference (to each quantity's peak) between the recursive DeNOC solver and

- the explicit-matrix reference ``linkdyn.dynamics.dense`` (eq. 27 with N_l, N_d, M, J formed
  as matrices, reactions from a stacked wrench balance): driver efforts, cut-joint multipliers
  and joint forces, column by column (a column that is identically ~0, such as a revolute cut's
  moment, is measured against its array's peak);
- the velocities and accelerations of every joint against 5-point finite differences of its
  positions (h = 1e-4 of the duration);

and the run's health figures: the closure residual relative to the mechanism's size and the
energy balance ``P_drivers + P_loads = dKE/dt`` (dKE/dt from the mass centres). Each backend
runs the table (the numpy reference and, with numba installed, the compiled kernels).

Usage: python benchmarks/accuracy.py
"""

from __future__ import annotations

import numpy as np

import linkdyn
from linkdyn import compiled, design
from linkdyn.cli import example_names
from linkdyn.dynamics import dense


def rel(a, b):
    """Largest |a - b| relative to the peak of |b|, column by column (a column that is
    identically ~0, such as a constant-speed driver's acceleration, against the array's peak)."""
    a, b = np.asarray(a).reshape(len(a), -1), np.asarray(b).reshape(len(b), -1)
    peak = np.max(np.abs(b), axis=0)
    scale = np.where(peak > 1e-9 * peak.max(), peak, peak.max())
    return float(np.max(np.abs(a - b) / scale))


def duration(mech):
    return mech.duration or (mech.cycles or 1.0) * next(d.period for d in mech.drivers if d.period)


def table(backend):
    print(f"[{backend}]")
    print(f"{'example':24s} {'vs dense':>10s} {'qd vs FD':>10s} {'qdd vs FD':>10s} "
          f"{'closure':>10s} {'energy':>10s}")
    for name in example_names():
        mech = linkdyn.load(linkdyn.example_path(name))
        missing = compiled.unsupported([j.kind for j in mech.joints])
        if backend == "compiled" and missing:  # the kernels have no code for these kinds
            print(f"{name:24s} (numpy only: {', '.join(missing)} joints)")
            continue
        T = duration(mech)
        t = np.linspace(0.0, T, 181)

        def analyze(times):
            return linkdyn.analyze(mech, times, backend=backend)
        sol = analyze(t)
        ref = dense.solve(mech, sol.kin, sol.loads.w_ext)
        d = max(rel(sol.dyn.tau, ref.tau), rel(sol.reactions.force, ref.force),
                rel(sol.dyn.lam, ref.lam) if ref.lam.size else 0.0)
        # 5-point differences of the joint coordinates around interior samples
        h = 1e-4 * T
        tc = t[5:-5:10]
        qs = [analyze(np.sort(np.concatenate(([0.0], tc + k * h)))).kin.q[1:]
              for k in (-2, -1, 0, 1, 2)]
        fd1 = (qs[0] - 8 * qs[1] + 8 * qs[3] - qs[4]) / (12 * h)
        fd2 = (-qs[0] + 16 * qs[1] - 30 * qs[2] + 16 * qs[3] - qs[4]) / (12 * h * h)
        exact = analyze(np.concatenate(([0.0], tc)))
        health = design.health(sol)
        print(f"{name:24s} {d:10.1e} {rel(fd1, exact.kin.qd[1:]):10.1e} "
              f"{rel(fd2, exact.kin.qdd[1:]):10.1e} {health['closure_residual_rel']:10.1e} "
              f"{health['energy_balance_residual_rel']:10.1e}")


def main():
    for backend in ["numpy"] + (["compiled"] if compiled.numba is not None else []):
        table(backend)

if __name__ == "__main__":
    main()
