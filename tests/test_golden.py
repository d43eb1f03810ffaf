"""Golden outputs: every column of every bundled example, on both backends, against the
numbers stored in ``tests/data/golden.npz`` (recorded by ``tests/golden.py``: the first seven
examples before the core was restructured for issue 12, the Scotch yoke once it was bundled);
and every column of short ``simulate`` runs, every metric of a seeded ``sweep`` and the best
design of a seeded ``optimize``, against ``tests/data/golden_runs.npz`` (recorded at 1fa002c,
before the core was restructured for issue 21). An
example whose joint kinds the compiled kernels have no code for must be refused by an explicit
``backend="compiled"`` with a message naming the kind, and run on numpy under ``"auto"``.

Each column must agree to 1e-12 of its scale: the column's peak, or the peak of its family of
the same unit in that example when larger (a column that is rounding noise, as the angle of a
slider that never turns, is held to its family's scale, not to its own noise). A refactoring
that changes any result beyond rounding fails here (a sweep's metric is held to its own peak
over the designs; the optimizer must find the same best design, each parameter to 1e-12 of its
range, each metric to 1e-12 of its value); an output meant to change is re-recorded
with ``python tests/golden.py`` and the commit says why.

A ``simulate`` run is held to 1e-8 of its scale instead: an integration carries the rounding of
every step forward, and the machine's own rounding moves it. Measured: the same commit on the
same numpy and scipy, with OpenBLAS's AVX-512 kernels against its AVX2 ones
(``OPENBLAS_CORETYPE=Haswell``), differs by 9.2e-10 on ``fourbar_release`` and 1.7e-12 on
``toggle_spring``, far below the runs' integration tolerances (1e-8 and 1e-5), which a change of
method or formula would cross.
"""

from __future__ import annotations

import numpy as np
import pytest

import linkdyn
from linkdyn import compiled

import golden

RTOL = 1e-12
SIMULATE_RTOL = 1e-8   # an integration's rounding grows with its steps (the docstring)
STORED = np.load(golden.PATH)
STORED_EXAMPLES = sorted({k.split("/")[0] for k in STORED.files})
RUNS = np.load(golden.RUNS)
BACKENDS = ["numpy", pytest.param("compiled", marks=pytest.mark.skipif(
    compiled.numba is None, reason="the compiled backend needs numba"))]


def family(column: str) -> str:
    """The unit family of a column: x and y share one, as do Fx and Fy, and the energies."""
    head = column.split("_")[0]
    return {"y": "x", "Fy": "Fx", "potential": "kinetic"}.get(head, head)


def scales(columns: dict[str, np.ndarray]) -> dict[str, float]:
    """Each column's scale: the larger of its peak and its family's peak; a moment's family
    scale is the peak force times the peak coordinate (N m)."""
    peak = {c: float(np.nanmax(np.abs(v))) for c, v in columns.items()}
    fam: dict[str, float] = {}
    for c, p in peak.items():
        fam[family(c)] = max(fam.get(family(c), 0.0), p)
    fam["M"] = max(fam.get("M", 0.0), fam.get("Fx", 0.0) * fam.get("x", 0.0))
    return {c: max(p, fam[family(c)]) for c, p in peak.items()}


def test_stored_file_covers_every_example():
    # the record holds every bundled example (the first seven as they were before issue 12's
    # restructuring; an example added since is recorded by `python tests/golden.py`)
    assert len(STORED_EXAMPLES) >= 8
    missing = set(golden.EXAMPLES) - set(STORED_EXAMPLES)
    assert not missing, f"not recorded: {sorted(missing)}; run: PYTHONPATH=src python tests/golden.py"
    assert set(STORED_EXAMPLES) <= set(golden.EXAMPLES)
    assert golden.PATH.stat().st_size < 1_000_000


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("example", STORED_EXAMPLES)
def test_outputs_match_stored(example, backend):
    mech, t = golden.times(example)
    kinds = compiled.unsupported([j.kind for j in mech.joints])
    if backend == "compiled" and kinds:
        # no kernel code for this kind: an explicit request is refused by name, auto runs numpy
        with pytest.raises(ValueError, match=kinds[0]):
            linkdyn.analyze(mech, t, backend="compiled")
        backend = "auto"
    cols = linkdyn.analyze(mech, t, backend=backend).columns
    stored = {k.split("/", 1)[1]: STORED[k] for k in STORED.files
              if k.split("/")[0] == example}
    missing = set(stored) - set(cols)
    assert not missing, f"{example}: columns gone: {sorted(missing)}"
    scale = scales(stored)
    bad = {}
    for c, ref in stored.items():
        err = float(np.max(np.abs(cols[c] - ref)))
        if not err <= RTOL * scale[c]:   # NaN fails too
            bad[c] = err / scale[c]
    assert not bad, f"{example} ({backend}): columns off by (relative to scale): {bad}"


def test_scale_floor_is_not_loose():
    # the family floor lifts noise columns only: a real column keeps its own peak as scale
    s = scales({"x_a.P": np.array([0.0, 0.5]), "y_b.Q": np.array([1e-17, 0.0]),
                "Fx_J1": np.array([10.0]), "M_J2": np.array([1e-15]), "phi_b": np.array([3.0])})
    assert s == {"x_a.P": 0.5, "y_b.Q": 0.5, "Fx_J1": 10.0, "M_J2": 5.0, "phi_b": 3.0}


def stored_run(prefix: str) -> dict[str, np.ndarray]:
    """The stored columns of one run of ``golden_runs.npz``, keyed by what follows ``prefix/``."""
    return {k[len(prefix) + 1:]: RUNS[k] for k in RUNS.files if k.startswith(prefix + "/")}


def off(got: dict, stored: dict, scale: dict, rtol: float = RTOL) -> dict[str, float]:
    """The columns of ``got`` farther than ``rtol * scale`` from ``stored`` (NaN where the
    stored value is NaN is agreement; anywhere else it fails), relative to their scale."""
    missing = set(stored) - set(got)
    assert not missing, f"columns gone: {sorted(missing)}"
    bad = {}
    for c, ref in stored.items():
        new = np.asarray(got[c], float)
        same_nan = np.array_equal(np.isnan(new), np.isnan(ref))
        err = float(np.nanmax(np.abs(new - ref), initial=0.0))
        if not (same_nan and err <= rtol * scale[c]):
            bad[c] = err / scale[c] if same_nan else "NaN moved"
    return bad


def test_stored_runs_cover_every_case():
    # every simulate example (and the released Hoeken), the sweep and the optimize are recorded
    runs = {golden.run_of(k) for k in RUNS.files}
    assert {f"simulate/{c}" for c in golden.SIMULATE} | {"sweep", "optimize"} <= runs
    assert set(golden.SIMULATE_EXAMPLES) <= set(golden.SIMULATE)
    assert golden.PATH.stat().st_size + golden.RUNS.stat().st_size < 1_000_000


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("case", sorted(golden.SIMULATE))
def test_simulate_matches_stored(case, backend):
    stored = stored_run(f"simulate/{case}")
    bad = off(golden.simulate(case, backend), stored, scales(stored), SIMULATE_RTOL)
    assert not bad, f"simulate {case} ({backend}): columns off by (relative to scale): {bad}"


@pytest.mark.parametrize("backend", BACKENDS)
def test_sweep_matches_stored(backend):
    # each metric (and each parameter) over the designs, to 1e-12 of its own peak
    stored = stored_run("sweep")
    assert stored["valid"].sum() >= len(stored["valid"]) // 2     # a study, not a failed one
    scale = {c: float(np.nanmax(np.abs(v), initial=0.0)) or 1.0 for c, v in stored.items()}
    bad = off(golden.sweep(backend), stored, scale)
    assert not bad, f"sweep ({backend}): columns off by (relative to their peak): {bad}"


@pytest.mark.parametrize("backend", BACKENDS)
def test_optimize_finds_the_stored_design(backend):
    stored = stored_run("optimize")
    scale = {c: (np.subtract(*golden.BOUNDS[c[len("values/"):]][::-1])
                 if c.startswith("values/") else abs(float(v)))
             for c, v in stored.items()}
    bad = off(golden.optimize(backend), stored, scale)
    assert not bad, f"optimize ({backend}): off by (relative to range or value): {bad}"
