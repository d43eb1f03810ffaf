"""Playback of report.html at the page's most frames: Hoeken's four-bar analyzed at 3601
samples (the page shows 2000 frames), played in headless Chromium with the plots on the
screen, against the same page's frame rate while paused, in the same run (a ratio: the
machine's and the browser's speed cancel out).

Prints the frames per second of each (median frame interval) and their ratio (issue 23's
target: playback keeps at least 0.8 of the paused rate, "a smooth cursor at any frame count").

Usage: python benchmarks/bench_page.py [--samples N] [--repeat R]
"""

from __future__ import annotations

import shutil
import statistics
import tempfile
from pathlib import Path

import numpy as np

import linkdyn
from linkdyn import design, report
from ratio import options, verdict  # noqa: E402

TARGET_RATIO = 0.8
SECONDS = 3.0

# a requestAnimationFrame loop's frame times over SECONDS (ms between frames, their median)
MEASURE = """s => new Promise(done => {
    const ts = [];
    const f = t => { ts.push(t); if (t - ts[0] < s * 1000) requestAnimationFrame(f);
                     else done(ts); };
    requestAnimationFrame(f);
})"""


def frame_rate(page, playing: bool) -> float:
    """Frames per second of the page over SECONDS, playing or paused (1000 / the median
    interval between animation frames)."""
    if playing:
        page.evaluate("document.getElementById('play').click()")
    ts = page.evaluate(MEASURE, SECONDS)
    if playing:
        page.evaluate("document.getElementById('play').click()")
    gaps = np.diff(ts)
    return 1000.0 / statistics.median(gaps.tolist())


def main() -> None:
    args = options(__doc__, samples=3601)
    from playwright.sync_api import sync_playwright

    mech = linkdyn.load(linkdyn.example_path("hoeken"))
    sol = linkdyn.analyze(mech, np.linspace(0.0, 8 / 3, args.samples))
    folder = Path(tempfile.mkdtemp())
    try:
        path = folder / "report.html"
        report.outputs(sol, design.summary(sol))["report.html"](path)
        exe = shutil.which("chromium") or "/usr/bin/chromium"
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=exe,
                                        args=["--headless", "--no-sandbox", "--disable-gpu"])
            page = browser.new_page(viewport={"width": 1440, "height": 900})
            page.goto(path.resolve().as_uri())
            page.wait_for_function("window.__linkdynFrame === 0")
            page.evaluate("window.scrollTo(0, document.getElementById('plotsec').offsetTop - 300)")
            frames = page.evaluate("JSON.parse(document.getElementById('linkdyn-data')"
                                   ".textContent).total_samples")
            paused = max(frame_rate(page, False) for _ in range(args.repeat))
            played = max(frame_rate(page, True) for _ in range(args.repeat))
            browser.close()
    finally:
        shutil.rmtree(folder, ignore_errors=True)
    print(f"report.html playback, Hoeken, {frames} samples "
          f"({min(frames, report.MAX_FRAMES)} frames), plots on the screen, 1440x900")
    print(f"  paused                 {paused:12.1f} frames/s")
    print(f"  playing                {played:12.1f} frames/s")
    print(verdict(played / paused, TARGET_RATIO))


if __name__ == "__main__":
    main()
