"""Cold compilation time of the compiled backend's kernels, stage by stage, on Hoeken.

Runs in a child process with numba's cache pointed at an empty temporary folder
(``NUMBA_CACHE_DIR``), so every kernel compiles from scratch and the project's own cache is
left as it is. Prints the CPU seconds (the process's user + system time, which a loaded
machine does not inflate) and the wall seconds each stage's first call takes: the kinematics (its kernel
and the continuation nodes), the dynamics, the reactions, the ``simulate`` right-hand side
and the fused sweep kernel. These are the figures behind the suite's cold start (the compiled
worker of ``make test``) and a user's first compiled run.

Usage: python benchmarks/bench_compile.py
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile

CHILD = r"""
import time
import numpy as np
import linkdyn
from linkdyn import kinematics, loads
from linkdyn.dynamics import compiled as dc

m = linkdyn.load(linkdyn.example_path("hoeken"))
t = np.linspace(0.0, 1.0, 50)
out = []


def stage(name, run):
    c0, t0 = time.process_time(), time.perf_counter()
    result = run()
    out.append((name, time.process_time() - c0, time.perf_counter() - t0))
    return result


kin = stage("kinematics", lambda: kinematics.solve(m, t, backend="compiled"))
applied = loads.wrenches(m, kin)
dyn = stage("dynamics", lambda: dc.solve(kin, applied))
stage("reactions", lambda: dc.reactions(kin, applied, dyn))
motor = linkdyn.load(linkdyn.example_path("hoeken_motor"))
stage("simulate right-hand side",
      lambda: linkdyn.simulate(motor, np.linspace(0.0, 0.2, 11), backend="compiled"))
stage("fused sweep", lambda: linkdyn.sweep(
    m, {"bodies.ground.points.O4[0]": np.linspace(85.0, 95.0, 64)}, t,
    metrics=["peak_tau_J1"], backend="compiled"))
print(f"{'stage':26s} {'CPU':>7s}   {'wall':>7s}")
for name, cpu, wall in out:
    print(f"{name:26s} {cpu:7.1f} s {wall:7.1f} s", flush=True)
print(f"{'all':26s} {sum(c for _, c, _ in out):7.1f} s {sum(w for _, _, w in out):7.1f} s")
"""


def main() -> None:
    try:
        import numba  # noqa: F401
    except ImportError:
        sys.exit("bench_compile needs numba: pip install 'linkdyn[fast]'")
    with tempfile.TemporaryDirectory() as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache, LINKDYN_BACKEND="compiled")
        print("cold compilation of the compiled backend's kernels (first call of each stage):")
        subprocess.run([sys.executable, "-c", CHILD], env=env, check=True)


if __name__ == "__main__":
    main()
