"""What the ratio benchmarks share (``bench_cam.py``, ``bench_friction.py``,
``bench_inverse.py``): their options, the
best of a few timings on the clock asked for, and the line that says whether a target is met.

A benchmark script imports it as a sibling module (``python benchmarks/bench_cam.py`` puts
``benchmarks/`` on the path).
"""

from __future__ import annotations

import argparse
import time


def options(doc: str, samples: int = 100_000, more=None) -> argparse.Namespace:
    """The command line of a ratio benchmark: ``--samples``, ``--repeat``, ``--backend`` and
    ``--clock`` (``cpu``: this process's CPU time, the other jobs of a shared machine left out),
    the script's docstring ``doc`` its description; ``.clock`` the clock as a function.
    ``more``: a function adding the script's own options to the parser."""
    ap = argparse.ArgumentParser(description=doc.splitlines()[0])
    if more is not None:
        more(ap)
    ap.add_argument("--samples", type=int, default=samples)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--backend", default="compiled")
    ap.add_argument("--clock", choices=("wall", "cpu"), default="cpu")
    args = ap.parse_args()
    args.time = time.process_time if args.clock == "cpu" else time.perf_counter
    return args


def best_time(fn, repeat: int, clock) -> float:
    """Seconds of ``fn()`` on ``clock``, the least of ``repeat`` runs."""
    times = []
    for _ in range(repeat):
        t0 = clock()
        fn()
        times.append(clock() - t0)
    return min(times)


def verdict(ratio: float, target: float) -> str:
    """The printed line of a ratio against its target (at least ``target``)."""
    return (f"  ratio                  {ratio:12.3f}   (target >= {target}: "
            f"{'met' if ratio >= target else 'NOT met'})")
