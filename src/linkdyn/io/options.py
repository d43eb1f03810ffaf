"""The sections that steer the solution rather than describe the mechanism: ``[assembly]``
(starting guesses), ``[topology]`` (the joints to cut) and ``[analysis]`` (CLI defaults)."""

from __future__ import annotations

from typing import Any

from .. import joints as jk
from ..model import GROUND
from .reader import MAX_SAMPLES, _Reader, _type_name


def _assembly(r: _Reader, section: Any, bodies, joints) -> tuple[dict, dict]:
    """Guesses: absolute angles ``phi`` (rad) of moving bodies, joint coordinates ``q`` (rad or m)."""
    section = r.table(section, "assembly", ("phi", "q"))
    moving = [b for b in bodies if b != GROUND]
    phi: dict[str, float] = {}
    for b, v in r.table(section.get("phi", {}), "assembly.phi", moving, noun="moving body",
                        what="moving bodies", note="The ground's angle is always 0").items():
        phi[b] = r.number(v, f"assembly.phi.{b}", r.angle_name) * r.angle
    q: dict[str, float] = {}
    for j, v in r.table(section.get("q", {}), "assembly.q", joints, noun="joint",
                        what="joints").items():
        scale, unit = ((r.angle, r.angle_name) if r.kind(joints[j].kind).angular
                       else (r.length, r.length_name))
        q[j] = r.number(v, f"assembly.q.{j}", unit) * scale
    return phi, q


def _initial(r: _Reader, section: Any, joints, drivers) -> tuple[dict, dict]:
    """``[initial]``: coordinates ``q`` (rad or m) and rates ``qd`` (rad/s or m/s) of the free
    degrees of freedom at t = 0, SI. Their number is checked against the mobility by
    :func:`linkdyn.forward.partition`."""
    section = r.table(section, "initial", ("q", "qd"))
    out: list[dict] = []
    for key, per in (("q", ""), ("qd", "/s")):
        values: dict[str, float] = {}
        for j, v in r.table(section.get(key, {}), f"initial.{key}", joints, noun="joint",
                            what="joints").items():
            if j in drivers:
                r.fail(f"initial.{key}.{j}", f"joint '{j}' is driven ({drivers[j][0]}): its "
                       "motion is prescribed, not free",
                       "Name only the joints of the free degrees of freedom")
            scale, unit = ((r.angle, r.angle_name) if r.kind(joints[j].kind).angular
                           else (r.length, r.length_name))
            values[j] = r.number(v, f"initial.{key}.{j}", unit + per) * scale
        out.append(values)
    return out[0], out[1]


def _topology(r: _Reader, section: Any, joints, drivers) -> tuple[str, ...] | None:
    section = r.table(section, "topology", ("cut",))
    if "cut" not in section:
        return None
    cut = section["cut"]
    if not isinstance(cut, list):
        r.fail("topology.cut", f"expected a list of joint names, got {_type_name(cut)}",
               'Write cut = ["J4"]')
    seen = set()
    for k, j in enumerate(cut):
        r.choice(j, f"topology.cut[{k}]", joints, "joint")
        if j in seen:
            r.fail(f"topology.cut[{k}]", f"joint '{j}' is listed twice", "List each cut joint once")
        seen.add(j)
        if j in drivers:
            r.fail(f"topology.cut[{k}]", f"joint '{j}' is driven ({drivers[j][0]}) and cannot be cut",
                   "Cut another joint of the same loop, or remove cut to choose automatically")
    return tuple(cut)


def _analysis(r: _Reader, section: Any, drivers, bodies, joints, loads=()) -> tuple:
    """Optional CLI defaults: ``(duration s, cycles, samples, path_point, path_range,
    output)``, each None when absent (``output`` empty); ``path_range`` is a range of the first
    driver's coordinate, SI; ``output`` the names of the loads (of ``loads``) the mechanism
    works against."""
    section = r.table(section, "analysis", ("duration", "cycles", "samples", "path_point",
                                            "path_range", "output"))
    if "duration" in section and "cycles" in section:
        r.fail("analysis", "give either duration or cycles, not both", "Remove one of them")
    duration = (r.number(section["duration"], "analysis.duration", "s", positive=True)
                if "duration" in section else None)
    cycles = (r.number(section["cycles"], "analysis.cycles", positive=True)
              if "cycles" in section else None)
    if cycles is not None and not any(d.period for _, d in drivers.values()):
        r.fail("analysis.cycles", "cycles needs a revolute driver turning at constant speed",
               "Give duration = ... (s) instead")
    samples = None
    if "samples" in section:
        s = section["samples"]
        if (isinstance(s, bool) or not isinstance(s, (int, float))
                or not (2 <= s <= MAX_SAMPLES) or not float(s).is_integer()):
            r.fail("analysis.samples", f"expected a whole number from 2 to {MAX_SAMPLES:,}, "
                   f"got {_type_name(s)}", "Write e.g. samples = 361")
        samples = int(s)
    path_point = None
    if "path_point" in section:
        path_point = r.string(section["path_point"], "analysis.path_point")
        body, _, point = path_point.partition(".")
        if body not in bodies or point not in bodies[body].points:
            r.fail("analysis.path_point", f"'{path_point}' is not a named point of a body",
                   "Write it as BODY.POINT, e.g. path_point = \"coupler.P\"")
    path_range = None
    if "path_range" in section:
        first = next(iter(drivers.values()), None)
        # without drivers the mobility check reports the real problem
        revolute = first is None or r.kind(joints[first[1].joint].kind).angular
        lo, hi = r.vector(section["path_range"], "analysis.path_range",
                          "rad or deg" if revolute else "length unit", n=2)
        scale = r.angle if revolute else r.length
        path_range = (float(lo * scale), float(hi * scale))
    return duration, cycles, samples, path_point, path_range, _output(r, section, loads)


def _output(r: _Reader, section: dict, loads) -> tuple[str, ...]:
    """``[analysis] output``: a list of names of loads that are not friction (whose power
    is the mechanism's output), each once."""
    if "output" not in section:
        return ()
    names = {ld.name: ld.kind for ld in loads if ld.name}
    value = section["output"]
    if not isinstance(value, list) or not value:
        r.fail("analysis.output", f"expected a list of load names, got {_type_name(value)}",
               "Write e.g. output = [\"press\"], naming [[loads]] by their name")
    out = []
    for k, x in enumerate(value):
        name = r.string(x, f"analysis.output[{k}]")
        if name not in names:
            r.fail(f"analysis.output[{k}]", f"'{name}' is not the name of a load",
                   "Name a [[loads]] entry (give it name = \"...\")"
                   + (f"; loads named: {', '.join(sorted(names))}" if names else ""))
        if names[name] == "friction":
            r.fail(f"analysis.output[{k}]", f"'{name}' is a friction load, which is a loss",
                   "Name the load the mechanism works against (a force, torque or damper)")
        if name in out:
            r.fail(f"analysis.output[{k}]", f"load '{name}' is listed twice",
                   "List each output load once")
        out.append(name)
    return tuple(out)
