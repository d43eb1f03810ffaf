"""``report.html``: one self-contained, offline page to look at a solution.

An animation of the mechanism (bodies through their named points, pivots, sliders, traced
coupler points) with play / scrub / speed controls, small-multiple plots of the joint motion,
driver efforts, joint reactions and cut-joint multipliers that follow the animation's time
cursor, the run summary and the model's description.

Everything is inline: the page's CSS and JavaScript come from ``report_assets/`` and the data is a
JSON blob in a ``<script type="application/json">``; no network access, no external resource.
Long runs are downsampled for the page (``max_frames``); ``results.csv`` keeps every sample.

Display units: angles in degrees, everything else SI (m, s, rad/s, N, N m).
"""

from __future__ import annotations

import html
import json
import math
from importlib import resources
from pathlib import Path

import numpy as np

from .model import GROUND, PRISMATIC, REVOLUTE

MAX_FRAMES = 2000
DEG = 180.0 / math.pi

# one colour per joint (or per driver / cut joint), the same in every panel
PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
           "#17becf", "#bcbd22", "#7f7f7f")
BODY_COLORS = ("#3b75af", "#e1812c", "#3a923a", "#c03d3e", "#9372b2", "#845b53", "#d684bd",
               "#2ab0c5", "#a9aa35", "#7f7f7f")
X_COLOR, Y_COLOR, M_COLOR = "#1f77b4", "#ff7f0e", "#2ca02c"


def outputs(sol, summary: dict, *, max_frames: int = MAX_FRAMES) -> dict:
    """Files this module contributes to ``linkdyn analyze --report``.

    Returns ``{"report.html": writer}`` where ``writer(path)`` writes the page.
    """
    def write(path: Path) -> None:
        Path(path).write_text(render(sol, summary, max_frames=max_frames), encoding="utf-8")

    return {"report.html": write}


def render(sol, summary: dict, *, max_frames: int = MAX_FRAMES) -> str:
    """The whole page as a string."""
    data = page_data(sol, max_frames=max_frames)
    m = sol.model
    blob = json.dumps(data, separators=(",", ":"), allow_nan=False)
    blob = blob.replace("</", "<\\/")  # never close the <script> early
    title = html.escape(m.name or "mechanism")
    n, total = len(data["t"]), int(len(sol.t))
    note = (f"{total} samples; the page shows {n} of them evenly spaced (results.csv has all)"
            if n < total else f"{total} samples")
    desc = f"<p class='desc'>{html.escape(m.description)}</p>" if m.description else ""
    return _PAGE.format(
        title=title, css=_asset("report.css"), js=_asset("report.js"), data=blob, desc=desc,
        note=html.escape(note), summary=summary_html(summary), model=model_html(sol),
        key=key_results_html(summary),
        version=html.escape(_version()))


# ------------------------------------------------------------------------------------ data

def frame_indices(n: int, max_frames: int = MAX_FRAMES) -> np.ndarray:
    """At most ``max_frames`` evenly spread sample indices of ``n``, both ends included."""
    if n <= max_frames:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, max_frames)).astype(int))


def _num(a, sig: int = 5) -> list:
    """A JSON-ready list with ``sig`` significant digits; NaN and inf become null."""
    a = np.asarray(a, float).ravel()
    txt = np.char.mod(f"%.{sig}g", np.where(np.isfinite(a), a, 0.0))
    return [float(s) if ok else None for s, ok in zip(txt.tolist(), np.isfinite(a).tolist())]


def joint_roles(sol) -> dict[str, str]:
    """``'cut'``, ``'tree'`` plus ``', driven'`` for every joint."""
    m = sol.model
    cut = set(int(c) for c in sol.topology.cut)
    driven = {d.joint for d in m.drivers}
    return {j.name: ("cut" if k in cut else "tree") + (", driven" if j.name in driven else "")
            for k, j in enumerate(m.joints)}


def multiplier_labels(sol) -> list[tuple[str, str, str]]:
    """``(joint, component label, unit)`` for each column of ``dyn.lam``.

    A cut revolute joint carries the force ``[lam_x, lam_y]`` (global, by the joint's first body
    on its second); a cut prismatic joint the moment and the force normal to its axis.
    """
    m = sol.model
    out = []
    for c in sol.topology.cut:
        j = m.joints[int(c)]
        if j.kind == PRISMATIC:
            out += [(j.name, "moment", "N m"), (j.name, "normal force", "N")]
        else:
            out += [(j.name, "x", "N"), (j.name, "y", "N")]
    return out


def _known_column(name: str) -> bool:
    prefixes = ("q_", "qd_", "qdd_", "phi_", "omega_", "alpha_", "tau_", "force_", "Fx_", "Fy_",
                "M_", "x_", "y_")
    return name == "t" or name.startswith(prefixes) or name in ("kinetic_energy",
                                                               "potential_energy")


def _body_shape(points: dict) -> tuple[str, list[str]]:
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
    shape, outline = _body_shape(pts)
    return [f"{GROUND}.{p}" for p in (outline if shape == "polygon" else pts)]


def page_data(sol, *, max_frames: int = MAX_FRAMES) -> dict:
    """Everything the page's script needs, JSON-ready (plot units: deg for angles, else SI)."""
    m = sol.model
    idx = frame_indices(len(sol.t), max_frames)
    t = np.asarray(sol.t)[idx]
    cols = sol.columns
    joints = list(m.joints)
    jcolor = {j.name: PALETTE[k % len(PALETTE)] for k, j in enumerate(joints)}
    roles = joint_roles(sol)
    series: dict[str, list] = {"t": _num(t, 7)}

    def add(key, values, sig=5):
        series[key] = _num(np.asarray(values)[idx], sig)
        return key

    # ---- geometry of the animation (m, global frame)
    points, bounds = {}, []
    ground = m.body(GROUND)
    for name, xy in ground.points.items():
        xy = np.asarray(xy, float)
        points[f"{GROUND}.{name}"] = {"x": float(xy[0]), "y": float(xy[1]), "static": True}
        bounds.append(xy[None, :])
    for b in m.moving_bodies:
        for name in b.points:
            xy = np.asarray(sol.point(b.name, name))
            bounds.append(xy[np.all(np.isfinite(xy), axis=1)])
            points[f"{b.name}.{name}"] = {"x": _num(xy[idx, 0], 6), "y": _num(xy[idx, 1], 6)}
    allxy = np.concatenate(bounds) if bounds else np.zeros((1, 2))
    lo, hi = allxy.min(0), allxy.max(0)
    size = float(max(np.max(hi - lo), 1e-9))

    bodies = []
    for k, b in enumerate(m.moving_bodies):
        shape, outline = _body_shape(b.points)
        bodies.append({"name": b.name, "color": BODY_COLORS[k % len(BODY_COLORS)], "shape": shape,
                       "outline": [f"{b.name}.{p}" for p in outline],
                       "points": [f"{b.name}.{p}" for p in b.points]})

    used = set()
    jlist = []
    for k, j in enumerate(joints):
        a_id, b_id = f"{j.body_a}.{j.point_a}", f"{j.body_b}.{j.point_b}"
        used |= {a_id, b_id}
        entry = {"name": j.name, "kind": j.kind, "a": a_id, "b": b_id, "role": roles[j.name],
                 "ground": GROUND in (j.body_a, j.body_b), "color": jcolor[j.name],
                 "first": j.body_a, "second": j.body_b}
        if j.kind == PRISMATIC:
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
    # traced: points no joint uses (coupler points), and joints between two bodies that are
    # not pivoted on the ground (e.g. the tool point of a five-bar)
    grounded = {j.body_a for j in joints if j.body_b == GROUND} | {
        j.body_b for j in joints if j.body_a == GROUND}
    floating = {f"{j.body_b}.{j.point_b}" for j in joints
                if GROUND not in (j.body_a, j.body_b)
                and not ({j.body_a, j.body_b} & grounded)}
    traces = [pid for pid in points if not points[pid].get("static")
              and (pid not in used or pid in floating)]
    allxy = np.concatenate(bounds)
    lo, hi = allxy.min(0), allxy.max(0)
    size = float(max(np.max(hi - lo), 1e-9))
    fmax = float(np.nanmax(np.linalg.norm(sol.reactions.force, axis=-1))) if joints else 0.0

    # ---- plot series and panels
    plots = []
    deg = {j.name: DEG if j.kind == REVOLUTE else 1.0 for j in joints}
    kin_names = {"q": ("Joint angles", "Joint displacements"),
                 "qd": ("Joint rates", "Joint rates"),
                 "qdd": ("Joint accelerations", "Joint accelerations")}
    units = {"q": ("deg", "m"), "qd": ("rad/s", "m/s"), "qdd": ("rad/s²", "m/s²")}
    for kind in ("q", "qd", "qdd"):
        for rev in (True, False):
            js = [j for j in joints if (j.kind == REVOLUTE) == rev]
            if not js:
                continue
            scale = (lambda j: deg[j.name]) if kind == "q" else (lambda j: 1.0)
            ser = [{"key": add(f"{kind}:{j.name}", cols[f"{kind}_{j.name}"] * scale(j)),
                    "label": j.name, "color": jcolor[j.name]} for j in js]
            title = kin_names[kind][0 if rev else 1]
            plots.append({"section": "Joint motion (relative joint coordinates q)",
                          "title": title, "unit": units[kind][0 if rev else 1], "series": ser})

    drivers = []
    for unit, word in (("N m", "torque"), ("N", "force")):
        ser = []
        for k, d in enumerate(m.drivers):
            if (m.joint(d.joint).kind == REVOLUTE) != (unit == "N m"):
                continue
            key = add(f"tau:{d.joint}", sol.dyn.tau[..., k])
            ser.append({"key": key, "label": d.joint, "color": jcolor[d.joint]})
            drivers.append({"joint": d.joint, "key": key, "unit": unit, "word": word,
                            "q": f"q:{d.joint}", "qunit": "deg" if unit == "N m" else "m",
                            "color": jcolor[d.joint]})
        if ser:
            plots.append({"section": "Driver efforts and joint reactions",
                          "title": f"Driver {word}", "unit": unit, "series": ser})
    plots.append({"section": "Driver efforts and joint reactions",
                  "title": "Reaction force magnitude |F|", "unit": "N",
                  "series": [{"key": f"F:{j.name}", "label": j.name, "color": jcolor[j.name]}
                             for j in joints]})
    for k, j in enumerate(joints):
        ser = [{"key": f"Fx:{j.name}", "label": "Fx", "color": X_COLOR},
               {"key": f"Fy:{j.name}", "label": "Fy", "color": Y_COLOR}]
        plots.append({"section": "Driver efforts and joint reactions",
                      "title": f"Reaction at {j.name} ({j.body_a} on {j.body_b})",
                      "unit": "N", "series": ser})
    prism = [(k, j) for k, j in enumerate(joints) if j.kind == PRISMATIC]
    if prism:
        ser = [{"key": add(f"M:{j.name}", sol.reactions.moment[..., k]), "label": j.name,
                "color": jcolor[j.name]} for k, j in prism]
        plots.append({"section": "Driver efforts and joint reactions",
                      "title": "Prismatic reaction moments", "unit": "N m", "series": ser})

    labels = multiplier_labels(sol)
    for c in dict.fromkeys(lbl[0] for lbl in labels):
        comps = [(k, lbl) for k, lbl in enumerate(labels) if lbl[0] == c]
        for unit in dict.fromkeys(lbl[2] for _, lbl in comps):
            ser = [{"key": add(f"lam:{c}:{lbl[1]}", sol.dyn.lam[..., k]),
                    "label": f"λ {lbl[1]}", "color": (X_COLOR, Y_COLOR)[n % 2]}
                   for n, (k, lbl) in enumerate(comps) if lbl[2] == unit]
            plots.append({"section": "Cut-joint multipliers λ (reaction at the cut joint)",
                          "title": f"λ at cut joint {c}", "unit": unit, "series": ser})

    try:
        from . import design
        fbs = design.four_bars(m)
        for n, fb in enumerate(fbs):
            key = add(f"mu:{n}", np.degrees(design.transmission_angle(sol, fb)))
            plots.append({"section": "Design", "title": f"Transmission angle "
                          f"({fb.coupler} / {fb.output})", "unit": "deg",
                          "series": [{"key": key, "label": "μ", "color": PALETTE[n]}]})
    except Exception:  # pragma: no cover - a design helper must never break the report
        pass
    energy = [{"key": add("ke", cols["kinetic_energy"]), "label": "kinetic",
               "color": PALETTE[0]}]
    if "potential_energy" in cols:
        energy.append({"key": add("pe", cols["potential_energy"]), "label": "potential",
                       "color": PALETTE[1]})
    plots.append({"section": "Design", "title": "Energy", "unit": "J", "series": energy})
    for n, name in enumerate(c for c in cols if not _known_column(c)):
        vals = np.asarray(cols[name], float)
        if vals.shape != np.shape(sol.t):
            continue
        plots.append({"section": "Other result columns", "title": name, "unit": "",
                      "series": [{"key": add(f"col:{name}", vals), "label": name,
                                  "color": PALETTE[n % len(PALETTE)]}]})

    # x axes: time, and the first driver's angle when it turns monotonically
    xaxes = [{"key": "t", "label": "t (s)"}]
    for d in m.drivers:
        if m.joint(d.joint).kind == REVOLUTE:
            q = np.asarray(cols[f"q_{d.joint}"])[idx] * DEG
            dq = np.diff(q)
            if len(q) > 1 and np.all(np.isfinite(q)) and (np.all(dq > 0) or np.all(dq < 0)):
                xaxes.append({"key": f"q:{d.joint}", "label": f"{d.joint} angle (deg)"})
            break

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
        "geom": {"points": points, "bodies": bodies, "joints": jlist, "traces": traces,
                 "bounds": [float(lo[0] - margin), float(lo[1] - margin - 0.05 * size),
                            float(hi[0] + margin), float(hi[1] + margin)],
                 "ground": _ground_outline(ground, used),
                 "fmax": fmax},
    }


# ------------------------------------------------------------------------------------ tables

def fmt(v) -> str:
    """A number for a table: 4 significant digits without needless exponents."""
    if v is None:
        return "—"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        v = float(v)
        if not math.isfinite(v):
            return str(v)
        if v == 0:
            return "0"
        a = abs(v)
        if 1e-3 <= a < 1e6:
            dec = max(0, 3 - int(math.floor(math.log10(a))))
            return f"{v:.{dec}f}"
        return f"{v:.3e}"
    if isinstance(v, (list, tuple)):
        if all(isinstance(x, (int, float, str)) for x in v):
            return ", ".join(fmt(x) if not isinstance(x, str) else x for x in v)
        return json.dumps(v)
    return str(v)


_UNITS = {"N": "N", "Nm": "N m", "s": "s", "deg": "deg", "m": "m", "mm": "mm", "W": "W",
          "J": "J", "kg": "kg", "rad": "rad", "rel": "relative", "kgm2": "kg m²",
          "kg_m2": "kg m²", "rpm": "rpm", "pct": "%", "percent": "%"}


def pretty_key(key: str) -> str:
    """``peak_force_N`` -> ``peak force (N)``; ``duration_s`` -> ``duration (s)``."""
    key = str(key)
    for suffix in sorted(_UNITS, key=len, reverse=True):
        if key.endswith("_" + suffix) and len(key) > len(suffix) + 1:
            return f"{key[:-len(suffix) - 1].replace('_', ' ')} ({_UNITS[suffix]})"
    return key.replace("_", " ")


def _e(x) -> str:
    return html.escape(str(x))


def _kv_table(d: dict, cls: str = "kv") -> str:
    rows = "".join(f"<tr><th>{_e(pretty_key(k))}</th><td>{_value_html(v)}</td></tr>"
                   for k, v in d.items())
    return f"<table class='{cls}'>{rows}</table>"


def _rows_table(rows: dict | list, first: str = "") -> str:
    """A table with one row per item of a dict of dicts (keys in the first column) or a list
    of dicts; columns are the union of the items' keys."""
    items = list(rows.items()) if isinstance(rows, dict) else [(None, r) for r in rows]
    cols: list[str] = []
    for _, r in items:
        cols += [k for k in r if k not in cols]
    head = (f"<th>{_e(first)}</th>" if isinstance(rows, dict) else "") + "".join(
        f"<th>{_e(pretty_key(c))}</th>" for c in cols)
    body = ""
    for name, r in items:
        cells = (f"<th>{_e(name)}</th>" if isinstance(rows, dict) else "") + "".join(
            f"<td>{_value_html(r.get(c))}</td>" for c in cols)
        body += f"<tr>{cells}</tr>"
    return f"<table class='grid'><thead><tr>{head}</tr></thead><tbody>{body}</tbody></table>"


def _value_html(v) -> str:
    if isinstance(v, dict):
        if v and all(isinstance(x, dict) for x in v.values()):
            return _rows_table(v)
        nested = {k: x for k, x in v.items() if isinstance(x, dict)}
        if len(nested) > 1:  # a table of the dict entries, then the plain ones
            plain = {k: x for k, x in v.items() if k not in nested}
            return _rows_table({pretty_key(k): x for k, x in nested.items()}) + (
                _kv_table(plain, "kv inner") if plain else "")
        return _kv_table(v, "kv inner")
    if isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
        return _rows_table(v)
    return _e(fmt(v))


def summary_html(s: dict) -> str:
    """The summary (``summary.json``) as tables: known sections laid out for a designer, any
    other key rendered generically."""
    s = dict(s)
    parts = []
    run_keys = ("model", "samples", "duration_s", "mobility", "loops", "cut_joints",
                "spanning_tree", "invalid_samples")
    run = {k: s.pop(k) for k in run_keys if k in s}
    src = s.pop("file", None)
    if src:
        run["file"] = Path(str(src)).name
    if "spanning_tree" in run and isinstance(run["spanning_tree"], dict):
        run["spanning_tree"] = ", ".join(f"{b} via {j}" for b, j in run["spanning_tree"].items())
    if run:
        parts.append(f"<h3>Run</h3>{_kv_table(run)}")
    drivers = s.pop("drivers", None)
    if drivers:
        rows = "".join(
            f"<tr><th>{_e(j)}</th><td>{_e(d.get('effort', ''))}</td>"
            f"<td class='num'>{_e(fmt(d.get('peak')))} {_e(d.get('unit', ''))}</td>"
            f"<td class='num'>{_e(fmt(d.get('peak_time_s')))} s</td>"
            f"<td class='num'>{_e(fmt(d.get('rms')))} {_e(d.get('unit', ''))}</td>"
            f"<td>{_e(d.get('motion', ''))}</td>"
            + "".join(f"<td>{_e(pretty_key(k))}: {_value_html(v)}</td>" for k, v in d.items()
                      if k not in ("effort", "unit", "peak", "peak_time_s", "rms", "motion"))
            + "</tr>" for j, d in drivers.items())
        parts.append("<h3>Drivers</h3><table class='grid'><thead><tr><th>joint</th>"
                     "<th>effort</th><th>peak |effort|</th><th>at t</th><th>RMS</th>"
                     "<th>motion</th></tr></thead><tbody>" + rows + "</tbody></table>")
    reactions = s.pop("reactions", None)
    if reactions:
        peak = max((r.get("peak_force_N") or 0.0) for r in reactions.values()) or 1.0
        rows = ""
        for j, r in reactions.items():
            f = r.get("peak_force_N")
            w = 0.0 if not f or not math.isfinite(f) else 100.0 * f / peak
            extra = "".join(f" {_e(pretty_key(k))}: {_e(fmt(v))}" for k, v in r.items()
                            if k not in ("peak_force_N", "peak_time_s"))
            rows += (f"<tr><th>{_e(j)}</th><td class='num'>{_e(fmt(f))} N</td>"
                     f"<td><span class='hbar' style='width:{w:.1f}%'></span></td>"
                     f"<td class='num'>{_e(fmt(r.get('peak_time_s')))} s</td>"
                     f"<td>{extra}</td></tr>")
        parts.append("<h3>Peak joint reactions</h3><table class='grid'><thead><tr><th>joint</th>"
                     "<th>peak |F|</th><th class='barcol'></th><th>at t</th><th></th></tr>"
                     "</thead><tbody>" + rows + "</tbody></table>")
    fbs = s.pop("four_bars", None)
    if fbs:
        rows = ""
        shown = ("links", "lengths_m", "grashof", "transmission_angle_deg", "mechanical_advantage",
                 "type", "pins", "frame")
        for fb in fbs:
            links = fb.get("links", {})
            L = fb.get("lengths_m", {})
            ta = fb.get("transmission_angle_deg", {})
            ma = fb.get("mechanical_advantage") or {}
            extra = {k: v for k, v in fb.items() if k not in shown}
            if fb.get("frame") not in (None, "ground"):
                extra["frame"] = fb["frame"]
            rows += ("<tr><td>" + _e(" / ".join(str(links.get(k, "")) for k in
                                                ("input", "coupler", "output")))
                     + (f"<br><span class='note'>pins {_e(', '.join(fb['pins']))}</span>"
                        if fb.get("pins") else "") + "</td><td>"
                     + _e(", ".join(f"{k} {fmt(v * 1e3)}" for k, v in L.items())) + "</td><td>"
                     + _e(fb.get("grashof", "")) + "</td><td class='num'>"
                     + _e(f"{fmt(ta.get('min'))} .. {fmt(ta.get('max'))}") + "<br>"
                     + _e(f"worst {fmt(ta.get('worst'))} at t = {fmt(ta.get('worst_time_s'))} s")
                     + "</td><td class='num'>"
                     + (_e(f"{fmt(ma.get('min'))} .. {fmt(ma.get('max'))}") if ma else "—")
                     + "</td><td>" + (_kv_table(extra) if extra else "") + "</td></tr>")
        parts.append("<h3>Four-bar loops</h3><table class='grid'><thead><tr><th>input / "
                     "coupler / output</th><th>lengths (mm)</th><th>Grashof type</th>"
                     "<th>transmission angle (deg)</th><th>mechanical advantage |ω_in/ω_out|"
                     "</th><th></th></tr></thead><tbody>" + rows + "</tbody></table>")
    health = s.pop("health", None)
    rest = {k: v for k, v in s.items()}
    for k, v in rest.items():
        title = pretty_key(k)
        parts.append(f"<h3>{_e(title[:1].upper() + title[1:])}</h3>"
                     + (_value_html(v) if isinstance(v, (dict, list)) else
                        f"<p class='num'>{_e(fmt(v))}</p>"))
    if health:
        parts.append(f"<h3>Numerical health</h3>{_kv_table(health)}")
    return "\n".join(parts)


def key_results_html(s: dict) -> str:
    """The few numbers a designer looks at first (beside the animation)."""
    rows = []
    for j, d in (s.get("drivers") or {}).items():
        rows.append((f"peak {d.get('effort', 'effort')} {j}",
                     f"{fmt(d.get('peak'))} {d.get('unit', '')} at t = "
                     f"{fmt(d.get('peak_time_s'))} s"))
        rows.append((f"RMS {d.get('effort', 'effort')} {j}",
                     f"{fmt(d.get('rms'))} {d.get('unit', '')}"))
    reactions = s.get("reactions") or {}
    if reactions:
        j, r = max(reactions.items(), key=lambda kv: kv[1].get("peak_force_N") or 0.0)
        rows.append(("highest joint load", f"{j}: {fmt(r.get('peak_force_N'))} N at t = "
                                           f"{fmt(r.get('peak_time_s'))} s"))
    fbs = s.get("four_bars") or []
    for fb in fbs:
        ta = fb.get("transmission_angle_deg", {})
        links = fb.get("links", {})
        which = (f" {links.get('coupler', '')}/{links.get('output', '')}"
                 if len(fbs) > 1 else "")
        rows.append((f"transmission angle{which}",
                     f"{fmt(ta.get('min'))} .. {fmt(ta.get('max'))} deg"))
        rows.append((f"Grashof type{which}", str(fb.get("grashof", ""))))
    shaking = (s.get("shaking") or {}).get("force_N")
    if isinstance(shaking, dict) and "peak" in shaking:
        rows.append(("shaking force", f"peak {fmt(shaking['peak'])} N, RMS "
                                      f"{fmt(shaking.get('rms'))} N"))
    for j, e in (s.get("driver_energy") or {}).items():
        fw = e.get("flywheel") if isinstance(e, dict) else None
        if isinstance(fw, dict) and fw.get("inertia_kg_m2") is not None:
            rows.append((f"flywheel {j}", f"{fmt(fw['inertia_kg_m2'])} kg m² for C_s = "
                                          f"{fmt(fw.get('speed_fluctuation'))}"))
    ps = s.get("path_straightness")
    if isinstance(ps, dict) and ps.get("max_deviation_m") is not None:
        rows.append((f"straightness of {ps.get('point', 'path')}",
                     f"max deviation {fmt(ps['max_deviation_m'] * 1e3)} mm over "
                     f"{fmt((ps.get('length_m') or 0.0) * 1e3)} mm"
                     + (" (whole run)" if ps.get("range") is None else "")))
    if s.get("invalid_samples"):
        rows.append(("WARNING", f"{s['invalid_samples']} singular samples (NaN)"))
    body = "".join(f"<tr><th>{_e(k)}</th><td>{_e(v)}</td></tr>" for k, v in rows)
    return f"<h3>Key results</h3><table class='kv key'>{body}</table>" if rows else ""


def model_html(sol) -> str:
    """Bodies, joints, drivers and loads of the model (lengths in mm)."""
    m = sol.model
    roles = joint_roles(sol)

    def mm(xy):
        return "(" + ", ".join(fmt(float(v) * 1e3) for v in np.asarray(xy, float)) + ")"

    rows = ""
    for b in m.bodies:
        pts = ", ".join(f"{_e(k)} {mm(v)}" for k, v in b.points.items())
        if b.name == GROUND:
            rows += f"<tr><th>{_e(b.name)}</th><td colspan='3'>fixed (global frame)</td>" \
                    f"<td>{pts}</td></tr>"
        else:
            rows += (f"<tr><th>{_e(b.name)}</th><td class='num'>{fmt(float(b.mass))}</td>"
                     f"<td class='num'>{mm(b.com)}</td><td class='num'>{fmt(float(b.inertia))}"
                     f"</td><td>{pts}</td></tr>")
    bodies = ("<table class='grid'><thead><tr><th>body</th><th>mass (kg)</th><th>mass centre "
              "(mm, local)</th><th>I about mass centre (kg m²)</th><th>points (mm, local)</th>"
              "</tr></thead><tbody>" + rows + "</tbody></table>")
    rows = ""
    for j in m.joints:
        extra = ""
        if j.kind == PRISMATIC:
            extra = f"axis ({fmt(float(j.axis[0]))}, {fmt(float(j.axis[1]))}) in {_e(j.body_a)}"
        rows += (f"<tr><th>{_e(j.name)}</th><td>{_e(j.kind)}</td><td>{_e(j.body_a)}."
                 f"{_e(j.point_a)} → {_e(j.body_b)}.{_e(j.point_b)}</td>"
                 f"<td>{_e(roles[j.name])}</td><td>{extra}</td></tr>")
    joints = ("<table class='grid'><thead><tr><th>joint</th><th>kind</th><th>first → second "
              "body</th><th>role</th><th></th></tr></thead><tbody>" + rows + "</tbody></table>")
    drv = "".join(f"<li><b>{_e(d.joint)}</b>: {_e(d.description)}</li>" for d in m.drivers)
    loads = "".join(
        f"<li>{_e(ld.kind)} on {_e(ld.body)}{'.' + _e(ld.point) if ld.point else ''}"
        f"{' – ' + _e(ld.body2) + '.' + _e(ld.point2) if ld.body2 else ''}"
        f"{' (' + _e(ld.name) + ')' if ld.name else ''}</li>" for ld in m.loads)
    g = np.asarray(m.gravity, float)
    out = [f"<p><b>Gravity</b> ({fmt(float(g[0]))}, {fmt(float(g[1]))}) m/s²"
           + (f" · <b>file</b> {_e(Path(m.source).name)}" if m.source else "") + "</p>",
           "<h3>Bodies</h3>", bodies, "<h3>Joints</h3>", joints,
           "<p class='note'>Reaction at a joint: the force by its first body on its second "
           "(global components). Driver effort: what the actuator applies on the second body. "
           "λ: the reaction at a cut joint, solved together with the driver efforts.</p>"]
    if drv:
        out += ["<h3>Drivers</h3>", f"<ul>{drv}</ul>"]
    if loads:
        out += ["<h3>Loads</h3>", f"<ul>{loads}</ul>"]
    return "\n".join(out)


# ------------------------------------------------------------------------------------ page

def _asset(name: str) -> str:
    return resources.files("linkdyn").joinpath("report_assets", name).read_text("utf-8")


def _version() -> str:
    try:
        from . import __version__
        return __version__
    except ImportError:  # pragma: no cover
        return ""


_PAGE = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="linkdyn {version}">
<title>{title} — linkdyn report</title>
<style>
{css}
</style>
</head>
<body>
<header>
<h1>{title}</h1>
{desc}
<p class="note">{note}. Angles in degrees, everything else SI. Click or drag on any plot to move
the time cursor; keys: space play/pause, ← → step.</p>
</header>
<section class="top">
  <div class="animbox">
    <svg id="anim" role="img" aria-label="animation of the mechanism"></svg>
    <div class="controls">
      <button id="play" type="button" title="play / pause (space)">▶ Play</button>
      <button id="stepback" type="button" title="previous frame (←)">◀</button>
      <button id="step" type="button" title="next frame (→)">▶|</button>
      <input id="scrubber" type="range" min="0" max="0" value="0" step="1"
             aria-label="time">
      <label>speed <select id="speed">
        <option value="0.25">0.25×</option><option value="0.5">0.5×</option>
        <option value="1" selected>1×</option><option value="2">2×</option>
        <option value="4">4×</option></select></label>
    </div>
    <div class="controls toggles">
      <label><input type="checkbox" id="show-labels" checked> labels</label>
      <label><input type="checkbox" id="show-traces" checked> traced points</label>
      <label><input type="checkbox" id="show-forces"> reaction forces</label>
      <span id="ratenote" class="note"></span>
    </div>
  </div>
  <aside class="info">
    <div id="time" class="time">t = 0 s</div>
    <div id="frameinfo" class="note"></div>
    <div id="drivers"></div>
    <div id="loaded" class="loaded"></div>
    <table id="jointforces" class="grid small"></table>
    {key}
  </aside>
</section>
<section>
  <div class="plotbar"><h2>Plots</h2>
  <label>x axis <select id="xaxis"></select></label></div>
  <div id="plots"></div>
</section>
<section class="tables">
<h2>Summary</h2>
{summary}
</section>
<section class="tables">
<h2>Model</h2>
{model}
</section>
<footer class="note">linkdyn {version} · recursive DeNOC kinematics and inverse dynamics</footer>
<script id="linkdyn-data" type="application/json">{data}</script>
<script>
{js}
</script>
</body>
</html>
"""
