"""What the page shows, JSON-ready: the samples thinned to at most ``max_frames`` frames, the
animation's geometry, and the series and panels of the plots (deg for angles, else SI).

The series keep every digit of the solution (results.csv's numbers at the page's frames); the
page carries them packed (:func:`carried`): float64 for every number it prints, float32 for what
it only draws (the point tracks, the instant centres).
"""

from __future__ import annotations

import base64
import math

import numpy as np

from .. import joints as jk
from ..model import GROUND
from ..units import REPORT
from .keys import driver_position, is_noise, key_results, scales

MAX_FRAMES = 2000
DEG = 1.0 / REPORT.unit("angle")[1]   # rad -> the page's angle unit (deg)

# one colour per joint (or per driver / cut joint), the same in every panel
PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
           "#17becf", "#bcbd22", "#7f7f7f")
BODY_COLORS = ("#3b75af", "#e1812c", "#3a923a", "#c03d3e", "#9372b2", "#845b53", "#d684bd",
               "#2ab0c5", "#a9aa35", "#7f7f7f")
X_COLOR, Y_COLOR, M_COLOR = "#1f77b4", "#ff7f0e", "#2ca02c"


def frame_indices(n: int, max_frames: int = MAX_FRAMES, keep=()) -> np.ndarray:
    """At most ``max_frames`` evenly spread sample indices of ``n``, both ends included, plus
    the samples ``keep`` (the key results' peaks, so a jump lands on the peak itself)."""
    if n <= max_frames:
        return np.arange(n)
    keep = np.unique(np.array([k for k in keep if k is not None], dtype=int))
    base = np.round(np.linspace(0, n - 1, max(2, max_frames - len(keep)))).astype(int)
    idx = np.unique(np.concatenate([base, keep]))
    missing = max_frames - len(idx)
    if missing > 0:  # a kept sample was already there: split the widest gaps
        gaps = np.diff(idx)
        wide = np.sort(np.argsort(-gaps, kind="stable")[:missing])
        idx = np.unique(np.concatenate([idx, idx[wide] + gaps[wide] // 2]))
    return idx


def _num(a, sig: int | None = None) -> list:
    """A JSON-ready list, every digit kept (``sig``: rounded to that many significant digits);
    NaN and inf become null."""
    a = np.asarray(a, float).ravel()
    ok = np.isfinite(a).tolist()
    if sig is None:
        return [v if f else None for v, f in zip(a.tolist(), ok)]
    txt = np.char.mod(f"%.{sig}g", np.where(np.isfinite(a), a, 0.0))
    return [float(s) if f else None for s, f in zip(txt.tolist(), ok)]


def packed(series: dict, drawn: bool = False) -> dict:
    """``series`` as the page carries it: each list of floats (null for a gap) as the base64
    text of its little-endian float64 bytes (NaN for a gap), every digit kept in about 11
    characters a value (a decimal that round-trips takes 18 to 24); the page's script
    unpacks it (``LD.unpack``, assets/common.js).

    ``drawn``: numbers the page only draws and never prints (the point tracks, the instant
    centres), as float32 instead, behind the prefix ``f4:``: about 7 significant digits (a
    ten-millionth of a metre on a mechanism a metre across, far below a pixel) in about 5.3
    characters a value."""
    dtype, head = ("<f4", "f4:") if drawn else ("<f8", "")

    def one(v):
        a = np.array([np.nan if x is None else x for x in v], dtype=dtype)
        return head + base64.b64encode(a.tobytes()).decode("ascii")
    return {k: one(v) for k, v in series.items()}


DRAWN = ("ic:",)   # series the page only draws (instant centres): carried as float32


def carried(data: dict) -> dict:
    """``data`` of :func:`page_data` (or the spatial page's) as the page carries it: the
    series and times packed (:func:`packed`), every digit kept for what the page prints
    (readouts, tables, exports); what it only draws as float32 (``drawn``): the series named
    in ``DRAWN``, each moving point's track and the free-body view's mass-centre tracks (a
    ground point, ``static``, stays as it is)."""
    ser = data["series"]
    series = {**packed({k: v for k, v in ser.items() if not k.startswith(DRAWN)}),
              **packed({k: v for k, v in ser.items() if k.startswith(DRAWN)}, drawn=True)}

    def pts(p):
        if p.get("static"):
            return p
        return {**p, **packed({c: p[c] for c in "xyz" if c in p}, drawn=True)}
    geom = {**data["geom"], "points": {k: pts(p) for k, p in data["geom"]["points"].items()}}
    if geom.get("freebody"):
        geom["freebody"] = [{**b, "com": b["com"] and packed(b["com"], drawn=True)}
                            for b in geom["freebody"]]
    return {**data, "series": series, "t": packed({"t": data["t"]})["t"], "geom": geom}


def joint_roles(sol) -> dict[str, str]:
    """``'cut'``, ``'tree'`` plus ``', driven'`` for every joint."""
    m = sol.model
    topo = sol.plan.topo if getattr(sol, "space", "planar") == "spatial" else sol.topology
    cut = set(int(c) for c in topo.cut)
    driven = {d.joint for d in m.drivers}
    return {j.name: ("cut" if k in cut else "tree") + (", driven" if j.name in driven else "")
            for k, j in enumerate(m.joints)}


def multiplier_labels(sol) -> list[tuple[str, str, str]]:
    """``(joint, component label, unit)`` for each column of ``dyn.lam``.

    Each cut joint's kind names its rows (``JointKind.multipliers``): a cut revolute joint
    carries the force ``[lam_x, lam_y]`` (global, by the joint's first body on its second); a
    cut prismatic joint the moment and the force normal to its axis; a slot the normal force.
    """
    m = sol.model
    out = []
    for c in sol.topology.cut:
        j = m.joints[int(c)]
        out += [(j.name, label, unit) for label, unit in jk.get(j.kind).multipliers]
    return out


def _known_column(name: str) -> bool:
    prefixes = ("q_", "qd_", "qdd_", "phi_", "omega_", "alpha_", "tau_", "force_", "Fx_", "Fy_",
                "M_", "x_", "y_", "vx_", "vy_", "ax_", "ay_", "power_", "value_", "friction_")
    return name == "t" or name.startswith(prefixes) or name in (
        "kinetic_energy", "potential_energy", "output_power", "efficiency")


def body_shape(points: dict) -> tuple[str, list[str]]:
    """How to draw a body from its named points: ``dot``, ``bar`` (two points), ``line``
    (collinear points, in order along the line) or ``polygon`` (convex hull, CCW)."""
    names = list(points)
    if len(names) == 1:
        return "dot", names
    if len(names) == 2:
        return "bar", names
    P = np.array([points[k] for k in names], float)
    c = P - P.mean(0)
    u, s, vt = np.linalg.svd(c, full_matrices=False)
    if s[1] <= 1e-6 * max(s[0], 1e-300):
        proj = c @ vt[0]
        return "line", [names[k] for k in np.argsort(proj, kind="stable")]
    # Andrew's monotone chain
    order = sorted(range(len(names)), key=lambda k: (P[k, 0], P[k, 1]))

    def turn(o, a, b):
        return (P[a, 0] - P[o, 0]) * (P[b, 1] - P[o, 1]) - (P[a, 1] - P[o, 1]) * (P[b, 0] - P[o, 0])

    lower, upper = [], []
    for k in order:
        while len(lower) >= 2 and turn(lower[-2], lower[-1], k) <= 0:
            lower.pop()
        lower.append(k)
    for k in reversed(order):
        while len(upper) >= 2 and turn(upper[-2], upper[-1], k) <= 0:
            upper.pop()
        upper.append(k)
    hull = lower[:-1] + upper[:-1]
    return "polygon", [names[k] for k in hull]


def _ground_outline(ground, used: set) -> list[str]:
    """Ground points that joints use, in outline order (drawn as the dashed fixed link)."""
    pts = {p: xy for p, xy in ground.points.items() if f"{GROUND}.{p}" in used}
    if len(pts) < 3:
        return [f"{GROUND}.{p}" for p in pts]
    shape, outline = body_shape(pts)
    return [f"{GROUND}.{p}" for p in (outline if shape == "polygon" else pts)]


def traced_points(model) -> list[str]:
    """The points whose paths the report traces (and ``linkdyn export --to svg|dxf`` draws),
    as ``BODY.POINT`` in body and point order: the points of moving bodies that no joint uses
    (coupler points), and the second points of joints between two bodies neither of which is
    pivoted on the ground (e.g. the tool point of a five-bar)."""
    joints = model.joints
    used = {f"{j.body_a}.{j.point_a}" for j in joints} | {f"{j.body_b}.{j.point_b}" for j in joints}
    grounded = {j.body_a for j in joints if j.body_b == GROUND} | {
        j.body_b for j in joints if j.body_a == GROUND}
    floating = {f"{j.body_b}.{j.point_b}" for j in joints
                if GROUND not in (j.body_a, j.body_b)
                and not ({j.body_a, j.body_b} & grounded)}
    return [f"{b.name}.{p}" for b in model.moving_bodies for p in b.points
            if f"{b.name}.{p}" not in used or f"{b.name}.{p}" in floating]


def point_tracks(sol, idx, axes: str) -> tuple[dict, np.ndarray]:
    """Every named point at the page's frames ``idx``, m, global (``axes``: ``"xy"`` or
    ``"xyz"``): a ground point once (``static``), a moving body's point per frame (every digit;
    the page carries them as float32, :func:`carried`); and every
    finite position of the run (k, len(axes)), for the view's bounds."""
    m = sol.model
    points, seen = {}, []
    for name, p in m.body(GROUND).points.items():
        p = np.asarray(p, float)
        points[f"{GROUND}.{name}"] = {**{c: float(p[n]) for n, c in enumerate(axes)},
                                      "static": True}
        seen.append(p[None, :])
    for b in m.moving_bodies:
        for name in b.points:
            p = np.asarray(sol.point(b.name, name))
            seen.append(p[np.all(np.isfinite(p), axis=1)])
            points[f"{b.name}.{name}"] = {c: _num(p[idx, n]) for n, c in enumerate(axes)}
    return points, np.concatenate(seen)


def body_entries(model, shape) -> list[dict]:
    """Each moving body as the page draws it: its colour, its outline by ``shape`` (a body's
    points -> (shape name, outline point names)) and its points."""
    bodies = []
    for k, b in enumerate(model.moving_bodies):
        kind, outline = shape(b.points)
        bodies.append({"name": b.name, "color": BODY_COLORS[k % len(BODY_COLORS)],
                       "shape": kind, "outline": [f"{b.name}.{p}" for p in outline],
                       "points": [f"{b.name}.{p}" for p in b.points]})
    return bodies


def freebody_entries(sol, idx, add, axes: str) -> list[dict]:
    """Each moving body's free-body diagram (:func:`linkdyn.design.free_body`) as the page's
    free-body view reads it, planar (``axes = "xy"``) or spatial (``"xyz"``): a joint's force
    is its sign times the joint's reaction series (``Fx:J``, ...); a weight constant over the
    run its value; any other force (a load, a sliding driver's effort, a sliding joint's
    friction) series of its own, added by ``add(key, values)``; ``com`` the mass centre's
    track. The page draws them head to tail; their sum, the polygon's closing side, is
    ``m a_G``."""
    from ..design import free_body
    out = []
    for n, b in enumerate(sol.model.moving_bodies):
        forces, _ = free_body(sol, b.name)
        items, com = [], None
        for f_n, f in enumerate(forces):
            it = {"label": f.label, "kind": f.kind, "at": f.where}
            fk = np.asarray(f.force, float)[idx]
            if f.kind == "joint":
                it.update({c: f"F{c}:{f.label}" for c in axes})
                it["sign"] = f.sign
            elif f.kind == "weight" and np.all(fk == fk[:1]):
                it["value"] = [float(v) for v in fk[0]]
            else:
                it.update({c: add(f"fb:{b.name}:{f_n}:{c}", fk[:, n_])
                           for n_, c in enumerate(axes)})
                it["sign"] = 1.0
            if f.where == "G":
                com = {c: _num(np.asarray(f.at, float)[idx, n_]) for n_, c in enumerate(axes)}
            items.append(it)
        out.append({"body": b.name, "color": BODY_COLORS[n % len(BODY_COLORS)],
                    "forces": items, "com": com})
    return out


def page_data(sol, *, max_frames: int = MAX_FRAMES, summary: dict | None = None) -> dict:
    """Everything the page's script needs, JSON-ready (plot units: deg for angles, else SI).

    ``key`` lists the key results (:func:`.keys.key_results`), each with the page ``frame``
    where it occurs; ``zero`` names the series left out of the plots as rounding noise (below
    ``keys.NOISE`` of their unit family's scale).
    """
    m = sol.model
    keyres = key_results(sol, summary)
    idx = frame_indices(len(sol.t), max_frames, [it["k"] for it in keyres])
    for it in keyres:
        k = it.pop("k")
        it["frame"] = None if k is None else int(np.searchsorted(idx, k))
        it["t"] = None if k is None else float(sol.t[k])
        pos = driver_position(sol, k)
        it["at"] = None if pos is None or not math.isfinite(pos[1]) else list(pos)
        if math.isinf(it["value"]):   # JSON has no inf: said by "infinite"
            it["infinite"] = True
        if not math.isfinite(it["value"]):
            it["value"] = None
    t = np.asarray(sol.t)[idx]
    cols = sol.columns
    joints = list(m.joints)
    jcolor = {j.name: PALETTE[k % len(PALETTE)] for k, j in enumerate(joints)}
    roles = joint_roles(sol)
    series: dict[str, list] = {"t": _num(t)}

    def add(key, values):
        series[key] = _num(np.asarray(values)[idx])
        return key

    # ---- geometry of the animation (m, global frame)
    ground = m.body(GROUND)
    points, allxy = point_tracks(sol, idx, "xy")
    bounds = [allxy]
    lo, hi = allxy.min(0), allxy.max(0)
    size = float(max(np.max(hi - lo), 1e-9))
    bodies = body_entries(m, body_shape)

    used = set()
    jlist = []
    for k, j in enumerate(joints):
        a_id, b_id = f"{j.body_a}.{j.point_a}", f"{j.body_b}.{j.point_b}"
        used |= {a_id, b_id}
        entry = {"name": j.name, "kind": j.kind, "a": a_id, "b": b_id, "role": roles[j.name],
                 "ground": GROUND in (j.body_a, j.body_b), "color": jcolor[j.name],
                 "first": j.body_a, "second": j.body_b}
        if "axis" in jk.get(j.kind).keys:
            phi_a = 0.0 if j.body_a == GROUND else sol.phi(j.body_a)
            ang = phi_a + math.atan2(float(j.axis[1]), float(j.axis[0])) + np.zeros(len(sol.t))
            entry["angle"] = _num(ang[idx], 6)
            if j.body_a == GROUND:  # a fixed guide: the stretch the slider travels
                o = np.asarray(ground.points[j.point_a], float)
                e = np.array([math.cos(ang[0]), math.sin(ang[0])])
                s = (np.asarray(sol.point(j.body_b, j.point_b)) - o) @ e
                s = s[np.isfinite(s)]
                pad = 0.08 * size
                s0, s1 = (float(s.min()) - pad, float(s.max()) + pad) if s.size else (-pad, pad)
                entry["guide"] = [float(v) for v in (*(o + s0 * e), *(o + s1 * e))]
                bounds.append(np.array([o + s0 * e, o + s1 * e]))
        jlist.append(entry)
        add(f"Fx:{j.name}", sol.reactions.force[..., k, 0])
        add(f"Fy:{j.name}", sol.reactions.force[..., k, 1])
        add(f"F:{j.name}", np.linalg.norm(sol.reactions.force[..., k, :], axis=-1))
    traces = traced_points(m)
    allxy = np.concatenate(bounds)
    lo, hi = allxy.min(0), allxy.max(0)
    size = float(max(np.max(hi - lo), 1e-9))
    fmax = float(np.nanmax(np.linalg.norm(sol.reactions.force, axis=-1))) if joints else 0.0

    # ---- plot series and panels
    plots, zero = [], []
    fam = scales(sol)
    cut = {m.joints[int(c)].name for c in sol.topology.cut}

    def panel(section, title, unit, ser, family=None):
        """A panel of the series that are not rounding noise (noise: listed in ``zero``)."""
        if family is not None:
            noise = [s for s in ser if is_noise(series[s["key"]], fam[family])]
            zero.extend(f"{title}: {s['label']}" for s in noise)
            for s in noise:  # shown as exact zeros in readouts
                series[s["key"]] = [0.0 if v is not None else None for v in series[s["key"]]]
            ser = [s for s in ser if s not in noise]
        if ser:
            plots.append({"section": section, "title": title, "unit": unit, "series": ser})

    deg = {j.name: DEG if jk.get(j.kind).angular else 1.0 for j in joints}
    motion = "Joint motion (relative joint coordinates q)"
    names = {True: ("Joint angles", "Joint angular rates", "Joint angular accelerations"),
             False: ("Slider displacements", "Slider rates", "Slider accelerations")}
    units = {True: ("deg", "rad/s", "rad/s²"), False: ("m", "m/s", "m/s²")}
    for n, kind in enumerate(("q", "qd", "qdd")):
        for rev in (True, False):
            js = [j for j in joints if jk.get(j.kind).angular == rev]
            if js:
                scale = (lambda j: deg[j.name]) if kind == "q" else (lambda j: 1.0)
                panel(motion, names[rev][n], units[rev][n],
                      [{"key": add(f"{kind}:{j.name}", cols[f"{kind}_{j.name}"] * scale(j)),
                        "label": j.name, "color": jcolor[j.name]} for j in js])

    # output versus input: each moving body's absolute angle against the one driver's
    # coordinate (bodies that only translate, or turn with the driver, left out)
    if len(m.drivers) == 1:
        d = m.drivers[0]
        q = np.asarray(cols[f"q_{d.joint}"], float)
        ang = jk.get(m.joint(d.joint).kind).angular
        qs = q * (DEG if ang else 1.0)
        ser = []
        for n, b in enumerate(m.moving_bodies):
            phi = np.asarray(sol.phi(b.name), float)
            ok = np.isfinite(phi)
            if ok.sum() < 2:
                continue
            phi = np.where(ok, phi, 0.0)
            phi[ok] = np.unwrap(phi[ok])
            span = np.ptp(phi[ok])
            if span <= 1e-9 or (ang and np.ptp((phi - q)[ok]) <= 1e-9 * max(span, 1.0)):
                continue
            ser.append({"key": add(f"phi:{b.name}", np.where(ok, phi * DEG, np.nan)),
                        "label": b.name, "color": BODY_COLORS[n % len(BODY_COLORS)]})
        if ser:
            key = f"q:{d.joint}"
            if key not in series:
                add(key, qs)
            plots.append({"section": "Link motion", "title": "Output versus input: link angles",
                          "unit": "deg", "series": ser,
                          "x": {"key": key, "label": f"{d.joint} {'angle (deg)' if ang else '(m)'}",
                                "short": d.joint, "angle": ang}})

    # the speed and acceleration of the traced points (a coupler point's speed along its path)
    pm = [pid for pid in traces if f"vx_{pid}" in cols]
    if pm:
        for word, c, unit in (("Speed", "v", "m/s"), ("Acceleration", "a", "m/s²")):
            panel("Point motion", f"{word} of traced points", unit,
                  [{"key": add(f"{c}:{pid}", np.hypot(cols[f"{c}x_{pid}"], cols[f"{c}y_{pid}"])),
                    "label": pid, "color": PALETTE[n % len(PALETTE)]}
                   for n, pid in enumerate(pm)])

    drivers = []
    efforts = "Driver efforts and joint reactions"
    for unit, word in (("N m", "torque"), ("N", "force")):
        ser = []
        for k, d in enumerate(m.drivers):
            if jk.get(m.joint(d.joint).kind).angular != (unit == "N m"):
                continue
            key = add(f"tau:{d.joint}", sol.dyn.tau[..., k])
            ser.append({"key": key, "label": d.joint, "color": jcolor[d.joint]})
            drivers.append({"joint": d.joint, "key": key, "unit": unit, "word": word,
                            "q": f"q:{d.joint}", "qunit": "deg" if unit == "N m" else "m",
                            "color": jcolor[d.joint]})
        panel(efforts, f"Driver {word}", unit, ser)
    panel(efforts, "Reaction force magnitude |F|", "N",
          [{"key": f"F:{j.name}", "label": j.name, "color": jcolor[j.name]} for j in joints],
          "N")
    for k, j in enumerate(joints):
        # a cut joint's reaction is its multipliers λ: one panel shows both, said in words
        panel(efforts, f"Reaction at {j.name} ({j.body_a} on {j.body_b})"
              + (", where the loop is cut" if j.name in cut else ""), "N",
              [{"key": f"Fx:{j.name}", "label": "Fx", "color": X_COLOR},
               {"key": f"Fy:{j.name}", "label": "Fy", "color": Y_COLOR}], "N")
    # the reactions in the second body's frame (Solution.reaction_local): along and across
    # the link each acts on, and each pin's polar load diagram (the force's tip over the run)
    local = "Joint forces in the link's frame"
    for j in joints:
        f = sol.reaction_local(j.name)
        add(f"Fa:{j.name}", f[..., 0])
        add(f"Fc:{j.name}", f[..., 1])
    for word, c in (("along", "a"), ("across", "c")):
        panel(local, f"Reaction {word} the body it acts on (its x axis)", "N",
              [{"key": f"F{c}:{j.name}", "label": f"{j.name} on {j.body_b}",
                "color": jcolor[j.name]} for j in joints], "N")
    for j in joints:
        if j.kind != "revolute" or is_noise(series[f"F:{j.name}"], fam["N"]):
            continue
        plots.append({"section": local, "kind": "polar", "unit": "N",
                      "title": f"Polar load at {j.name} in {j.body_b}'s frame",
                      "x": {"key": f"Fa:{j.name}", "label": "along (N)", "short": "along"},
                      "series": [{"key": f"Fc:{j.name}", "label": "across",
                                  "color": jcolor[j.name]}]})
    prism = [(k, j) for k, j in enumerate(joints) if "M" in jk.get(j.kind).reaction]
    if prism:
        panel(efforts, "Guide reaction moments", "N m",
              [{"key": add(f"M:{j.name}", sol.reactions.moment[..., k]), "label": j.name,
                "color": jcolor[j.name]} for k, j in prism], "N m")

    try:
        from .. import design
        fbs = design.four_bars(m)
        for n, fb in enumerate(fbs):
            key = add(f"mu:{n}", REPORT.value(design.transmission_angle(sol, fb), "angle"))
            panel("Design", f"Transmission angle ({fb.coupler} / {fb.output})", "deg",
                  [{"key": key, "label": "μ", "color": PALETTE[n % len(PALETTE)]}])
        from ..design.checks import guide_transmission_angle, slider_rods
        for n, (g, rod, pin, other) in enumerate(slider_rods(m)):
            key = add(f"mu_s:{n}", REPORT.value(guide_transmission_angle(sol, g, rod, pin, other),
                                                "angle"))
            panel("Design", f"Transmission angle ({rod} / {g.body_b})", "deg",
                  [{"key": key, "label": "μ", "color": PALETTE[(n + 3) % len(PALETTE)]}])
        ws = design.shaking_wrench(sol)
        panel("Design", "Shaking force on the frame", "N",
              [{"key": add("shake:Fx", ws[..., 1]), "label": "Fx", "color": X_COLOR},
               {"key": add("shake:Fy", ws[..., 2]), "label": "Fy", "color": Y_COLOR}], "N")
        panel("Design", "Shaking moment (about the origin)", "N m",
              [{"key": add("shake:M", ws[..., 0]), "label": "M", "color": M_COLOR}], "N m")
    except Exception:  # pragma: no cover - a design helper must never break the report
        pass
    # a roller's Hertz line contact on its cam: the peak pressure over the cycle
    from ..design.overview import contact_stress
    for name, hz in contact_stress(sol).items():
        panel("Design", f"Contact stress at {name} (Hertz peak pressure, roller on cam)",
              REPORT.unit("pressure")[0],
              [{"key": add(f"hertz:{name}", REPORT.value(hz["p_max_Pa"], "pressure")),
                "label": "p_max",
                "color": jcolor[name]}])
    energy = [{"key": add("ke", cols["kinetic_energy"]), "label": "kinetic",
               "color": PALETTE[0]}]
    if "potential_energy" in cols:
        energy.append({"key": add("pe", cols["potential_energy"]), "label": "potential",
                       "color": PALETTE[1]})
    panel("Design", "Energy", "J", energy, "J")
    # each load's value against time, and the power of every driver and load
    from ..loads import VALUE_COLUMNS, VALUE_UNITS, labels
    for n, (ld, label) in enumerate(zip(m.loads, labels(m))):
        if ld.kind not in VALUE_COLUMNS:   # friction: its friction_<joint> columns, below
            continue
        names = VALUE_COLUMNS[ld.kind]
        if not all(f"{c}_{label}" in cols for c in names):
            continue
        tint = (X_COLOR, Y_COLOR) if len(names) > 1 else (PALETTE[n % len(PALETTE)],)
        panel("Loads and power", f"{label} ({ld.kind.replace('_', ' ')})", VALUE_UNITS[ld.kind],
              [{"key": add(f"col:{c}_{label}", cols[f"{c}_{label}"]),
                "label": {"value_x": "x", "value_y": "y"}.get(c, ld.kind.replace("_", " ")),
                "color": colour} for c, colour in zip(names, tint)])
    powers = [c for c in cols if c.startswith("power_")]
    if powers:
        panel("Loads and power", "Power of the drivers and loads", "W",
              [{"key": add(f"col:{c}", cols[c]), "label": c[len("power_"):],
                "color": PALETTE[n % len(PALETTE)]} for n, c in enumerate(powers)])
    # friction: each joint's couple or force and its power; the instantaneous efficiency
    fr = getattr(sol, "friction", None)
    if fr is not None:
        for angular, title, unit in ((True, "Friction couples", "N m"),
                                     (False, "Friction forces", "N")):
            panel("Friction and efficiency", title, unit,
                  [{"key": add(f"col:friction_{j}", cols[f"friction_{j}"]), "label": j,
                    "color": jcolor[j]} for j, a in zip(fr.joints, fr.angular) if a == angular])
        panel("Friction and efficiency", "Friction power (minus the power it dissipates)", "W",
              [{"key": add(f"col:friction_power_{j}", cols[f"friction_power_{j}"]), "label": j,
                "color": jcolor[j]} for j in fr.joints])
    if "efficiency" in cols:
        panel("Friction and efficiency", "Instantaneous efficiency (output power / drivers' power)",
              "%", [{"key": add("col:efficiency", 100 * np.asarray(cols["efficiency"], float)),
                     "label": "η", "color": PALETTE[0]}])
        panel("Friction and efficiency", "Power into the output loads", "W",
              [{"key": add("col:output_power", cols["output_power"]), "label": "output",
                "color": PALETTE[1]}])
    for n, name in enumerate(c for c in cols if not _known_column(c)):
        vals = np.asarray(cols[name], float)
        if vals.shape != np.shape(sol.t):
            continue
        panel("Other result columns", name, "",
              [{"key": add(f"col:{name}", vals), "label": name,
                "color": PALETTE[n % len(PALETTE)]}])

    # external loads drawn on the animation: forces at their points, torques on their bodies
    # (a motor's joint_torque on its joint's second body), springs and dampers between their
    # two points; their values as the loads stage computed them (formulas of the state too)
    drawn_loads = []
    for n, ld in enumerate(m.loads):
        if n >= len(sol.loads.values):   # pragma: no cover - a loads stage without values
            break
        v = np.asarray(sol.loads.values[n], float)
        label = ld.name or f"{ld.kind} on {ld.body}"
        if ld.kind == "force" and ld.point:
            v = np.broadcast_to(v, (2, len(sol.t)))
            drawn_loads.append({"kind": "force", "at": f"{ld.body}.{ld.point}", "label": label,
                                "x": add(f"load:{n}:x", v[0]), "y": add(f"load:{n}:y", v[1])})
        elif ld.kind in ("torque", "joint_torque"):
            v = np.broadcast_to(v, (len(sol.t),))
            at = ld.point if ld.kind == "joint_torque" else list(m.body(ld.body).points)[0]
            drawn_loads.append({"kind": "torque", "at": f"{ld.body}.{at}", "label": label,
                                "m": add(f"load:{n}:m", v)})
        elif ld.kind in ("spring", "damper"):
            v = np.broadcast_to(v, (len(sol.t),))
            ends = (f"{ld.body}.{ld.point}", f"{ld.body2}.{ld.point2}")
            drawn_loads.append({"kind": ld.kind, "at": ends[0], "to": ends[1], "label": label,
                                "v": add(f"load:{n}:v", v), "pair": sorted(ends)})
    # springs and dampers between the same two points are drawn side by side: each its lane
    # (-0.5, 0.5 for two, ...)
    for ld in drawn_loads:
        if "pair" in ld:
            same = [x for x in drawn_loads if x.get("pair") == ld["pair"]]
            ld["lane"] = same.index(ld) - 0.5 * (len(same) - 1)
    for ld in drawn_loads:
        ld.pop("pair", None)
    # the shaking force is drawn at the centre of the ground pivots
    pivots = [p for p in _ground_outline(ground, used)]
    shaking = None
    if "shake:Fx" in series and pivots:
        c = np.mean([ground.points[p.split(".", 1)[1]] for p in pivots], axis=0)
        shaking = {"x": float(c[0]), "y": float(c[1]), "fx": "shake:Fx", "fy": "shake:Fy"}

    freebody = freebody_entries(sol, idx, add, "xy")

    # x axes: time, and the first driver's angle when it turns monotonically
    xaxes = [{"key": "t", "label": "t (s)"}]
    for d in m.drivers:
        if jk.get(m.joint(d.joint).kind).angular:
            q = np.asarray(cols[f"q_{d.joint}"])[idx] * DEG
            dq = np.diff(q)
            if len(q) > 1 and np.all(np.isfinite(q)) and (np.all(dq > 0) or np.all(dq < 0)):
                xaxes.append({"key": f"q:{d.joint}", "label": f"{d.joint} angle (deg)"})
            break

    # instant centres of velocity of the moving bodies (Solution.instant_centre); null where
    # a body translates
    ics = []
    for k, b in enumerate(m.moving_bodies):
        ic = np.asarray(sol.instant_centre(b.name))
        if not np.any(np.isfinite(ic[..., 0])):
            continue
        ics.append({"body": b.name, "color": BODY_COLORS[k % len(BODY_COLORS)],
                    "x": add(f"ic:{b.name}:x", ic[..., 0]),
                    "y": add(f"ic:{b.name}:y", ic[..., 1])})

    margin = 0.07 * size
    return {
        "name": m.name,
        "t": series["t"],
        "total_samples": int(len(sol.t)),
        "valid": [bool(v) for v in np.asarray(sol.valid)[idx]],
        "series": series,
        "plots": plots,
        "xaxes": xaxes,
        "drivers": drivers,
        "key": keyres,
        "zero": zero,
        "geom": {"points": points, "bodies": bodies, "joints": jlist, "traces": traces,
                 "bounds": [float(lo[0] - margin), float(lo[1] - margin - 0.05 * size),
                            float(hi[0] + margin), float(hi[1] + margin)],
                 "ground": _ground_outline(ground, used),
                 "fmax": fmax, "loads": drawn_loads, "shaking": shaking, "ics": ics,
                 "freebody": freebody},
    }
