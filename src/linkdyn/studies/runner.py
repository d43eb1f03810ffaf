"""Sweeps: many designs of one model, each solved and reduced to its metrics.

A sweep is a table of designs (one row of parameter values each, in the file's units), cut into
chunks. A chunk builds its designs' models, solves them as one batch (``linkdyn.analyze`` over a
design axis; a spatial model's designs by ``linkdyn.spatial.analyze_designs``, every stage on
all designs' samples at once, in :func:`evaluate_models`), keeps only the metrics (:mod:`.metrics`) and drops the time histories, so memory is
bounded by the chunk whatever the number of designs. Chunks run in this process, in local worker
processes, or on a Dask cluster, with the same results. With an output directory each finished
chunk is written at once (``chunks/chunk-<k>.parquet``), so a killed sweep resumes without
computing a finished chunk again.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import sys
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from collections.abc import Sequence
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from .. import backend as backend_mod
from ..analysis import analyze, analyze_layout, failure, layout_stages
from ..errors import AssemblyError, ModelError
from ..kinematics import driver_values
from ..dynamics import compiled as compiled_dynamics
from ..kinematics.positions import ACCEPT, assemble, not_assembled
from ..kinematics.solution import reduced
from . import checks, files
from .files import _pandas
from . import metrics as metrics_mod
from . import vectorize
from .params import Space
from ..units import Units

METHODS = ("grid", "random", "lhs", "sobol")
# design-samples per chunk (the unit of work, of writing and of resuming): four chunks per
# worker, within these bounds (see :func:`default_chunk`)
CHUNK_SAMPLES = (1_000_000, 10_000_000)
# design-samples solved at once: ~120 MB of time histories at most. Batches of 1e5 to 2e5 run
# fastest per sample (their arrays are reused from the heap and stay nearer the caches;
# measured on Hoeken, CPU time of a 5,000-design chunk: 0.66-0.80 s at 1.5e5, 1.0-1.05 s at
# 5e4 where each batch's fixed Python costs (assembly, continuation nodes, metrics) take over,
# 1.1-1.6 s at 2.5e5 and 4-6.5 s at 1e6)
BATCH_SAMPLES = 150_000
# a spatial model's design-samples times its bodies solved at once (its stages hold more per
# sample and body: 6-D twists, screws, spatial inertias, the closure Jacobian): about 300 MB of
# arrays for the RSUR four-bar's 4 bodies (38,000 design-samples)
SPATIAL_BATCH_BODY_SAMPLES = 150_000


# --- the designs ------------------------------------------------------------------------------

def sample(bounds, method: str = "sobol", n: int | None = None, seed: int | None = 0,
           counts=None) -> np.ndarray:
    """Parameter values (D, P) covering the box ``bounds`` ((lo, hi) per parameter).

    Parameters
    ----------
    method : {'grid', 'random', 'lhs', 'sobol'}
        ``grid``: every combination of ``counts[k]`` evenly spaced values per parameter (both ends
        included; a count missing takes ``round(n ** (1 / P))``, at least 2); ``random``: uniform;
        ``lhs``: Latin hypercube; ``sobol``: scrambled Sobol points (scipy.stats.qmc).
    n : int
        Number of designs (not for a grid with every count given).
    seed : int or None
        Seed of the random, LHS and Sobol points (the same seed gives the same designs).
    """
    lo = np.array([b[0] for b in bounds], float)
    hi = np.array([b[1] for b in bounds], float)
    P = len(lo)
    seed = checks.seed(seed)
    if method == "grid":
        axes = [np.linspace(a, b, c) if c > 1 else np.array([a])
                for a, b, c in zip(lo, hi, grid_counts(n, counts, P))]
        return np.stack([g.ravel() for g in np.meshgrid(*axes, indexing="ij")], axis=-1)
    n = design_count(method, n, counts, P)
    if method == "random":
        u = np.random.default_rng(seed).random((n, P))
    else:
        import warnings

        from scipy.stats import qmc
        gen = (qmc.LatinHypercube(d=P, seed=seed) if method == "lhs"
               else qmc.Sobol(d=P, scramble=True, seed=seed))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # Sobol balance wants a power of 2; any n is fine
            u = gen.random(n)
    return lo + u * (hi - lo)


def grid_counts(n: int | None, counts, P: int) -> list[int]:
    """Values per parameter of a grid: ``counts[k]``, or where missing ``round(n ** (1 / P))``
    (at least 2; ``n`` default ``2 ** P``)."""
    n = checks.count(n, "--designs", "designs")
    default = max(2, int(round((n or 2 ** P) ** (1.0 / P))))
    return [c or default for c in list(counts or [None] * P)]


def design_count(method: str, n: int | None, counts, P: int) -> int:
    """The number of designs :func:`sample` makes, found without making them."""
    if method not in METHODS:
        raise ModelError(f"unknown method '{method}'", field="--method",
                         fix="Use one of " + ", ".join(METHODS))
    if method == "grid":
        return math.prod(grid_counts(n, counts, P))
    if n is None:
        raise ModelError("the number of designs must be given", field="--designs",
                         fix="Give --designs N")
    return checks.count(n, "--designs", "designs")


def check_size(task: Task, designs: int, *, workers: int = 1, scheduler=None,
               option: str = "--designs") -> None:
    """Refuse a study of ``designs`` designs of ``task`` that cannot fit in memory or finish
    (:func:`.checks.sweep_size`, at the backend it would run)."""
    checks.sweep_size(designs, len(task.space.params), len(task.metrics), len(task.t),
                      workers=workers,
                      backend=_backend(task, designs * len(task.t), runs=False).name,
                      local=scheduler is None, option=option)


# --- one chunk --------------------------------------------------------------------------------

@dataclass(frozen=True)
class Task:
    """Everything a worker needs to evaluate designs (pickled to processes and Dask workers)."""

    space: Space
    t: np.ndarray
    metrics: tuple[str, ...]
    backend: str | backend_mod.Backend | None = None   # chosen once for the sweep by run()
    path_point: str | None = None
    path_range: tuple | None = None
    fluctuation: float = 0.02
    builder: Any = None   # vectorize.Builder of the study (derived from the designs if None)

    def __post_init__(self):   # the study's numbers checked once, whoever builds the task
        object.__setattr__(self, "t", checks.times(self.t))
        object.__setattr__(self, "fluctuation", checks.fluctuation(self.fluctuation))
        object.__setattr__(self, "path_range", checks.path_range(self.path_range))

    def with_builder(self, lo, hi) -> Task:
        """This task with the builder of designs ranging over ``lo``..``hi`` (P,), file units
        (none for a spatial model: its designs are built by the loader, then solved as one batch)."""
        if self.space.spatial:
            return self
        return replace(self, builder=vectorize.derive(self.space, lo, hi))


class Designs(Sequence):
    """The models of designs ``values`` (D, P) of a space, each built when read (the batch's
    ``Solution.designs``: the solve itself needs no model per design)."""

    def __init__(self, space: Space, values: np.ndarray):
        self.space, self.values = space, values

    def __len__(self) -> int:
        return len(self.values)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[i] for i in range(len(self))[k]]
        return self.space.model(self.values[k])


def _reason(err) -> str:
    """An error's text without the file name (the same for every design)."""
    err.file = ""
    return str(err)


def evaluate(task: Task, values) -> dict[str, np.ndarray]:
    """Validity, reason and metrics of designs ``values`` (D, P).

    A design is valid when its model is valid, it assembles, and every sample closes clear of a
    singular position; otherwise ``valid`` is False, its metrics NaN and ``reason`` the message
    ``linkdyn.analyze`` would raise for it alone (without the file name).

    Returns
    -------
    dict
        ``valid`` (D,) bool, ``reason`` (D,) object (str, '' when valid) and each metric (D,).
    """
    values = np.asarray(values, float).reshape(-1, len(task.space.params))
    if task.space.spatial:
        return evaluate_models(task, values)
    builder = task.builder
    if builder is None:
        builder = vectorize.derive(task.space, np.min(values, axis=0), np.max(values, axis=0))
    if not builder.vectorized:
        return evaluate_models(task, values)
    D = len(values)
    Z = builder.numbers(values)
    lay, guesses = builder.stacked(Z)
    reason = np.full(D, "", dtype=object)
    # the loader's checks, on the arrays; a design that may fail one is read by the loader
    ok = np.ones(D, bool)
    for k in np.flatnonzero(builder.suspect(values, Z, lay)):
        try:
            task.space.model(values[k])
        except ModelError as e:
            ok[k], reason[k] = False, _reason(e)
    valid = np.zeros(D, bool)
    out = {name: np.full(D, np.nan) for name in task.metrics}
    batches, start, apart = _batches(builder, lay, guesses, np.flatnonzero(ok), len(task.t))
    for k in apart:   # no assembly mode closes its dyads: analyze's error, nothing solved
        reason[k] = _reason(_not_assembled(task.space.model(values[k]), builder.layout))
    # the backend chosen once for the chunk, so that a small last batch runs it too
    backend = _backend(task, D * len(task.t), builder.layout)
    spec = _metrics_only(task, builder.layout, backend)
    at = 0   # the batch's columns of ``start``, the chunk's assembly
    for idx in batches:
        cols = slice(at, at + len(idx))
        at += len(idx)
        if spec is not None:   # the kernel keeps the metrics only
            sub = lay if len(idx) == D else lay.take(idx)
            got = reduced(builder.guess_models({k: g[idx] for k, g in guesses.items()},
                                               len(idx)), sub, task.t, start[:, cols],
                          partial(compiled_dynamics.sweep, metrics=spec[1]))
            if got is not None:
                ok = got["ok"]
                metric = spec[0].values(spec[2], got["reduced"], got["path"], got["q_drv"],
                                        len(task.t))
                valid[idx] = ok
                for name, v in metric.items():
                    out[name][idx] = np.where(ok, v, np.nan)
                if np.all(ok):
                    continue
                # a design with a sample that is not valid: solved again, kept, for its
                # reason (and its metrics NaN) as analyze gives them
                idx, cols = idx[~ok], np.arange(cols.start, cols.stop)[~ok]
        sub = lay if len(idx) == D else lay.take(idx)
        sol = analyze_layout(builder.guess_models({k: g[idx] for k, g in guesses.items()},
                                                  len(idx)), sub, task.t, backend=backend,
                             designs=Designs(task.space, values[idx]),
                             reactions=metrics_mod.reads_reactions(task.metrics),
                             start=start[:, cols])
        _fill(task, sol, idx, valid, reason, out)
    return {"valid": valid, "reason": reason, **out}


def _metrics_only(task: Task, layout, backend) -> tuple | None:
    """``(Reduced, dynamics.compiled.Metrics, the study's model)`` when the sweep kernel can keep the task's
    metrics only (:func:`.metrics.reduced`; the compiled backend, the sweep kernel's layout:
    :func:`linkdyn.dynamics.compiled.fusable`), else None (the solution is kept and
    :func:`.metrics.evaluate` reads it)."""
    if not backend.compiled or not compiled_dynamics.fusable(layout):
        return None
    model = task.space.model()
    spec = metrics_mod.reduced(model, task.metrics, path_point=task.path_point,
                               path_range=task.path_range)
    if spec is None:
        return None
    return spec, compiled_dynamics.Metrics(tuple((k, how) for _, k, how in spec.efforts),
                                           spec.point, ACCEPT), model


def _backend(task: Task, samples: int, layout=None, runs: bool = True) -> backend_mod.Backend:
    """The backend of ``task`` chosen (:func:`linkdyn.backend.choose`) for ``samples``
    design-samples of its model (``layout``: the study's, whose loads say whether the sweep
    kernel runs it), so that every batch of a sweep runs it."""
    if task.space.spatial:   # the spatial solver runs on numpy
        name = getattr(task.backend, "name", task.backend)
        if name == "compiled":
            raise ModelError("the compiled backend is not yet for spatial models",
                             file=task.space.source, field="--backend",
                             fix="Drop --backend compiled (spatial models run on numpy)")
        return backend_mod.choose("numpy", backend_mod.Work(samples, 1), [], runs=runs)
    base = task.space.model()
    reactions = metrics_mod.reads_reactions(task.metrics)
    stages = layout_stages(layout, reactions) if layout is not None else backend_mod.ANALYSIS
    work = backend_mod.Work(samples, len(base.bodies) - 1, stages=stages)
    return backend_mod.choose(task.backend, work, [j.kind for j in base.joints], runs=runs)


def _batches(builder, lay, guesses, idx, T: int):
    """The designs ``idx`` of a chunk in batches solved at once, of at most ``BATCH_SAMPLES``
    design-samples each, as equal as may be (memory is bounded by a batch's time histories),
    their assembly at t = 0, and the designs that cannot be assembled whatever the start.

    The designs are assembled at once for the whole chunk
    (:func:`linkdyn.kinematics.positions.assemble`: a damped Newton solve from the
    ``[assembly]`` guesses, restarts for the designs it does not close), so that its Python
    costs, and the restarts, are paid once per chunk and not once per batch. A design's
    assembly, like the rest of its solution, does not depend on the designs solved with it.
    For a mechanism of dyads, a design whose dyads close in no assembly mode at t = 0
    (:func:`linkdyn.kinematics.dyads.closable`, which the assembly checks first and reports)
    is left out of the batches: nothing of it is solved.

    Returns
    -------
    batches : list of ndarray
        The batches' design indices.
    start : ndarray (n, B) or None
        The batched designs' tree coordinates at t = 0, batch after batch (NaN for a design
        that does not assemble).
    apart : ndarray
        The designs left out.
    """
    if not len(idx):
        return [], None, idx
    sub = lay if len(idx) == lay.designs else lay.take(idx)
    models = builder.guess_models({k: g[idx] for k, g in guesses.items()}, len(idx))
    q, can = assemble(models, sub, sub.driver_values(np.zeros(1))[0][..., 0], 0.0,
                      raise_error=False, closable=True)
    if not np.any(can):
        return [], None, idx
    size = max(1, BATCH_SAMPLES // max(T, 1))
    batches = np.array_split(idx[can], -(-int(np.sum(can)) // size))
    return batches, q[:, can], idx[~can]


def _not_assembled(model, lay) -> AssemblyError:
    """The error of a design that cannot be assembled at t = 0, as ``analyze`` raises it
    (``lay``: a layout of its topology)."""
    return not_assembled(model, lay, driver_values(model, np.zeros(1))[0][:, 0], 0.0)


def _fill(task: Task, sol, idx, valid, reason, out) -> None:
    """Validity, reasons and metrics of the solved designs ``idx`` (``sol``'s designs)."""
    good = np.all(sol.valid, axis=-1)
    kin = sol.kin
    for j in np.flatnonzero(~good):  # the message analyze would give this design alone
        m = sol.designs[j]
        if not np.isfinite(kin.residual[j, 0]) and not np.any(sol.valid[j]):
            err: AssemblyError = _not_assembled(m, kin.layout)
        else:
            i = int(np.argmin(sol.valid[j]))
            err = failure(m, task.t[i], kin.residual[j, i])
        reason[idx[j]] = _reason(err)
    values_m = metrics_mod.evaluate(sol, task.metrics, path_point=task.path_point,
                                    path_range=task.path_range, fluctuation=task.fluctuation)
    valid[idx] = good
    for name, v in values_m.items():
        out[name][idx] = np.where(good, v, np.nan)


def evaluate_models(task: Task, values) -> dict[str, np.ndarray]:
    """:func:`evaluate` by the per-design path: a model per design, then their layouts."""
    D = len(values)
    models, errors = task.space.models(values)
    valid = np.zeros(D, bool)
    reason = np.array([_reason(e) if e is not None else "" for e in errors], dtype=object)
    out = {name: np.full(D, np.nan) for name in task.metrics}
    ok = [k for k in range(D) if models[k] is not None]
    if ok and task.space.spatial:
        _fill_each(task, models, ok, valid, reason, out)
    elif ok:
        sol = analyze([models[k] for k in ok], task.t, backend=task.backend)
        _fill(task, sol, np.array(ok), valid, reason, out)
    return {"valid": valid, "reason": reason, **out}


def _fill_each(task: Task, models, idx, valid, reason, out) -> None:
    """Validity, reasons and metrics of the designs ``idx`` of a spatial model, solved together
    by :func:`linkdyn.spatial.analyze_designs` (batches of at most ``SPATIAL_BATCH_BODY_SAMPLES``
    design-samples times bodies); a design's reason is the message
    :func:`linkdyn.spatial.analyze` raises for it alone."""
    from .. import spatial

    idx = np.asarray(idx, dtype=int)
    bodies = len(models[idx[0]].bodies) if len(idx) else 1
    size = max(1, SPATIAL_BATCH_BODY_SAMPLES // (max(len(task.t), 1) * bodies))
    for part in np.array_split(idx, -(-len(idx) // size)):
        sol, kept, errors = spatial.analyze_designs([models[k] for k in part], task.t)
        for k, e in zip(part, errors):
            if e is not None:
                reason[k] = _reason(e)
        if sol is None:
            continue
        good = np.array([errors[j] is None for j in kept], bool)
        rows = part[kept]
        valid[rows] = good
        for name, v in metrics_mod.evaluate(sol, task.metrics).items():
            out[name][rows] = np.where(good, v, np.nan)


def _run_chunk(task: Task, k: int, values, outdir: str | None):
    """Evaluate chunk ``k`` and, with an output directory, write it (atomically)."""
    cols = evaluate(task, values)
    if outdir is not None:
        _write_chunk(Path(outdir), k, cols)
    return k, cols


def _write_chunk(outdir: Path, k: int, cols) -> None:
    pd = _pandas()
    path = files.chunk_path(outdir, k)
    tmp = path.with_name(path.name + f".tmp{os.getpid()}")
    pd.DataFrame(cols).to_parquet(tmp, index=False)
    os.replace(tmp, path)  # a chunk file exists only when complete


# --- the sweep --------------------------------------------------------------------------------

class Progress:
    """A progress line on stderr: designs done, rate (design-samples/s) and time left."""

    def __init__(self, total: int, samples: int, stream=None, every: float = 0.5):
        self.total, self.samples, self.stream, self.every = total, samples, stream or sys.stderr, every
        self.start = time.perf_counter()
        self.last = -1e9
        self.done = 0
        self.new = 0
        self.last_done = -1

    def update(self, designs: int, computed: bool, final: bool = False) -> None:
        self.done += designs
        self.new += designs if computed else 0
        now = time.perf_counter()
        if not final and now - self.last < self.every and self.done < self.total:
            return
        if final and self.last_done == self.done:  # the line already shows the end
            self.stream.write("\n")
            self.stream.flush()
            return
        self.last_done = self.done
        self.last = now
        el = now - self.start
        rate = self.new / el if el > 0 else 0.0
        left = (self.total - self.done) / rate if rate > 0 else float("nan")
        bar = "#" * int(30 * self.done / max(self.total, 1))
        self.stream.write(f"\r[{bar:<30}] {self.done}/{self.total} designs  "
                          f"{rate * self.samples:.3g} design-samples/s  "
                          f"{'left ' + _duration(left) if self.done < self.total else 'done'}   ")
        if final:
            self.stream.write("\n")
        self.stream.flush()


def _duration(s: float) -> str:
    if not np.isfinite(s):
        return "?"
    return f"{s:.0f} s" if s < 120 else f"{s / 60:.1f} min"


def _fingerprint(task: Task, values: np.ndarray, chunk: int) -> str:
    h = hashlib.sha256()
    h.update(json.dumps(task.space.data, sort_keys=True, default=str).encode())
    h.update(json.dumps([task.space.paths, list(task.metrics), task.path_point,
                         None if task.path_range is None else list(task.path_range),
                         task.fluctuation, chunk]).encode())
    h.update(np.ascontiguousarray(task.t).tobytes())
    h.update(np.ascontiguousarray(values).tobytes())
    return h.hexdigest()


def default_chunk(D: int, T: int, workers: int = 1) -> int:
    """Designs per chunk of a sweep of D designs x T samples: a quarter of each worker's share
    of the sweep (so that K workers finish together within about a chunk), within
    ``CHUNK_SAMPLES`` design-samples. Memory does not depend on it (it is bounded by the batch,
    ``BATCH_SAMPLES``); a chunk's fixed costs (sorting its designs into batches, the first load
    of the compiled kernels in a fresh worker) are spread over at least 1e6 design-samples; and
    the backend is the sweep's, so a small chunk does not fall back to numpy."""
    lo, hi = CHUNK_SAMPLES
    return max(1, min(max(D * T // (4 * max(workers, 1)), lo), hi) // max(T, 1))


def run(task: Task, values, *, outdir=None, resume: bool = False, chunk: int | None = None,
        workers: int = 1, scheduler=None, progress: bool = False, _stop_after: int | None = None):
    """Evaluate designs ``values`` (D, P) in chunks; the table of designs (pandas DataFrame).

    Parameters
    ----------
    outdir : path, optional
        Write each finished chunk to ``outdir/chunks/`` and, at the end, ``designs.parquet`` and
        ``summary.json`` there (then the chunks are removed).
    resume : bool
        Keep the finished chunks of an interrupted sweep of the same study in ``outdir`` and
        compute only the others (a different study there is an error).
    chunk : int, optional
        Designs per chunk (default :func:`default_chunk`: a quarter of each worker's share,
        within ``CHUNK_SAMPLES`` design-samples; memory is bounded by the batch,
        ``BATCH_SAMPLES``, not the chunk).
    workers : int
        Local worker processes (1: this process).
    scheduler : str or distributed.Client, optional
        Run the chunks on this Dask cluster instead (address such as ``tcp://host:8786``).

    Returns
    -------
    (DataFrame, dict)
        The table (one row per design: ``design``, the parameters, ``valid``, ``reason``, the
        metrics) and run statistics (chunks computed and reused, seconds, rate).
    """
    values = np.asarray(values, float).reshape(-1, len(task.space.params))
    D, T = len(values), len(task.t)
    chunk = checks.count(chunk, "--chunk", "designs per chunk")
    workers = checks.workers(workers)
    check_size(task, D, workers=workers, scheduler=scheduler)
    if task.builder is None and D:   # the map from parameters to layouts, derived once
        task = task.with_builder(np.min(values, axis=0), np.max(values, axis=0))
    if D:   # one backend for every chunk and batch, by the size of the whole sweep
        task = replace(task, backend=_backend(task, D * T, getattr(task.builder, "layout",
                                                                   None)))
    chunk = int(chunk or default_chunk(D, T, workers))
    starts = list(range(0, D, chunk))
    results: dict[int, dict] = {}
    out = Path(outdir) if outdir is not None else None
    client = _connect(scheduler) if scheduler is not None else None   # before any file
    prepared = False
    try:
        if out is not None:
            names = ("valid", "reason", *task.metrics)
            found = files.prepare_chunks(out, _fingerprint(task, values, chunk), D, chunk,
                                         resume)
            prepared = True
            for k in (k for k in found if k < len(starts)):   # a damaged one is redone
                cols = files.read_chunk(out, k, names, len(values[starts[k]:][:chunk]))
                if cols is not None:
                    results[k] = cols
        return _compute(task, values, starts, chunk, results, out, workers, client, progress,
                        _stop_after)
    except BaseException:
        if prepared and not results:   # nothing finished: no chunks folder left behind
            files.remove_chunks(out)
        raise
    finally:
        if client is not None and client is not scheduler:
            client.close()


def _compute(task, values, starts, chunk, results, out, workers, client, progress,
             _stop_after):
    """The chunks of :func:`run` not in ``results``, then the table and the statistics."""
    pd = _pandas()
    D, T = len(values), len(task.t)
    reused = len(results)
    bar = Progress(D, T) if progress else None
    if bar:
        for k in results:
            bar.update(len(results[k]["valid"]), computed=False)
    todo = [k for k in range(len(starts)) if k not in results]
    t0 = time.perf_counter()
    outs = None if out is None else str(out)

    def done(k, cols):
        results[k] = cols
        if bar:
            bar.update(len(cols["valid"]), computed=True)
        if _stop_after is not None and len(results) - reused >= _stop_after:
            raise KeyboardInterrupt(f"stopped after {_stop_after} chunks (test hook)")

    part = {k: values[starts[k]:starts[k] + chunk] for k in todo}
    if client is not None:
        _run_dask(client, task, part, outs, done)
    elif workers > 1 and len(todo) > 1:
        with ProcessPoolExecutor(max_workers=min(workers, len(todo))) as pool:
            pending = {pool.submit(_run_chunk, task, k, part[k], outs) for k in todo}
            try:
                while pending:
                    finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                    for f in finished:
                        done(*f.result())
            except BaseException:
                for f in pending:
                    f.cancel()
                raise
    else:
        for k in todo:
            done(*_run_chunk(task, k, part[k], outs))
    seconds = time.perf_counter() - t0
    if bar:
        bar.update(0, computed=False, final=True)
    cols = {name: np.concatenate([results[k][name] for k in range(len(starts))])
            for name in ("valid", "reason", *task.metrics)}
    table = {"design": np.arange(D)}
    table.update({p.path: values[:, i] for i, p in enumerate(task.space.params)})
    table.update(cols)
    df = pd.DataFrame(table)
    df["valid"] = df["valid"].astype(bool)
    df["reason"] = df["reason"].astype(str)
    computed = len(todo)
    stats = {"chunks": len(starts), "chunks_computed": computed, "chunks_reused": reused,
             "designs_per_chunk": chunk, "seconds": seconds,
             "design_samples_per_s": (sum(len(part[k]) for k in todo) * T / seconds
                                      if seconds > 0 and computed else None)}
    return df, stats


def _run_dask(client, task, part, outs, done) -> None:
    from distributed import as_completed

    task_f = client.scatter(task, broadcast=True)
    futures = [client.submit(_run_chunk, task_f, k, v, outs, pure=False)
               for k, v in part.items()]
    try:
        for f in as_completed(futures):
            done(*f.result())
    except BaseException:
        client.cancel(futures)
        raise


#: Seconds to wait for a Dask scheduler to answer.
CONNECT_TIMEOUT = 1.5


def _connect(scheduler):
    """A ``distributed.Client`` of ``scheduler`` (a client, returned as it is, or an address),
    or a ModelError naming ``--scheduler`` at once for an address that is not one or where
    nothing answers within :data:`CONNECT_TIMEOUT` s."""
    if not isinstance(scheduler, str):
        from distributed import Client
        if isinstance(scheduler, Client):
            return scheduler
        raise ModelError(f"the scheduler must be an address or a distributed.Client, not "
                         f"{type(scheduler).__name__}", field="--scheduler",
                         fix="Give an address such as tcp://host:8786")
    host, port = _address(scheduler)
    if host is not None:   # nothing listening: said at once, not after distributed's 30 s
        import socket
        try:
            socket.create_connection((host, port), timeout=CONNECT_TIMEOUT).close()
        except OSError as e:
            raise ModelError(f"no Dask scheduler answers at {scheduler} "
                             f"({e.strerror or e or 'timed out'})", field="--scheduler",
                             fix="Start the scheduler (dask scheduler) and its workers, check "
                                 "the address, or drop --scheduler to run locally") from None
    try:
        from distributed import Client
    except ImportError as exc:
        raise ModelError("--scheduler needs Dask", field="--scheduler",
                         fix="pip install 'linkdyn[dask]'") from exc
    try:
        return Client(scheduler, timeout=max(CONNECT_TIMEOUT, 10.0))
    except (OSError, ValueError, TypeError) as e:
        raise ModelError(f"cannot connect to the Dask scheduler at {scheduler} ({e})",
                         field="--scheduler", fix="Check the address (e.g. tcp://host:8786)"
                         ) from None


_SCHEMES = ("tcp", "tls", "inproc", "ucx", "ws", "wss")


def _address(text: str) -> tuple[str | None, int | None]:
    """(host, port) of a TCP-based scheduler address (``tcp://``, ``tls://``, ``ws(s)://`` or
    none), (None, None) for another scheme; a ModelError for what is not an address."""
    scheme, sep, rest = text.strip().partition("://")
    if not sep:
        scheme, rest = "tcp", text.strip()
    if scheme not in _SCHEMES:
        raise ModelError(f"unknown scheduler address scheme '{scheme}' in {text!r}",
                         field="--scheduler",
                         fix="Give an address such as tcp://host:8786 (schemes: "
                             + ", ".join(_SCHEMES) + ")")
    if scheme in ("inproc", "ucx"):
        return None, None
    host, colon, port = rest.rstrip("/").rpartition(":")
    host = host.strip("[]")
    if not colon or not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise ModelError(f"cannot read the scheduler address {text!r}", field="--scheduler",
                         fix="Give HOST:PORT, e.g. tcp://127.0.0.1:8786")
    return host, int(port)


def summary(task: Task, df, stats: dict, *, bounds=None, method=None, seed=None) -> dict:
    """``summary.json`` of a sweep: what was varied, how many designs are valid, and for each
    metric its range over the valid designs, the design where it is smallest, its unit (SI),
    its sense (``'min'`` or ``'max'``: which way is better) and its best valid design; and
    ``units``, the model file's length and angle units (the pages show every number in them)."""
    valid = df["valid"].to_numpy()
    u = Units.of(task.space.model())
    out = {"model": task.space.source, "designs": int(len(df)), "valid": int(valid.sum()),
           "units": {"length": u.length, "angle": u.angle},
           "invalid": int((~valid).sum()), "samples": int(len(task.t)),
           "duration_s": float(task.t[-1] - task.t[0]) if len(task.t) else 0.0,
           "method": method, "seed": seed,
           "parameters": [{"path": p.path, "unit": p.unit, "base": p.base,
                           **({"low": float(b[0]), "high": float(b[1])} if b is not None else {})}
                          for p, b in zip(task.space.params, bounds or [None] * len(
                              task.space.params))],
           "metrics": {}, "run": stats}
    reasons = df.loc[~df["valid"], "reason"].value_counts()
    out["invalid_reasons"] = {str(k): int(v) for k, v in list(reasons.items())[:10]}
    for name in task.metrics:
        col = df[name].to_numpy(float)
        rows = metrics_mod.ranked(df, name)
        if not len(rows):
            out["metrics"][name] = None
            continue
        k = int(np.nanargmin(col))
        out["metrics"][name] = {"min": float(np.nanmin(col)), "max": float(np.nanmax(col)),
                                "min_design": int(df["design"].iloc[k]),
                                "unit": metrics_mod.unit(name),
                                "sense": metrics_mod.sense(name),
                                "best": float(col[rows[0]]),
                                "best_design": int(df["design"].iloc[rows[0]])}
    return out


PREVIEWS = 3   # best designs of each metric whose own report the sweep page shows


def best_designs(df, metrics, n: int = PREVIEWS) -> list[int]:
    """Rows of the ``n`` best valid designs of each metric (by its sense, best first, ties by
    design number: :func:`linkdyn.studies.metrics.ranked`), each row once, in the order met."""
    rows: list[int] = []
    for name in metrics:
        for k in metrics_mod.ranked(df, name)[:n]:
            if int(k) not in rows:
                rows.append(int(k))
    return rows


def preview_outputs(task: Task, df, rows) -> dict:
    """``design-<number>.html`` for the designs ``rows`` of the table: each design rebuilt from
    the model file and its parameter values, analyzed alone and shown by its own report page
    (:func:`linkdyn.report.render`, with the mechanism's animation), as ``linkdyn analyze
    --report`` would write it. ``{file name: writer}`` for :func:`linkdyn.outputs.write_outputs`.
    """
    from .. import design
    from ..report import render

    params = [p.path for p in task.space.params]
    files = {}
    for k in rows:
        model = task.space.model(df[params].iloc[k].to_numpy(float))
        if task.space.spatial:   # as linkdyn analyze --report writes it
            from ..spatial import analyze as spatial_analyze
            from ..spatial.cli import summary as spatial_summary
            sol = spatial_analyze(model, task.t)
            summ = spatial_summary(sol)
        else:
            sol = analyze(model, task.t, allow_singular=True, backend=task.backend)
            summ = design.summary(sol, fluctuation=task.fluctuation,
                                  path_point=task.path_point or model.path_point,
                                  path_range=task.path_range, default_range=model.path_range)

        def write(path, sol=sol, summ=summ):
            path.write_text(render(sol, summ), encoding="utf-8")
        files[f"design-{int(df['design'].iloc[k])}.html"] = write
    return files


def write_results(outdir, df, summary_data: dict, *, report: bool = False,
                  task: Task | None = None) -> list[Path]:
    """Write ``designs.parquet`` and ``summary.json`` (and with ``report``, ``sweep.html`` and,
    given the ``task``, the report page ``design-<number>.html`` of the best designs of each
    metric, which the sweep page shows; all or none, by :func:`linkdyn.outputs.write_outputs`),
    then drop the chunks. Returns the files written."""
    from ..outputs import write_outputs

    previews = {}
    if report and task is not None:
        previews = preview_outputs(task, df, best_designs(df, task.metrics))
    names = ["designs.parquet", "summary.json", *(["sweep.html", *previews] if report else [])]
    # the files written, listed in summary.json: a later run removes those it does not write
    text = json.dumps({**summary_data, "files": names}, indent=2, default=_json_default) + "\n"
    out = {"designs.parquet": lambda p: df.to_parquet(p, index=False),
           "summary.json": lambda p: p.write_text(text)}
    if report:
        from ..report.sweep import render_sweep
        page = render_sweep(df, json.loads(text), os.fspath(outdir),
                            previews={int(n[len("design-"):-len(".html")]): n for n in previews})
        out["sweep.html"] = lambda p: p.write_text(page, encoding="utf-8")
        out.update(previews)
    written = write_outputs(Path(outdir), out, owned=files.owned_before(
        outdir, "summary.json", ("designs.parquet", "sweep.html", "design-*.html")))
    files.remove_chunks(Path(outdir))
    return written


def _json_default(x):
    if isinstance(x, np.generic):
        return x.item()
    raise TypeError(type(x).__name__)
