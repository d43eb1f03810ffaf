"""``report.html``: one self-contained, offline page to look at a solution.

An animation of the mechanism (bodies through their named points, pivots, sliders, traced
coupler points) with play / scrub / speed controls, small-multiple plots of the joint motion,
driver efforts, joint reactions and cut-joint multipliers that follow the animation's time
cursor, the run summary and the model's description.

Everything is inline: the page's CSS and JavaScript come from ``assets/`` and the data is a JSON
blob in a ``<script type="application/json">``; no network access, no external resource.
Long runs are downsampled for the page (``max_frames``); ``results.csv`` keeps every sample.

Display units: angles in degrees, everything else SI (m, s, rad/s, N, N m).

:mod:`.data` selects the frames and builds the JSON data the page's script draws from
(:mod:`.spatial` for spatial models: a 3-D view the user turns and zooms, ``assets/view3d.js``,
in place of the plane's ``assets/view2d.js``), :mod:`.tables` lays out the summary and the model
as HTML tables, and :mod:`.page` assembles the document.
"""

from .data import (BODY_COLORS, DEG, M_COLOR, MAX_FRAMES, PALETTE, X_COLOR, Y_COLOR,
                   frame_indices, joint_roles, multiplier_labels, page_data)
from .keys import key_results
from .page import outputs, render
from .tables import fmt, key_results_html, model_html, pretty_key, summary_html

__all__ = ["outputs", "render", "page_data", "key_results", "frame_indices", "joint_roles", "multiplier_labels",
           "fmt", "pretty_key", "summary_html", "key_results_html", "model_html", "MAX_FRAMES",
           "DEG", "PALETTE", "BODY_COLORS", "X_COLOR", "Y_COLOR", "M_COLOR"]
