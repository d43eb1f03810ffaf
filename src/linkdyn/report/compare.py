"""``compare.html``: several designs on one self-contained page, their curves overlaid and their
key results side by side.

Each design is solved and summarized exactly as ``linkdyn analyze`` does; its key results are
:func:`.keys.key_results` of its own solution (so each column equals that design's own report),
and its curves are the series of its own :func:`.data.page_data`, drawn together against time
(or against the first driver's angle when every design has it).
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np

from ..errors import ModelError
from .data import MAX_FRAMES, PALETTE, page_data
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
    return {"designs": designs, "panels": panels, "xaxes": xaxes}


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


def key_table_html(designs: list) -> str:
    """Key results side by side: one row per result (in the first design's order, then any
    other design's), one column per design; '—' where a design has no such result."""
    rows: dict[tuple[str, str], list] = {}
    for n, d in enumerate(designs):
        for it in d["key"]:
            rows.setdefault((it["group"], it["label"]), [None] * len(designs))[n] = it
    head = "".join(f"<th style='color:{d['color']}'>{html.escape(d['name'])}</th>" for d in designs)
    body, group = "", None
    for (g, label), its in rows.items():
        if g != group:
            group = g
            body += f"<tr class='grp'><th colspan='{len(designs) + 1}'>{html.escape(g)}</th></tr>"
        cells = "".join(
            "<td>—</td>" if it is None else
            f"<td class='num' data-value='{'' if it['value'] is None else repr(it['value'])}'>"
            f"<b>{html.escape(key_value(it))}</b><br><span class='note'>"
            f"{html.escape(key_where(it))}</span></td>" for it in its)
        body += f"<tr><th>{html.escape(label)}</th>{cells}</tr>"
    return (f"<table class='grid cmp'><thead><tr><th></th>{head}</tr></thead>"
            f"<tbody>{body}</tbody></table>")


def render_compare(runs, *, max_frames: int = MAX_FRAMES) -> str:
    """The whole comparison page as a string."""
    data = compare_data(runs, max_frames=max_frames)
    names = ", ".join(d["name"] for d in data["designs"])
    files = "".join(f"<li style='color:{d['color']}'><b>{html.escape(d['name'])}</b>: "
                    f"{html.escape(d['model'] or '')}, {fmt(d['samples'])} samples</li>"
                    for d in data["designs"])
    body = _BODY.format(title=html.escape(f"Comparison: {names}"), files=files,
                        table=key_table_html(data["designs"]))
    return html_page(title=html.escape(f"Comparison: {names}"), body=body, data=data,
                     script="compare.js", css=_CSS)


_CSS = """
table.cmp td { min-width: 9em; }
table.cmp tr.grp th { background: var(--panel); font-size: 12px; text-transform: uppercase; color: var(--muted); }
"""

_BODY = """<header>
<h1>{title}</h1>
<ul class="designs">{files}</ul>
<p class="note">Angles in degrees, everything else SI. Each design solved as
<code>linkdyn analyze</code> solves it; hover a plot to read every design's value.</p>
</header>
<section>
  <div class="plotbar"><h2>Curves</h2>
  <label>x axis <select id="xaxis"></select></label></div>
  <div id="plots" class="pgrid"></div>
</section>
<section class="tables">
<h2>Key results</h2>
<div class="scroll">{table}</div>
</section>
"""
