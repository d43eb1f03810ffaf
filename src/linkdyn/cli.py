"""Command line: a thin layer over the library.

Exit status: 0 success; 2 invalid model or arguments; 3 the mechanism cannot be assembled or
passes a singular position. User errors print one message and no traceback.
"""

from __future__ import annotations

import json
import shutil
import sys
import threading
import time
from importlib import resources
from pathlib import Path
from types import SimpleNamespace

import click
import numpy as np

from .errors import LinkdynError, ModelError
from .outputs import ANALYSIS_OUTPUTS, check_outdir, owned_before, write_outputs
from .sampling import check_memory, times as sample_times

EXAMPLES = "examples"


def _fail(err: LinkdynError) -> None:
    click.echo(f"error: {err}", err=True)
    sys.exit(err.exit_code)


class _Group(click.Group):
    """Maps user errors to their exit status; click's own usage errors exit 2."""

    def invoke(self, ctx):
        from .errors import quiet_numerics

        try:
            with quiet_numerics():  # a bad number is reported by the checks, not as a warning
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
    from .backend import show_progress
    show_progress(lambda line: click.echo(line, err=True))   # e.g. before a first compilation


# ---------------------------------------------------------------------------- example

def example_names() -> list[str]:
    """Names of the bundled example models."""
    files = resources.files("linkdyn").joinpath(EXAMPLES).iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".toml"))


def simulation_example_names() -> list[str]:
    """Names of the bundled models for ``linkdyn simulate`` (free degrees of freedom, no
    driver for each: ``examples/simulate/``)."""
    files = resources.files("linkdyn").joinpath(EXAMPLES, "simulate").iterdir()
    return sorted(f.name[:-5] for f in files if f.name.endswith(".toml"))


def spatial_example_names() -> list[str]:
    """Names of the bundled spatial models (``examples/spatial/``; none if the folder is
    absent)."""
    folder = resources.files("linkdyn").joinpath(EXAMPLES, "spatial")
    if not folder.is_dir():
        return []
    return sorted(f.name[:-5] for f in folder.iterdir() if f.name.endswith(".toml"))


def example_text(name: str) -> str:
    """TOML text of a bundled example (``analyze``, ``simulate`` or spatial models)."""
    names = example_names()
    for folder, listed in (("simulate", simulation_example_names()),
                           ("spatial", spatial_example_names())):
        if name not in names and name in listed:
            return resources.files("linkdyn").joinpath(EXAMPLES, folder,
                                                       name + ".toml").read_text("utf-8")
    if name not in names:
        import difflib
        names = names + simulation_example_names() + spatial_example_names()
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
        for n in simulation_example_names():
            desc = tomllib.loads(example_text(n)).get("mechanism", {}).get("name", "")
            click.echo(f"{n:24s} {desc} (linkdyn simulate)")
        for n in spatial_example_names():
            desc = tomllib.loads(example_text(n)).get("mechanism", {}).get("name", "")
            click.echo(f"{n:24s} {desc} (spatial)")
        return
    click.echo(example_text(name), nl=False)


_BACKEND = click.option(
    "--backend", type=click.Choice(["auto", "numpy", "compiled"]), default="auto",
    show_default=True,
    help="Per-sample kernels (default: LINKDYN_BACKEND if set, else auto).")


def _backend(ctx: click.Context, value: str) -> str | None:
    """The backend to pass on: the option's value when given on the command line, else None
    (``LINKDYN_BACKEND`` if set, else ``auto``; the library checks the variable's value)."""
    given = ctx.get_parameter_source("backend") is not click.core.ParameterSource.DEFAULT
    return value if given else None


# ---------------------------------------------------------------------------- check

_ALLOW_OUTSIDE = click.option(
    "--allow-outside-tables", "allow_outside", is_flag=True,
    help="Read motion tables outside the model file's folder (refused by default).")


@main.command()
@click.argument("model", type=click.Path(dir_okay=False))
@_ALLOW_OUTSIDE
def check(model, allow_outside):
    """Validate MODEL, assemble it at t = 0 and over its run, and describe it.

    Exit 3 where it cannot be assembled or locks (naming the loop and the driver values); a
    model with free coordinates (for simulate) is assembled at t = 0 with its [initial] values.
    """
    from . import design, io, topology
    from .units import Units

    mech = io.load_model(model, allow_outside=allow_outside)
    if mech.space == "spatial":
        from .spatial import cli as spatial_cli
        spatial_cli.check(mech, model)
        return
    u = Units.of(mech)
    topo, free = _check_topology(mech)
    click.echo(f"{mech.name}  ({model})")
    if mech.description:
        click.echo(f"  {mech.description}")
    click.echo(f"bodies ({len(mech.bodies)}):")
    for b in mech.bodies:
        extra = "" if b.name == "ground" else (f"  mass {u.show(b.mass, 'mass')}, I_c "
                                               f"{u.show(b.inertia, 'inertia')}")
        click.echo(f"  {b.name:14s} points: {', '.join(b.points)}{extra}")
    click.echo("\n".join(topology.joint_lines(mech, topo, free[0].free if free else ())))
    click.echo(f"mobility (Grübler–Kutzbach): {topo.mobility}; drivers: {len(mech.drivers)}")
    for d in mech.drivers:
        click.echo(f"  {d.joint}: {d.description}")
    if topo.n_loops and not (mech.assembly_phi or mech.assembly_q) and not free:
        click.echo("assembly: " + _assembly_at_zero(mech, topo))
    for fb in design.four_bars(mech):
        L = ", ".join(f"{k} {u.show(v, 'length')}" for k, v in
                      zip(("ground", "input", "coupler", "output"), fb.lengths))
        click.echo(f"four-bar {fb.input}/{fb.coupler}/{fb.output}: {fb.grashof} ({L})")
    for sc in design.checks.slider_cranks(mech):
        lg = lambda v: design.checks.length(mech, v)  # noqa: E731
        click.echo(f"slider-crank {sc.crank}/{sc.rod}/{sc.slider} (guide {sc.guide}): crank "
                   f"{lg(sc.r)}, rod {lg(sc.l)}, offset {lg(sc.e)}: the crank "
                   + ("can turn fully (crank + offset < rod)" if sc.turns else
                      "cannot turn fully (crank + offset >= rod)"))
    if free:
        _check_free(mech, *free)
    else:
        _check_run(mech, topo)
    click.echo("model OK")


def not_yet(mech, what: str) -> None:
    """Exit 2 for a command (or option) that does not take spatial models yet."""
    if getattr(mech, "space", "planar") == "spatial":
        raise ModelError(f"{what} is not yet for spatial models", file=mech.source,
                         field="mechanism.space",
                         fix="Use linkdyn check or linkdyn analyze (results.csv, summary.json) "
                             "on spatial models")


def _check_topology(mech):
    """``check``'s topology: the model's own when fully driven; for a model meant for
    ``simulate`` (fewer drivers than its mobility, and an ``[initial]`` section or no driver at
    all) the one ``simulate`` builds, with ``(partition, q0)``
    (:func:`linkdyn.design.checks.free_coordinates`). Any other mismatch is refused as
    ``analyze`` refuses it."""
    from . import topology
    from .design.checks import free_coordinates

    try:
        return topology.build(mech), None
    except ModelError as err:
        for_simulate = mech.initial_q or mech.initial_qd or not mech.drivers
        if err.field != "drivers" or "Add" not in err.fix or not for_simulate:
            raise
    part, q0 = free_coordinates(mech)
    return part.layout.topo, (part, q0)


def _check_free(mech, part, q0) -> None:
    """``check`` of a model for ``simulate``: its free coordinates and their start."""
    from .design.checks import shown

    topo = part.layout.topo
    at = {mech.joints[topo.tree_joint[i]].name: q0[i] for i in range(1, topo.n)}
    given = "[initial] q" if mech.initial_q else "the [assembly] guess"
    click.echo(f"free coordinates (integrated by linkdyn simulate): {', '.join(part.free)}, "
               f"from {given}: " + ", ".join(f"q_{j} = {shown(mech, j, at[j])}"
                                            for j in part.free))
    rates = ", ".join(f"qd_{j} = {shown(mech, j, mech.initial_qd.get(j, 0.0))}/s"
                      for j in part.free)
    click.echo(f"assembles at t = 0 ({rates}); analyze needs "
               f"{topo.mobility - len(mech.drivers)} more driver(s), simulate none")


def _check_run(mech, topo) -> None:
    """``check`` of a driven model over its run: it assembles and does not lock (exit 3
    naming the loop and the driver values otherwise), with the dyads' motion over it."""
    from . import design
    from .design.checks import over_run, slider_crank_runs, span
    from .units import Units

    u = Units.of(mech)

    try:
        t = sample_times(mech, None, None, None)
    except ModelError as err:   # no run defined: the start only
        over_run(mech, np.zeros(1), topo)
        click.echo(f"assembles at t = 0 (no run to check over: {err.message})")
        return
    sol = over_run(mech, t, topo)
    names = [j.name for j in mech.joints]
    ranges = ", ".join(
        f"q_{d.joint} = {span(mech, d.joint, float(np.min(q)), float(np.max(q)))}"
        for d in mech.drivers for q in [sol.kin.q[:, names.index(d.joint)]])
    click.echo(f"assembles at t = 0 and over the run ({len(t)} samples, t = 0 .. "
               f"{t[-1]:.4g} s{', ' + ranges if ranges else ''}), clear of singular positions")
    for fb in design.four_bars(mech):
        mu = design.transmission_angle(sol, fb)
        words = design.fourbar.travel_words(design.fourbar.link_travel(sol, fb), u)
        click.echo(f"  four-bar {fb.input}/{fb.coupler}/{fb.output}: {words}; transmission "
                   f"angle {u.span(np.min(mu), np.max(mu), 'angle', 4)}")
    for sc in slider_crank_runs(sol):
        click.echo("  " + slider_crank_words(sc, u))


def slider_crank_words(sc: dict, u) -> str:
    """A slider-crank's run (:func:`linkdyn.design.checks.slider_crank_runs`, or its entry in
    summary.json) in words, in the units ``u`` (:class:`linkdyn.units.Units`, the file's):
    ``slider-crank rod/slider: stroke 100.7 mm (q_J4 128.452 .. 229.129 mm); transmission
    angle 67.11 .. 89.89 deg (rod against the guide's normal)``, as ``check`` and ``analyze``
    print it."""
    mu = sc["transmission_angle_rad"]
    lo, hi = sc["travel_m"]
    return (f"slider-crank {sc['rod']}/{sc['slider']}: stroke {u.show(sc['stroke_m'], 'length', 4)}"
            f" (q_{sc['guide']} {u.span(lo, hi, 'length')}); transmission angle "
            f"{u.span(mu['min'], mu['max'], 'angle', 4)} (rod against the guide's normal)")


def _assembly_at_zero(mech, topo) -> str:
    """``check``'s account of the assembly mode a model without a guess gets at t = 0."""
    from . import kinematics
    from .errors import AssemblyError

    if topo.mobility != len(mech.drivers):
        return "no [assembly] guess in the model (not assembled: the drivers do not match " \
               "the mobility)"
    try:
        kin = kinematics.solve(mech, np.zeros(1), backend="numpy")
    except AssemblyError:
        return ("no [assembly] guess in the model, and the loops do not close at t = 0 from "
                "zero angles (analyze stops with exit status 3)")
    phi = {b.name: float(kin.pose.phi[kin.layout.topo.bodies.index(b.name)][0])
           for b in mech.moving_bodies}
    from .units import Units
    return assembly_words(phi, 0.0, Units.of(mech))


# ---------------------------------------------------------------------------- analyze

class Progress:
    """Progress of a long run on a terminal: after ``delay`` s (at once for a big run) one line
    on stderr shows a bar of the steps done, the current step and the elapsed time. Silent when
    the stream is not a terminal (pipes, tests, CI)."""

    def __init__(self, total: int, *, big: bool = False, delay: float = 2.0, stream=None):
        self.stream = stream if stream is not None else sys.stderr
        self.on = bool(getattr(self.stream, "isatty", lambda: False)())
        self.total, self.done, self.label = total, -1, ""
        self.delay, self.t0, self.shown = (0.0 if big else delay), time.monotonic(), False
        self._stop, self._lock = threading.Event(), threading.Lock()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def __enter__(self):
        if self.on:
            self._thread.start()
        return self

    def __exit__(self, *exc):
        if self.on:
            self._stop.set()
            self._thread.join()
            if self.shown:
                if exc[0] is None:
                    self.done, self.label = self.total, "done"
                    self._draw()
                click.echo("", file=self.stream)
        return False

    def step(self, label: str) -> None:
        self.done, self.label = self.done + 1, label
        if self.shown:  # once the bar is up, a new step shows at once, not at the next tick
            self._draw()

    def _run(self) -> None:
        while not self._stop.wait(0.0 if not self.shown and self.delay == 0 else 0.25):
            if time.monotonic() - self.t0 >= self.delay:
                self.shown = True
                self._draw()

    def _draw(self) -> None:
        with self._lock:  # the ticker thread and step() both draw
            self._draw_line()

    def _draw_line(self) -> None:
        n = 24 * max(self.done, 0) // max(self.total, 1)
        line = (f"  [{'#' * n}{'-' * (24 - n)}] {min(max(self.done, 0), self.total)}/"
                f"{self.total} {time.monotonic() - self.t0:5.1f} s  {self.label}")
        width = shutil.get_terminal_size((80, 24)).columns - 1
        click.echo("\r" + line[:width].ljust(width), file=self.stream, nl=False)


def json_safe(x):
    """JSON-ready copy of ``x``: NaN and infinities become null (strict JSON has neither)."""
    if isinstance(x, dict):
        return {k: json_safe(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [json_safe(v) for v in x]
    if isinstance(x, (float, np.floating)):
        return float(x) if np.isfinite(x) else None
    if isinstance(x, np.integer):
        return int(x)
    return x


def _columns(sol, units: str) -> dict:
    """The result columns to write: SI as SPEC says (``units='si'``), or in the model file's
    units with the unit in each name (``'model'``, :func:`linkdyn.units.model_columns`)."""
    if units == "model":
        from .units import Units, model_columns
        return model_columns(sol.columns, sol.units, Units.of(sol.model))
    return sol.columns


def write_csv(sol, path: Path, units: str = "si") -> None:
    """``results.csv``: one row per sample, SPEC columns, every value round-trips exactly;
    SI, or with ``units='model'`` in the model file's units (``q_J1 [deg]``).

    Uses pyarrow's CSV writer when it is installed (about ten times faster for long runs).
    """
    cols = _columns(sol, units)
    try:
        import pyarrow as pa
        from pyarrow import csv as pacsv
    except ImportError:
        names = list(cols)
        data = np.stack([np.asarray(cols[k], float) for k in names], axis=-1)
        np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt="%.17g")
        return
    table = pa.table({k: np.asarray(v, dtype=float) for k, v in cols.items()})
    with open(path, "wb") as f:
        f.write((",".join(table.column_names) + "\n").encode())
        pacsv.write_csv(table, f, pacsv.WriteOptions(include_header=False, quoting_style="none"))


def write_parquet(sol, path: Path, units: str = "si") -> None:
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise ModelError("--format parquet needs pyarrow", field="--format",
                         fix="pip install 'linkdyn[parquet]', or use --format csv") from None
    if units == "si" and hasattr(sol, "to_dataframe"):   # a planar solution's frame
        sol.to_dataframe().reset_index().to_parquet(path, index=False)  # t as a column
        return
    pq.write_table(pa.table({k: np.asarray(v, float) for k, v in _columns(sol, units).items()}),
                   path)


_UNITS = click.option(
    "--units", "table_units", type=click.Choice(["si", "model"]), default="si",
    show_default=True,
    help="Units of results.csv: SI (m, rad, N, ...), or the model file's (mm, deg, ...) with "
         "the unit in each column's header, e.g. 'q_J1 [deg]'.")


def summary_text(s: dict) -> str:
    """The printed summary of an ``analyze`` run, from its summary dict (computed before any
    file is written, so a failure here leaves nothing behind), in the model file's units
    (``s['units']``, :class:`linkdyn.units.Units`)."""
    from .report.tables import denoise
    from .units import Units

    s = denoise(s)  # a rounding residual (a cycle's net work of 1e-16 J) prints as 0
    u = Units(**s.get("units", {}))
    lines: list[str] = []
    echo = lines.append

    def num(x, fmt, scale=1.0):  # a figure the run could not give (None or NaN) is "n/a"
        return "n/a" if x is None or not np.isfinite(x) else format(x * scale, fmt)

    def shown(x, quantity, digits=4):   # an SI value in the file's unit, with the unit
        return u.show(x, quantity, digits)

    def deg(x):   # a summary figure kept in degrees, in the file's angle unit
        return None if x is None else np.radians(x)

    echo(f"{s['model']}: {s['samples']} samples over {num(s['duration_s'], '.6g')} s")
    echo(f"  mobility {s['mobility']}, loops {s['loops']}, cut joints: "
         f"{', '.join(s['cut_joints']) or 'none'}")
    asm = s.get("assembly")
    if asm and not asm["guess"] and s["loops"]:
        echo(f"  assembly: {assembly_words(asm['start_phi_rad'], asm['start_time_s'], u)}")
    for fb in s["four_bars"]:
        ta = fb["transmission_angle_deg"]
        echo(f"  four-bar {fb['links']['input']}/{fb['links']['coupler']}/"
             f"{fb['links']['output']}: {fb['grashof']}"
             + (f"; {fb['motion']['words']}" if fb.get("motion", {}).get("words") else "")
             + f"; transmission angle {u.span(deg(ta['min']), deg(ta['max']), 'angle', 4)}")
        if "mechanical_advantage" in fb:
            ma = fb["mechanical_advantage"]
            frame = "" if fb.get("frame", "ground") == "ground" else f", frame {fb['frame']}"
            lo = "0" if ma.get("zero_at_s") else num(ma["min"], ".4g")
            hi = "infinite" if ma.get("infinite_at_s") else num(ma["max"], ".4g")
            stops = "; ".join(f"{word} where the {link} stops, t = "
                              + ", ".join(num(x, ".4g") for x in ma[key]) + " s"
                              for key, word, link in (("zero_at_s", "0", "input"),
                                                      ("infinite_at_s", "infinite", "output"))
                              if ma.get(key))
            echo(f"    mechanical advantage |w_in/w_out| {lo}..{hi}{frame}"
                 + (f" ({stops})" if stops else ""))
    for sc in s.get("slider_cranks", []):
        echo("  " + slider_crank_words(sc, u))
    for j, d in s["drivers"].items():
        q = "force" if d["effort"] == "force" else "torque"
        echo(f"  driver {j}: peak {d['effort']} {shown(d['peak'], q, 6)} at "
             f"t = {num(d['peak_time_s'], '.4g')} s, RMS {shown(d['rms'], q, 6)}")
    for j, e in s.get("driver_energy", {}).items():
        if e["work_J"] is not None:
            fw = e["flywheel"]
            fly = (f"; flywheel {shown(fw['inertia_kg_m2'], 'inertia')} for C_s = "
                   f"{num(fw['speed_fluctuation'], '.3g')}" if fw else "")
            work = (f"work {num(e['work_J'], '.4g')} J (+{num(e['positive_work_J'], '.4g')} / "
                    f"{num(e['negative_work_J'], '.4g')})")
            if "joint" in e:   # an actuator inside a joint (a motor's joint_torque)
                ld = s.get("load_energy", {}).get(j, {})
                peak = (f"peak {'torque' if e['kind'] == 'joint_torque' else 'force'} "
                        f"{num(ld.get('peak'), '.4g')} {ld.get('unit', '')} at t = "
                        f"{num(ld.get('peak_time_s'), '.4g')} s, " if ld else "")
                echo(f"  actuator {j} ({e['kind']} in {e['joint']}): {peak}{work}, mean power "
                     f"{num(e['mean_power_W'], '.4g')} W")
                continue
            echo(f"  driver {j}: {work}, energy fluctuation "
                 f"{num(e['energy_fluctuation_J'], '.4g')} J{fly}")
    for label, e in s.get("load_energy", {}).items():
        if e["kind"] in ("joint_torque", "joint_force") or e["work_J"] is None:
            continue   # printed with the drivers
        what = {"force": "force", "spring": "tension", "damper": "tension"}.get(e["kind"],
                                                                                "torque")
        extra = (f", dissipated {num(e['dissipated_J'], '.4g')} J" if e["kind"] == "damper"
                 else " (counted in the potential energy)" if e["kind"] == "spring" else "")
        echo(f"  {e['kind']} {label}: peak {what} {num(e['peak'], '.4g')} {e['unit']} at t = "
             f"{num(e['peak_time_s'], '.4g')} s, work {num(e['work_J'], '.4g')} J{extra}")
    if "shaking" in s:
        f, mz = s["shaking"]["force_N"], s["shaking"]["moment_Nm"]
        echo(f"  shaking force peak {shown(f['peak'], 'force', 6)} at t = "
             f"{num(f['peak_time_s'], '.4g')} s, RMS {shown(f['rms'], 'force', 6)}; shaking "
             f"moment (about the origin) peak {shown(mz['peak'], 'torque', 6)}")
    ps = s.get("path_straightness")
    if ps:
        q = "angle" if ps.get("range_unit", "rad") == "rad" else "length"
        echo(f"  path of {ps['point']}: deviation from a straight line max "
             f"{shown(ps['max_deviation_m'], 'length')}, RMS "
             f"{shown(ps['rms_deviation_m'], 'length')} over "
             f"{shown(ps['length_m'], 'length')}"
             + ("" if ps["range"] is None else
                f" (driver range {u.span(ps['range'][0], ps['range'][1], q, 4)})"))
    for j, c in s.get("contact", {}).items():   # a cam's contact, which can only push
        echo(f"  contact {j}: least force {shown(c['min_force_N'], 'force', 6)} at t = "
             f"{num(c['min_time_s'], '.4g')} s" + (
                 f"; LOSS OF CONTACT at {c['lost_samples']} samples, t = "
                 f"{num(c['lost_from_s'], '.4g')} .. {num(c['lost_to_s'], '.4g')} s: the "
                 "follower would leave the cam; stiffen its spring or raise the preload"
                 if c["lost_samples"] else "; never lost"))
        if c.get("leaves"):   # where the contact force first crosses zero
            x = c["leaves"]
            echo(f"    the contact force crosses zero at t = {num(x['time_s'], '.6g')} s, cam "
                 f"angle {shown(x['cam_angle_rad'], 'angle', 5)}, cam speed "
                 f"{num(x['cam_speed_rad_s'], '.6g', 30 / np.pi)} rpm: the follower would leave "
                 "the cam there (the joint holds it on; its flight is not modelled)")
        if c.get("stress"):   # a roller's Hertz line contact
            h = c["stress"]
            echo(f"    contact stress (Hertz, line contact) peak "
                 f"{shown(h['max_pressure_Pa'], 'pressure', 6)} at t = "
                 f"{num(h['max_time_s'], '.4g')} s, cam angle "
                 f"{shown(h['max_cam_angle_rad'], 'angle', 4)}: force "
                 f"{shown(h['force_N'], 'force', 6)}, half-width "
                 f"{shown(h['half_width_m'], 'length', 4)}, profile radius "
                 f"{shown(h['cam_radius_m'], 'length', 6)}")
        if c.get("jump_speed_rad_s") is not None:   # the constant speed where it is first lost
            echo(f"    at constant speed the follower would leave the cam from "
                 f"{num(c['jump_speed_rad_s'], '.6g', 30 / np.pi)} rpm (first at t = "
                 f"{num(c['jump_time_s'], '.4g')} s of this run)")
        for label, fix in c.get("springs", {}).items():   # the least spring that holds it
            ways = ([f"free length {shown(fix['free_length_m'], 'length', 6)} (its force "
                     f"{shown(abs(fix['tension_change_N']), 'force', 4)} more in "
                     f"{'tension' if fix['tension_change_N'] >= 0 else 'compression'})"]
                    if fix["free_length_m"] is not None else []) + (
                [f"stiffness {shown(fix['stiffness_N_m'], 'stiffness', 6)} (same free length)"]
                if fix["stiffness_N_m"] is not None else [])
            echo(f"    {label} keeps it on at this speed with " + (
                " or ".join(ways) if ways else "no change of its own"))
    if s.get("friction"):
        from .friction import summary_lines
        lines.extend(summary_lines(s["friction"]))
    if s.get("output"):
        from .friction import output_lines
        lines.extend(output_lines(s["output"]))
    echo("  peak reactions:")
    for j, r in s["reactions"].items():
        m = r.get("peak_moment_Nm")
        if m is not None and r.get("peak_force_N") and abs(m) <= 1e-12 * r["peak_force_N"]:
            m = 0.0  # rounding noise: below 1e-12 of the joint's force times a metre
        extra = f", moment {shown(m, 'torque', 6)}" if "peak_moment_Nm" in r else ""
        echo(f"    {j:8s} {shown(r['peak_force_N'], 'force', 6)} at t = "
             f"{num(r['peak_time_s'], '.4g')} s{extra}")
    h = s["health"]
    balance = (f"{num(h['energy_balance_residual_rel'], '.2e')} (relative)"
               if h.get("energy_balance_residual_rel") is not None or "energy_balance" not in h
               else h["energy_balance"])
    echo(f"  closure residual {num(h['closure_residual_rel'], '.2e')} (relative), energy "
         f"balance {balance}, worst "
         f"condition number {num(h['worst_condition_number'], '.3g')}")
    smp = s.get("sampling")
    if smp and smp["coarse"]:
        step = max(smp["driver_step"].values())
        echo(f"  NOTE: the samples are up to {shown(step, 'angle')} of driver travel apart: "
             "peaks, travel, work and the path are those of the samples, not of the motion "
             "between them; give more --samples to resolve it")
    if s["invalid_samples"]:
        echo(f"  WARNING: {s['invalid_samples']} samples that do not close or sit at a singular "
             "position are written as NaN rows")
    return "\n".join(lines)


def assembly_words(phi: dict, time: float, units=None) -> str:
    """The assembly mode chosen without an ``[assembly]`` guess, in words, the angles (rad in
    ``phi``) in ``units``' angle unit (:class:`linkdyn.units.Units`; None: deg)."""
    from .units import Units

    units = units or Units(angle="deg")
    angles = ", ".join(f"phi_{b} = {units.show(v, 'angle', 4)}" for b, v in phi.items()
                       if v is not None)
    return (f"no [assembly] guess in the model: solved from zero angles, the mechanism starts "
            f"(t = {time:.4g} s) with {angles}; give [assembly] phi near another position to "
            "choose another assembly mode")


def print_summary(s: dict) -> None:
    click.echo(summary_text(s))


def _path_range(text, mech):
    """``--path-range 'A:B'`` -> (A, B) in SI (rad or m) of ``mech``'s first driver coordinate,
    or None: a bare number is in the model file's unit, a number with a unit in that unit
    (``110deg:250deg``, ``0.1m:0.2m``; :meth:`linkdyn.units.Units.parse`)."""
    from .units import Units, coordinate

    if text is None:
        return None
    if not mech.drivers:
        raise ModelError("--path-range is a range of the first driver, and the model has "
                         "none", field="--path-range", fix="Drop --path-range")
    quantity = coordinate(mech, mech.drivers[0].joint)
    u = Units.of(mech)
    example = "--path-range 110:250" if quantity == "angle" else "--path-range 0.1:0.2"
    parts = text.split(":")
    if len(parts) != 2:
        raise ModelError(f"--path-range must be A:B, got '{text}'", field="--path-range",
                         fix=f"Give two numbers in the file's unit ({u.unit(quantity)[0]}), e.g. "
                             f"{example}")
    try:
        a, b = (u.parse(x, quantity, "--path-range", example) for x in parts)
    except ModelError as err:
        raise ModelError(f"--path-range must be A:B, got '{text}': {err.message}",
                         field="--path-range", fix=err.fix) from None
    return a, b


def _check_path_range(sol, si) -> None:
    """Raise, naming --path-range, unless the run has 3 samples or more in the range ``si``
    (rad or m), which the message gives in the file's unit."""
    from .design.path import _in_range
    from .units import Units, coordinate

    mech = sol.model
    joint = mech.drivers[0].joint
    u, quantity = Units.of(mech), coordinate(mech, joint)
    q = sol.kin.q[..., [j.name for j in mech.joints].index(joint)]
    n = int(np.sum(_in_range(mech, q, si) & np.isfinite(q)))
    if n >= 3:
        return
    raise ModelError(f"the run never reaches the range {u.span(*si, quantity)} of "
                     f"q_{joint} with the 3 samples a line needs (it holds {n}); this run "
                     f"covers {u.span(float(np.nanmin(q)), float(np.nanmax(q)), quantity)}",
                     field="--path-range",
                     fix=f"Give a range A:B of the first driver's coordinate that the run "
                         f"covers, in the model file's unit ({u.unit(quantity)[0]})")


@main.command()
@click.argument("model", type=click.Path(dir_okay=False))
@click.option("-o", "--outdir", default="out", show_default=True, type=click.Path(),
              help="Folder for results.csv, summary.json (and the report).")
@click.option("--samples", type=int, help="Number of samples (both ends included).")
@click.option("--duration", type=float, help="Duration in s.")
@click.option("--cycles", type=float, help="Duration in driver revolutions.")
@click.option("--format", "fmt", type=click.Choice(["csv", "parquet"]), default="csv",
              show_default=True)
@click.option("--report", is_flag=True, help="Also write a self-contained report.html "
              "(animation, interactive plots, summary).")
@click.option("--plots", "plots_", is_flag=True,
              help="Also write static figures plot_*.png and plot_*.svg (matplotlib).")
@click.option("--allow-singular", is_flag=True,
              help="Keep going through singular positions; their rows are NaN.")
@click.option("--fluctuation", type=float, default=0.02, show_default=True,
              help="Coefficient of speed fluctuation C_s for the flywheel size.")
@click.option("--path-point", metavar="BODY.POINT",
              help="Point whose path straightness is reported (default: the only free "
                   "coupler point, if any).")
@click.option("--path-range", metavar="A:B",
              help="Range of the first driver's coordinate for --path-point, in the model "
                   "file's angle unit (length unit for a slider), or with a unit "
                   "(110deg:250deg); default: the whole run.")
@_UNITS
@_BACKEND
@_ALLOW_OUTSIDE
@click.pass_context
def analyze(ctx, model, outdir, samples, duration, cycles, fmt, report, allow_singular,
            fluctuation, path_point, path_range, plots_, backend, allow_outside,
            table_units="si"):
    """Solve kinematics and inverse dynamics of MODEL; write results and a summary."""
    from . import design, io
    from .analysis import analyze as run

    if duration is not None and cycles is not None:
        raise ModelError("give --duration or --cycles, not both", field="--duration",
                         fix="Drop one of them")
    check_outdir(outdir)
    mech = io.load_model(model, allow_outside=allow_outside)
    if mech.space == "spatial":
        from .spatial import cli as spatial_cli
        if path_point or path_range:
            not_yet(mech, "analyze --path-point and --path-range")
        if _backend(ctx, backend) == "compiled":
            not_yet(mech, "the compiled backend")
        t = sample_times(mech, samples, duration, cycles)
        text, summ, sol = spatial_cli.analyze(mech, t, allow_singular)
        if (report or plots_) and summ["invalid_samples"]:
            not_yet(mech, "a report or plots of a run with gaps (--allow-singular)")
        files = _results(_spatial_table(sol), summ, fmt, table_units)
        if report:
            from . import report as report_mod
            files.update(report_mod.outputs(sol, summ))
        if plots_:  # the page's panels as figures (costly: --report does not add them)
            from . import plots as plots_mod
            from .report import spatial as spatial_report
            files.update(plots_mod.panel_outputs(spatial_report.page_data(sol, summary=summ)))
        written = _write_results(outdir, files)
        click.echo(text)
        click.echo(f"wrote {', '.join(map(str, written))}")
        return
    q_range = _path_range(path_range, mech)   # SI, from the file's unit
    if path_point is not None:
        from .design.path import _parse_point
        _parse_point(mech, path_point)   # an unknown BODY.POINT names --path-point
    t = sample_times(mech, samples, duration, cycles)
    progress = Progress(4, big=len(t) > 1_000_000)  # a bar on a terminal for long runs only
    with progress:
        # everything is computed (solution, summary, its text) before any file is written
        progress.step(f"solving {len(t)} samples")
        try:
            sol = run(mech, t, allow_singular=allow_singular,
                      backend=_backend(ctx, backend))
        except MemoryError:  # below the estimate of sample_times, yet more than is free now
            raise ModelError(f"not enough free memory for {len(t)} samples", field="--samples",
                             fix="Give fewer samples, or split the run into parts with "
                                 "--duration") from None
        progress.step("summary")
        if q_range is not None:
            _check_path_range(sol, q_range)
        summ = design.summary(sol, fluctuation=fluctuation,
                              path_point=path_point or mech.path_point, path_range=q_range,
                              default_range=mech.path_range)
        text = summary_text(summ)
        files = _results(sol, summ, fmt, table_units)
        if report:
            from . import report as report_mod
            files.update(report_mod.outputs(sol, summ))
        if plots_ or report:  # SPEC: --report adds the plots and report.html
            from . import plots as plots_mod
            files.update(plots_mod.outputs(sol))
        progress.total = 2 + len(files)
        written = _write_results(outdir, files, progress)
    click.echo(text)
    click.echo(f"wrote {', '.join(map(str, written))}")


def _spatial_table(sol) -> SimpleNamespace:
    """A spatial solution's table as :func:`_results` reads a planar one's: ``columns``,
    ``units`` (SI, of each column) and ``model`` (whose file's units ``--units model`` uses)."""
    return SimpleNamespace(columns=sol.columns(), units=sol.units(), model=sol.model)


def _results(sol, summ: dict, fmt: str, table_units: str = "si") -> dict:
    """The results table (SI, or the file's units: ``table_units``, ``--units model``) and
    ``summary.json`` of ``analyze`` and ``simulate`` as writers for :func:`_write_results`;
    ``summary.json`` lists every file of the run (``files``), filled in by
    :func:`_write_results`."""
    files = {
        "results.csv" if fmt == "csv" else "results.parquet":
            (lambda p: write_csv(sol, p, table_units)) if fmt == "csv" else
            (lambda p: write_parquet(sol, p, table_units)),
        "summary.json": lambda p: p.write_text(json.dumps(
            {**json_safe(summ), "files": list(files)}, indent=2, allow_nan=False)),
    }
    return files


def _write_results(outdir, files: dict, progress=None) -> list[Path]:
    """Write ``files`` (of :func:`_results`, with the report and plots) all or nothing. A file
    of an earlier run that this run does not write again (the other table format, the report
    and plots of an earlier ``--report`` run) is removed only when that run's ``summary.json``
    lists it as its own: a ``report.html`` or ``results.csv`` no run wrote is the user's and
    stays as it is."""
    return write_outputs(outdir, files, owned=owned_before(outdir, "summary.json",
                                                           ANALYSIS_OUTPUTS),
                         progress=progress)


# ---------------------------------------------------------------------------- compare

@main.command()
@click.argument("models", nargs=-1, type=click.Path(dir_okay=False))
@click.option("-o", "--outdir", default="out/compare", show_default=True, type=click.Path(),
              help="Folder for compare.html, compare.json and compare.csv.")
@click.option("--sweep", "sweep_dir", type=click.Path(file_okay=False),
              help="Also compare a sweep's best designs: the folder of its designs.parquet "
                   "and summary.json.")
@click.option("--by", "by_metric", metavar="METRIC",
              help="The sweep metric that ranks its designs (best first: the lowest, or the "
                   "largest for min_transmission_angle and stroke_*); needed with --sweep.")
@click.option("--best", "n_best", type=int, default=3, show_default=True,
              help="How many of the sweep's best valid designs to compare.")
@click.option("--samples", type=int, help="Number of samples of each design (both ends "
              "included) [default: each model's own].")
@click.option("--duration", type=float, help="Duration in s of every design.")
@click.option("--cycles", type=float, help="Duration in driver revolutions of every design.")
@click.option("--fluctuation", type=float, default=0.02, show_default=True,
              help="Coefficient of speed fluctuation C_s for the flywheel size.")
@_BACKEND
@_ALLOW_OUTSIDE
@click.pass_context
def compare(ctx, models, outdir, samples, duration, cycles, fluctuation, sweep_dir, by_metric,
            n_best, backend, allow_outside):
    """Compare designs MODELS... on one page: curves overlaid, key results side by side.

    Each design is solved and summarized as `linkdyn analyze` does with the same options, so
    each column of the page holds that design's own numbers.
    """
    from . import design, io
    from .analysis import analyze as run
    from .report import compare as compare_mod
    from .studies.checks import fluctuation as check_fluctuation

    fluctuation = check_fluctuation(fluctuation)
    if duration is not None and cycles is not None:
        raise ModelError("give --duration or --cycles, not both", field="--duration",
                         fix="Drop one of them")
    # each design: (file, its name, its model, what the sweep row holds or None)
    designs = [(path, Path(path).stem, io.load_model(path, allow_outside=allow_outside), None)
               for path in models]
    if sweep_dir is not None:
        from .studies.files import need_parquet
        need_parquet("compare --sweep")   # designs.parquet: say how to install, no traceback
        designs += compare_mod.sweep_best(sweep_dir, by_metric, n_best)
    elif by_metric is not None:
        raise ModelError("--by ranks a sweep's designs, and no --sweep is given", field="--by",
                         fix="Give --sweep OUTDIR of the sweep, or drop --by")
    if len(designs) < 2:
        raise ModelError("compare needs at least two model files", field="MODELS",
                         fix="Give two or more model files, e.g. linkdyn compare a.toml b.toml, "
                             "or a sweep's designs with --sweep DIR --by METRIC")
    spatial = _one_space(designs)
    check_outdir(outdir)
    runs, names = [], []
    for path, stem, mech, _ in designs:
        t = sample_times(mech, samples, duration, cycles)
        if spatial:   # solved and summarized as linkdyn analyze does
            from .spatial import analyze as run_spatial, cli as spatial_cli
            if backend == "compiled":
                not_yet(mech, "the compiled backend")
            sol = run_spatial(mech, t)
            summ = spatial_cli.summary(sol)
        else:
            sol = run(mech, t, backend=_backend(ctx, backend))
            summ = design.summary(sol, fluctuation=fluctuation, path_point=mech.path_point,
                                  default_range=mech.path_range)
        name = stem if stem not in names else f"{stem} ({len(names) + 1})"
        names.append(name)
        runs.append((name, sol, summ))
    table = compare_mod.compare_data(runs)
    page = compare_mod.render_compare(runs, data=table)
    data = {name: {"file": str(path), **({"sweep": row} if row else {}),
                   "summary": json_safe(summ)}
            for (name, _, summ), (path, _, _, row) in zip(runs, designs)}
    files = {"compare.html": lambda p: p.write_text(page, encoding="utf-8"),
             "compare.json": lambda p: p.write_text(json.dumps(data, indent=2, allow_nan=False)),
             "compare.csv": lambda p: p.write_text(compare_mod.compare_csv(table),
                                                   encoding="utf-8")}
    written = write_outputs(outdir, files, owned=tuple(files))
    for name, sol, summ in runs:
        peaks = ", ".join(f"peak |{c}| {v:.6g} {'N m' if c.startswith('tau') else 'N'}"
                          for c, v in summ["peak_effort"].items()) if (
            spatial) else ", ".join(f"{j} peak {d['effort']} {d['peak']:.6g} {d['unit']}"
                                    for j, d in summ["drivers"].items())
        click.echo(f"{name}: {summ['model']}, {summ['samples']} samples; {peaks}")
    click.echo(f"wrote {', '.join(map(str, written))}")


def _one_space(designs) -> bool:
    """Whether the designs compared are spatial (exit 2 when planar and spatial are mixed)."""
    spaces = {mech.space for _, _, mech, _ in designs}
    if len(spaces) > 1:
        path = next(p for p, _, m, _ in designs if m.space == "spatial")
        raise ModelError("compare takes planar or spatial models, not both on one page",
                         file=str(path), field="mechanism.space",
                         fix="Compare the spatial models and the planar ones separately")
    return spaces == {"spatial"}


# ---------------------------------------------------------------------------- simulate

def simulation_summary(sol, summ: dict) -> dict:
    """``summ`` (of :func:`linkdyn.design.summary`) with the simulation's figures added: the
    speed of the independent coordinates (:func:`linkdyn.design.speed_statistics`), the
    energy account (:func:`linkdyn.design.energy_account`) and the integration's figures."""
    from . import design

    s = dict(summ)
    s["speed"] = design.speed_statistics(sol)
    s["energy_account_J"] = design.energy_account(sol)
    s["simulation"] = integration(sol)
    return s


def integration(sol) -> dict:
    """The integration's figures of a simulation (planar or spatial) for its summary."""
    ke, pe = (np.asarray(x() if callable(x) else x) for x in (sol.kinetic_energy,
                                                               sol.potential_energy))
    return {
        "free_joints": list(sol.free),
        **{k: sol.stats[k] for k in ("method", "rtol", "atol", "atol_rates", "steps",
                                     "rhs_evaluations", "energy_projections")},
        # where a free joint with friction stuck, slipped or reversed (F13; planar models:
        # spatial ones have no friction loads)
        **({"stick_slip": [{"t_s": ts, "joint": j, "event": what}
                           for ts, j, what in sol.stats["stick_slip"]]}
           if sol.model.space == "planar" and sol.friction is not None else {}),
        # where the free coordinates changed near a dead point of theirs (time s, joints)
        "coordinate_switches": [{"t_s": ts, "free_joints": fr}
                                for ts, fr in sol.stats.get("switches", [])],
        "energy_balance_drift_rel": sol.energy_drift,
        "closure_residual_max_rel": sol.stats["closure_residual"],
        "free_effort_residual_rel": sol.stats["free_effort_residual"],
        "energy_J": {"kinetic_start": float(ke[0]), "kinetic_end": float(ke[-1]),
                     "potential_start": float(pe[0]), "potential_end": float(pe[-1]),
                     "work": float(sol.work[-1])},
    }


def speed_text(s: dict, mech) -> str:
    """The printed lines of a simulation's speed statistics and energy account (from its
    summary dict), each ending in a newline: a turning coordinate's speed in rpm, another's
    in the model file's angle or length unit per second."""
    from .design.speed import RPM
    from .io.units import ANGLE_UNITS, LENGTH_UNITS

    def num(x, fmt):
        return "n/a" if x is None or not np.isfinite(x) else format(x, fmt)

    lines = []
    for j, e in s.get("speed", {}).items():
        w = e["window"]
        if e["turns"]:
            unit, vals = "rpm", (e["mean_rpm"], e["min_rpm"], e["max_rpm"])
            size = None
        else:
            name = mech.angle_unit if e["unit"] == "rad/s" else mech.length_unit
            size = (ANGLE_UNITS if e["unit"] == "rad/s" else LENGTH_UNITS)[name]
            unit, vals = f"{name}/s", tuple(x / size for x in (e["mean"], e["min"], e["max"]))
        cf = e["coefficient_of_fluctuation"]
        run_up = f"run-up {num(e['run_up_time_s'], '.4g')} s"
        if e["steady"] is False:
            change = e["mean_change"] * (RPM if e["turns"] else 1.0 / size)
            run_up += (f"; NOT steady yet: the mean speed changed by {change:+.4g} {unit} from "
                       "the window before (run longer)")
        elif e["steady"] is None:
            run_up += "; steadiness unknown (the run holds less than two windows)"
        lines.append(
            f"  speed of {j} over the {w['over']} (t = {num(w['start_s'], '.4g')}.."
            f"{num(w['end_s'], '.4g')} s): mean {num(vals[0], '.6g')} {unit}, min "
            f"{num(vals[1], '.6g')}, max {num(vals[2], '.6g')} {unit}, coefficient of "
            "fluctuation " + (num(cf, ".4g") if cf is not None else
                              "not meaningful (it swings to and fro)") + f"; {run_up}")
    a = s.get("energy_account_J")
    if a and a["residual"] is not None:
        lines.append(
            f"  energy: kinetic {a['kinetic_change'] + 0.0:+.4g} J, potential "
            f"{a['potential_change'] + 0.0:+.4g} J = drivers {a['driver_work'] + 0.0:+.4g} J + "
            f"loads {a['load_work'] + 0.0:+.4g} J - dampers {a['damper_dissipation'] + 0.0:.4g} J"
            + (f" - friction {a['friction_dissipation'] + 0.0:.4g} J"
               if a.get("friction_dissipation") else "")
            + f" (residual {a['residual'] + 0.0:+.3g} J, trapezoid rule over the samples)")
    return "".join(line + "\n" for line in lines)


@main.command()
@click.argument("model", type=click.Path(dir_okay=False))
@click.option("-o", "--outdir", default="out", show_default=True, type=click.Path(file_okay=False),
              help="Folder for results.csv, summary.json (and the report).")
@click.option("--duration", type=float, help="Duration in s [default: [analysis] duration].")
@click.option("--samples", type=int, help="Number of output samples, both ends included "
              "[default: [analysis] samples, else 501].")
@click.option("--rtol", type=float, default=1e-8, show_default=True,
              help="Relative tolerance of the ODE solver.")
@click.option("--atol", type=float, default=1e-10, show_default=True,
              help="Absolute tolerance of the ODE solver (rad, m, per s, J).")
@click.option("--method", type=click.Choice(["DOP853", "RK45", "RK23", "Radau", "BDF", "LSODA"]),
              default="DOP853", show_default=True,
              help="scipy ODE solver; an implicit one (BDF, LSODA, Radau) for stiff springs.")
@click.option("--format", "fmt", type=click.Choice(["csv", "parquet"]), default="csv",
              show_default=True)
@click.option("--report", is_flag=True, help="Also write plots and a self-contained report.html.")
@click.option("--no-project", "no_project", is_flag=True,
              help="Do not put each step's end back on the energy balance (F11); the "
                   "integrator's own steps only.")
@_UNITS
@_BACKEND
@_ALLOW_OUTSIDE
@click.pass_context
def simulate(ctx, model, outdir, duration, samples, rtol, atol, method, fmt, report, no_project,
             backend, allow_outside, table_units="si"):
    """Integrate the free degrees of freedom of MODEL from [initial] under its loads (forward
    dynamics); drivers, if any, still prescribe their joints. Writes the same results as
    analyze, plus potential_energy and work, and the energy balance in the summary."""
    from . import design, io
    from .forward import simulate as run, tolerances

    check_outdir(outdir)
    rtol, atol = tolerances(rtol, atol, ("--rtol", "--atol"))
    mech = io.load_model(model, allow_outside=allow_outside)
    for given, what in ((fmt != "csv", "--format parquet"),
                        (_backend(ctx, backend) == "compiled", "--backend compiled")):
        if given:
            not_yet(mech, f"simulate {what}")
    d_field = "--duration" if duration is not None else "analysis.duration"
    duration = mech.duration if duration is None else duration
    if duration is None:
        raise ModelError("no duration to simulate", field="--duration",
                         fix="Give --duration T (s) or [analysis] duration")
    if not (0 < duration < np.inf):
        raise ModelError(f"{d_field} must be positive and finite, got {duration}", field=d_field,
                         fix="Give a positive, finite duration in s")
    n_field = "--samples" if samples is not None else "analysis.samples"
    samples = samples if samples is not None else (mech.samples or 501)
    if samples < 2:
        raise ModelError(f"{n_field} must be at least 2, got {samples}", field=n_field,
                         fix="Give --samples 2 or more")
    check_memory(mech, samples, n_field)
    t = np.linspace(0.0, float(duration), int(samples))
    # everything is computed (solution, summary, its text) before any file is written
    sol = run(mech, t, rtol=rtol, atol=atol, method=method, backend=_backend(ctx, backend),
              project=not no_project)
    if mech.space == "spatial":
        from .spatial import cli as spatial_cli
        summ, text = spatial_cli.simulation(sol, integration(sol))
        rows = _spatial_table(sol)
    else:
        summ = simulation_summary(sol, design.summary(sol))
        text = summary_text(summ) + "\n" + speed_text(summ, mech)
        rows = sol
    sim = summ["simulation"]
    text = text + (
        f"  simulation: free joints {', '.join(sim['free_joints'])}; {sim['method']} "
        f"rtol {sim['rtol']:g} atol {sim['atol']:g}"
        + (f" (the free rates' {sim['atol_rates']:.2g}, their resolution under the right-hand "
           f"side)" if sim["atol_rates"] > sim["atol"] else "")
        + f": {sim['steps']} steps, "
        f"{sim['rhs_evaluations']} evaluations; energy balance drift "
        f"{sim['energy_balance_drift_rel']:.2e} (relative to the largest energy)"
        + "".join(f"\n  free coordinates switched to {', '.join(sw['free_joints'])} at "
                  f"t = {sw['t_s']:.6g} s (a dead point of the previous ones)"
                  for sw in sim["coordinate_switches"]))
    files = _results(rows, summ, fmt, table_units)
    if report:
        from . import plots as plots_mod
        from . import report as report_mod
        files.update(report_mod.outputs(sol, summ))
        if mech.space != "spatial":   # a spatial page's figures: analyze --plots (below)
            files.update(plots_mod.outputs(sol))
    written = _write_results(outdir, files)
    click.echo(text)
    click.echo(f"wrote {', '.join(map(str, written))}")


# ---------------------------------------------------------------------------- equilibrium

_AT_START = click.option(
    "--at-start", is_flag=True,
    help="No Newton step: take the start ([initial] q) as the equilibrium, e.g. a published "
         "one, and linearize there; the residual says how far it is from one.")


@main.command()
@click.argument("model", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print the results as JSON (SI units).")
@_AT_START
@_ALLOW_OUTSIDE
def equilibrium(model, as_json, at_start, allow_outside):
    """The static equilibrium of MODEL's free joints under its loads, from [initial] q (else the
    assembly), drivers held at their t = 0 position, and whether it is stable."""
    _equilibrium(model, as_json, allow_outside, with_modes=False, at_start=at_start)


@main.command()
@click.argument("model", type=click.Path(dir_okay=False))
@click.option("--json", "as_json", is_flag=True, help="Print the results as JSON (SI units).")
@click.option("--report", is_flag=True,
              help="Also write mode<k>.html: each oscillating mode animated over one period.")
@click.option("-o", "--outdir", default="out/modes", show_default=True,
              type=click.Path(file_okay=False), help="Folder for the --report pages.")
@_AT_START
@_ALLOW_OUTSIDE
def modes(model, as_json, report, outdir, at_start, allow_outside):
    """The small vibrations of MODEL about its static equilibrium: natural frequencies (Hz),
    damping ratios and mode shapes of the free joints and every tree joint."""
    md = _equilibrium(model, as_json, allow_outside, with_modes=True, at_start=at_start)
    if report:
        from . import design, modal as eq_mod
        from .analysis import analyze as run
        from .report import render

        check_outdir(outdir)
        files = {}
        for k in md.oscillating:
            # the mode's motion, analyzed and shown as linkdyn analyze --report shows a run
            moving = eq_mod.mode_motion(md, int(k))
            sol = run(moving, np.linspace(0.0, moving.duration, 121))
            if moving.space == "spatial":
                from .spatial import cli as spatial_cli
                summ = spatial_cli.summary(sol)
            else:
                summ = design.summary(sol)
            page = render(sol, summ)
            files[f"mode{k + 1}.html"] = lambda path, page=page: Path(path).write_text(
                page, encoding="utf-8")
        if not files:
            raise ModelError("no mode swings (every root is overdamped or unstable): no page "
                             "to animate", field="--report", fix="Drop --report")
        written = write_outputs(outdir, files, owned=("mode*.html",))
        if not as_json:
            click.echo(f"wrote {', '.join(map(str, written))}")


def _equilibrium(model, as_json, allow_outside, with_modes, at_start):
    from . import io, modal as eq_mod

    mech = io.load_model(model, allow_outside=allow_outside)
    eq = eq_mod.equilibrium(mech, search=not at_start)
    md = eq_mod.modes(eq) if with_modes else None
    if as_json:
        click.echo(json.dumps(json_safe(eq_mod.as_dict(eq, md)), indent=2))
    else:
        click.echo(eq_mod.text(eq, md))
    return md


# ---------------------------------------------------------------------------- cam

@main.command()
@click.argument("camfile", type=click.Path(dir_okay=False))
@click.option("-o", "--outdir", default="out/cam", show_default=True,
              type=click.Path(file_okay=False), help="Folder for cam.csv.")
def cam(camfile, outdir):
    """Design a disc cam from its follower's motion (CAMFILE: [units] and [cam] with
    [[cam.segments]], a table or a formula; a translating or an oscillating follower): prints
    the lift or swing, SVAJ peaks, the largest pressure angle, the smallest radius of curvature
    and any undercutting, and writes cam.csv (SVAJ, pressure angle, curvature, the pitch curve
    and the profile's points, SI)."""
    from . import cams
    from .io import camfile as cam_file

    check_outdir(outdir)
    design, n = cam_file.read(camfile)
    prof = cams.profile(design, n)
    table = cams.columns(prof)

    def write(path):
        import csv
        with open(path, "w", newline="", encoding="utf-8") as fh:
            w = csv.writer(fh)
            w.writerow(list(table))
            for row in zip(*(v.tolist() for v in table.values())):
                w.writerow([repr(x) for x in row])
    written = write_outputs(outdir, {"cam.csv": write}, owned=("cam.csv",))
    click.echo(cam_file.text(prof))
    click.echo(f"wrote {', '.join(map(str, written))}")


# ---------------------------------------------------------------------------- reproduce

@main.command()
@click.argument("name")
@click.option("-o", "--outdir", type=click.Path(),
              help="Output folder [default: out/reproduce-NAME].")
def reproduce(name, outdir):
    """Reproduce a published example: its figures (PNG), results.csv and a README.

    NAME: hoeken, the seed paper's worked example (Figs. 5-7: joint motion, cut-joint
    multipliers and driving torque, joint reactions).
    """
    from . import plots

    out = Path(outdir or f"out/reproduce-{name}")
    check_outdir(out)
    sol, figs = plots.reproduce(name)
    files = {"results.csv": lambda p: write_csv(sol, p), **figs}
    written = write_outputs(out, files, owned=tuple(files))
    click.echo(f"{sol.model.name}: {len(sol.t)} samples over {sol.t[-1] - sol.t[0]:.6g} s")
    click.echo(f"wrote {', '.join(map(str, written))}")
    click.echo(f"see {out / 'README.txt'} for what each figure shows and the sign conventions")


# ---------------------------------------------------------------------------- export

@main.command("export")
@click.argument("model", type=click.Path(dir_okay=False))
@click.option("--to", "to", required=True, type=click.Choice(["mjcf", "svg", "dxf"]),
              help="mjcf: a MuJoCo model; svg, dxf: the drawing at --at and the traced paths.")
@click.option("-o", "--output", type=click.Path(dir_okay=False),
              help="File to write [default: the model's name with .xml, .svg or .dxf].")
@click.option("--at", type=float, default=0.0, show_default=True,
              help="Time in s of the pose drawn (svg, dxf) or the MJCF's bodies are placed at.")
@click.option("--plane", type=click.Choice(["xy", "yz", "zx", "xz", "yx", "zy"]),
              help="svg, dxf of a spatial model: the plane it is projected on, its first axis "
                   "drawn right, its second up [default: xy].")
@_ALLOW_OUTSIDE
def export(model, to, output, at, plane, allow_outside):
    """Write MODEL as a MuJoCo model (MJCF) or its drawing (SVG, DXF) for CAD."""
    from . import io
    from .io.export import FORMATS, export as run
    from .outputs import check_file, write_file

    out = Path(output) if output else Path(Path(model).stem + FORMATS[to])
    check_file(out)
    mech = io.load_model(model, allow_outside=allow_outside)
    done = run(mech, to, at=at, plane=plane)
    write_file(out, done.text)
    for note in done.notes:
        click.echo(note)
    click.echo(f"wrote {out}")


# ---------------------------------------------------------------------------- import

@main.command("import")
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("-o", "--output", type=click.Path(dir_okay=False),
              help="Model file to write, *.toml or *.json [default: FILE's name with .toml].")
@click.option("--length-unit", default="m", show_default=True,
              help="Length unit of FILE's numbers (pylinkage and Pyslvs have none): m, mm, cm, "
                   "in...")
@click.option("--input", "pair", metavar="BASE,DRIVE",
              help="Pyslvs's input pair (joint numbers: the crank's ground joint, the joint it "
                   "carries), for an expression, which has none, or instead of a project's.")
def import_(file, output, length_unit, pair):
    """Write a mechanism saved by pylinkage (its JSON) or drawn in Pyslvs (its expression or
    YAML project) as a linkdyn model file.

    Masses are placeholders (1 kg uniform bars per link); one pylinkage step is one second, a
    Pyslvs crank turns once a second.
    """
    from .io import read_input
    from .io.pylinkage import import_pylinkage, model_text
    from .io.pyslvs import import_pyslvs, is_pyslvs
    from .outputs import check_file, write_file

    out = Path(output) if output else Path(Path(file).stem + ".toml")
    if out.suffix.lower() not in (".toml", ".json"):
        raise ModelError(f"cannot write a model file named '{out}'", field="-o",
                         fix="Name it *.toml or *.json")
    check_file(out)
    if is_pyslvs(file, read_input(file, "file to import")):
        inputs = None
        if pair is not None:
            try:
                inputs = [tuple(int(k) for k in pair.split(","))]
            except ValueError:
                raise ModelError(f"expected two joint numbers BASE,DRIVE, got '{pair}'",
                                 field="--input", fix="Give e.g. --input 0,1") from None
        done = import_pyslvs(file, length_unit=length_unit, inputs=inputs)
    else:
        done = import_pylinkage(file, length_unit=length_unit)
    write_file(out, model_text(done, out.suffix))
    for note in done.notes:
        click.echo(note)
    click.echo(f"wrote {out}")


if __name__ == "__main__":  # pragma: no cover
    main()


# ---------------------------------------------------------------------------- design studies

from .studies.cli import optimize as _optimize_command  # noqa: E402  (needs the helpers above)
from .studies.cli import sweep as _sweep_command  # noqa: E402

main.add_command(_sweep_command, "sweep")
main.add_command(_optimize_command, "optimize")
