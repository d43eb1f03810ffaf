"""What the default backend ``auto`` costs against the better explicit choice, in the same run.

``linkdyn.simulate`` of two models whose right-hand side numpy evaluates slowly, each timed with
``backend="compiled"`` and with ``backend="auto"`` (the default), the compiled kernels already
in numba's on-disk cache (the first compiled run, untimed, puts them there):

  1. the N-window parallelogram chain of ``bench_simulate.py`` falling under gravity through
     its flat, singular position;
  2. a slider-crank press: the bundled offset slider-crank released from its driver, a motor's
     torque-speed line on the crank with a flywheel, and a pressing force on the slider over
     part of its stroke.

Printed: each run's wall and CPU time, its right-hand sides, the backend it ended on and the
evaluation after which ``auto`` switched to compiled (``Simulation.stats``), and the ratio
auto / compiled (wall). The ratio is the figure: about 1 once ``auto`` loads cached kernels
quickly; at 1fa002c, where ``auto`` switched after a fixed 20,000 evaluations, the 40-window
chain ran about 60 times longer on ``auto``.

Usage: python benchmarks/bench_auto.py [--windows N] [--chain-duration T] [--press-duration T]
       [--rtol R] [--skip-chain] [--skip-press]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import math  # noqa: E402
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


def compare(name, model, t, rtol):
    atol = rtol * 1e-2
    linkdyn.simulate(model, t[:2] * 0.01, rtol=rtol, atol=atol, backend="compiled")  # cache
    rows = {}
    for backend in ("compiled", "auto"):
        sim, wall, cpu = timed(lambda: linkdyn.simulate(model, t, rtol=rtol, atol=atol,
                                                        backend=backend))
        st = sim.stats
        rows[backend] = wall
        print(f"  {backend:9s} {wall:8.2f} s wall {cpu:8.2f} s CPU  {st['rhs_evaluations']:7d} "
              f"right-hand sides; ran {st.get('backend', '?')}, compiled after "
              f"{st.get('compiled_after', '?')} evaluations", flush=True)
    print(f"  auto / compiled (wall): {rows['auto'] / rows['compiled']:.2f}", flush=True)


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
        compare("chain", chain(a.windows), np.linspace(0.0, a.chain_duration, 21), a.rtol)
    if not a.skip_press:
        print(f"slider-crank press, {a.press_duration} s, rtol {a.rtol}")
        compare("press", press(), np.linspace(0.0, a.press_duration, 61), a.rtol)


if __name__ == "__main__":
    main()
