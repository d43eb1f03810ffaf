"""``linkdyn sweep`` and ``linkdyn optimize``: the command-line face of :mod:`linkdyn.studies`."""

from __future__ import annotations

import json
import os
import re
import sys
from pathlib import Path
from types import SimpleNamespace

import click
import numpy as np

from ..cli import json_safe, _path_range
from ..sampling import times as sample_times
from ..errors import ModelError
from ..outputs import check_outdir, write_outputs
from ..units import Units
from .metrics import quantity

_VARY = re.compile(r"\s*([^=\s]+)\s*=\s*([^:]+):([^:]+?)(?::(\d+))?\s*\Z")
_UNIT_BOUND = re.compile(r"\s*[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?\s*[A-Za-z][\w/^ ]*\Z")


def parse_vary(texts) -> tuple[list[str], list[tuple[float, float]], list[int | None]]:
    """``PATH=LO:HI[:N]`` options -> paths, bounds, counts (None where no N)."""
    paths, bounds, counts = [], [], []
    def _bound(x):   # a number in the file's units, or a text with a unit (_with_units)
        try:
            return float(x)
        except ValueError:
            if _UNIT_BOUND.match(x):
                return x.strip()
            raise

    for text in texts:
        m = _VARY.match(text)
        try:
            _bound(m.group(2)), _bound(m.group(3))
        except (AttributeError, ValueError):
            raise ModelError(f"cannot read --vary {text!r}", field="--vary",
                             fix="Write PATH=LO:HI or PATH=LO:HI:N in the file's units, e.g. "
                                 "--vary bodies.ground.points.O4[0]=80:100:11") from None
        n = int(m.group(4)) if m.group(4) else None
        lo, hi = (_bound(x) for x in (m.group(2), m.group(3)))
        if n is not None and n < 1:
            raise ModelError(f"--vary {text!r} asks for {n} values", field="--vary",
                             fix="Give N >= 1")
        paths.append(m.group(1))
        bounds.append((lo, hi))
        counts.append(n)
    return paths, bounds, counts


def _common(f):
    """Options shared by sweep and optimize."""
    for opt in reversed([
        click.option("--vary", "vary", multiple=True, metavar="PATH=LO:HI[:N]",
                     help="A design parameter: dotted field path of the model file, its range in "
                          "the file's units and, for a grid, its number of values. Repeat."),
        click.option("--samples", type=int, help="Samples per design (default: the model's)."),
        click.option("--duration", type=float, help="Duration in s."),
        click.option("--cycles", type=float, help="Duration in driver revolutions."),
        click.option("--seed", type=int, default=0, show_default=True,
                     help="Seed of the random, LHS and Sobol designs and of the optimizer."),
        click.option("--path-point", metavar="BODY.POINT",
                     help="Point of path_deviation (default: the model's [analysis] path_point)."),
        click.option("--path-range", metavar="A:B",
                     help="Range of the first driver's coordinate for path_deviation, in the "
                          "model file's angle (or length) unit, or with a unit (110deg:250deg; "
                          "default: the model's [analysis] path_range)."),
        click.option("--fluctuation", type=float, default=0.02, show_default=True,
                     help="Coefficient of speed fluctuation of flywheel_inertia."),
        click.option("--backend", type=click.Choice(["auto", "numpy", "compiled"]),
                     default="auto", show_default=True, help="Per-sample kernels."),
    ]):
        f = opt(f)
    return f


def _setup(model, vary, samples, duration, cycles):
    from .params import check_ranges, space

    if duration is not None and cycles is not None:
        raise ModelError("give --duration or --cycles, not both", field="--duration",
                         fix="Drop one of them")
    paths, bounds, counts = parse_vary(vary)
    sp = space(model, paths)
    bounds = _with_units(sp, bounds)
    check_ranges(sp, bounds)
    t = sample_times(sp.model(), samples, duration, cycles)
    return sp, t, bounds, counts


def _with_units(sp, bounds) -> list[tuple[float, float]]:
    """``--vary`` bounds in each parameter's unit (the file's): a bound typed with a unit
    (``80mm``, ``8cm``, ``1.2 kg``, ``30deg``) is converted to it; a bare number is already
    in it."""
    units = Units(**{k: v for k, v in sp.data.get("units", {}).items()
                     if k in ("length", "angle")}) if isinstance(sp.data.get("units"), dict) \
        else Units()
    out = []
    for p, pair in zip(sp.params, bounds):
        q = units.quantity_of(p.unit)
        conv = []
        for b in pair:
            if isinstance(b, str):
                if q is None:
                    raise ModelError(f"--vary {p.path}: a bound with a unit ({b!r}) needs a "
                                     f"parameter of one quantity; {p.path} is in {p.unit or 'no unit'}",
                                     field="--vary", fix="Give the bound as a bare number in "
                                                         "the file's units")
                name = "rpm" if p.unit == "rev/min" else p.unit
                b = units.parse(b, q, "--vary") / (Units.size(name, q) or 1.0)
            conv.append(float(b))
        out.append(tuple(conv))
    return out


def _show_progress(flag):
    return flag if flag is not None else bool(getattr(sys.stderr, "isatty", lambda: False)())


@click.command()
@click.argument("model", type=click.Path(dir_okay=False))
@_common
@click.option("--method", type=click.Choice(["grid", "random", "lhs", "sobol"]),
              help="How designs fill the ranges (default: grid if every --vary gives N, "
                   "else sobol).")
@click.option("--designs", type=int, help="Number of designs (random, lhs, sobol; for a grid, "
                                          "the total when N is not given). Default 1024.")
@click.option("--designs-csv", type=click.Path(dir_okay=False),
              help="Evaluate the designs of a CSV file instead: a header of field paths, one "
                   "row per design, in the file's units.")
@click.option("--metric", "metrics", multiple=True,
              help="A metric to keep (repeat; default: every metric of the model).")
@click.option("-o", "--outdir", default="out", show_default=True,
              type=click.Path(file_okay=False), help="Output directory.")
@click.option("--workers", type=int, default=1, show_default=True,
              help="Local worker processes.")
@click.option("--scheduler", metavar="ADDRESS",
              help="Run on this Dask cluster (e.g. tcp://host:8786) instead of local processes.")
@click.option("--chunk", type=int,
              help="Designs per chunk (default: a quarter of each worker's share, within 1e6 "
                   "to 1e7 design-samples).")
@click.option("--resume", is_flag=True,
              help="Continue an interrupted sweep in OUTDIR: finished chunks are kept.")
@click.option("--progress/--no-progress", default=None,
              help="Progress bar on stderr (default: when stderr is a terminal).")
@click.option("--report", is_flag=True,
              help="Also write OUTDIR/sweep.html: the scatter of any two columns, the Pareto "
                   "front of two metrics and the best designs, one self-contained page.")
def sweep(model, vary, samples, duration, cycles, seed, path_point, path_range, fluctuation,
          backend, method, designs, designs_csv, metrics, outdir, workers, scheduler, chunk,
          resume, progress, report):
    """Solve many designs of MODEL; one row of metrics per design.

    Writes OUTDIR/designs.parquet (the parameters, valid, reason and the metrics of every design)
    and OUTDIR/summary.json. Finished chunks go to OUTDIR/chunks/ as they finish, so --resume
    after an interruption computes only what is missing.
    """
    from . import checks, files
    from . import runner as sweep_mod
    from .metrics import check_names

    files.need_parquet("sweep")   # designs.parquet: say how to install, before any work
    workers, chunk = checks.workers(workers), checks.count(chunk, "--chunk", "designs per chunk")
    designs, seed = checks.count(designs, "--designs", "designs"), checks.seed(seed)
    check_outdir(outdir)
    files.read_state(Path(outdir))   # a chunks folder that is not a sweep's: refused at once
    if designs_csv:
        if vary:
            raise ModelError("give --vary or --designs-csv, not both", field="--designs-csv",
                             fix="Drop one of them")
        values, paths = files.read_designs(designs_csv)
        from .params import space
        sp = space(model, paths)
        t = sample_times(sp.model(), samples, duration, cycles)
        bounds, counts = None, None
        method = "csv"
    else:
        if not vary:
            raise ModelError("nothing to vary", field="--vary",
                             fix="Give --vary PATH=LO:HI[:N] (e.g. bodies.crank.mass=1:2) or "
                                 "--designs-csv FILE")
        sp, t, bounds, counts = _setup(model, vary, samples, duration, cycles)
        method = method or ("grid" if all(counts) else "sobol")
        designs = designs if designs is not None or method == "grid" else 1024
    q_range = _path_range(path_range, sp.model())   # SI, from the file's unit
    names = tuple(check_names(sp.model(), list(metrics) or None, path_point=path_point))
    task = sweep_mod.Task(sp, t, names, None if backend == "auto" else backend, path_point,
                          q_range, fluctuation)
    # the number of designs bounded before they are made
    n = len(values) if method == "csv" else sweep_mod.design_count(method, designs, counts,
                                                                   len(bounds))
    sweep_mod.check_size(task, n, workers=workers, scheduler=scheduler, option={
        "csv": "--designs-csv", "grid": "--vary"}.get(method, "--designs"))
    if method != "csv":
        values = sweep_mod.sample(bounds, method, designs, seed, counts)
    out = Path(outdir)
    df, stats = sweep_mod.run(task, values, outdir=out, resume=resume, chunk=chunk,
                              workers=workers, scheduler=scheduler,
                              progress=_show_progress(progress))
    summ = sweep_mod.summary(task, df, stats, bounds=bounds, method=method, seed=seed)
    written = sweep_mod.write_results(out, df, json_safe(summ), report=report, task=task)
    rate = stats["design_samples_per_s"]
    click.echo(f"{summ['designs']} designs x {len(t)} samples: {summ['valid']} valid, "
               f"{summ['invalid']} invalid; {stats['chunks_computed']} chunks computed"
               + (f", {stats['chunks_reused']} reused" if stats["chunks_reused"] else "")
               + (f" in {stats['seconds']:.3g} s ({rate:.3g} design-samples/s)" if rate else ""))
    for name, m in summ["metrics"].items():
        if m is not None:
            click.echo(_metric_line(name, m, Units.of(sp.model())))
    pages = [p for p in written if p.name.startswith("design-")]
    click.echo(f"wrote {', '.join(str(p) for p in written if p not in pages)}"
               + (f" and the reports of {len(pages)} best designs "
                  f"({', '.join(p.name for p in pages)})" if pages else ""))


def _metric_line(name: str, m: dict, units: Units) -> str:
    """A metric of the sweep's summary in one line: its range in the model file's unit and
    its best design (by its sense: the largest where larger is better)."""
    word = "largest" if m["sense"] == "max" else "smallest"
    return (f"  {name:<24} {units.span(m['min'], m['max'], quantity(name) or 'number')}"
            + f"  (best: design {m['best_design']}, the {word})")


@click.command()
@click.argument("model", type=click.Path(dir_okay=False))
@_common
@click.option("--minimize", metavar="METRIC", help="The metric to minimize.")
@click.option("--maximize", metavar="METRIC",
              help="The metric to maximize instead (e.g. min_transmission_angle).")
@click.option("--constraint", "constraints", multiple=True, metavar='"METRIC<=VALUE"',
              help="A constraint on a metric (<= or >=), in the model file's unit of the "
                   "metric's quantity, or with a unit such as mm, deg. Repeat.")
@click.option("--popsize", type=int, default=15, show_default=True,
              help="Differential evolution: population per parameter.")
@click.option("--maxiter", type=int, default=60, show_default=True,
              help="Differential evolution: largest number of generations.")
@click.option("-o", "--outdir", default="out", show_default=True,
              type=click.Path(file_okay=False), help="Output directory.")
@click.option("--report", is_flag=True, help="Also write the best design's report.html.")
def optimize(model, vary, samples, duration, cycles, seed, path_point, path_range, fluctuation,
             backend, minimize, maximize, constraints, popsize, maxiter, outdir, report):
    """Minimize (or maximize) a metric of MODEL over --vary ranges, subject to --constraint.

    Differential evolution (a generation solved as one batch of designs), then a batched
    compass search. Writes OUTDIR/best.toml (the model file with the best values),
    OUTDIR/optimize.json (with each constraint's status and each parameter's change) and the
    best design's OUTDIR/results.csv and summary.json (and report.html, headed by the
    objective, the constraints, active or not, and the parameters changed). When no
    design meets every constraint it exits with status 3, naming the constraint nearest to
    holding, and writes nothing.
    """
    from .. import design
    from ..analysis import analyze
    from ..io.writer import dumps_toml
    from .files import owned_before
    from .optimize import optimize as run, standing
    from ..cli import write_csv

    if not vary:
        raise ModelError("nothing to vary", field="--vary", fix="Give --vary PATH=LO:HI")
    check_outdir(outdir)
    paths, bounds, _ = parse_vary(vary)
    sp, t, bounds, _ = _setup(model, vary, samples, duration, cycles)
    q_range = _path_range(path_range, sp.model())   # SI, from the file's unit
    u = Units.of(sp.model())
    res = run(model, dict(zip(paths, bounds)), t, minimize, constraints, maximize=maximize,
              seed=seed, popsize=popsize, maxiter=maxiter,
              backend=None if backend == "auto" else backend,
              path_point=path_point, path_range=q_range, fluctuation=fluctuation)
    _check_feasible(res, model, sp)
    best = res.model
    if sp.spatial:   # the best design's summary as linkdyn analyze writes it
        from ..spatial import analyze as spatial_analyze
        from ..spatial.cli import summary as spatial_summary
        sol = spatial_analyze(best, t)
        summ = spatial_summary(sol)
    else:
        sol = analyze(best, t, allow_singular=True)
        summ = design.summary(sol, fluctuation=fluctuation,
                              path_point=path_point or best.path_point,
                              path_range=q_range, default_range=best.path_range)
    verb = "minimize" if res.sense == "min" else "maximize"
    st = standing(res, sp, dict(zip(paths, bounds)), u)
    info = {"model": os.fspath(model), verb: res.objective, "objective": res.objective,
            "sense": res.sense,
            "constraints": [str(c) for c in res.constraints],
            "feasible": res.feasible, "parameters": res.values, "metrics": res.metrics,
            "evaluations": res.evaluations, "generations": res.generations,
            "seconds": res.seconds, "seed": seed, "samples": len(t),
            "history": res.history, "objective_shown": st["objective"]["shown"],
            "constraint_status": st["constraints"], "changes": st["parameters"]}
    files = {"best.toml": lambda p: p.write_text(
                 f"# {res.objective} {verb}d by linkdyn optimize from {Path(model).name}"
                 + "".join(f", {c}" for c in res.constraints) + "\n"
                 + dumps_toml(res.data), encoding="utf-8"),
             "optimize.json": lambda p: p.write_text(json.dumps(json_safe(info), indent=2)),
             # a spatial solution's columns are a method (linkdyn analyze writes them so too)
             "results.csv": lambda p: write_csv(SimpleNamespace(columns=sol.columns())
                                                if sp.spatial else sol, p),
             "summary.json": lambda p: p.write_text(json.dumps(json_safe(summ), indent=2,
                                                               allow_nan=False))}
    if report:
        from .. import plots as plots_mod
        from .. import report as report_mod
        from ..report.optimized import optimize_html
        files.update(report_mod.outputs(
            sol, summ, title=f"{best.name or Path(model).stem}: {res.objective} {verb}d",
            intro=optimize_html(st, evaluations=res.evaluations, seconds=res.seconds)))
        if not sp.spatial:   # a spatial page's figures cost several runs: analyze --plots
            files.update(plots_mod.outputs(sol))
    out = Path(outdir)
    # the files written, listed in optimize.json: a later run removes those it does not write
    info["files"] = list(files)
    write_outputs(out, files, owned=owned_before(out, "optimize.json", (
        "best.toml", "summary.json", "results.csv", "report.html", "plot_*.png",
        "plot_*.svg")))
    click.echo(f"best design (feasible) after {res.evaluations} designs in {res.seconds:.3g} s:")
    units_of = {p.path: p.unit for p in sp.params}
    for p, v in res.values.items():   # in the file's units, as --vary gave them
        click.echo(f"  {p} = {v:.6g} {units_of.get(p, '')}".rstrip())
    for n, v in res.metrics.items():
        click.echo(f"  {n} = {u.show(v, quantity(n) or 'number')}")
    click.echo(f"wrote {', '.join(str(out / f) for f in files)}")


def _check_feasible(res, model, sp) -> None:
    """An infeasible optimum is an error (exit 3, nothing written): it names the constraint
    nearest to holding, by how much it is missed in the constraint's unit, and the design."""
    from .optimize import Infeasible

    if res.feasible:
        return
    units_of = {p.path: p.unit for p in sp.params}
    at = ", ".join(f"{p} = {v:.6g} {units_of.get(p, '')}".rstrip() for p, v in res.values.items())
    raise Infeasible(f"{Path(model).name}: no design in the --vary ranges meets every "
                     f"constraint after {res.evaluations} designs; the nearest to holding is "
                     f"{res.nearest()}, at {at}. Relax that constraint or widen the ranges")

