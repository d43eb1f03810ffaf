"""Cost of joint friction in ``analyze``: Hoeken's four-bar with friction at its four pins
against the same four-bar without friction, on one backend, in the same run (a ratio: the
machine's speed cancels out).

Prints samples per second of each and their ratio (issue 25's target: at least 0.5 on the
compiled backend), and the split of the friction run's time among its parts.

Usage: python benchmarks/bench_friction.py [--samples N] [--repeat R] [--backend B]
       [--clock wall|cpu]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import cProfile  # noqa: E402
import dataclasses  # noqa: E402
import pstats  # noqa: E402

import numpy as np  # noqa: E402

import linkdyn  # noqa: E402
from linkdyn.friction import joint_friction  # noqa: E402
from ratio import best_time, options, verdict  # noqa: E402

TARGET_RATIO = 0.5   # issue 25: friction at four pins at least half the frictionless throughput


def with_friction(mech, mu=0.15, radius=0.008):
    """``mech`` with friction (mu, pin radius in m) in every revolute joint."""
    extra = tuple(joint_friction(mech, j.name, mu, radius) for j in mech.joints)
    return dataclasses.replace(mech, loads=mech.loads + extra)



#: the parts of the friction run's time (function names of the profile), in the order run
PARTS = (("kinematics", "kinematics/solution.py", "solve"),
         ("applied loads", "linkdyn/loads.py", "wrenches"),
         ("friction kernel", "friction_compiled.py", "_kernel"),
         ("friction loads", "friction.py", "with_efforts"),
         ("friction outputs", "friction.py", "friction_of"))


def split(fn, clock, repeat):
    """The time of ``fn()`` on ``clock`` (s) and the time of each of :data:`PARTS` in it, by
    the profiler: the least of ``repeat`` runs of each (the profiler's own cost is in the
    whole, not in the parts)."""
    total, parts = float("inf"), {name: float("inf") for name, _, _ in PARTS}
    for _ in range(repeat):
        prof = cProfile.Profile(clock)
        prof.runcall(fn)
        stats = pstats.Stats(prof).stats
        total = min(total, max((v[3] for v in stats.values()), default=0.0))
        for name, where, fn_name in PARTS:
            parts[name] = min(parts[name], sum(
                v[3] for (path, _, func), v in stats.items()
                if path.replace("\\", "/").endswith(where) and func == fn_name))
    return total, parts


def main():
    args = options(__doc__)
    clock = args.time
    plain = linkdyn.load(linkdyn.example_path("hoeken"))
    rubbing = with_friction(plain)
    t = np.linspace(0.0, 1.0, args.samples)
    for m in (plain, rubbing):   # warm-up: the kernels compiled or loaded once
        linkdyn.analyze(m, t[:100], backend=args.backend)
    tp = best_time(lambda: linkdyn.analyze(plain, t, backend=args.backend), args.repeat, clock)
    tf = best_time(lambda: linkdyn.analyze(rubbing, t, backend=args.backend), args.repeat,
                   clock)
    sol = linkdyn.analyze(rubbing, t, backend=args.backend)
    print(f"Hoeken, {args.samples} samples, backend {args.backend}, {args.clock} clock")
    print(f"  without friction     {args.samples / tp:12.4g} samples/s")
    print(f"  friction at 4 pins   {args.samples / tf:12.4g} samples/s "
          f"(Newton {sol.friction.iterations} iterations)")
    ratio = tp / tf
    print(verdict(ratio, TARGET_RATIO))
    total, parts = split(lambda: linkdyn.analyze(rubbing, t, backend=args.backend), clock,
                         args.repeat)
    print(f"  split of a friction run ({1e3 * total:.1f} ms under the profiler, each the "
          f"least of {args.repeat}):")
    for name, x in parts.items():
        print(f"    {name:20s} {1e3 * x:8.1f} ms  {x / total:6.1%}")
    rest = max(total - sum(parts.values()), 0.0)
    print(f"    {'the rest':20s} {1e3 * rest:8.1f} ms  {rest / total:6.1%}")


if __name__ == "__main__":
    main()
