"""``compare.html``: several designs on one self-contained page, their curves and traced paths
overlaid, their key results side by side with each one's difference from the first design
(absolute and %) and the better value marked by its sense, and the model parameters that differ.

Each design is solved and summarized exactly as ``linkdyn analyze`` does; its key results are
:func:`.keys.key_results` of its own solution (so each column equals that design's own report),
and its curves are the series of its own :func:`.data.page_data`, drawn together against time
(or against the first driver's angle when every design has it). :func:`compare_csv` is the
export: the key results and the differing fields as one table, at full precision.
"""

from __future__ import annotations

import csv
import html
import io
from pathlib import Path

import numpy as np

from ..errors import ModelError
from .data import MAX_FRAMES, PALETTE, packed, page_data
from .page import html_page
from .tables import fmt, key_value, key_where

# panels overlaid: the sections and titles of page_data's plots worth comparing (not each
# joint's reaction components: their magnitudes are compared)
_SECTIONS = ("Driver efforts and joint reactions", "Point motion", "Design")
_PER_JOINT = ("Reaction at", "Reaction force at", "Reaction couple at")


def compare_data(runs, *, max_frames: int = MAX_FRAMES) -> dict:
    """The page's data for ``runs``: a list of ``(name, solution, summary)``, all planar or all
    spatial (each design's data that of its own report page: :func:`.data.page_data` or
    :func:`.spatial.page_data`)."""
    designs, per = [], []
    for n, (name, sol, summ) in enumerate(runs):
        if getattr(sol, "space", "planar") == "spatial":
            from .spatial import page_data as spatial_page_data
            d = spatial_page_data(sol, max_frames=max_frames, summary=summ)
        else:
            d = page_data(sol, max_frames=max_frames, summary=summ)
        per.append(d)
        designs.append({"name": name, "model": sol.model.name, "color": PALETTE[n % len(PALETTE)],
                        "key": d["key"], "samples": d["total_samples"]})
    # panels: one per (plot, series) present in every design, in the first design's order
    panels = []
    for spec in per[0]["plots"]:
        if spec["section"] not in _SECTIONS or spec["title"].startswith(_PER_JOINT):
            continue
        for s in spec["series"]:
            if all(s["key"] in d["series"] for d in per):
                title = spec["title"] if len(spec["series"]) == 1 else f"{spec['title']}: {s['label']}"
                panels.append({"title": title, "unit": spec["unit"], "key": s["key"]})
    keys = {p["key"] for p in panels}
    # x axes every design has (time always; the first driver's angle when all turn it)
    xaxes = [a for a in per[0]["xaxes"] if all(any(b["key"] == a["key"] for b in d["xaxes"])
                                               for d in per)]
    for d, out in zip(per, designs):
        out["series"] = {k: v for k, v in d["series"].items()
                         if k in keys or k in {a["key"] for a in xaxes}}
    out = {"designs": designs, "panels": panels, "xaxes": xaxes,
           "rows": key_rows(designs), "differs": differing(runs)}
    if all(getattr(sol, "space", "planar") != "spatial" for _, sol, _ in runs):
        out.update(traced_paths(runs, per))
    return out


SAME = 1e-9   # key results closer than this fraction of the larger are equal (no best)


def key_rows(designs: list) -> list[dict]:
    """Key results side by side: one row per result (in the first design's order, then any
    other design's), each with ``values`` (one per design, None where it has none), ``diff``
    and ``pct``: each design's value minus the first design's and that as % of the first's
    |value| (None for the first, where either is missing, and ``pct`` where the first is 0),
    ``sense`` (:func:`.keys.key_sense`) and ``best``: the designs whose value is best in that
    sense (the smallest or largest magnitude; none when every value is equal or no sense)."""
    from .keys import key_sense

    rows: dict[tuple[str, str], dict] = {}
    for n, d in enumerate(designs):
        for it in d["key"]:
            row = rows.setdefault((it["group"], it["label"]), {
                "group": it["group"], "label": it["label"], "unit": it["unit"],
                "sense": key_sense(it["label"]), "items": [None] * len(designs)})
            row["items"][n] = it
    out = []
    for row in rows.values():
        vals = [None if it is None or not _finite(it["value"]) else float(it["value"])
                for it in row["items"]]
        ref = vals[0]
        row["values"] = vals
        row["diff"] = [None if n == 0 or v is None or ref is None else v - ref
                       for n, v in enumerate(vals)]
        row["pct"] = [None if dv is None or ref == 0 else 100.0 * dv / abs(ref)
                      for dv in row["diff"]]
        # the better value: the smallest (or largest) magnitude, 'min' or 'max' sense; values
        # within SAME of each other are one (the rounding of equal designs marks none)
        have = [abs(v) for v in vals if v is not None]
        best = []
        if row["sense"] and len(have) > 1 and max(have) - min(have) > SAME * max(have):
            pick = min(have) if row["sense"] == "min" else max(have)
            best = [n for n, v in enumerate(vals)
                    if v is not None and abs(abs(v) - pick) <= SAME * max(have)]
        row["best"] = best
        out.append(row)
    return out


def _finite(v) -> bool:
    return isinstance(v, (int, float)) and np.isfinite(v)


def traced_paths(runs, per) -> dict:
    """The traced points' paths (:func:`.data.traced_points`) that every design has:
    ``paths``, ``{point: [[x...], [y...]] per design}`` on each page's frames, in the first
    design's file length unit (``length_unit``), for the overlay."""
    from ..units import Units

    u = Units.of(runs[0][1].model)
    common = [p for p in per[0]["geom"]["traces"] if all(p in d["geom"]["traces"] for d in per)]
    paths = {p: [[_scaled(d["geom"]["points"][p][c], u) for c in ("x", "y")] for d in per]
             for p in common}
    return {"paths": paths, "length_unit": u.unit("length")[0]}


def _scaled(values, u) -> list:
    """A track in the file's length unit, at 6 significant digits (drawn only)."""
    return [None if v is None else float(f"{float(u.value(v, 'length')):.6g}") for v in values]


# fields of a model file that do not make one design differ from another
_NOT_PARAMETERS = ("mechanism.name", "mechanism.description")


def flatten(data, prefix: str = "") -> dict:
    """A model file's structure (:func:`linkdyn.io.writer.model_to_dict`) as dotted field
    paths, as ``--vary`` names them: ``{'bodies.coupler.points.P[0]': 230.4, ...}`` (a list of
    named tables keyed by its names, a list of numbers by index)."""
    out = {}
    if isinstance(data, dict):
        for k, v in data.items():
            out.update(flatten(v, f"{prefix}.{k}" if prefix else str(k)))
    elif isinstance(data, list) and data and all(isinstance(v, dict) and "name" in v
                                                 for v in data):
        for v in data:
            out.update(flatten({k: x for k, x in v.items() if k != "name"},
                               f"{prefix}.{v['name']}"))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            out.update(flatten(v, f"{prefix}[{i}]"))
    else:
        out[prefix] = data
    return out


def differing(runs) -> list[dict]:
    """The model fields whose values differ between the designs (numbers beyond 1e-9 of their
    size, the rounding of a file written back): ``[{'path', 'values'}]``, each design's value
    in its own file's units (None where it has no such field), in the first design's order."""
    from ..io.writer import model_to_dict

    flat = [flatten(model_to_dict(sol.model)) for _, sol, _ in runs]
    paths = list(flat[0]) + [p for f in flat[1:] for p in f if p not in flat[0]]
    out = []
    for p in dict.fromkeys(paths):
        if p in _NOT_PARAMETERS:
            continue
        vals = [f.get(p) for f in flat]
        if any(not _same(v, vals[0]) for v in vals[1:]):
            out.append({"path": p, "values": vals})
    return out


def _same(a, b) -> bool:
    if isinstance(a, (int, float)) and isinstance(b, (int, float)) and not isinstance(
            a, bool) and not isinstance(b, bool):
        return abs(a - b) <= 1e-9 * max(abs(a), abs(b), 1e-300)
    return a == b


def sweep_best(sweep_dir, metric, n_best) -> list:
    """The ``n_best`` valid designs of a sweep with the lowest ``metric``: ``(file, name, model,
    row)`` each, the model rebuilt from the sweep's base file and the design's parameter values
    (``row``: the design number, its parameters in the file's units and its metric, SI).

    A damaged or foreign sweep folder, an unknown metric or a parameter value the model file
    does not accept is a ModelError naming ``--sweep``, ``--by`` or the field.
    """
    from ..studies import params as params_mod
    from ..studies.files import read_sweep

    info, df = read_sweep(sweep_dir)
    folder = Path(sweep_dir)
    metrics = [m for m in info["metrics"] if m in df.columns]
    if metric is None or metric not in metrics:
        what = ("--sweep needs --by METRIC" if metric is None else
                f"no metric '{metric}' in {folder / 'summary.json'}")
        raise ModelError(what, field="--by",
                         fix="Rank by one of the sweep's metrics: " + ", ".join(metrics))
    if n_best < 1:
        raise ModelError(f"--best must be at least 1, not {n_best}", field="--best",
                         fix="Give --best 1 or more")
    base = Path(info["model"])
    if not base.is_file() and (folder / base.name).is_file():
        base = folder / base.name
    if not base.is_file():
        raise ModelError(f"the sweep's model file {info['model']} is not found", field="--sweep",
                         fix="Run compare from the folder the sweep ran in (its summary.json "
                             "names the model file relative to it)")
    paths = [p["path"] for p in info["parameters"]]
    sp = params_mod.space(str(base), paths)
    from ..studies.metrics import ranked
    ok = df.iloc[ranked(df, metric)]   # best first, in the metric's sense
    if ok.empty:
        raise ModelError(f"no valid design in {folder / 'designs.parquet'} has a {metric}",
                         field="--sweep", fix="Rank by another metric, or sweep other ranges")
    out = []
    for _, r in ok.head(n_best).iterrows():
        values = [float(r[p]) for p in paths]
        row = {"design": int(r["design"]), "parameters": dict(zip(paths, values)),
               metric: float(r[metric])}
        out.append((str(base), f"{base.stem} #{row['design']}", sp.model(values), row))
    return out


def key_table_html(designs: list, rows: list) -> str:
    """Key results side by side (:func:`key_rows`): one column per design; under each value
    but the first design's, its difference from the first (absolute and %); the better value
    in its row's sense marked "best"; '—' where a design has no such result."""
    head = "".join(f"<th style='color:{d['color']}'>{html.escape(d['name'])}</th>" for d in designs)
    body, group = "", None
    for row in rows:
        if row["group"] != group:
            group = row["group"]
            body += (f"<tr class='grp'><th colspan='{len(designs) + 1}'>{html.escape(group)}"
                     "</th></tr>")
        cells = ""
        for n, it in enumerate(row["items"]):
            if it is None:
                cells += "<td>—</td>"
                continue
            best = n in row["best"]
            delta = _delta(row, n)
            cells += (f"<td class='num{' best' if best else ''}' data-value="
                      f"'{'' if it['value'] is None else repr(it['value'])}'>"
                      f"<b>{html.escape(key_value(it))}</b>"
                      + (" <span class='besttag'>best</span>" if best else "")
                      + (f"<br><span class='delta'>{html.escape(delta)}</span>" if delta else "")
                      + f"<br><span class='note'>{html.escape(key_where(it))}</span></td>")
        signed = any(it and it.get("signed") for it in row["items"])
        sense = {"min": f"smaller {'magnitude ' if signed else ''}is better",
                 "max": "larger is better"}.get(row["sense"], "")
        body += (f"<tr data-label='{html.escape(row['label'])}'><th>{html.escape(row['label'])}"
                 + (f"<br><span class='note'>{sense}</span>" if sense else "")
                 + f"</th>{cells}</tr>")
    return (f"<table class='grid cmp'><thead><tr><th></th>{head}</tr></thead>"
            f"<tbody>{body}</tbody></table>")


def _delta(row: dict, n: int) -> str:
    """``'Δ +1.234 N m (+5.6 %)'``: design ``n``'s difference from the first design."""
    dv, pct = row["diff"][n], row["pct"][n]
    if dv is None:
        return ""
    text = f"Δ {'+' if dv > 0 else ''}{fmt(dv)} {row['unit']}".rstrip()
    return text + (f" ({'+' if pct > 0 else ''}{fmt(pct)} %)" if pct is not None else "")


def differs_html(designs: list, differs: list) -> str:
    """The model fields that differ between the designs, one column per design (each in its
    file's units)."""
    if not differs:
        return "<p class='note'>The designs' model files hold the same values.</p>"
    head = "".join(f"<th style='color:{d['color']}'>{html.escape(d['name'])}</th>" for d in designs)
    body = "".join(
        f"<tr data-path='{html.escape(r['path'])}'><th><code>{html.escape(r['path'])}</code></th>"
        + "".join("<td class='num'>" + ("—" if v is None else html.escape(
            fmt(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else str(v)))
            + "</td>" for v in r["values"]) + "</tr>" for r in differs)
    return (f"<table class='grid' id='differs'><thead><tr><th>field (file units)</th>{head}"
            f"</tr></thead><tbody>{body}</tbody></table>")


def compare_csv(data: dict) -> str:
    """``compare.csv``: the comparison's table for a spreadsheet, from :func:`compare_data`.

    One row per key result (``kind`` = ``key result``; its group, label, unit and sense, each
    design's value at full precision, ``inf`` where it is infinite, empty where a design has
    none; each other design's difference from the first, absolute and in %; the best designs'
    names, ``;``-separated) and one per model field that differs (``kind`` = ``model field``,
    its dotted path, each design's value in its own file's units).
    """
    names = [d["name"] for d in data["designs"]]
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(["kind", "group", "name", "unit", "sense", *names,
                *(f"diff {n}" for n in names[1:]), *(f"pct {n}" for n in names[1:]), "best"])

    def cell(v):
        return "" if v is None else repr(float(v)) if isinstance(v, (int, float)) and not \
            isinstance(v, bool) else str(v)

    for row in data["rows"]:
        values = [("inf" if it is not None and it.get("infinite") else cell(v))
                  for it, v in zip(row["items"], row["values"])]
        w.writerow(["key result", row["group"], row["label"], row["unit"], row["sense"] or "",
                    *values, *map(cell, row["diff"][1:]), *map(cell, row["pct"][1:]),
                    ";".join(names[n] for n in row["best"])])
    for f in data["differs"]:
        w.writerow(["model field", "", f["path"], "file units", "", *map(cell, f["values"]),
                    *[""] * (2 * (len(names) - 1)), ""])
    return out.getvalue()


def render_compare(runs, *, max_frames: int = MAX_FRAMES, data: dict | None = None) -> str:
    """The whole comparison page as a string (``data``: :func:`compare_data` of ``runs``, if
    already made)."""
    data = data if data is not None else compare_data(runs, max_frames=max_frames)
    names = ", ".join(d["name"] for d in data["designs"])
    files = "".join(f"<li style='color:{d['color']}'><b>{html.escape(d['name'])}</b>: "
                    f"{html.escape(d['model'] or '')}, {fmt(d['samples'])} samples</li>"
                    for d in data["designs"])
    body = _BODY.format(title=html.escape(f"Comparison: {names}"), files=files,
                        table=key_table_html(data["designs"], data["rows"]),
                        differs=differs_html(data["designs"], data["differs"]))
    data = {**data, "designs": [{**d, "series": packed(d["series"])} for d in data["designs"]]}
    return html_page(title=html.escape(f"Comparison: {names}"), body=body, data=data,
                     script="compare.js", css=_CSS)


_CSS = """
table.cmp td { min-width: 9em; }
table.cmp tr.grp th { background: var(--panel); font-size: 12px; text-transform: uppercase; color: var(--muted); }
table.cmp td.best { background: #e8f5e9; }
.besttag { font-size: 11px; color: #2e7d32; font-weight: bold; }
.delta { font-size: 12px; }
#pathbox { max-width: 640px; }
#pathbox svg { width: 100%; height: auto; display: block; }
#pathbox .ppath { fill: none; stroke-width: 1.8; }
"""

_BODY = """<header>
<h1>{title}</h1>
<ul class="designs">{files}</ul>
<p class="note">Angles in degrees, everything else SI (the traced paths in the first model
file's length unit, the fields in each file's units). Each design solved as <code>linkdyn analyze</code> solves it; hover a plot
to read every design's value. Differences are from the first design.</p>
</header>
<section class="tables">
<h2>Key results</h2>
<div class="scroll">{table}</div>
<h2>Parameters that differ</h2>
<div class="scroll">{differs}</div>
</section>
<section>
  <h2>Traced paths</h2>
  <div id="pathbox" class="panel"></div>
</section>
<section>
  <div class="plotbar"><h2>Curves</h2>
  <label>x axis <select id="xaxis"></select></label></div>
  <div id="plots" class="pgrid"></div>
</section>
"""
