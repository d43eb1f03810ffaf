"""Command line: a thin layer over the library.

Exit status: 0 success; 2 invalid model or arguments; 3 the mechanism cannot be assembled or
passes a singular position. User errors print one message and no traceback.
"""

from __future__ import annotations

import json
import os
import shutil
import sys
import tempfile
from importlib import resources
from pathlib import Path

import click
import numpy as np

from .errors import LinkdynError, ModelError

EXAMPLES = "examples"


def _fail(err: LinkdynError) -> None:
    click.echo(f"error: {err}", err=True)
    sys.exit(err.exit_code)


class _Group(click.Group):
    """Maps user errors to their exit status; click's own usage errors exit 2."""

    def invoke(self, ctx):
        try:
            return super().invoke(ctx)
        except LinkdynError as err:
            _fail(err)


@click.group(cls=_Group, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="linkdyn")
def main():
    """linkdyn: kinematics and inverse dynamics of planar closed-loop mechanisms.

    Recursive DeNOC method: loops are cut at one joint each; the cut-joint reactions (Lagrange
    multipliers) and the driver efforts come from one small linear solve per sample, then every
    other joint reaction body by body.
    """


# ---------------------------------------------------------------------------- example

def example_names() -> list[str]:
    """Names of the bundled example models."""
    files = resources.files("linkdyn").joinpath(EXAMPLES).iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".toml"))


def example_text(name: str) -> str:
    """TOML text of a bundled example."""
    names = example_names()
    if name not in names:
        import difflib
        close = difflib.get_close_matches(name, names, n=1)
        raise ModelError(f"no bundled example named '{name}'", field="NAME",
                         fix=(f"Did you mean '{close[0]}'? " if close else "")
                         + "Available: " + ", ".join(names))
    return resources.files("linkdyn").joinpath(EXAMPLES, name + ".toml").read_text("utf-8")


@main.command()
@click.argument("name", required=False)
@click.option("--list", "list_", is_flag=True, help="List the bundled examples.")
def example(name, list_):
    """Print a bundled example model (e.g. `linkdyn example hoeken > hoeken.toml`)."""
    if list_ or not name:
        import tomllib
        for n in example_names():
            desc = tomllib.loads(example_text(n)).get("mechanism", {}).get("name", "")
            click.echo(f"{n:24s} {desc}")
        return
    click.echo(example_text(name), nl=False)


# ---------------------------------------------------------------------------- check

@main.command()
@click.argument("model", type=click.Path(dir_okay=False))
def check(model):
    """Validate MODEL and describe it without solving."""
    from . import design, io, topology

    mech = io.load_model(model)
    topo = topology.build(mech)
    click.echo(f"{mech.name}  ({model})")
    if mech.description:
        click.echo(f"  {mech.description}")
    click.echo(f"bodies ({len(mech.bodies)}):")
    for b in mech.bodies:
        extra = "" if b.name == "ground" else f"  mass {b.mass:.6g} kg, I_c {b.inertia:.6g} kg m^2"
        click.echo(f"  {b.name:14s} points: {', '.join(b.points)}{extra}")
    click.echo(f"joints ({len(mech.joints)}):")
    for k, j in enumerate(mech.joints):
        role = "cut" if k in topo.cut else "tree"
        if j.name in [d.joint for d in mech.drivers]:
            role += ", driven"
        click.echo(f"  {j.name:8s} {j.kind:9s} {j.body_a}.{j.point_a} -> {j.body_b}.{j.point_b}"
                   f"  [{role}]")
    click.echo("spanning tree (parent <- body via joint):")
    for i in range(1, topo.n):
        click.echo(f"  {topo.bodies[topo.parent[i]]} <- {topo.bodies[i]} via "
                   f"{mech.joints[topo.tree_joint[i]].name}")
    cuts = ", ".join(mech.joints[j].name for j in topo.cut) or "none"
    click.echo(f"loops: {topo.n_loops}; cut joints: {cuts}")
    click.echo(f"mobility (Grübler–Kutzbach): {topo.mobility}; drivers: {len(mech.drivers)}")
    for d in mech.drivers:
        click.echo(f"  {d.joint}: {d.description}")
    for fb in design.four_bars(mech):
        L = ", ".join(f"{k} {v * 1e3:.6g} mm" for k, v in
                      zip(("ground", "input", "coupler", "output"), fb.lengths))
        click.echo(f"four-bar {fb.input}/{fb.coupler}/{fb.output}: {fb.grashof} ({L})")
    click.echo("model OK")


# ---------------------------------------------------------------------------- analyze

def _times(mech, samples, duration, cycles) -> np.ndarray:
    samples = samples or mech.samples or 361
    if samples < 2:
        raise ModelError("--samples must be at least 2", field="--samples",
                         fix="Give --samples 2 or more")
    if duration is None and cycles is None:
        duration, cycles = mech.duration, mech.cycles
    if duration is None:
        periods = [d.period for d in mech.drivers if d.period]
        if not periods:
            raise ModelError("no duration: the drivers do not rotate at constant speed, so "
                             "a cycle is undefined", field="analysis.duration",
                             fix="Give --duration T (s) or [analysis] duration")
        duration = (cycles or 1.0) * periods[0]
    if not duration > 0:
        raise ModelError(f"duration must be positive, got {duration}", field="--duration",
                         fix="Give a positive duration in s")
    return np.linspace(0.0, float(duration), int(samples))


def _write_outputs(outdir: Path, files: dict[str, callable]) -> None:
    """Write every output into a temporary folder, then move them into place: no partial
    output is left behind if anything fails."""
    outdir.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=".linkdyn-", dir=outdir))
    try:
        for name, write in files.items():
            write(tmp / name)
        for name in files:
            os.replace(tmp / name, outdir / name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def write_csv(sol, path: Path) -> None:
    """``results.csv``: one row per sample, SPEC columns, full precision."""
    names, data = sol.to_array()
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt="%.17g")


def write_parquet(sol, path: Path) -> None:
    try:
        import pyarrow  # noqa: F401
    except ImportError:
        raise ModelError("--format parquet needs pyarrow", field="--format",
                         fix="pip install 'linkdyn[parquet]', or use --format csv") from None
    sol.to_dataframe().to_parquet(path, index=False)


def print_summary(s: dict) -> None:
    click.echo(f"{s['model']}: {s['samples']} samples over {s['duration_s']:.6g} s")
    click.echo(f"  mobility {s['mobility']}, loops {s['loops']}, cut joints: "
               f"{', '.join(s['cut_joints']) or 'none'}")
    for fb in s["four_bars"]:
        ta = fb["transmission_angle_deg"]
        click.echo(f"  four-bar {fb['links']['input']}/{fb['links']['coupler']}/"
                   f"{fb['links']['output']}: {fb['grashof']}; transmission angle "
                   f"{ta['min']:.2f}..{ta['max']:.2f} deg")
    for j, d in s["drivers"].items():
        click.echo(f"  driver {j}: peak {d['effort']} {d['peak']:.6g} {d['unit']} at "
                   f"t = {d['peak_time_s']:.4g} s, RMS {d['rms']:.6g} {d['unit']}")
    click.echo("  peak reactions:")
    for j, r in s["reactions"].items():
        extra = f", moment {r['peak_moment_Nm']:.6g} N m" if "peak_moment_Nm" in r else ""
        click.echo(f"    {j:8s} {r['peak_force_N']:.6g} N at t = {r['peak_time_s']:.4g} s{extra}")
    h = s["health"]
    click.echo(f"  closure residual {h['closure_residual_rel']:.2e} (relative), power balance "
               f"{h['power_balance_residual_rel']:.2e} (relative), worst condition number "
               f"{h['worst_condition_number']:.3g}")
    if s["invalid_samples"]:
        click.echo(f"  WARNING: {s['invalid_samples']} singular samples written as NaN")


@main.command()
@click.argument("model", type=click.Path(dir_okay=False))
@click.option("-o", "--outdir", default="out", show_default=True, type=click.Path(file_okay=False),
              help="Folder for results.csv, summary.json (and the report).")
@click.option("--samples", type=int, help="Number of samples (both ends included).")
@click.option("--duration", type=float, help="Duration in s.")
@click.option("--cycles", type=float, help="Duration in driver revolutions.")
@click.option("--format", "fmt", type=click.Choice(["csv", "parquet"]), default="csv",
              show_default=True)
@click.option("--report", is_flag=True, help="Also write plots and a self-contained report.html.")
@click.option("--allow-singular", is_flag=True,
              help="Keep going through singular positions; their rows are NaN.")
def analyze(model, outdir, samples, duration, cycles, fmt, report, allow_singular):
    """Solve kinematics and inverse dynamics of MODEL; write results and a summary."""
    from . import design, io
    from .analysis import analyze as run

    if duration is not None and cycles is not None:
        raise ModelError("give --duration or --cycles, not both", field="--duration",
                         fix="Drop one of them")
    mech = io.load_model(model)
    t = _times(mech, samples, duration, cycles)
    sol = run(mech, t, allow_singular=allow_singular)
    summ = design.summary(sol)
    out = Path(outdir)
    files = {
        "results.csv" if fmt == "csv" else "results.parquet":
            (lambda p: write_csv(sol, p)) if fmt == "csv" else (lambda p: write_parquet(sol, p)),
        "summary.json": lambda p: p.write_text(json.dumps(summ, indent=2, allow_nan=True)),
    }
    if report:
        from . import report as report_mod
        files.update(report_mod.outputs(sol, summ))
    _write_outputs(out, files)
    print_summary(summ)
    click.echo(f"wrote {', '.join(str(out / f) for f in files)}")


if __name__ == "__main__":  # pragma: no cover
    main()
