"""Design studies: vary numbers of a model file, solve every design, keep one row of metrics each.

- :mod:`.params`: design parameters named by dotted field paths (``bodies.crank.mass``), in the
  file's units, applied to the parsed file and rebuilt by :func:`linkdyn.model_from_dict`;
- :mod:`.metrics`: the per-design metrics (peak and RMS efforts, joint forces, transmission
  angle, path deviation, shaking force, flywheel), from the functions the summary uses;
- :mod:`.runner`: designs in chunks, locally, in worker processes or on a Dask cluster, resumable;
- :mod:`.optimize`: differential evolution over the same space, one generation per batch;
- :mod:`.checks`: the studies' inputs (seeds, counts, sizes, times, ranges) checked before any
  work; :mod:`.files`: the chunks folder, earlier outputs, a designs CSV and a sweep's folder,
  read and removed so that nothing a study did not write is touched.
"""

from __future__ import annotations

import numpy as np

from .metrics import check_names
from .metrics import evaluate as evaluate_metrics
from .metrics import names as metric_names
from .params import Parameter, Space, check_ranges, resolve, space
from .runner import Task, run, sample

__all__ = ["sweep", "grid", "sample", "space", "resolve", "check_ranges", "Parameter", "Space",
           "metric_names", "evaluate_metrics", "Task", "run"]


def grid(params: dict) -> dict:
    """Every combination of the values of each parameter: ``{path: values (D,)}`` with
    D the product of the lengths (the first parameter varies slowest)."""
    mesh = np.meshgrid(*[np.asarray(v, float).ravel() for v in params.values()], indexing="ij")
    return {p: g.ravel() for p, g in zip(params, mesh)}


def sweep(model, params, t, metrics=None, *, outdir=None, resume=False, workers: int = 1,
          scheduler=None, chunk=None, backend=None, path_point=None, path_range=None,
          fluctuation: float = 0.02, progress: bool = False):
    """Solve many designs of ``model`` and return one row of metrics per design.

    Parameters
    ----------
    model : str, os.PathLike, dict or Model
        A model file (parameters in its units, as written), a parsed model dict, or a Model.
    params : dict or pandas.DataFrame
        ``{path: values}``: one array of D values per dotted field path (design k takes the k-th
        value of each; :func:`grid` makes every combination), in the file's units.
    t : array_like (T,)
        Sample times, s (the same for every design).
    metrics : sequence of str, optional
        Metric names (default: every metric of the model, see :mod:`linkdyn.studies.metrics`).
    outdir : path, optional
        Write finished chunks there as they finish, then ``designs.parquet`` and ``summary.json``.
    resume : bool
        Continue an interrupted sweep in ``outdir`` without recomputing its finished chunks.
    workers : int
        Local worker processes; ``scheduler`` (address or ``distributed.Client``) uses a Dask
        cluster instead. The results are the same either way.
    chunk : int, optional
        Designs per chunk (memory is bounded by one chunk's time histories per worker).
    backend : str, optional
        ``'numpy'`` or ``'compiled'`` (see :func:`linkdyn.analyze`).
    path_point, path_range, fluctuation
        For ``path_deviation`` (range of the first driver's coordinate, rad or m) and
        ``flywheel_inertia`` (coefficient of speed fluctuation).

    Returns
    -------
    pandas.DataFrame
        Columns ``design``, one per parameter path, ``valid``, ``reason`` and the metrics (SI);
        ``df.attrs['stats']``: chunks computed and reused, seconds, design-samples per second.
    """
    from .checks import designs_table

    paths, values = designs_table(params)
    sp = space(model, paths)
    names = tuple(check_names(sp.model(), metrics, path_point=path_point))
    task = Task(sp, t, names, backend, path_point, path_range, fluctuation)
    df, stats = run(task, values, outdir=outdir, resume=resume, chunk=chunk, workers=workers,
                    scheduler=scheduler, progress=progress)
    if outdir is not None:
        from .runner import summary, write_results
        write_results(outdir, df, summary(task, df, stats))
    df.attrs["stats"] = stats
    return df
