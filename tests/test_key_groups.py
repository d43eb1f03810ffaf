"""The report's key result groups keep one colour each on every page (they were coloured by
their position on the page, so a page without four-bar loops shifted every later group)."""

from __future__ import annotations

import re

import numpy as np

import linkdyn
from linkdyn import report


def test_each_key_result_group_keeps_its_colour_on_every_page():
    # the group colours were by position: a page without four-bar loops shifted the rest
    seen: dict[str, set] = {}
    for name in ("hoeken", "slider_crank", "scotch_yoke"):
        model = linkdyn.load(linkdyn.example_path(name))
        sol = linkdyn.analyze(model, np.linspace(0.0, 0.5, 7), backend="numpy")
        html = report.tables.key_results_html(report.page_data(sol)["key"])
        for cls, group in re.findall(r"class='keyitem (g\d)' data-group='([^']*)'", html):
            seen.setdefault(group, set()).add(cls)
    assert {"Four-bar loops", "Slider dyads", "Energy"} <= set(seen)
    assert all(len(c) == 1 for c in seen.values()), seen
    assert len({c for cs in seen.values() for c in cs}) == len(seen)   # one colour per group
