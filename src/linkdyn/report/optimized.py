"""The head of ``linkdyn optimize --report``'s page: what was optimized, to what value, under
which constraints (each active or not) and by changing which parameters, from
:func:`linkdyn.studies.optimize.standing`."""

from __future__ import annotations

import html

from .tables import fmt


def optimize_html(st: dict, *, evaluations: int, seconds: float) -> str:
    """The section shown first on the best design's report page.

    Parameters
    ----------
    st : dict
        :func:`linkdyn.studies.optimize.standing` of the run (values in the model file's units).
    evaluations : int
        Designs solved.
    seconds : float
        Wall time of the search.
    """
    e = html.escape
    ob = st["objective"]
    verb = "minimized" if ob["sense"] == "min" else "maximized"
    cons = "".join(
        f"<tr data-metric='{e(c['metric'])}' class='{'active' if c['active'] else ''}'>"
        f"<th>{e(c['text'])}</th><td class='num'>{e(c['shown'])}</td>"
        f"<td>{'active (at its bound: it limits the design)' if c['active'] else 'holds with room'}"
        f"</td></tr>" for c in st["constraints"])
    cons = (f"<table class='grid' id='opt-constraints'><thead><tr><th>constraint</th>"
            f"<th>best design</th><th>status</th></tr></thead><tbody>{cons}</tbody></table>"
            if cons else "<p class='note'>No constraints.</p>")
    rows = ""
    for p in st["parameters"]:
        unit = f" {p['unit']}" if p["unit"] else ""
        pct = f" ({'+' if p['pct'] > 0 else ''}{fmt(p['pct'])} %)" if p["pct"] is not None else ""
        edge = (f"at the {p['at_bound']} bound of its range ({fmt(p['range'][0])} .. "
                f"{fmt(p['range'][1])}{unit}): the optimum may lie beyond it"
                if p["at_bound"] else "")
        rows += (f"<tr data-path='{e(p['path'])}'><th><code>{e(p['path'])}</code></th>"
                 f"<td class='num'>{e(fmt(p['base']) + unit)}</td>"
                 f"<td class='num'><b>{e(fmt(p['best']) + unit)}</b></td>"
                 f"<td class='num'>{e(('+' if p['change'] > 0 else '') + fmt(p['change']) + unit + pct)}"
                 f"</td><td class='edge'>{e(edge)}</td></tr>")
    return (f"<section class='tables optim' id='optimize'>"
            f"<h2>Optimized: {e(ob['metric'])} {verb} to <span class='num'>{e(ob['shown'])}"
            f"</span></h2>"
            f"<p class='note'>linkdyn optimize solved {evaluations} designs in {seconds:.3g} s; "
            f"this page and results.csv are the best design's run.</p>"
            f"<h3>Constraints</h3><div class='scroll'>{cons}</div>"
            f"<h3>Parameters changed</h3><div class='scroll'><table class='grid' id='opt-params'>"
            f"<thead><tr><th>parameter</th><th>base model</th><th>best design</th><th>change</th>"
            f"<th></th></tr></thead><tbody>{rows}</tbody></table></div></section>")
