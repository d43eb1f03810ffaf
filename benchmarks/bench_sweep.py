"""How fast does a design sweep run, and how much memory does it take?

Hoeken's linkage with its ground distance (``bodies.ground.points.O4[0]``, 60-120 mm) and its
coupler length (``bodies.coupler.points.O3[0]``, 90-140 mm) varied over Sobol designs, 360
samples per design (one crank turn), metrics ``peak_tau_J1`` and ``path_deviation`` kept per
design, the default backend choice (compiled with numba). Each run is a fresh process, so its
peak memory (the largest resident set of the process or of any one of its worker processes) is
that run's alone; with K workers the machine holds about K + 1 such processes.

It prints design-samples per second of the sweep (each chunk's layout built at once from the
parameter arrays, ``linkdyn.studies.vectorize``) on one worker and on every core, and, measured
in the same run as baselines: the per-design path (a model read by the loader and a layout
compiled per design, what sweeps did before the vectorized builder) on one worker, and the
hand-written compiled kernel of ``bench_ceiling.py`` (the full analysis of this one four-bar,
one core). Then where one worker's time goes per chunk (building the layouts, the loader's checks
and batching, the solve, the metrics), and the peak memory at two numbers of designs (memory is
bounded by the batch, not by the number of designs).

Targets (issue 14): 1e6 designs x 360 samples in under 60 s on the 2-core machine, that is at
least 3e6 design-samples/s per core; peak memory under 1 GB at any number of designs.

Usage: python benchmarks/bench_sweep.py [--designs N] [--samples T] [--no-ceiling]
       python benchmarks/bench_sweep.py --chunk-only [--designs N]   (one chunk's stages in CPU
       time, the minimum of five runs in one process: to compare two versions of the code in one
       window, run it alternately with each version's ``src`` on PYTHONPATH)
       python benchmarks/bench_sweep.py --kernels   (one batch's compiled stages, CPU time: the
       kinematics kernel then the dynamics stage, as ``analyze`` runs them, against the sweep
       kernel that fuses them, ``linkdyn.dynamics.compiled.sweep``)
       python benchmarks/bench_sweep.py --spatial [--designs N] [--samples T]   (a spatial
       sweep: the RSUR four-bar's crank pin and crank length and the coupler's far end varied,
       default 200 designs x 360 samples, its designs solved as one batch,
       ``linkdyn.spatial.analyze_designs``, against a Python loop of ``linkdyn.spatial.analyze``
       over the same designs, what spatial sweeps did before: the same-run ratio of the two,
       each the shorter of two alternating runs, CPU time, one core)
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import resource  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

import linkdyn  # noqa: E402
from linkdyn.studies import sample  # noqa: E402
from linkdyn.studies.runner import default_chunk  # noqa: E402

BOX = {"bodies.ground.points.O4[0]": (60.0, 120.0), "bodies.coupler.points.O3[0]": (90.0, 140.0)}
METRICS = ["peak_tau_J1", "path_deviation"]
TARGET_PER_CORE = 3e6  # design-samples/s
TARGET_MEMORY = 1 << 30  # bytes


def child(designs: int, samples: int, workers: int, per_design: int = 0) -> dict:
    """One sweep in this process (and its workers): rate and peak memory. ``per_design``: by
    the per-design path (a model and a layout per design) instead of the vectorized builder."""
    from dataclasses import replace

    from linkdyn.studies import Task, run, space
    from linkdyn.studies.metrics import Reduced, check_names

    mech = linkdyn.load(linkdyn.example_path("hoeken"))
    t = np.linspace(0.0, mech.drivers[0].period, samples)
    values = sample(list(BOX.values()), "sobol", designs, seed=0)
    sp = space(linkdyn.example_path("hoeken"), list(BOX))
    task = Task(sp, t, tuple(check_names(sp.model(), METRICS))).with_builder(
        *np.array(list(BOX.values())).T)
    if per_design:
        task = replace(task, builder=replace(task.builder, A=None, why="per-design baseline"))
    # imports and the compiled kernels' first load (a batch large enough for them)
    run(task, sample(list(BOX.values()), "sobol", min(designs, 250_000 // samples + 1), seed=1))
    t0, c0 = time.perf_counter(), _cpu()
    df, _ = run(task, values, workers=workers)
    seconds, cpu = time.perf_counter() - t0, _cpu() - c0
    rss = [resource.getrusage(w).ru_maxrss * 1024 for w in (resource.RUSAGE_SELF,
                                                             resource.RUSAGE_CHILDREN)]
    return {"designs": designs, "samples": samples, "workers": workers, "seconds": seconds,
            "rate": designs * samples / seconds, "cpu": cpu, "cpu_rate": designs * samples / cpu,
            "valid": int(df.valid.sum()), "peak_bytes": max(rss)}


SPATIAL_BOX = {"bodies.crank.points.B[0]": (36.0, 44.0), "bodies.crank.points.B[2]": (-8.0, 8.0),
               "bodies.coupler.points.C[2]": (148.0, 156.0)}
SPATIAL_METRICS = ("peak_tau_J1", "rms_tau_J1", "peak_F_J2", "peak_F_J4", "peak_shaking_force")


def spatial(designs: int, samples: int) -> dict:
    """CPU seconds of a spatial sweep of the RSUR four-bar: its designs as one batch (the
    runner's chunk, ``evaluate``) and one after another (``linkdyn.spatial.analyze`` per
    design, then its metrics), alternately, twice each; and the largest difference of a
    metric between the two, relative to the metric's largest value."""
    from linkdyn import spatial as sp_mod
    from linkdyn.studies import Task, space
    from linkdyn.studies import metrics as metrics_mod
    from linkdyn.studies.runner import evaluate

    path = linkdyn.example_path("rsur")
    sp = space(path, list(SPATIAL_BOX))
    t = np.linspace(0.0, 1.0, samples)                  # one crank turn at 60 rpm
    task = Task(sp, t, SPATIAL_METRICS)
    values = sample(list(SPATIAL_BOX.values()), "sobol", designs, seed=0)

    def batched():
        return evaluate(task, values)

    def loop():
        out = {name: np.full(designs, np.nan) for name in SPATIAL_METRICS}
        for k, v in enumerate(values):
            try:
                sol = sp_mod.analyze(sp.model(v), t)
            except linkdyn.LinkdynError:
                continue
            for name, x in metrics_mod.evaluate(sol, SPATIAL_METRICS).items():
                out[name][k] = x
        return out
    evaluate(task, values[:2])                           # imports
    seconds = {"batch": [], "loop": []}
    for _ in range(2):
        for name, f in (("batch", batched), ("loop", loop)):
            c0 = _cpu()
            res = f()
            seconds[name].append(_cpu() - c0)
            if name == "batch":
                got = res
            else:
                ref = res
    worst = max(float(np.nanmax(np.abs(got[n] - ref[n])) / np.nanmax(np.abs(ref[n])))
                for n in SPATIAL_METRICS)
    return {"batch": min(seconds["batch"]), "loop": min(seconds["loop"]),
            "valid": int(np.sum(got["valid"])), "worst": worst}


def _cpu() -> float:
    """CPU seconds (user + system) of this process and of its finished worker processes."""
    return sum(r.ru_utime + r.ru_stime for r in (resource.getrusage(resource.RUSAGE_SELF),
                                                resource.getrusage(resource.RUSAGE_CHILDREN)))


def stages(designs: int, samples: int, repeat: int = 1) -> dict:
    """CPU seconds of one worker's chunk of ``designs`` designs by stage: the layouts from the
    parameter arrays, the batching and the chunk's assembly at t = 0 (``runner._batches``), the
    solve (``analyze_layout``), the metrics and reasons, the rest (the loader's checks on the
    arrays); with ``repeat``, each the minimum of that many runs of the chunk. The solve is
    the metrics-only sweep's (``kinematics.solution.reduced``; its metrics from the kernel's
    reductions and path, ``metrics.Reduced.values``), and ``analyze_layout`` where the solution
    is kept (a design with an invalid sample, or metrics the kernel does not reduce). Inside
    the solve, ``branch`` (the continuation nodes followed, ``kinematics.positions.follow``,
    their closing kernel included) and ``kernel`` (the compiled kinematics and dynamics: the
    sweep kernel ``dynamics.compiled.sweep``, or the stages' kernels when the layout has other
    loads), parts of ``solve``, not added to the total again."""
    from linkdyn import analysis
    from linkdyn.dynamics import compiled as dc
    from linkdyn.kinematics import compiled as kc
    from linkdyn.kinematics import solution as ks
    from linkdyn.studies import Task, space
    from linkdyn.studies import runner
    from linkdyn.studies.metrics import Reduced, check_names

    mech = linkdyn.load(linkdyn.example_path("hoeken"))
    t = np.linspace(0.0, mech.drivers[0].period, samples)
    values = sample(list(BOX.values()), "sobol", designs, seed=0)
    sp = space(linkdyn.example_path("hoeken"), list(BOX))
    task = Task(sp, t, tuple(check_names(sp.model(), METRICS))).with_builder(
        *np.array(list(BOX.values())).T)
    clock = {"batches": 0.0, "solve": 0.0, "metrics": 0.0}
    inner = {"branch": 0.0, "kernel": 0.0}   # parts of the solve

    def timed(f, key, into=clock):
        def g(*a, **k):
            t0 = time.process_time()
            try:
                return f(*a, **k)
            finally:
                into[key] += time.process_time() - t0
        return g
    solve, fill, batches = runner.analyze_layout, runner._fill, runner._batches
    reduce_, values_of = runner.reduced, Reduced.values   # the metrics-only sweep's
    runner.analyze_layout, runner._fill = timed(solve, "solve"), timed(fill, "metrics")
    runner._batches = timed(batches, "batches")
    runner.reduced, Reduced.values = timed(reduce_, "solve"), timed(values_of, "metrics")
    parts = [(ks, "follow", "branch"), (dc, "sweep", "kernel"), (kc, "run", "kernel"),
             (analysis.compiled_dynamics, "solve", "kernel")]
    saved = [getattr(mod, name) for mod, name, _ in parts]
    for mod, name, key in parts:
        setattr(mod, name, timed(getattr(mod, name), key, inner))
    try:
        runner.evaluate(task, values[:250_000 // samples + 1])   # the kernels' first load
        runs = []
        for _ in range(repeat):
            clock.update(batches=0.0, solve=0.0, metrics=0.0)
            inner.update(branch=0.0, kernel=0.0)
            t0 = time.process_time()
            Z = task.builder.numbers(values)
            task.builder.stacked(Z)
            layouts = time.process_time() - t0
            t0 = time.process_time()
            runner.evaluate(task, values)
            total = time.process_time() - t0
            runs.append({"layouts": layouts, **clock, "rest": total - sum(clock.values()),
                         "total": total, **inner})
    finally:
        runner.analyze_layout, runner._fill, runner._batches = solve, fill, batches
        runner.reduced, Reduced.values = reduce_, values_of
        for (mod, name, _), f in zip(parts, saved):
            setattr(mod, name, f)
    return {k: min(r[k] for r in runs) for k in runs[0]}


def kernels(samples: int, repeat: int = 5) -> dict:
    """CPU seconds per design-sample of one batch of a sweep's chunk (the runner's batch size,
    ``runner.BATCH_SAMPLES`` design-samples), its branch already followed: the kinematics kernel
    (``kinematics.compiled.run``) then the dynamics stage (``dynamics.compiled.solve``), against
    the sweep kernel (``dynamics.compiled.sweep``, both fused, writing only the joints' motion and
    the poses of the kinematics), each with the solution built from its arrays, and the sweep
    kernel keeping the metrics only (``sweep(..., metrics=)``), with the metrics from its
    reductions and path; the minimum of ``repeat`` alternating runs."""
    from linkdyn import loads as loads_mod
    from linkdyn.dynamics import compiled as dc
    from linkdyn.kinematics import compiled as kc
    from linkdyn.kinematics.solution import _from_kernel
    from linkdyn.studies import Task, runner, space
    from linkdyn.studies.metrics import check_names

    mech = linkdyn.load(linkdyn.example_path("hoeken"))
    t = np.linspace(0.0, mech.drivers[0].period, samples)
    sp = space(linkdyn.example_path("hoeken"), list(BOX))
    task = Task(sp, t, tuple(check_names(sp.model(), METRICS)), backend="compiled").with_builder(
        *np.array(list(BOX.values())).T)
    seen = []
    sweep = dc.sweep

    def spy(*a, **k):
        seen.append((a, k))
        return sweep(*a, **k)
    dc.sweep = spy
    try:   # one batch's arguments of the sweep kernel (and every kernel compiled)
        runner.evaluate(task, sample(list(BOX.values()), "sobol",
                                     runner.BATCH_SAMPLES // samples, seed=0))
    finally:
        dc.sweep = sweep
    (lay, tt, *state), how = seen[0]
    how = {k: v for k, v in how.items() if k != "metrics"}
    model, D = sp.model(), lay.designs

    def stages():
        out = kc.run(lay, tt, *state, **how)
        kin = _from_kernel(model, lay, tt, out, out["err"].reshape(D, samples))
        dc.solve(kin, loads_mod.wrenches(None, kin))

    def fused():
        out = sweep(lay, tt, *state, **how)
        kin = _from_kernel(model, lay, tt, out, out["err"].reshape(D, samples), lambda: None)
        dc.swept(kin, loads_mod.wrenches(None, kin))
    spec, keep, _ = runner._metrics_only(task, lay, runner._backend(task, D * samples, lay))

    def metrics_only():
        out = sweep(lay, tt, *state, metrics=keep, **how)
        spec.values(model, out["reduced"], out["path"], state[0], samples)
    best = {"stages": np.inf, "fused": np.inf, "metrics": np.inf}
    for _ in range(repeat):
        for name, f in (("stages", stages), ("fused", fused), ("metrics", metrics_only)):
            t0 = time.process_time()
            f()
            best[name] = min(best[name], (time.process_time() - t0) / (D * samples))
    return {"designs": D, **best}


def in_fresh_process(designs: int, samples: int, workers: int, per_design: int = 0) -> dict:
    done = subprocess.run([sys.executable, __file__, "--child", str(designs), str(samples),
                           str(workers), str(per_design)], capture_output=True, text=True,
                          timeout=3600)
    if done.returncode:
        raise SystemExit(done.stderr[-2000:])
    return json.loads(done.stdout.strip().splitlines()[-1])


def ceiling_rate(samples: int) -> float:
    """Design-samples per second of the hand-written compiled kernel (full analysis), one core,
    over as many samples as the sweep's designs x samples (at most 4e6)."""
    from bench_ceiling import ROWS_ALL, setup
    from bench_hoeken import best_time

    mech = linkdyn.load(linkdyn.example_path("hoeken"))
    run = setup(mech)
    t = np.linspace(0.0, mech.drivers[0].period, samples)
    run(t[:100], np.empty((ROWS_ALL, 100)))  # compile
    return samples / best_time(lambda: run(t, np.empty((ROWS_ALL, samples))), 3)


def projection(cpu_rate: float, cores: int | None = None) -> str:
    """The projected time of the issue's target sweep (1e6 designs x 360 samples) on this
    machine's ``cores`` with every core at ``cpu_rate`` design-samples per CPU second (an
    otherwise idle machine, workers' start-up left out), against the 60 s target."""
    cores = cores or (len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity")
                      else os.cpu_count())
    s = 1e6 * 360 / (cpu_rate * cores)
    return (f"1e6 designs x 360 samples on {cores} cores at this rate: {s:.0f} s "
            f"(target 60 s: {'met' if s < 60 else 'NOT met'})")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    ap.add_argument("--designs", type=int, default=10_000)
    ap.add_argument("--samples", type=int, default=360)
    ap.add_argument("--no-ceiling", action="store_true",
                    help="skip the hand-written kernel (its compile takes about a minute)")
    ap.add_argument("--chunk-only", action="store_true",
                    help="only one chunk's stages, CPU time, minimum of five runs")
    ap.add_argument("--kernels", action="store_true",
                    help="only one batch's compiled stages against the sweep kernel, CPU time")
    ap.add_argument("--spatial", action="store_true",
                    help="a spatial sweep (RSUR, default 200 designs): batched against the loop")
    ap.add_argument("--child", nargs=4, type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.spatial:
        D = args.designs if "--designs" in sys.argv else 200
        r = spatial(D, args.samples)
        print(f"RSUR spatial sweep: {D} Sobol designs x {args.samples} samples, crank pin, crank "
              f"length and coupler end varied, metrics {', '.join(SPATIAL_METRICS)}; CPU s, each "
              f"the shorter of 2 alternating runs (load average {os.getloadavg()[0]:.2f})")
        print(f"  designs as one batch {r['batch']:.3g} s ({D * args.samples / r['batch']:.4g} "
              f"design-samples/s), a loop of spatial.analyze {r['loop']:.3g} s "
              f"({D * args.samples / r['loop']:.4g}): the batch runs {r['loop'] / r['batch']:.3g}x "
              f"faster; {r['valid']} valid; largest metric difference {r['worst']:.2g} of its "
              f"largest value")
        return
    if args.child:
        print(json.dumps(child(*args.child)))
        return
    if args.kernels:
        k = kernels(args.samples)
        print(f"one batch of {k['designs']} designs x {args.samples} samples, CPU ns per "
              f"design-sample (each the minimum of 5 alternating runs; load average "
              f"{os.getloadavg()[0]:.2f}): kinematics kernel then dynamics stage "
              f"{k['stages'] * 1e9:.0f}, sweep kernel (fused) {k['fused'] * 1e9:.0f}, "
              f"sweep kernel keeping the metrics only (their reductions and the path point; "
              f"the metrics from them) {k['metrics'] * 1e9:.0f}")
        return
    if args.chunk_only:
        chunk = min(args.designs, default_chunk(args.designs, args.samples))
        st = stages(chunk, args.samples, repeat=5)
        print(f"one chunk of {chunk} designs x {args.samples} samples, one worker, CPU s "
              f"(each the minimum of 5 runs in one process; load average "
              f"{os.getloadavg()[0]:.2f}): " + ", ".join(f"{k} {v:.3g}" for k, v in st.items()))
        rate = chunk * args.samples / st["total"]
        print(f"  {rate:.4g} design-samples per CPU second; " + projection(rate))
        ns = {k: v / (chunk * args.samples) * 1e9 for k, v in st.items()}
        print("  CPU ns per design-sample: " + ", ".join(
            f"{k} {ns[k]:.0f}" for k in ("layouts", "batches", "solve", "metrics", "rest",
                                          "total"))
              + f"; of the solve: the branch (continuation nodes) {ns['branch']:.0f}, the "
              f"compiled kinematics and dynamics {ns['kernel']:.0f}, the rest of the solve "
              f"(the solution's arrays, finiteness, Python) "
              f"{ns['solve'] - ns['branch'] - ns['kernel']:.0f}")
        return
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    D, T = args.designs, args.samples
    print(f"Hoeken sweep: {D} Sobol designs x {T} samples, ground distance and coupler length "
          f"varied, metrics {', '.join(METRICS)}")
    one = in_fresh_process(D, T, 1)
    allc = in_fresh_process(D, T, cores) if cores > 1 else one
    small = in_fresh_process(max(D // 4, 1), T, 1)
    base = in_fresh_process(max(D // 10, 1), T, 1, per_design=1)
    ceiling = None if args.no_ceiling else ceiling_rate(min(D * T, 4_000_000))
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"  load average (1 min) at the end of the runs: {load:.2f} on {os.cpu_count()} cores")
    for label, r in (("one worker", one), (f"{cores} workers", allc)):
        print(f"  {label:<11} {r['rate']:10.4g} design-samples/s  ({r['seconds']:.3g} s, "
              f"{r['valid']} valid, peak memory of a process {r['peak_bytes'] / 2**20:.0f} MB); "
              f"per CPU second {r['cpu_rate']:.4g} ({r['cpu']:.3g} s of CPU)")
    print(f"  per-design path (a model and a layout per design; {base['designs']} designs, one "
          f"worker, same run) {base['rate']:.4g} design-samples/s: the vectorized builder runs "
          f"{one['rate'] / base['rate']:.3g}x faster on one worker")
    print(f"  {cores} workers run {allc['rate'] / one['rate']:.3g}x one worker's rate")
    chunk = min(D, default_chunk(D, T))   # the sweep's default chunk on one worker
    st = stages(chunk, T)
    print(f"  one chunk of {chunk} designs, one worker: "
          + ", ".join(f"{k} {v:.3g} s" for k, v in st.items()))
    print(f"  peak memory at {small['designs']} designs {small['peak_bytes'] / 2**20:.0f} MB, "
          f"at {D} designs {one['peak_bytes'] / 2**20:.0f} MB (one worker): target < 1 GB "
          f"{'met' if max(one['peak_bytes'], allc['peak_bytes']) < TARGET_MEMORY else 'NOT met'}")
    per_core = allc["rate"] / cores
    print(f"  per CPU second on {cores} workers {allc['cpu_rate']:.4g} design-samples/s (the "
          f"rate per core of an otherwise idle machine, processes' start-up included): "
          + projection(allc["cpu_rate"], cores))
    if ceiling:
        print(f"  hand-written compiled kernel (bench_ceiling, full analysis, one core) "
              f"{ceiling:.4g} samples/s: the sweep on one worker runs at "
              f"{one['rate'] / ceiling:.2%} of it")
    print(f"  per core on {cores} workers {per_core:.4g} design-samples/s: target "
          f"{TARGET_PER_CORE:.0e} {'met' if per_core >= TARGET_PER_CORE else 'NOT met'}; "
          f"1e6 designs x 360 samples would take {1e6 * 360 / allc['rate']:.0f} s (target 60 s)")


if __name__ == "__main__":
    main()
