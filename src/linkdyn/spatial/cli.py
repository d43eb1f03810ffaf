"""What ``linkdyn check`` and ``linkdyn analyze`` print and write for a spatial model: the
description, the summary (mobility, redundancy, peak efforts and reactions) and the table
(the command line, :mod:`linkdyn.cli`, writes ``results.csv`` and ``summary.json``)."""

from __future__ import annotations

import click
import numpy as np

from .. import topology
from ..model import GROUND
from . import analyze as run, check as inspect
from . import kinematics as sk


def check(mech, path: str) -> None:
    """Print the model, its tree and cut joints, Grübler–Kutzbach's count, the mobility from
    the closure Jacobian's rank at the assembly and the redundant rows; exit 3 where it does
    not assemble, exit 2 where the mobility is not the number of drivers."""
    info = inspect(mech)
    p = info["plan"]
    topo = p.topo
    click.echo(f"{mech.name}  ({path})  [spatial]")
    if mech.description:
        click.echo(f"  {mech.description}")
    click.echo(f"bodies ({len(mech.bodies)}):")
    for b in mech.bodies:
        extra = "" if b.name == GROUND else f"  mass {b.mass:g} kg"
        click.echo(f"  {b.name:14s} points: {', '.join(b.points)}{extra}")
    click.echo("\n".join(topology.joint_lines(mech, topo)))
    click.echo(f"mobility (Grübler–Kutzbach, 6*({topo.n}-1) - sum(6 - f)): {info['gruebler']}")
    click.echo(f"mobility (closure Jacobian's rank {info['rank']} of {info['rows']} rows): "
               f"{info['mobility']}; drivers: {len(mech.drivers)}")
    if info["redundant"]:
        click.echo(f"redundant constraint rows ({len(info['redundant'])}): "
                   + ", ".join(info["redundant"]))
    for d in mech.drivers:
        click.echo(f"  {d.joint}: {d.description}")
    if info["free"]:
        click.echo(f"free coordinates (linkdyn simulate): {', '.join(info['free'])}; "
                   "assembles at t = 0")
    else:
        _over_run(mech, info["plan"])
    click.echo("model OK")


def _over_run(mech, p) -> None:
    """The kinematics over the model's run (``[analysis]`` or a driver's period): exit 3
    naming the time and driver values where it stops closing or passes a singular position."""
    from ..errors import ModelError
    from ..sampling import times
    try:
        t = times(mech, None, None, None)
    except ModelError as err:                  # no run defined: the start only
        click.echo(f"assembles at t = 0 (no run to check over: {err.message})")
        return
    sk.solve(mech, p, t)
    click.echo(f"assembles at t = 0 and over the run ({len(t)} samples, t = 0 .. "
               f"{t[-1]:.4g} s), clear of singular positions")


def summary(sol) -> dict:
    """``summary.json`` of a spatial run: mobility, redundancy, peak efforts and reactions."""
    info = sol.plan
    cols = sol.columns()
    valid = getattr(sol, "valid", np.ones(len(sol.t), bool))
    first = int(np.argmax(valid))       # the first sample solved (allow_singular: gaps)
    rank = int(sk.rank_of(info, sol.motion.J[first:first + 1])[0])
    peaks = {}
    for j in sol.model.joints:
        r = sol.reaction(j.name)[valid]
        peaks[j.name] = {"force": float(np.max(np.linalg.norm(r[:, :3], axis=1))),
                         "moment": float(np.max(np.linalg.norm(r[:, 3:], axis=1)))}
    efforts = {name: float(np.max(np.abs(cols[name][valid]))) for name in cols
               if name.startswith(("tau_", "force_"))}
    return {"model": sol.model.name, "space": "spatial", "samples": int(len(sol.t)),
            "duration": float(sol.t[-1] - sol.t[0]),
            "mobility_gruebler": int(info.topo.mobility), "mobility": int(info.n_q - rank),
            "cut_joints": [sol.model.joints[j].name for j in info.topo.cut],
            "redundancy": sol.redundancy.describe() if sol.redundancy else None,
            "peak_effort": efforts, "peak_reaction": peaks,
            "peak_kinetic_energy": float(np.max(sol.kinetic_energy()[valid])),
            "invalid_samples": int(np.sum(~valid)),
            "invalid_times_s": [float(x) for x in np.asarray(sol.t)[~valid]]}


def text(s: dict) -> str:
    lines = [f"{s['model']}: {s['samples']} samples over {s['duration']:.6g} s (spatial)",
             f"mobility {s['mobility']} (Grübler–Kutzbach {s['mobility_gruebler']})"]
    if s["redundancy"]:
        r = s["redundancy"]
        lines.append(f"redundant rows: {', '.join(r['redundant_rows']) or 'none'}; reactions "
                     f"undetermined by statics: {r['undetermined_dimension']} combination(s) of "
                     + ", ".join(r["undetermined_components"])
                     + " (reported: the minimum-norm ones)")
    for name, v in s["peak_effort"].items():
        lines.append(f"peak |{name}|: {v:.6g} {'N m' if name.startswith('tau') else 'N'}")
    for name, v in s["peak_reaction"].items():
        lines.append(f"peak reaction {name}: |F| {v['force']:.6g} N, |M| {v['moment']:.6g} N m")
    if s.get("invalid_samples"):
        times = ", ".join(f"{x:.6g}" for x in s["invalid_times_s"][:10])
        more = " ..." if len(s["invalid_times_s"]) > 10 else ""
        lines.append(f"WARNING: {s['invalid_samples']} samples that do not close or sit at a "
                     f"singular position are written as NaN rows (t = {times}{more} s)")
    return "\n".join(lines)


def analyze(mech, t, allow_singular: bool = False):
    """Solve ``mech`` at ``t``: the printed summary, the summary (``summary.json``'s content)
    and the solution (its ``columns()`` the results table; the report draws it).
    ``allow_singular``: samples at a singular position, or past the sample where the loops stop
    closing, become NaN rows, named in the summary (:func:`linkdyn.spatial.analyze`)."""
    sol = run(mech, t, allow_singular=allow_singular)
    s = summary(sol)
    return text(s), s, sol


def simulation(sol, integration: dict) -> tuple[dict, str]:
    """``summary.json`` and the printed summary of ``linkdyn simulate`` on a spatial model:
    :func:`summary` with the integration's figures (``integration``, as the planar run's)."""
    s = summary(sol)
    s["simulation"] = integration
    return s, text(s) + "\n"
