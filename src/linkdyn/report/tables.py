"""The summary (``summary.json``) and the model as HTML tables, numbers to 4 significant digits."""

from __future__ import annotations

import html
import json
import math
from pathlib import Path

import numpy as np

from .. import joints as jk
from ..model import GROUND
from .data import joint_roles


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
        if "axis" in jk.get(j.kind).keys:
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
