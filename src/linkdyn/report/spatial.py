"""What the page shows of a spatial solution (:class:`linkdyn.spatial.SpatialSolution`),
JSON-ready, in the layout of :func:`.data.page_data` so the one page script draws it: the
frames, the series and panels of the plots (deg for angles, else SI), the key results, and
``geom`` with ``dim = 3`` for the 3-D view (``assets/view3d.js``): every named point's
global position (m) at each frame, the bodies' outlines, the joints with their axes' global
directions at each frame, the loads drawn as arrows, and the bounding sphere the camera fits.
"""

from __future__ import annotations

import math

import numpy as np

from ..model import GROUND
from ..units import REPORT
from .data import (BODY_COLORS, DEG, MAX_FRAMES, PALETTE, X_COLOR, Y_COLOR, M_COLOR, _num,
                   body_entries, body_shape, frame_indices, freebody_entries, point_tracks,
                   traced_points)
from .keys import NOISE, _k, is_noise, key_item

Z_COLOR = M_COLOR


def _kind(sol, joint: str):
    """The spatial joint kind of ``joint`` (its coordinates, effort, couple)."""
    return sol.plan.kinds[[j.name for j in sol.model.joints].index(joint)]


def scales(sol) -> dict[str, float]:
    """Scale of each unit family over the run, as :func:`.keys.scales` for planar models: ``'N'``
    the largest reaction or driver force, ``'N m'`` the largest reaction moment or driver
    torque or that force times the mechanism's size, ``'J'`` the largest energy."""
    m, cols = sol.model, sol.columns()

    def peak(x):
        x = np.abs(np.asarray(x, float))
        return float(np.nanmax(x)) if x.size and np.any(np.isfinite(x)) else 0.0

    r = np.stack([sol.reaction(j.name) for j in m.joints], 1) if m.joints else np.zeros((1, 1, 6))
    eff = {d.joint: sol.effort(d.joint) for d in m.drivers}
    f = max([peak(r[..., :3])] + [peak(v) for k, v in eff.items() if not _kind(sol, k).angular])
    pts = np.array([np.asarray(xy, float) for b in m.bodies for xy in b.points.values()])
    size = float(np.ptp(pts, axis=0).max()) if len(pts) > 1 else 1.0
    n_m = max([f * size, peak(r[..., 3:])] + [peak(v) for k, v in eff.items()
                                                 if _kind(sol, k).angular])
    e = max(peak(cols["kinetic_energy"]), peak(cols["potential_energy"]))
    return {"N": f, "N m": n_m, "J": e}


def key_results(sol, summary: dict | None = None) -> list[dict]:
    """The key results of a spatial run, in the items of :func:`.keys.key_results`: each
    driver's largest, smallest and RMS effort; each joint's peak reaction force and couple;
    with redundant constraints, how many reaction sets statics leaves open and which
    components they touch; the largest and smallest kinetic energy."""
    m, items, sc = sol.model, [], scales(sol)

    def add(*args, **kw):
        items.append(key_item(*args, **kw))

    for d in m.drivers:
        kind = _kind(sol, d.joint)
        tau, unit = sol.effort(d.joint), ("N m" if kind.angular else "N")
        word = "torque" if kind.angular else "force"
        add("Driver efforts", f"max {word} {d.joint}", tau, _k(tau, np.nanargmax), unit,
            signed=True, scale=sc[unit])
        add("Driver efforts", f"min {word} {d.joint}", tau, _k(tau, np.nanargmin), unit,
            signed=True, scale=sc[unit])
        items.append({"group": "Driver efforts", "label": f"RMS {word} {d.joint}",
                      "value": float(np.sqrt(np.nanmean(np.asarray(tau, float) ** 2))),
                      "unit": unit, "signed": False, "k": None, "note": ""})
    for j in m.joints:
        r = sol.reaction(j.name)
        f, c = np.linalg.norm(r[:, :3], axis=1), np.linalg.norm(r[:, 3:], axis=1)
        add("Joint loads", f"peak |F| {j.name}", f, _k(f, np.nanargmax), "N", scale=sc["N"],
            note=f"{j.body_a} on {j.body_b}")
        if not _kind(sol, j.name).couple_free:
            add("Joint loads", f"peak |M| {j.name}", c, _k(c, np.nanargmax), "N m",
                scale=sc["N m"], note=f"about {j.body_b}.{j.point_b}")
    if sol.redundancy is not None and sol.redundancy.basis.shape[2]:
        r = sol.redundancy   # redundant constraints: say which reactions statics leaves open
        items.append({"group": "Joint loads", "label": "reaction sets statics leaves open",
                      "value": int(r.basis.shape[2]), "unit": "", "signed": False, "k": None,
                      "note": "reactions shown: the minimum-norm ones; undetermined: "
                              + ", ".join(r.components)})
    ke = np.asarray(sol.kinetic_energy(), float)
    add("Energy", "max kinetic energy", ke, _k(ke, np.nanargmax), "J", scale=sc["J"])
    add("Energy", "min kinetic energy", ke, _k(ke, np.nanargmin), "J", scale=sc["J"])
    return items


def _outline(points: dict) -> tuple[str, list[str]]:
    """:func:`.data.body_shape` of a body's points (3,) in their own best-fit plane."""
    if len(points) < 3:
        return body_shape(points)
    P = np.array(list(points.values()), float)
    _, _, vt = np.linalg.svd(P - P.mean(0), full_matrices=False)
    return body_shape({k: (P[n] - P.mean(0)) @ vt[:2].T for n, k in enumerate(points)})


def page_data(sol, *, max_frames: int = MAX_FRAMES, summary: dict | None = None) -> dict:
    """Everything the page's script needs for a spatial solution, JSON-ready, with the keys of
    :func:`.data.page_data` (``geom["dim"] = 3``)."""
    m, cols = sol.model, sol.columns()
    keyres = key_results(sol, summary)
    idx = frame_indices(len(sol.t), max_frames, [it["k"] for it in keyres])
    d0 = m.drivers[0] if m.drivers else None
    for it in keyres:
        k = it.pop("k")
        it["frame"] = None if k is None else int(np.searchsorted(idx, k))
        it["t"] = None if k is None else float(sol.t[k])
        it["at"] = None
        if k is not None and d0 is not None and f"q_{d0.joint}" in cols:
            quantity = "angle" if _kind(sol, d0.joint).angular else "length"
            q = REPORT.value(float(cols[f"q_{d0.joint}"][k]), quantity)
            it["at"] = [d0.joint, q, REPORT.unit(quantity)[0]] if math.isfinite(q) else None
        if math.isinf(it["value"]):   # JSON has no inf: said by "infinite"
            it["infinite"] = True
        if not math.isfinite(it["value"]):
            it["value"] = None
    series: dict[str, list] = {"t": _num(np.asarray(sol.t)[idx])}

    def add(key, values, sig=None):
        series[key] = _num(np.asarray(values)[idx], sig)
        return key

    # ---- geometry (m, global): points, bodies, joints with their axes at each frame
    points, allp = point_tracks(sol, idx, "xyz")
    lo, hi = allp.min(0), allp.max(0)
    centre = 0.5 * (lo + hi)
    radius = float(max(np.max(np.linalg.norm(allp - centre, axis=1)), 1e-9))
    bodies = body_entries(m, _outline)

    def axis_series(key, body, e):
        """A body-fixed unit vector ``e`` (3,) turned into global at each frame."""
        v = np.broadcast_to(np.asarray(e, float), (len(sol.t), 3)) if body == GROUND else \
            np.einsum("tij,j->ti", sol.rotation(body), np.asarray(e, float))
        return [add(f"{key}:{c}", v[:, n], 4) for n, c in enumerate("xyz")]

    joints = list(m.joints)
    jcolor = {j.name: PALETTE[k % len(PALETTE)] for k, j in enumerate(joints)}
    roles = {j.name: ("cut" if k in set(int(c) for c in sol.plan.topo.cut) else "tree")
             + (", driven" if j.name in {d.joint for d in m.drivers} else "")
             for k, j in enumerate(joints)}
    jlist, used = [], set()
    for j in joints:
        a_id, b_id = f"{j.body_a}.{j.point_a}", f"{j.body_b}.{j.point_b}"
        used |= {a_id, b_id}
        entry = {"name": j.name, "kind": j.kind, "a": a_id, "b": b_id, "role": roles[j.name],
                 "ground": GROUND in (j.body_a, j.body_b), "color": jcolor[j.name],
                 "first": j.body_a, "second": j.body_b}
        if np.any(j.axis):
            entry["axis"] = axis_series(f"axis:{j.name}", j.body_a, j.axis)
        if j.kind == "universal":
            entry["axis2"] = axis_series(f"axis2:{j.name}", j.body_b, j.axis2)
        r = sol.reaction(j.name)
        for n, c in enumerate(("Fx", "Fy", "Fz", "Mx", "My", "Mz")):
            add(f"{c}:{j.name}", r[:, n])
        add(f"F:{j.name}", np.linalg.norm(r[:, :3], axis=1))
        add(f"M:{j.name}", np.linalg.norm(r[:, 3:], axis=1))
        jlist.append(entry)
    fmax = max([float(np.nanmax(series[f"F:{j.name}"] + [0.0])) for j in joints] + [0.0])

    # ---- plot panels (noise: below keys.NOISE of the unit family's scale, left out)
    plots, zero, fam = [], [], scales(sol)

    def panel(section, title, unit, ser, family=None):
        if family is not None:
            noise = [s for s in ser if is_noise(series[s["key"]], fam[family])]
            zero.extend(f"{title}: {s['label']}" for s in noise)
            for s in noise:
                series[s["key"]] = [0.0 if v is not None else None for v in series[s["key"]]]
            ser = [s for s in ser if s not in noise]
        if ser:
            plots.append({"section": section, "title": title, "unit": unit, "series": ser})

    # each joint coordinate: the joint's colour, a second one of the same joint another
    coords = [(j, suffix, ang, PALETTE[(joints.index(j) + 5 * c) % len(PALETTE)])
              for j in joints if j.kind != "spherical"
              for c, (suffix, ang) in enumerate(_kind(sol, j.name).coordinates_named)]
    motion = "Joint motion (relative joint coordinates q)"
    names = {True: ("Joint angles", "Joint angular rates", "Joint angular accelerations"),
             False: ("Joint travels", "Joint travel rates", "Joint travel accelerations")}
    units = {True: ("deg", "rad/s", "rad/s²"), False: ("m", "m/s", "m/s²")}
    for n, kind in enumerate(("q", "qd", "qdd")):
        for ang in (True, False):
            ser = [{"key": add(f"{kind}:{j.name}{sfx}", cols[f"{kind}_{j.name}{sfx}"]
                               * (DEG if kind == "q" and ang else 1.0)),
                    "label": j.name + sfx, "color": colour}
                   for j, sfx, a, colour in coords if a == ang]
            panel(motion, names[ang][n], units[ang][n], ser)
    panel("Link motion", "Angular speed of the bodies |ω|", "rad/s",
          [{"key": add(f"w:{b.name}", np.linalg.norm(sol.omega(b.name), axis=1)),
            "label": b.name, "color": BODY_COLORS[n % len(BODY_COLORS)]}
           for n, b in enumerate(m.moving_bodies)])
    traces = traced_points(m)
    for word, c, unit in (("Speed", "v", "m/s"), ("Acceleration", "a", "m/s²")):
        panel("Point motion", f"{word} of traced points", unit,
              [{"key": add(f"{c}:{pid}", np.linalg.norm(
                  [cols[f"{c}{x}_{pid}"] for x in "xyz"], axis=0)),
                "label": pid, "color": PALETTE[n % len(PALETTE)]} for n, pid in enumerate(traces)])

    drivers = []
    efforts = "Driver efforts and joint reactions"
    for unit, word in (("N m", "torque"), ("N", "force")):
        ser = []
        for d in m.drivers:
            if _kind(sol, d.joint).angular != (unit == "N m"):
                continue
            key = add(f"tau:{d.joint}", sol.effort(d.joint))
            ser.append({"key": key, "label": d.joint, "color": jcolor[d.joint]})
            drivers.append({"joint": d.joint, "key": key, "unit": unit, "word": word,
                            "q": f"q:{d.joint}", "qunit": "deg" if unit == "N m" else "m",
                            "color": jcolor[d.joint]})
        panel(efforts, f"Driver {word}", unit, ser)
    panel(efforts, "Reaction force magnitude |F|", "N",
          [{"key": f"F:{j.name}", "label": j.name, "color": jcolor[j.name]} for j in joints], "N")
    panel(efforts, "Reaction couple magnitude |M|", "N m",
          [{"key": f"M:{j.name}", "label": j.name, "color": jcolor[j.name]} for j in joints
           if not _kind(sol, j.name).couple_free], "N m")
    tint = (X_COLOR, Y_COLOR, Z_COLOR)
    for j in joints:
        panel(efforts, f"Reaction force at {j.name} ({j.body_a} on {j.body_b})", "N",
              [{"key": f"F{c}:{j.name}", "label": f"F{c}", "color": col}
               for c, col in zip("xyz", tint)], "N")
        if not _kind(sol, j.name).couple_free:
            panel(efforts, f"Reaction couple at {j.name} (about {j.body_b}.{j.point_b})", "N m",
                  [{"key": f"M{c}:{j.name}", "label": f"M{c}", "color": col}
                   for c, col in zip("xyz", tint)], "N m")
    panel("Energy", "Energy", "J",
          [{"key": add("ke", cols["kinetic_energy"]), "label": "kinetic", "color": PALETTE[0]},
           {"key": add("pe", cols["potential_energy"]), "label": "potential",
            "color": PALETTE[1]}], "J")

    # ---- loads drawn in the view: forces at their points, couples on their bodies
    drawn = []
    for n, ld in enumerate(m.loads):
        if ld.kind not in ("force", "torque") or ld.value is None \
                or getattr(ld.value, "state_variables", ()):
            continue   # springs and dampers are drawn as lines; state formulas not shown
        v = np.broadcast_to(np.asarray(ld.value(np.asarray(sol.t)), float), (len(sol.t), 3))
        at = f"{ld.body}.{ld.point or list(m.body(ld.body).points)[0]}"
        drawn.append({"kind": ld.kind, "at": at, "label": ld.name or f"{ld.kind} on {ld.body}",
                      "v": [add(f"load:{n}:{c}", v[:, i]) for i, c in enumerate("xyz")]})
    springs = [{"kind": ld.kind, "at": f"{ld.body}.{ld.point}", "to": f"{ld.body2}.{ld.point2}",
                "label": ld.name or ld.kind} for ld in m.loads if ld.kind in ("spring", "damper")]

    xaxes = [{"key": "t", "label": "t (s)"}]
    if d0 is not None and _kind(sol, d0.joint).angular and f"q:{d0.joint}" in series:
        q = np.asarray(series[f"q:{d0.joint}"], float)
        dq = np.diff(q)
        if len(q) > 1 and np.all(np.isfinite(q)) and (np.all(dq > 0) or np.all(dq < 0)):
            xaxes.append({"key": f"q:{d0.joint}", "label": f"{d0.joint} angle (deg)"})
    return {
        "name": m.name,
        "t": series["t"],
        "total_samples": int(len(sol.t)),
        "valid": [True] * len(idx),
        "series": series,
        "plots": plots,
        "xaxes": xaxes,
        "drivers": drivers,
        "key": keyres,
        "zero": zero,
        "geom": {"dim": 3, "points": points, "bodies": bodies, "joints": jlist,
                 "traces": traces, "ground": [p for p in points if p in used and
                                              p.startswith(f"{GROUND}.")],
                 "centre": [float(c) for c in centre], "radius": radius,
                 "home": _home_view(allp), "fmax": fmax, "loads": drawn, "springs": springs,
                 # each link's free body (data.freebody_entries), drawn by freebody.js
                 "freebody": freebody_entries(sol, idx, add, "xyz")},
    }


def _home_view(P: np.ndarray) -> dict:
    """The camera's starting view (deg), z up: azimuth -60 and elevation 25 (x to the right,
    y going back) for a mechanism that fills space; a (nearly) flat one is seen 30 deg off
    its plane's normal, so it reads as its drawing does."""
    _, s, vt = np.linalg.svd(P - P.mean(0), full_matrices=False)
    if len(s) < 3 or s[2] > 0.15 * s[0]:
        return {"az": -60.0, "el": 25.0}
    n = vt[2] * (1.0 if vt[2][2] >= 0 else -1.0)
    if n[2] > 0.99:          # lying in a horizontal plane: look from the front, 60 deg down
        return {"az": -90.0, "el": 60.0}
    return {"az": math.degrees(math.atan2(n[1], n[0])) - 30.0,
            "el": math.degrees(math.asin(float(np.clip(n[2], -1.0, 1.0))))}
