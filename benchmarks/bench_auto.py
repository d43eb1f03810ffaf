"""What the default backend ``auto`` costs against the better explicit choice, in the same run.

``linkdyn.simulate`` of two models whose right-hand side numpy evaluates slowly, each timed with
``backend="compiled"`` and with ``backend="auto"`` (the default), the compiled kernels already
in numba's on-disk cache (the first compiled run, untimed, puts them there):

  1. the N-window parallelogram chain of ``bench_simulate.py`` falling under gravity through
     its flat, singular position;
  2. a slider-crank press: the bundled offset slider-crank released from its driver, a motor's
     torque-speed line on the crank with a flywheel, and a pressing force on the slider over
     part of its stroke.

Each pair is timed twice: in this process, where the first run has loaded the kernels (``auto``
then has no start-up left to weigh, ``linkdyn.backend.IN_PROCESS``, and runs compiled from the
first evaluation), and each run in a fresh child process, as one command of the command line
runs (the kernels loaded from numba's cache during the run; ``auto`` starts on numpy and
switches once numpy's evaluations would have paid for that load, by the cost model's constants).

Printed: each run's wall and CPU time, its right-hand sides, the backend it ended on and the
evaluation after which ``auto`` switched to compiled (``Simulation.stats``), and the ratio
auto / compiled (wall) of each pair. At 1fa002c, where ``auto`` switched after a fixed 20,000
evaluations, the 40-window chain ran about 60 times longer on ``auto``.

Usage: python benchmarks/bench_auto.py [--windows N] [--chain-duration T] [--press-duration T]
       [--rtol R] [--skip-chain] [--skip-press]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import tomllib  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import linkdyn  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))


def chain(n: int):
    from builders import parallelogram_chain

    return parallelogram_chain(n, math.pi / 4, cut=[f"B{k}" for k in range(1, n + 1)])


def press():
    """The bundled slider-crank without its driver: a motor (2 N m stalled, no torque at
    600 rpm = 3600 deg/s) and a flywheel on the crank, a 400 N pressing force on the slider
    while it is beyond 200 mm, gravity."""
    d = tomllib.loads(linkdyn.example_path("slider_crank").read_text())
    d.pop("drivers")
    d.pop("analysis", None)
    d["bodies"][1]["inertia"] = 20000.0        # kg mm^2: crank with flywheel
    d["initial"] = {"q": {"J1": 0.0}, "qd": {"J1": 0.0}}
    d["loads"] = [
        {"kind": "joint_torque", "joint": "J1", "value": "2.0*(1 - qd_J1/3600)"},
        {"kind": "force", "body": "slider", "point": "B",
         "value": ["where(q_J4 > 200, -400, 0)", "0"]}]
    return linkdyn.model_from_dict(d)


def timed(run):
    w, c = time.perf_counter(), time.process_time()
    out = run()
    return out, time.perf_counter() - w, time.process_time() - c


def run(name, size, duration, rtol, backend):
    """One ``simulate`` of model ``name`` ("chain" of ``size`` windows, or "press"), timed:
    (wall s, CPU s, its stats)."""
    model = chain(size) if name == "chain" else press()
    t = np.linspace(0.0, duration, 21 if name == "chain" else 61)
    sim, wall, cpu = timed(lambda: linkdyn.simulate(model, t, rtol=rtol, atol=rtol * 1e-2,
                                                    backend=backend))
    return wall, cpu, {k: sim.stats[k] for k in ("rhs_evaluations", "backend", "compiled_after")}


def in_child(*args):
    """:func:`run` in a fresh Python process (its kernels loaded from numba's cache)."""
    code = ("import json, sys; sys.path.insert(0, sys.argv[1]); import bench_auto as b; "
            "print(json.dumps(b.run(sys.argv[2], int(sys.argv[3]), float(sys.argv[4]), "
            "float(sys.argv[5]), sys.argv[6])))")
    out = subprocess.run([sys.executable, "-c", code, str(Path(__file__).parent),
                          *map(str, args)], capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def compare(name, size, duration, rtol):
    run(name, size, duration * 0.01, rtol, "compiled")   # kernels in the cache and this process
    for where, timer in (("this process", run), ("fresh process", in_child)):
        rows = {}
        for backend in ("compiled", "auto"):
            wall, cpu, st = timer(name, size, duration, rtol, backend)
            rows[backend] = wall
            print(f"  {backend:9s} {wall:8.2f} s wall {cpu:8.2f} s CPU  "
                  f"{st['rhs_evaluations']:7d} right-hand sides; ran {st['backend']}, compiled "
                  f"after {st['compiled_after']} evaluations ({where})", flush=True)
        print(f"  {where}: auto / compiled (wall): {rows['auto'] / rows['compiled']:.2f}",
              flush=True)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--windows", type=int, default=40)
    ap.add_argument("--chain-duration", type=float, default=0.6)
    ap.add_argument("--press-duration", type=float, default=3.0)
    ap.add_argument("--rtol", type=float, default=1e-8)
    ap.add_argument("--skip-chain", action="store_true")
    ap.add_argument("--skip-press", action="store_true")
    a = ap.parse_args()
    os.environ.pop("LINKDYN_BACKEND", None)
    if not a.skip_chain:
        print(f"{a.windows}-window parallelogram chain, {a.chain_duration} s, rtol {a.rtol}")
        compare("chain", a.windows, a.chain_duration, a.rtol)
    if not a.skip_press:
        print(f"slider-crank press, {a.press_duration} s, rtol {a.rtol}")
        compare("press", 0, a.press_duration, a.rtol)


if __name__ == "__main__":
    main()
