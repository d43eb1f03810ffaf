"""The summary (``summary.json``) and the model as HTML tables, numbers to 4 significant digits."""

from __future__ import annotations

import html
import json
import math
from pathlib import Path

import numpy as np

from ..model import GROUND
from ..units import REPORT
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
          "kg_m2": "kg m²", "rpm": "rpm", "pct": "%", "percent": "%", "rad_s": "rad/s",
          "m_s": "m/s", "rad_s2": "rad/s²", "m_s2": "m/s²", "N_m": "N m"}


def denoise(x, noise: float = 1e-12):
    """A copy of the summary with rounding noise shown as zero: in each dict, a number below
    ``noise`` of the largest magnitude among its siblings of the same unit suffix (``work_J``
    beside ``positive_work_J``, ``mean_power_W`` beside ``max_power_W``) becomes 0."""
    if isinstance(x, list):
        return [denoise(v, noise) for v in x]
    if not isinstance(x, dict):
        return x
    out = {k: denoise(v, noise) for k, v in x.items()}
    nums = {k: v for k, v in out.items() if isinstance(v, float) and math.isfinite(v)}
    for suffix in {k.rsplit("_", 1)[-1] for k in nums if "_" in k}:
        same = {k: v for k, v in nums.items() if k.endswith("_" + suffix)}
        top = max(abs(v) for v in same.values())
        for k, v in same.items():
            if abs(v) <= noise * top:
                out[k] = 0.0
    return out


def _travel_in_degrees(travel: dict) -> dict:
    """Joint travel as the page shows angles: degrees (a length stays in m)."""
    out = {}
    for j, e in travel.items():
        if isinstance(e, dict) and e.get("unit") == "rad":
            e = {k: (REPORT.value(v, "angle")
                     if k in ("min", "max", "range") and isinstance(v, float) else v)
                 for k, v in e.items()}
            e["unit"] = "deg"
        out[j] = e
    return out


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


def summary_html(s: dict, scales: dict | None = None) -> str:
    """The summary (``summary.json``) as tables: known sections laid out for a designer, any
    other key rendered generically. Rounding noise shows as 0: a value below 1e-12 of its
    siblings of the same unit, or a reaction moment below 1e-12 of ``scales['N m']``
    (:func:`.keys.scales`)."""
    s = denoise(dict(s))
    if scales and isinstance(s.get("reactions"), dict):
        s["reactions"] = {j: {k: (0.0 if k == "peak_moment_Nm" and isinstance(v, float)
                                  and abs(v) <= 1e-12 * scales.get("N m", 0.0) else v)
                              for k, v in r.items()} for j, r in s["reactions"].items()}
    if isinstance(s.get("joint_travel"), dict):
        s["joint_travel"] = _travel_in_degrees(s["joint_travel"])
    ps = s.get("path_straightness")
    if isinstance(ps, dict):  # lengths in mm, the range in the driver's display unit
        ps = dict(ps)
        for k in [k for k in ps if k.endswith("_m") and isinstance(ps[k], (int, float))]:
            ps[k[:-2] + "_mm"] = REPORT.value(ps.pop(k), "length")
        if isinstance(ps.get("range"), (list, tuple)) and ps.get("range_unit", "rad") == "rad":
            ps["range_deg"] = [REPORT.value(v, "angle") for v in ps.pop("range")]
        s["path_straightness"] = ps
    if isinstance(s.get("slider_cranks"), list):   # lengths in mm, angles in deg, as the page
        s["slider_cranks"] = [
            {**{k: v for k, v in sc.items()
                if k not in ("stroke_m", "travel_m", "transmission_angle_rad")},
             "stroke_mm": REPORT.value(sc["stroke_m"], "length"),
             "travel_mm": [REPORT.value(x, "length") for x in sc["travel_m"]],
             "transmission_angle_deg": {k: (v if k.endswith("_s") or v is None
                                            else REPORT.value(v, "angle"))
                                        for k, v in sc["transmission_angle_rad"].items()}}
            for sc in s["slider_cranks"]]
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
                     + _e(", ".join(f"{k} {fmt(REPORT.value(v, 'length'))}"
                                    for k, v in L.items())) + "</td><td>"
                     + _e(fb.get("grashof", "")) + "</td><td class='num'>"
                     + _e(f"{fmt(ta.get('min'))} .. {fmt(ta.get('max'))}") + "<br>"
                     + _e(f"worst {fmt(ta.get('worst'))} at t = {fmt(ta.get('worst_time_s'))} s")
                     + "</td><td class='num'>"
                     + (_e(f"{fmt(ma.get('min'))} .. "
                           + ("∞" if ma.get("infinite_at_s") else fmt(ma.get("max"))))
                        + "".join(f"<br><span class='note'>{word} where the {link} stops, t = "
                                  + _e(", ".join(fmt(x) for x in ma[key])) + " s</span>"
                                  for key, word, link in (("zero_at_s", "0", "input"),
                                                          ("infinite_at_s", "∞", "output"))
                                  if ma.get(key))
                        if ma else "—")
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


def key_value(item: dict) -> str:
    """A key result's value as text: 4 significant digits, a sign on signed quantities."""
    v = item.get("value")
    text = "∞" if item.get("infinite") else fmt(v)
    if item.get("signed") and isinstance(v, float) and v > 0:
        text = "+" + text
    return f"{text} {item.get('unit', '')}".strip()


def key_where(item: dict) -> str:
    """Where a key result occurs: ``t = 0.7944 s · J1 = 286.0 deg``."""
    if item.get("t") is None:
        return ""
    at = item.get("at")
    return f"t = {fmt(item['t'])} s" + (f" · {at[0]} = {fmt(at[1])} {at[2]}" if at else "")


def group_colour(group: str) -> int:
    """The colour class number (``g0`` .. ``g6``) of a key result group: fixed by the group
    (:data:`.keys.GROUPS`), not by where it falls on a page."""
    from .keys import GROUPS
    return GROUPS.index(group) if group in GROUPS else len(GROUPS) - 1


def key_results_html(items: list) -> str:
    """The key results (:func:`.keys.key_results` with their page frames) in one dense grid,
    in reading order, each tagged with its group; a result that occurs at one sample is a
    button that moves the animation there (``data-frame``)."""
    cells, groups = [], []
    for it in items:
        if it["group"] not in groups:
            groups.append(it["group"])
        g = group_colour(it["group"])
        where = key_where(it)
        inner = (f"<span class='kl'>{_e(it['label'])}</span>"
                 f"<span class='kv'>{_e(key_value(it))}</span>"
                 f"<span class='kt'>{_e(where)}"
                 + (f"{' · ' if where else ''}{_e(it['note'])}" if it.get("note") else "")
                 + "</span>")
        attrs = f"class='keyitem g{g}' data-group='{_e(it['group'])}'"
        if it.get("frame") is not None:
            cells.append(f"<button type='button' {attrs} data-frame='{it['frame']}' "
                         f"title='{_e(it['group'])}: show this instant'>{inner}</button>")
        else:
            cells.append(f"<div {attrs} title='{_e(it['group'])}'>{inner}</div>")
    legend = "".join(f"<span class='keytag g{group_colour(g)}'>{_e(g)}</span>" for g in groups)
    return (f"<div class='keylegend'>{legend}</div><div class='keygrid'>{''.join(cells)}</div>"
            if cells else "")


def _inertia(i) -> str:
    """A planar body's moment of inertia, or a spatial body's tensor (its diagonal when the
    products are zero)."""
    i = np.asarray(i, float)
    if i.ndim == 0:
        return fmt(float(i))
    if not np.any(i - np.diag(np.diag(i))):
        return "diag(" + ", ".join(fmt(float(v)) for v in np.diag(i)) + ")"
    return "[" + "; ".join(", ".join(fmt(float(v)) for v in row) for row in i) + "]"


def model_html(sol) -> str:
    """Bodies, joints, drivers and loads of the model (lengths in mm)."""
    m = sol.model
    roles = joint_roles(sol)

    def mm(xy):
        return "(" + ", ".join(fmt(REPORT.value(float(v), "length"))
                               for v in np.asarray(xy, float)) + ")"

    rows = ""
    for b in m.bodies:
        pts = ", ".join(f"{_e(k)} {mm(v)}" for k, v in b.points.items())
        if b.name == GROUND:
            rows += f"<tr><th>{_e(b.name)}</th><td colspan='3'>fixed (global frame)</td>" \
                    f"<td>{pts}</td></tr>"
        else:
            rows += (f"<tr><th>{_e(b.name)}</th><td class='num'>{fmt(float(b.mass))}</td>"
                     f"<td class='num'>{mm(b.com)}</td><td class='num'>{_inertia(b.inertia)}"
                     f"</td><td>{pts}</td></tr>")
    bodies = ("<table class='grid'><thead><tr><th>body</th><th>mass (kg)</th><th>mass centre "
              "(mm, local)</th><th>I about mass centre (kg m²)</th><th>points (mm, local)</th>"
              "</tr></thead><tbody>" + rows + "</tbody></table>")
    rows = ""
    for j in m.joints:
        extra = ""
        if np.any(np.asarray(j.axis, float)):
            extra = f"axis ({', '.join(fmt(float(v)) for v in j.axis)}) in {_e(j.body_a)}"
        if np.any(np.asarray(getattr(j, "axis2", 0.0), float)):
            extra += f"; axis2 ({', '.join(fmt(float(v)) for v in j.axis2)}) in {_e(j.body_b)}"
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
    out = [f"<p><b>Gravity</b> ({', '.join(fmt(float(v)) for v in g)}) m/s²"
           + (f" · <b>file</b> {_e(Path(m.source).name)}" if m.source else "") + "</p>",
           "<h3>Bodies</h3>", bodies, "<h3>Joints</h3>", joints,
           "<p class='note'>Reaction at a joint: the force by its first body on its second "
           "(global components)"
           + (", and the couple about the second body's point; with redundant constraints "
              "the minimum-norm reactions. " if getattr(sol, "space", "planar") == "spatial"
              else ". ")
           + "Driver effort: what the actuator applies on the second body. "
           "A joint where a loop is cut: its reaction is solved together with the driver "
           "efforts (the method's multipliers λ), the others follow body by body.</p>"]
    if drv:
        out += ["<h3>Drivers</h3>", f"<ul>{drv}</ul>"]
    if loads:
        out += ["<h3>Loads</h3>", f"<ul>{loads}</ul>"]
    return "\n".join(out)
