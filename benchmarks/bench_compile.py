"""Cold compilation time of the compiled backend's kernels, stage by stage, on Hoeken.

Runs in a child process with numba's cache pointed at an empty temporary folder
(``NUMBA_CACHE_DIR``), so every kernel compiles from scratch and the project's own cache is
left as it is. Prints the seconds each stage's first call takes: the kinematics (its kernel
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
t0 = time.perf_counter()
kin = kinematics.solve(m, t, backend="compiled")
out.append(("kinematics", time.perf_counter() - t0))
applied = loads.wrenches(m, kin)
t0 = time.perf_counter()
dyn = dc.solve(kin, applied)
out.append(("dynamics", time.perf_counter() - t0))
t0 = time.perf_counter()
dc.reactions(kin, applied, dyn)
out.append(("reactions", time.perf_counter() - t0))
motor = linkdyn.load(linkdyn.example_path("hoeken_motor"))
t0 = time.perf_counter()
linkdyn.simulate(motor, np.linspace(0.0, 0.2, 11), backend="compiled")
out.append(("simulate right-hand side", time.perf_counter() - t0))
t0 = time.perf_counter()
linkdyn.sweep(m, {"bodies.ground.points.O4[0]": np.linspace(85.0, 95.0, 64)}, t,
              metrics=["peak_tau_J1"], backend="compiled")
out.append(("fused sweep", time.perf_counter() - t0))
for name, s in out:
    print(f"{name:26s} {s:7.1f} s")
print(f"{'all':26s} {sum(s for _, s in out):7.1f} s")
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
