"""``sweep.html``: a sweep's designs on one self-contained page: the scatter of any two columns,
the Pareto front of two metrics and the best designs of a metric.

The front is computed here, by :func:`pareto_front`, for every pair of metrics over the valid
designs, each metric taken in its sense (larger is better for ``min_transmission_angle``:
:func:`linkdyn.studies.metrics.cost`); the page only highlights it, and ranks the best designs
by the senses it is given.
"""

from __future__ import annotations

import html
import math
from pathlib import Path

import numpy as np

from .page import html_page


def pareto_front(a, b) -> np.ndarray:
    """Indices of the Pareto front of two objectives, both minimized.

    Parameters
    ----------
    a, b : array_like, shape (n,)
        The two objectives of ``n`` points; non-finite values take no part.

    Returns
    -------
    ndarray of int, shape (m,)
        Increasing indices of the points that no other point dominates (``j`` dominates ``i``
        when ``a[j] <= a[i]`` and ``b[j] <= b[i]``, one of them strictly). Equal points are
        all on the front.
    """
    a, b = np.asarray(a, float), np.asarray(b, float)
    idx = np.flatnonzero(np.isfinite(a) & np.isfinite(b))
    if not len(idx):
        return idx
    # sort by a, then b: a point is on the front when its b is the lowest of its equal-a group
    # and strictly below every b of a strictly smaller a
    o = idx[np.lexsort((b[idx], a[idx]))]
    sa, sb = a[o], b[o]
    start = np.flatnonzero(np.r_[True, sa[1:] != sa[:-1]])       # first of each equal-a group
    group = np.cumsum(np.r_[True, sa[1:] != sa[:-1]]) - 1         # group of each sorted point
    first = start[group]
    before = np.r_[np.inf, np.minimum.accumulate(sb)][first]      # min b over smaller a
    on = (sb == sb[first]) & (sb < before)
    return np.sort(o[on])


def _col(values) -> list:
    """A column for JSON: finite floats, None elsewhere."""
    return [float(v) if v is not None and math.isfinite(v) else None for v in values]


def sweep_data(df, summary: dict, outdir: str = "OUTDIR", previews=None) -> dict:
    """The page's data: every design row, the column roles, each metric's sense (``'min'`` or
    ``'max'``), the Pareto front of every pair of metrics in their senses (indices into the
    rows, valid designs only) and ``previews``: design number ->
    the file of its own report page (beside the sweep page)."""
    params = [p["path"] for p in summary["parameters"]]
    from ..studies.metrics import cost, sense, unit

    metrics = [m for m in summary["metrics"]]
    valid = df["valid"].to_numpy(bool)
    cols = {c: _col(df[c].to_numpy(float)) for c in params + metrics}
    fronts = {}
    for i, m1 in enumerate(metrics):
        for m2 in metrics[i + 1:]:
            a = np.where(valid, cost(m1, df[m1].to_numpy(float)), np.nan)
            b = np.where(valid, cost(m2, df[m2].to_numpy(float)), np.nan)
            fronts[f"{m1}|{m2}"] = pareto_front(a, b).tolist()
    return {"design": [int(d) for d in df["design"]], "valid": valid.tolist(),
            "reason": [str(r) if isinstance(r, str) else "" for r in df["reason"]],
            "params": params, "units": {**{p["path"]: p.get("unit") or "" for p in summary["parameters"]},
                                    **{m: unit(m) for m in metrics}},
            "metrics": metrics, "senses": {m: sense(m) for m in metrics}, "cols": cols, "fronts": fronts, "outdir": outdir,
            "previews": {str(k): v for k, v in (previews or {}).items()}}


def render_sweep(df, summary: dict, outdir: str = "OUTDIR", previews=None) -> str:
    """The whole sweep page as a string; ``previews``: design number -> its report page's file,
    shown in the page (the best designs' animations)."""
    data = sweep_data(df, summary, outdir, previews)
    model = summary.get("model")
    title = html.escape(f"Sweep of {Path(model).name if model else 'a model'}")
    note = html.escape(f"{summary['designs']} designs ({summary['valid']} valid, "
                       f"{summary['invalid']} invalid) x {summary['samples']} samples, "
                       f"method {summary.get('method')}")
    return html_page(title=title, body=_BODY.format(title=title, note=note), data=data,
                     script="sweep.js", css=_CSS)


_CSS = """
#scatter { max-width: 720px; }
#scatter circle.pt { fill: #1565c0; fill-opacity: 0.6; }
#scatter circle.pt.invalid { fill: #9e9e9e; fill-opacity: 0.5; }
#scatter circle.pt.front { fill: #c62828; fill-opacity: 1; }
#scatter circle.pt.hot { stroke: #000; stroke-width: 2; }
#scatter path.frontline { fill: none; stroke: #c62828; stroke-width: 1.5; }
#best tr[data-preview] { cursor: pointer; }
#best tr.shown td { background: #fff3e0; }
#preview { width: 100%; height: 760px; border: 1px solid #ccc; display: none; }
"""

_BODY = """<header>
<h1>{title}</h1>
<p class="note">{note}. Parameters in the model file's units, metrics SI. Hover a point to read
its design.</p>
</header>
<section>
  <div class="plotbar"><h2>Designs</h2>
  <label>x <select id="sx"></select></label>
  <label>y <select id="sy"></select></label>
  <label><input type="checkbox" id="hideinvalid"> hide invalid designs</label>
  <label><input type="checkbox" id="logx"> log x</label>
  <label><input type="checkbox" id="logy"> log y</label></div>
  <div class="plotbar"><h2>Pareto front</h2>
  <label>best <select id="pa"></select></label>
  <label>and <select id="pb"></select></label>
  <span id="frontnote" class="note"></span></div>
  <div id="scatter" class="panel"></div>
</section>
<section class="tables">
  <div class="plotbar"><h2>Best designs</h2>
  <label>best by <select id="bm"></select></label>
  <label>how many <select id="bn"><option>3</option><option>5</option><option>10</option></select></label></div>
  <div class="scroll"><table id="best" class="grid"></table></div>
  <p class="note">Compare them curve by curve: <code id="cmpcmd"></code></p>
  <p class="note" id="previewnote"></p>
  <iframe id="preview" title="the design's own report"></iframe>
</section>
"""
