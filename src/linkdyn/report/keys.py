"""The key results a designer acts on, taken from the motion: each one a number with the sample
where it occurs (so the page can jump there), its time and the first driver's position.

Every peak keeps its sign (the largest and the smallest value of a signed quantity are both
listed); magnitudes (joint forces, the shaking force) are listed with the sample of their peak.
A value below ``NOISE`` of its unit family's scale is rounding noise and is reported as zero.
"""

from __future__ import annotations

import numpy as np

from .. import joints as jk
from ..design.checks import guide_normal, guide_transmission_angle, slider_rods
from ..model import GROUND
from ..units import REPORT

NOISE = 1e-12  # relative to the scale of the quantity's unit family

#: The key results' groups, in reading order; each keeps its colour (``g<n>``) on every page.
GROUPS = ("Driver efforts", "Joint loads", "Four-bar loops", "Slider dyads",
          "Shaking (on the frame)", "Energy", "Path")


def scales(sol) -> dict[str, float]:
    """Scale of each unit family over the run: ``'N'`` the largest joint force or driver force,
    ``'N m'`` the largest driver torque or force times the mechanism's size, ``'J'`` the largest
    kinetic energy. A series whose peak is below ``NOISE`` of its family's scale is rounding
    noise (a revolute cut's moment, a balanced pivot's force)."""
    m = sol.model

    def peak(x):
        x = np.abs(np.asarray(x, float))
        return float(np.nanmax(x)) if x.size and np.any(np.isfinite(x)) else 0.0

    f = peak(sol.reactions.force) if len(m.joints) else 0.0
    torques = [sol.dyn.tau[..., k] for k, d in enumerate(m.drivers)
               if jk.get(m.joint(d.joint).kind).angular]
    forces = [sol.dyn.tau[..., k] for k, d in enumerate(m.drivers)
              if not jk.get(m.joint(d.joint).kind).angular]
    f = max([f] + [peak(x) for x in forces])
    pts = [np.asarray(xy, float) for b in m.bodies for xy in b.points.values()]
    size = float(np.ptp(np.array(pts), axis=0).max()) if len(pts) > 1 else 1.0
    n_m = max([f * size] + [peak(x) for x in torques])
    e = peak(sol.columns["kinetic_energy"])
    if "potential_energy" in sol.columns:
        e = max(e, peak(sol.columns["potential_energy"]))
    return {"N": f, "N m": n_m, "J": e}


def is_noise(values, scale: float) -> bool:
    """Whether every finite value is below ``NOISE`` of ``scale`` (all zero counts)."""
    v = np.abs(np.asarray(values, float))
    v = v[np.isfinite(v)]
    return bool(v.size == 0 or np.max(v) <= NOISE * scale)


def _k(x, pick) -> int | None:
    x = np.asarray(x, float)
    if not np.any(np.isfinite(x)):
        return None
    return int(pick(x))


def key_item(group: str, label: str, x, k, unit: str, *, signed: bool = False,
             scale: float | None = None, note: str = "") -> dict:
    """One key result: the value of the series ``x`` at sample ``k`` (NaN without one), shown
    as 0 when within :data:`NOISE` of ``scale``; ``signed`` keeps its sign on the page."""
    v = float(x[k]) if k is not None else float("nan")
    if scale is not None and abs(v) <= NOISE * scale:
        v = 0.0
    return {"group": group, "label": label, "value": v, "unit": unit, "signed": signed,
            "k": k, "note": note}


def key_results(sol, summary: dict | None = None) -> list[dict]:
    """The key results, in reading order.

    Each item: ``group``, ``label``, ``value`` (float, SI but angles in deg), ``unit``,
    ``signed`` (show the sign), ``k`` (sample index where it occurs, or None), ``note``.
    """
    from .. import design

    m, summary = sol.model, summary or {}
    items: list[dict] = []
    sc = scales(sol)

    def add(*args, **kw):
        items.append(key_item(*args, **kw))

    # driver efforts: the largest and the smallest (signed), the RMS
    for k, d in enumerate(m.drivers):
        angular = jk.get(m.joint(d.joint).kind).angular
        tau, unit = sol.dyn.tau[..., k], ("N m" if angular else "N")
        word = "torque" if angular else "force"
        add("Driver efforts", f"max {word} {d.joint}", tau, _k(tau, np.nanargmax), unit,
            signed=True, scale=sc[unit])
        add("Driver efforts", f"min {word} {d.joint}", tau, _k(tau, np.nanargmin), unit,
            signed=True, scale=sc[unit])
        rms = float(np.sqrt(np.nanmean(np.asarray(tau, float) ** 2)))
        items.append({"group": "Driver efforts", "label": f"RMS {word} {d.joint}",
                      "value": rms, "unit": unit, "signed": False, "k": None, "note": ""})

    # joint loads: the peak force of every joint (bearing sizing); a guide's side load
    for k, j in enumerate(m.joints):
        f = np.linalg.norm(sol.reactions.force[..., k, :], axis=-1)
        add("Joint loads", f"peak |F| {j.name}", f, _k(f, np.nanargmax), "N", scale=sc["N"],
            note=f"{j.body_a} on {j.body_b}")
        kind = jk.get(j.kind)
        if not kind.angular and "axis" in kind.keys:  # a guide: its normal force
            n = guide_normal(sol, j)
            side = np.sum(sol.reactions.force[..., k, :] * n, axis=-1)
            kk = _k(np.abs(side), np.nanargmax)
            add("Joint loads", f"side load {j.name}", side, kk, "N", signed=True,
                scale=sc["N"], note="normal to the guide, + to its left")
            if "M" in kind.reaction:
                M = sol.reactions.moment[..., k]
                if not is_noise(M, sc["N m"]):
                    add("Joint loads", f"guide moment {j.name}", M, _k(np.abs(M), np.nanargmax),
                        "N m", signed=True, scale=sc["N m"])

    # a roller's contact stress on its cam (Hertz line contact): its peak over the run
    from ..design.overview import contact_stress
    for name, hz in contact_stress(sol).items():
        p = hz["p_max_Pa"]
        add("Joint loads", f"peak contact stress {name}", p, _k(p, np.nanargmax), "Pa",
            note="Hertz line contact of the roller on the cam")

    # motion quality of every four-bar loop: transmission angle, mechanical advantage
    for fb in design.four_bars(m):
        which = f"{fb.coupler}/{fb.output}"
        mu = REPORT.value(design.transmission_angle(sol, fb), "angle")
        add("Four-bar loops", f"min transmission angle {which}", mu, _k(mu, np.nanargmin), "deg")
        add("Four-bar loops", f"max transmission angle {which}", mu, _k(mu, np.nanargmax), "deg")
        ma = np.asarray(design.mechanical_advantage(sol, fb), float)
        for end, pick, link, bound in (("min", np.nanargmin, "input", 0.0),
                                       ("max", np.nanargmax, "output", np.inf)):
            label = f"{end} mechanical advantage {which}"
            at = design.stops(sol, fb, link)
            if not at:   # the link never stops: the sampled extreme is the linkage's
                add("Four-bar loops", label, ma, _k(ma, pick), "", note="|ω_in / ω_out|")
                continue
            # a link that stops: the advantage reaches its bound there, between samples
            where = stop_words(sol, at)
            items.append({"group": "Four-bar loops", "label": label, "value": bound, "unit": "",
                          "signed": False, "k": at[0]["k"],
                          "note": f"|ω_in / ω_out|, {'zero' if bound == 0 else 'infinite'} "
                                  f"where the {link} stops: {where}"})

    # the RRP dyad of each guide: transmission angle between the rod that drives the slider
    # and the guide's normal (90 deg: the rod pushes along the guide)
    for j, rod, pin, other in slider_rods(m):
        mu = REPORT.value(guide_transmission_angle(sol, j, rod, pin, other), "angle")
        which = f"{rod}/{j.body_b if rod != j.body_b else j.body_a}"
        add("Slider dyads", f"min transmission angle {which}", mu, _k(mu, np.nanargmin), "deg",
            note="rod against the guide's normal")

    # balancing: what the frame feels
    ws = design.shaking_wrench(sol)
    fs = np.linalg.norm(ws[..., 1:], axis=-1)
    add("Shaking (on the frame)", "peak shaking force", fs, _k(fs, np.nanargmax), "N",
        scale=sc["N"])
    ms = ws[..., 0]
    add("Shaking (on the frame)", "max shaking moment", ms, _k(ms, np.nanargmax), "N m",
        signed=True, scale=sc["N m"], note="about the global origin")
    add("Shaking (on the frame)", "min shaking moment", ms, _k(ms, np.nanargmin), "N m",
        signed=True, scale=sc["N m"], note="about the global origin")

    # energy
    ke = np.asarray(sol.columns["kinetic_energy"], float)
    add("Energy", "max kinetic energy", ke, _k(ke, np.nanargmax), "J", scale=sc["J"])
    add("Energy", "min kinetic energy", ke, _k(ke, np.nanargmin), "J", scale=sc["J"])
    for j, e in (summary.get("driver_energy") or {}).items():
        fw = e.get("flywheel") if isinstance(e, dict) else None
        if isinstance(fw, dict) and fw.get("inertia_kg_m2") is not None:
            items.append({"group": "Energy", "label": f"flywheel on {j}",
                          "value": float(fw["inertia_kg_m2"]), "unit": "kg m²", "signed": False,
                          "k": None, "note": f"for C_s = {fw.get('speed_fluctuation')}"})
    # friction: the energy it takes over the run (and per cycle), the efficiency over the run
    fr, out = summary.get("friction"), summary.get("output")
    if isinstance(fr, dict):
        per = fr.get("energy_lost_per_cycle_J")
        items.append({"group": "Friction and efficiency", "label": "energy lost in friction",
                      "value": float(fr["energy_lost_J"]), "unit": "J", "signed": False,
                      "k": None, "note": "over the run" + (f", {per:.4g} J per cycle"
                                                          if per is not None else "")})
        if fr.get("efficiency") is not None:
            items.append({"group": "Friction and efficiency", "label": "efficiency (friction)",
                          "value": 100 * float(fr["efficiency"]), "unit": "%",
                          "signed": False, "k": None,
                          "note": "1 - friction loss / drivers' net work"})
    if isinstance(out, dict) and out.get("efficiency") is not None:
        eta = np.asarray(sol.columns["efficiency"], float)
        items.append({"group": "Friction and efficiency",
                      "label": f"efficiency to {', '.join(out['loads'])}",
                      "value": 100 * float(out["efficiency"]), "unit": "%", "signed": False,
                      "k": None, "note": "output work / drivers' net work over the run"})
        add("Friction and efficiency", "least instantaneous efficiency", 100 * eta,
            _k(eta, np.nanargmin), "%", note="output power / drivers' power")
    ps = summary.get("path_straightness")
    if isinstance(ps, dict) and ps.get("max_deviation_m") is not None:
        items.append({"group": "Path", "label": f"straightness of {ps.get('point', 'path')}",
                      "value": REPORT.value(float(ps["max_deviation_m"]), "length"),
                      "unit": REPORT.unit("length")[0],
                      "signed": False, "k": None,
                      "note": "max deviation over "
                              + REPORT.show(float(ps.get("length_m") or 0), "length", 4)
                              + (" (whole run)" if ps.get("range") is None else "")})
    return items


# which way a key result is better, by its label's start: 'min' smaller magnitude, 'max' larger;
# the others (the largest transmission angle, kinetic energy) have no sense
_SENSES = (("max torque", "min"), ("min torque", "min"), ("RMS torque", "min"),
           ("max force", "min"), ("min force", "min"), ("RMS force", "min"),
           ("peak |F|", "min"), ("side load", "min"), ("guide moment", "min"),
           ("min transmission angle", "max"), ("min mechanical advantage", "max"),
           ("peak shaking force", "min"), ("max shaking moment", "min"),
           ("min shaking moment", "min"), ("flywheel on", "min"), ("straightness of", "min"))


def key_sense(label: str) -> str | None:
    """Which way the key result ``label`` is better: ``'min'`` (a smaller magnitude: efforts,
    joint and shaking forces, the flywheel, a path's deviation), ``'max'`` (larger: the
    smallest transmission angle and mechanical advantage, as the sweep's metrics), or None (no
    sense: the largest transmission angle, kinetic energy)."""
    return next((sense for start, sense in _SENSES if label.startswith(start)), None)


def stop_words(sol, at: list[dict]) -> str:
    """Where a link stops (:func:`linkdyn.design.stops`), in words: the first driver's
    coordinate at each stop in the page's units (``'J1 = 48.34, 228.3 deg'``), else the
    times."""
    d = sol.model.drivers[0] if sol.model.drivers else None
    if d is None or any(s["q"] is None for s in at):
        return "t = " + ", ".join(f"{s['t']:.4g}" for s in at) + " s"
    quantity = "angle" if jk.get(sol.model.joint(d.joint).kind).angular else "length"
    return (f"{d.joint} = " + ", ".join(f"{REPORT.value(s['q'], quantity):.4g}" for s in at)
            + f" {REPORT.unit(quantity)[0]}")


def driver_position(sol, k: int) -> tuple[str, float, str] | None:
    """``(joint, value, unit)`` of the first driver at sample ``k`` (deg for an angle, mm for
    a length)."""
    if not sol.model.drivers or k is None:
        return None
    d = sol.model.drivers[0]
    q = float(sol.columns[f"q_{d.joint}"][k])
    quantity = "angle" if jk.get(sol.model.joint(d.joint).kind).angular else "length"
    return d.joint, float(REPORT.value(q, quantity)), REPORT.unit(quantity)[0]
