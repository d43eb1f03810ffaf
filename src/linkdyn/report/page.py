"""The page itself: the tables, the data blob and the inline CSS and JavaScript of ``assets/``,
assembled into one self-contained HTML document."""

from __future__ import annotations

import html
import json
from importlib import resources
from pathlib import Path

from .data import MAX_FRAMES, carried, page_data
from .keys import scales
from .tables import key_results_html, model_html, summary_html


def outputs(sol, summary: dict, *, max_frames: int = MAX_FRAMES, title: str | None = None,
            intro: str = "") -> dict:
    """Files this module contributes to ``linkdyn analyze --report`` (and, with a ``title``
    and an ``intro``, to ``linkdyn optimize --report``: see :func:`render`).

    Returns ``{"report.html": writer}`` where ``writer(path)`` writes the page.
    """
    def write(path: Path) -> None:
        Path(path).write_text(render(sol, summary, max_frames=max_frames, title=title,
                                     intro=intro), encoding="utf-8")

    return {"report.html": write}


def render(sol, summary: dict, *, max_frames: int = MAX_FRAMES, title: str | None = None,
           intro: str = "") -> str:
    """The whole page as a string; ``title`` instead of the model's name, and ``intro``, HTML
    shown first under the header (an optimize's objective, constraints and changes)."""
    spatial = getattr(sol, "space", "planar") == "spatial"
    if spatial:
        from . import spatial as sp
        data = sp.page_data(sol, max_frames=max_frames, summary=summary)
        sc = sp.scales(sol)
    else:
        data, sc = page_data(sol, max_frames=max_frames, summary=summary), scales(sol)
    m = sol.model
    title = html.escape(title or m.name or "mechanism")
    n, total = len(data["t"]), int(len(sol.t))
    note = (f"{total} samples; the page shows {n} of them evenly spaced (results.csv has all)"
            if n < total else f"{total} samples")
    desc = f"<p class='desc'>{html.escape(m.description)}</p>" if m.description else ""
    body = _BODY.format(
        title=title, desc=desc, note=html.escape(note), intro=intro,
        summary=summary_html(summary, sc), model=model_html(sol),
        key=key_results_html(data["key"]))
    data = carried(data)
    return html_page(title=title, kind="linkdyn report", body=body, data=data,
                     script=("view2d.js", "view3d.js", "freebody.js", "report.js"),
                     footer="recursive DeNOC kinematics and inverse dynamics")


def html_page(*, title: str, body: str, data: dict, script: str | tuple, kind: str = "linkdyn",
              css: str = "", footer: str = "") -> str:
    """One self-contained page: the shared head and ``report.css`` (plus the page's own
    ``css``), its ``body``, ``data`` as JSON in ``#linkdyn-data`` and the script
    ``common.js`` + ``assets/<script>`` (a tuple: those files in order). ``title`` is already
    HTML-escaped."""
    blob = json.dumps(data, separators=(",", ":"), allow_nan=False)
    blob = blob.replace("</", "<\\/")  # never close the <script> early
    version = html.escape(_version())
    return _SHELL.format(title=title, kind=kind, version=version,
                         css=_asset("report.css") + css, body=body, data=blob,
                         js=_script(script),
                         footer=f"linkdyn {version}" + (f" · {footer}" if footer else ""))


def _asset(name: str) -> str:
    return resources.files("linkdyn.report").joinpath("assets", name).read_text("utf-8")


def _script(name: str | tuple) -> str:
    """A page's script: the shared helpers of ``assets/common.js`` (the global ``LD``), then
    the page's own ``assets/NAME`` (or each of the tuple ``NAME``, in order)."""
    names = (name,) if isinstance(name, str) else tuple(name)
    return "\n".join(_asset(n) for n in ("common.js",) + names)


def _version() -> str:
    from .._version import __version__
    return __version__


_SHELL = """<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<meta name="generator" content="linkdyn {version}">
<title>{title} — {kind}</title>
<style>
{css}
</style>
</head>
<body>
{body}<footer class="note">{footer}</footer>
<script id="linkdyn-data" type="application/json">{data}</script>
<script>
{js}
</script>
</body>
</html>
"""

_BODY = """<header>
<h1>{title}</h1>
{desc}
<p class="note">{note}. Angles in degrees, everything else SI. Click or drag on any plot to move
the time cursor; keys: space play/pause, ← → step.</p>
</header>
{intro}<section class="top">
  <div class="animbox">
    <svg id="anim" role="img" aria-label="animation of the mechanism"></svg>
    <div class="controls">
      <button id="play" type="button" title="play / pause (space)">▶ Play</button>
      <button id="stepback" type="button" title="previous frame (←)" aria-label="previous frame">◀</button>
      <button id="step" type="button" title="next frame (→)" aria-label="next frame">▶|</button>
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
      <label><input type="checkbox" id="show-forces"> forces</label>
      <label><input type="checkbox" id="show-ics"> instant centres</label>
      <span id="ratenote" class="note"></span>
    </div>
    <div id="forcekey" class="forcekey" hidden></div>
  </div>
  <aside class="info">
    <div id="time" class="time">t = 0 s</div>
    <div id="frameinfo" class="note"></div>
    <div id="drivers"></div>
    <div id="loaded" class="loaded"></div>
    <div class="scroll"><table id="jointforces" class="grid small"></table></div>
  </aside>
</section>
<section id="freebody">
  <h2>Free body <span class="note">every force on one link at the frame shown, and its force
  polygon: the forces head to tail, closed by their sum m a_G (Newton's law)</span></h2>
  <div class="controls"><label>link <select id="fbody"></select></label></div>
  <div class="fbwrap">
    <svg id="fbd" role="img" aria-label="free-body diagram of the link"></svg>
    <svg id="fbpoly" role="img" aria-label="force polygon of the link"></svg>
    <div class="scroll"><table id="fbtable" class="grid small"></table></div>
  </div>
</section>
<section class="keys">
<h2>Key results <span class="note">click one to show that instant</span></h2>
{key}
</section>
<section id="plotsec">
  <div class="plotbar"><h2>Plots</h2>
  <label>x axis <select id="xaxis"></select></label></div>
  <div id="plots"></div>
</section>
<section class="tables" id="summary">
<h2>Summary</h2>
<div class="scroll">{summary}</div>
</section>
<section class="tables" id="model">
<h2>Model</h2>
<div class="scroll">{model}</div>
</section>
"""
