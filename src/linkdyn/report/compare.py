"""``compare.html``: several designs on one self-contained page, their curves overlaid and their
key results side by side.

Each design is solved and summarized exactly as ``linkdyn analyze`` does; its key results are
:func:`.keys.key_results` of its own solution (so each column equals that design's own report),
and its curves are the series of its own :func:`.data.page_data`, drawn together against time
(or against the first driver's angle when every design has it).
"""

from __future__ import annotations

import html

from .data import MAX_FRAMES, PALETTE, page_data
from .page import html_page
from .tables import fmt, key_value, key_where

# panels overlaid: the sections and titles of page_data's plots worth comparing
_SECTIONS = ("Driver efforts and joint reactions", "Point motion", "Design")


def compare_data(runs, *, max_frames: int = MAX_FRAMES) -> dict:
    """The page's data for ``runs``: a list of ``(name, solution, summary)``."""
    designs, per = [], []
    for n, (name, sol, summ) in enumerate(runs):
        d = page_data(sol, max_frames=max_frames, summary=summ)
        per.append(d)
        designs.append({"name": name, "model": sol.model.name, "color": PALETTE[n % len(PALETTE)],
                        "key": d["key"], "samples": d["total_samples"]})
    # panels: one per (plot, series) present in every design, in the first design's order
    panels = []
    for spec in per[0]["plots"]:
        if spec["section"] not in _SECTIONS or spec["title"].startswith("Reaction at"):
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
