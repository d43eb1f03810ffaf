"""Where the compiled backend's time goes, on the bundled Hoeken four-bar, one core.

Prints, in ns per sample:
  1. the kinematics and dynamics kernels alone (the dynamics kernel takes the reactions in its
     blocks, as ``analyze`` runs it), writing into outputs already touched (each kernel re-run
     on the arguments of a real ``linkdyn.analyze`` call);
  2. the kinematics kernel with blocks of 512, 1024 and 2048 samples (linkdyn uses
     ``linkdyn.kinematics.compiled.BLOCK``);
  3. each step of the kinematics kernel, called block by block from Python (each figure
     includes a few ns of call overhead per sample);
  4. ``linkdyn.compiled.arctan2`` against the C library's ``math.atan2`` in a compiled loop
     over an array (the first compiles to vector instructions, the second stays scalar);
and the speed of filling fresh memory against memory already touched, which is what separates
the kernels' own time from the end-to-end throughput of ``make bench``.

Usage: python benchmarks/bench_kernels.py [--samples N] [--clock wall|cpu]   (needs numba: pip install 'linkdyn[fast]')
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402

import math  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import linkdyn  # noqa: E402
from linkdyn import compiled  # noqa: E402
from linkdyn.dynamics import compiled as dc  # noqa: E402
from linkdyn.kinematics import compiled as kc  # noqa: E402

import bench_hoeken  # noqa: E402
from bench_hoeken import best_time, one_core  # noqa: E402

py = compiled.from_python   # a kernel's helper alone, callable from Python


def kernel_arguments(mech, t):
    """The kernels ``linkdyn.analyze`` calls and their arguments (outputs included):
    ``{name: (kernel, args)}`` for the kinematics, dynamics and reactions, those it called
    (the dynamics kernel takes the reactions in its blocks when they are wanted)."""
    seen = {}
    kernels = {"kinematics": (kc, "kernel"), "dynamics": (dc, "_dynamics"),
               "reactions": (dc, "_reactions")}
    real = {name: getattr(mod, attr) for name, (mod, attr) in kernels.items()}

    def spy(name, fn):
        def call(*args):
            seen[name] = args
            return fn(*args)
        return call
    for name, (mod, attr) in kernels.items():
        setattr(mod, attr, spy(name, real[name]))
    try:
        linkdyn.analyze(mech, t, backend="compiled")
    finally:
        for name, (mod, attr) in kernels.items():
            setattr(mod, attr, real[name])
    return {name: (real[name], seen[name]) for name in kernels if name in seen}


def steps(args):
    """The kinematics kernel's steps, each a function of a block ``(k0, nb)`` (design 0, the
    outputs of the real call as the work arrays, its scratch from ``kinematics.compiled.scratch``);
    ``(table, block)``."""
    (L, X, q, phi, c, s, r, e, J, qd, qdd, tw, td, cut, pivot, err, fin, block) = args
    n, nc, nd = len(L.parent), len(L.cut_a), len(L.dependent)
    cq, sq, up, low, rhs, P, A, sol, col, perm, _ = kc.scratch(n, nc, nd, J.shape[0], block)
    py(kc._cut_frames)(L, 0, 0, 0, block, c, s, r, P)   # the first block's, for every block
    closed = [x.copy() for x in (q, phi, c, s, r, e)]   # the close step turns a copy
    return {
        "place the bodies": lambda k0, nb: py(kc._place)(L, 0, 0, k0, nb, q, cq, sq, phi, c, s, r,
                                                     e),
        "close the dyads": lambda k0, nb: py(kc._close)(L, X.modes, 0, 0, k0, nb, *closed, up, low),
        "cut frames": lambda k0, nb: py(kc._cut_frames)(L, 0, 0, k0, nb, c, s, r, P),
        "closure residual": lambda k0, nb: py(kc._residual)(L, 0, k0, 0, k0, nb, phi, P, err, rhs),
        "closure Jacobian": lambda k0, nb: py(kc._jacobian)(L, 0, 0, k0, nb, r, e, P, J),
        "factor J_dep (once per sample)": lambda k0, nb: py(kc._factor_dep)(L.dependent, J, 0, k0,
                                                                        nb, A, perm, col),
        "one J_dep solve (two per sample)": lambda k0, nb: py(kc._solve_dep)(
            L.dependent, A, perm, col, 0, k0, nb, rhs, qd, sol),
        "twists": lambda k0, nb: py(kc._twists)(L, 0, k0, nb, r, e, qd, tw),
        "twist rates (two passes per sample)": lambda k0, nb: py(kc._twist_rates)(
            L, 0, k0, nb, r, e, tw, qd, qdd, td),
        "closure bias": lambda k0, nb: py(kc._bias)(L, 0, 0, k0, nb, r, tw, td, P, rhs),
        "cut-joint motion": lambda k0, nb: py(kc._cut_motion)(L, 0, 0, k0, nb, phi, r, tw, td, P,
                                                              cut),
    }, block


@compiled.njit
def _arctan2_loop(y, x, out):
    for k in range(len(y)):
        out[k] = compiled.arctan2(y[k], x[k])


@compiled.njit
def _atan2_loop(y, x, out):
    for k in range(len(y)):
        out[k] = math.atan2(y[k], x[k])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--samples", type=int, default=300_000)
    ap.add_argument("--clock", choices=("wall", "cpu"), default="wall",
                    help="cpu: this process's CPU time (a shared machine's other jobs left out)")
    args = ap.parse_args()
    bench_hoeken.CLOCK = time.process_time if args.clock == "cpu" else time.perf_counter
    one_core()
    mech = linkdyn.load(linkdyn.example_path("hoeken"))
    T = args.samples
    t = np.linspace(0.0, mech.drivers[0].period, T)
    linkdyn.analyze(mech, t[:1000], backend="compiled")   # compile once
    kernels = kernel_arguments(mech, t)
    kin_kernel, kin_args = kernels["kinematics"]
    print(f"Hoeken four-bar, {T} samples, one core, best of 5 ({args.clock} clock), outputs "
          "already touched")
    for name, (kernel, args) in kernels.items():
        per = best_time(lambda: kernel(*args), 5)
        print(f"{name + ' kernel':18s} {per / T * 1e9:7.1f} ns/sample")
    for block in (512, 1024, 2048):
        args = kin_args[:-1] + (block,)
        per = best_time(lambda: kin_kernel(*args), 5)
        print(f"kinematics kernel, blocks of {block:4d} {per / T * 1e9:7.1f} ns/sample")
    print("kinematics kernel, step by step:")
    table, block = steps(kin_args)
    for name, fn in table.items():
        fn(0, block)
        per = best_time(lambda: [fn(k0, min(block, T - k0)) for k0 in range(0, T, block)], 3)
        print(f"  {name:38s} {per / T * 1e9:7.1f} ns/sample")
    # angles: straight-line arctan2 against the C library's, random directions
    rng = np.random.default_rng(0)
    y, x, out = rng.standard_normal(T), rng.standard_normal(T), np.empty(T)
    for name, loop in (("linkdyn.compiled.arctan2", _arctan2_loop), ("math.atan2", _atan2_loop)):
        loop(y, x, out)
        per = best_time(lambda: loop(y, x, out), 5)
        print(f"{name + ' over an array':38s} {per / T * 1e9:7.1f} ns/call")
    # first writes to fresh memory against writes to memory already touched
    size = 10_000_000
    touched = np.empty(size)
    touched.fill(0.0)
    warm = best_time(lambda: touched.fill(1.0), 3)
    fresh = best_time(lambda: np.empty(size).fill(1.0), 3)
    print(f"filling memory: fresh {touched.nbytes / fresh / 1e9:.1f} GB/s, "
          f"already touched {touched.nbytes / warm / 1e9:.1f} GB/s")


if __name__ == "__main__":
    main()
