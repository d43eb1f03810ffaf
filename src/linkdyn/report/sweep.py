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


#: a design within this fraction of a parameter's range width from a bound is "at the bound"
EDGE = 0.01


def at_bounds(values, low: float, high: float) -> np.ndarray:
    """Where designs sit on a bound of a parameter's range.

    Parameters
    ----------
    values : array_like, shape (D,)
        The parameter's value of each design, in the file's units.
    low, high : float
        The range it was varied over, same units.

    Returns
    -------
    ndarray of int, shape (D,)
        -1 within :data:`EDGE` of the range's width from ``low``, +1 from ``high``, else 0
        (a best design there may have a better one outside the range).
    """
    x = np.asarray(values, float)
    tol = EDGE * abs(high - low)
    return np.where(np.abs(x - low) <= tol, -1, np.where(np.abs(x - high) <= tol, 1, 0))


def trade_off(df, metrics) -> list[str]:
    """The default pair of axes: the two metrics that most oppose each other over the valid
    designs, i.e. the pair whose costs (:func:`linkdyn.studies.metrics.cost`, smaller better)
    have the most negative Spearman rank correlation (one improves where the other worsens);
    the first two metrics when no pair has two finite values in common."""
    from ..studies.metrics import cost

    valid = df["valid"].to_numpy(bool)
    costs = {m: np.where(valid, cost(m, df[m].to_numpy(float)), np.nan) for m in metrics}
    best, pair = np.inf, list(metrics[:2])
    for i, m1 in enumerate(metrics):
        for m2 in metrics[i + 1:]:
            ok = np.isfinite(costs[m1]) & np.isfinite(costs[m2])
            if ok.sum() < 3:
                continue
            # Spearman's rho: Pearson's correlation of the ranks
            a, b = _ranks(costs[m1][ok]), _ranks(costs[m2][ok])
            sa, sb = a - a.mean(), b - b.mean()
            den = math.sqrt(float(sa @ sa) * float(sb @ sb))
            rho = float(sa @ sb) / den if den > 0 else 0.0
            if rho < best:
                best, pair = rho, [m1, m2]
    return pair


def _ranks(x) -> np.ndarray:
    """Average ranks (1-based) of the finite values of ``x``, NaN elsewhere."""
    x = np.asarray(x, float)
    out = np.full(x.shape, np.nan)
    ok = np.flatnonzero(np.isfinite(x))
    v = x[ok]
    order = np.argsort(v, kind="stable")
    sv = v[order]
    # equal values share the mean of their positions
    first = np.r_[True, sv[1:] != sv[:-1]]
    group = np.cumsum(first) - 1
    starts = np.flatnonzero(first)
    ends = np.r_[starts[1:], len(sv)]
    mean = (starts + ends - 1) / 2.0 + 1.0
    r = np.empty(len(v))
    r[order] = mean[group]
    out[ok] = r
    return out


def sweep_data(df, summary: dict, outdir: str = "OUTDIR", previews=None) -> dict:
    """The page's data.

    Every design row with each column in the model file's units (``cols``; parameters are
    already in them, metrics are turned from SI by :class:`linkdyn.units.Units` of
    ``summary['units']``) and ``units``, each column's unit name; each metric's sense
    (``'min'`` or ``'max'``); the Pareto front of every pair of metrics in their senses
    (``fronts``: indices into the rows, valid designs only); ``pair``, the default axes
    (:func:`trade_off`); ``edges``, per parameter with a range, each design's
    :func:`at_bounds`, and ``ranges``, those ranges; ``previews``: design number -> the file of
    its own report page (beside the sweep page).
    """
    from ..studies.metrics import cost, quantity, sense, unit
    from ..units import Units

    params = [p["path"] for p in summary["parameters"]]
    u = Units(**summary.get("units") or {})
    metrics = [m for m in summary["metrics"]]
    valid = df["valid"].to_numpy(bool)
    cols = {c: _col(df[c].to_numpy(float)) for c in params}
    units = {p["path"]: p.get("unit") or "" for p in summary["parameters"]}
    for m in metrics:
        q = quantity(m)
        cols[m] = _col(u.value(df[m].to_numpy(float), q) if q else df[m].to_numpy(float))
        units[m] = u.unit(q)[0] if q else unit(m)
    fronts = {}
    for i, m1 in enumerate(metrics):
        for m2 in metrics[i + 1:]:
            a = np.where(valid, cost(m1, df[m1].to_numpy(float)), np.nan)
            b = np.where(valid, cost(m2, df[m2].to_numpy(float)), np.nan)
            fronts[f"{m1}|{m2}"] = pareto_front(a, b).tolist()
    ranges = {p["path"]: [p["low"], p["high"]] for p in summary["parameters"]
              if "low" in p and "high" in p}
    edges = {k: at_bounds(df[k].to_numpy(float), lo, hi).tolist() for k, (lo, hi) in
             ranges.items()}
    return {"design": [int(d) for d in df["design"]], "valid": valid.tolist(),
            "reason": [str(r) if isinstance(r, str) else "" for r in df["reason"]],
            "params": params, "units": units, "file_units": [u.length, u.angle],
            "metrics": metrics, "senses": {m: sense(m) for m in metrics}, "cols": cols,
            "fronts": fronts, "pair": trade_off(df, metrics) if len(metrics) > 1 else [],
            "ranges": ranges, "edges": edges, "edge": EDGE, "outdir": outdir,
            "previews": {str(k): v for k, v in (previews or {}).items()}}


def render_sweep(df, summary: dict, outdir: str = "OUTDIR", previews=None) -> str:
    """The whole sweep page as a string; ``previews``: design number -> its report page's file,
    shown in the page (the best designs' animations)."""
    data = sweep_data(df, summary, outdir, previews)
    model = summary.get("model")
    title = html.escape(f"Sweep of {Path(model).name if model else 'a model'}")
    note = html.escape(f"{summary['designs']} designs ({summary['valid']} valid, "
                       f"{summary['invalid']} invalid) x {summary['samples']} samples, "
                       f"method {summary.get('method')}; every number in the model file's "
                       f"units ({data['file_units'][0]}, {data['file_units'][1]}), each with "
                       f"its unit")
    return html_page(title=title, body=_BODY.format(title=title, note=note), data=data,
                     script="sweep.js", css=_CSS)


_CSS = """
.sweepgrid { display: grid; grid-template-columns: minmax(0, 720px) minmax(0, 1fr); gap: 0 22px;
             align-items: start; }
.sweepgrid h2 { margin-top: 6px; }
.plotbar.wrap { flex-wrap: wrap; gap: 4px 14px; }
#scatter { max-width: 720px; }
#scatter circle.pt { fill: #1565c0; fill-opacity: 0.6; }
#scatter circle.pt.invalid { fill: #9e9e9e; fill-opacity: 0.5; }
#scatter circle.pt.front { fill: #c62828; fill-opacity: 1; }
#scatter.coloured circle.pt { fill-opacity: 0.9; }
#scatter.coloured circle.pt.front { stroke: #c62828; stroke-width: 2.2; }
#scatter circle.pt.edge { stroke: #ef6c00; stroke-width: 1.6; }
#scatter circle.pt.hot { stroke: #000; stroke-width: 2; }
#scatter path.frontline { fill: none; stroke: #c62828; stroke-width: 1.5; }
#colorbar { display: none; align-items: center; gap: 8px; font-size: 12px; margin: 4px 0; }
#colorbar .ramp { flex: 0 1 220px; height: 10px; border-radius: 2px;
                  background: linear-gradient(to right, #440154, #3b528b, #21918c, #5ec962, #fde725); }
#filters td, #filters th { padding: 1px 6px 1px 2px; }
#filters input { width: 7.5em; font: inherit; }
#filters .span { color: var(--muted); font-size: 12px; white-space: nowrap; }
#best tr[data-preview] { cursor: pointer; }
#best tr.shown td { background: #fff3e0; }
#best td.edge { color: #e65100; }
#best td.edge::after { content: attr(data-edge); font-size: 11px; margin-left: 3px; }
#edgenote { color: #e65100; }
#preview { width: 100%; height: 760px; border: 1px solid #ccc; display: none; }
@media (max-width: 1099px) { .sweepgrid { grid-template-columns: minmax(0, 1fr); } }
@media (max-width: 700px) { #filters input { width: 5.5em; min-height: 36px; } }
"""

_BODY = """<header>
<h1>{title}</h1>
<p class="note">{note}. Hover a point to read its design; an orange ring or cell marks a design
within 1 % of a bound of its range (the best may lie beyond it).</p>
</header>
<div class="sweepgrid">
<section>
  <div class="plotbar wrap"><h2>Designs</h2>
  <label>x <select id="sx"></select></label>
  <label>y <select id="sy"></select></label>
  <label>colour <select id="sc"></select></label>
  <label><input type="checkbox" id="hideinvalid"> hide invalid</label>
  <label><input type="checkbox" id="logx"> log x</label>
  <label><input type="checkbox" id="logy"> log y</label></div>
  <div class="plotbar wrap"><h2>Pareto front</h2>
  <label>best <select id="pa"></select></label>
  <label>and <select id="pb"></select></label>
  <span id="frontnote" class="note"></span></div>
  <div id="scatter" class="panel"></div>
  <div id="colorbar"><span id="cblo"></span><span class="ramp"></span><span id="cbhi"></span>
  <span id="cbname" class="note"></span></div>
</section>
<section class="tables">
  <div class="plotbar wrap"><h2>Best designs</h2>
  <label>best by <select id="bm"></select></label>
  <label>how many <select id="bn"><option>3</option><option>5</option><option>10</option></select></label></div>
  <p class="note" id="filternote"></p>
  <div class="scroll"><table id="best" class="grid"></table></div>
  <p class="note" id="edgenote"></p>
  <p class="note">Compare them curve by curve: <code id="cmpcmd"></code></p>
  <h2>Filters</h2>
  <p class="note">Keep the designs whose values lie within these limits (in the units shown;
  blank: no limit). The plot, its front and the best designs show only those.</p>
  <div class="scroll"><table id="filters" class="grid small"></table></div>
</section>
</div>
<section class="tables">
  <p class="note" id="previewnote"></p>
  <iframe id="preview" title="the design's own report"></iframe>
</section>
"""
