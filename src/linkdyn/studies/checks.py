"""Checks of a design study's inputs (``sweep``, ``optimize``, ``compare --sweep``), each a small
function that returns the value to use or raises :class:`~linkdyn.errors.ModelError` naming the
option (or the Python argument) and the fix, before anything is solved or written.

Sizes are bounded before anything is allocated: a sweep's table of designs must fit in the
machine's memory and, run locally, be expected to finish within :data:`MAX_SECONDS` at the
fastest rate measured (:data:`RATES`), as ``analyze --samples`` is bounded by the memory.
"""

from __future__ import annotations

import math
import numbers
import os

import numpy as np

from ..errors import ModelError
from ..sampling import memory

#: Largest seed (numpy and scipy take seeds from 0 to 2**32 - 1 alike).
MAX_SEED = 2 ** 32 - 1
#: Local worker processes per core at most.
WORKERS_PER_CPU = 4
#: Peak memory of a sweep per design and per column of its table (parameters, ``valid``,
#: ``reason``, metrics), bytes: the chunks' columns, their concatenation, the DataFrame and
#: the Parquet writer's copy each hold one (measured about 20 B on Hoeken).
BYTES_PER_DESIGN_VALUE = 40
#: Memory of the reason of an invalid design (a message of about 150 characters), bytes.
BYTES_PER_REASON = 250
#: Fastest sweep rates measured, design-samples per second per worker
#: (docs/design-studies.md: 3.1-3.3e6 compiled on Hoeken; numpy about a tenth of it).
RATES = {"compiled": 4e6, "numpy": 4e5}
#: Longest local sweep accepted (estimated at :data:`RATES`), s: one day.
MAX_SECONDS = 86_400.0


def _integer(value, option: str, what: str):
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise ModelError(f"{option} must be a whole number ({what}), got {value!r}",
                         field=option, fix=f"Give {option} as a whole number")
    return int(value)


def seed(value, option: str = "--seed") -> int | None:
    """A seed of the random designs and of the optimizer: None or 0 .. :data:`MAX_SEED`."""
    if value is None:
        return None
    value = _integer(value, option, "a seed")
    if not 0 <= value <= MAX_SEED:
        raise ModelError(f"{option} must be from 0 to {MAX_SEED}, got {value}", field=option,
                         fix=f"Give {option} 0 or another seed up to 2**32 - 1")
    return value


def fluctuation(value, option: str = "--fluctuation") -> float:
    """The coefficient of speed fluctuation C_s of ``flywheel_inertia``: finite and positive."""
    try:
        c = float(value)
    except (TypeError, ValueError):
        c = math.nan
    if not (math.isfinite(c) and c > 0):
        raise ModelError(f"the coefficient of speed fluctuation must be a positive, finite "
                         f"number, got {value!r}", field=option,
                         fix=f"Give {option} e.g. 0.02 (C_s = (w_max - w_min) / w_mean)")
    return c


def count(value, option: str, what: str) -> int | None:
    """A number of designs, of designs per chunk: None (the default) or a whole number >= 1."""
    if value is None:
        return None
    value = _integer(value, option, what)
    if value < 1:
        raise ModelError(f"{option} must be at least 1 ({what}), got {value}", field=option,
                         fix=f"Give {option} 1 or more, or leave it out for the default")
    return value


def workers(value, option: str = "--workers") -> int:
    """Local worker processes: 1 .. :data:`WORKERS_PER_CPU` per core of this machine."""
    value = _integer(value, option, "worker processes")
    top = WORKERS_PER_CPU * (os.cpu_count() or 1)
    if not 1 <= value <= top:
        raise ModelError(f"{option} must be from 1 to {top} ({WORKERS_PER_CPU} per core of this "
                         f"machine), got {value}", field=option,
                         fix=f"Give {option} up to {os.cpu_count() or 1} (one per core runs "
                             "fastest), or --scheduler ADDRESS for a cluster")
    return value


def times(t, name: str = "t") -> np.ndarray:
    """Sample times of a study: a 1-D array of finite times, s."""
    if isinstance(t, (str, bytes)):
        t = None
    try:
        arr = np.asarray(t, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{name} must be an array of times (s), not {type(t).__name__}",
                         field=name, fix="Pass t = numpy.linspace(0, duration, samples)") \
            from None
    if arr.ndim != 1 or arr.size < 1:
        raise ModelError(f"{name} must be a 1-D array of at least one time, got shape "
                         f"{arr.shape}", field=name,
                         fix="Pass t = numpy.linspace(0, duration, samples)")
    if not np.all(np.isfinite(arr)):
        k = int(np.argmin(np.isfinite(arr)))
        raise ModelError(f"{name}[{k}] = {arr[k]} is not a finite time", field=name,
                         fix="Pass finite times, e.g. numpy.linspace(0, duration, samples)")
    return arr


def pair(value, name: str, what: str) -> tuple[float, float]:
    """Two finite numbers ``(a, b)`` (a bound, a path range)."""
    try:
        a, b = (float(x) for x in value)
    except (TypeError, ValueError):
        raise ModelError(f"{name} must be two numbers ({what}), got {value!r}", field=name,
                         fix="Give two numbers (LO, HI)") from None
    if not (math.isfinite(a) and math.isfinite(b)):
        raise ModelError(f"{name} must be two finite numbers ({what}), got {value!r}",
                         field=name, fix="Give two finite numbers (LO, HI)")
    return a, b


def path_range(value, name: str = "path_range") -> tuple[float, float] | None:
    """The driver range of ``path_deviation``: None or two finite numbers (rad or m)."""
    return None if value is None else pair(value, name, "the first driver's range, rad or m")


def sweep_size(designs: int, params: int, metrics: int, samples: int, *, workers: int = 1,
               backend: str = "numpy", local: bool = True, option: str = "--designs") -> None:
    """Refuse a sweep whose table cannot fit in memory or which, run locally, cannot finish
    within :data:`MAX_SECONDS` even at the fastest rate measured (:data:`RATES`).

    Parameters
    ----------
    designs, params, metrics, samples : int
        D designs of P parameters, M metrics each, T samples per design.
    workers : int
        Local worker processes.
    backend : {'numpy', 'compiled'}
        The backend the sweep would run.
    local : bool
        Run on this machine (no ``--scheduler``, whose cluster's speed is not known).
    option : str
        What set the number of designs, for the message.
    """
    need = float(designs) * ((params + metrics + 2) * BYTES_PER_DESIGN_VALUE + BYTES_PER_REASON)
    have = memory()
    if need > have:
        raise ModelError(f"{designs:,} designs would need about {need / 1e9:.3g} GB of memory "
                         f"for their table, more than this machine has ({have / 1e9:.3g} GB)",
                         field=option, fix="Give fewer designs, or split the sweep into several "
                                           "(each its own -o folder)")
    if not local:
        return
    rate = RATES.get(backend, RATES["numpy"]) * max(workers, 1)
    seconds = float(designs) * samples / rate
    if seconds > MAX_SECONDS:
        raise ModelError(f"{designs:,} designs x {samples:,} samples would take at least "
                         f"{seconds / 3600:.3g} h on {workers} worker{'s' * (workers > 1)} (at "
                         f"{rate:.3g} design-samples/s, the fastest measured), more than the "
                         f"limit of {MAX_SECONDS / 3600:.3g} h", field=option,
                         fix="Give fewer designs or samples, more --workers, or run it on a "
                             "cluster with --scheduler ADDRESS")


def grid_count(counts, option: str = "--vary") -> int:
    """Designs of a grid: the product of the counts (exact, before anything is allocated)."""
    return math.prod(int(c) for c in counts)


def designs_table(params, name: str = "params") -> tuple[list[str], np.ndarray]:
    """``{path: values}`` (or a DataFrame of designs) -> (paths, values (D, P)): at least one
    parameter, one finite number per design for each."""
    if hasattr(params, "columns"):  # a DataFrame of designs
        params = {c: params[c] for c in params.columns}
    if not isinstance(params, dict) or not params:
        raise ModelError(f"{name} must name at least one parameter, got {params!r:.80}",
                         field=name, fix="Pass {path: values}, e.g. {'bodies.crank.mass': "
                                         "[1.0, 1.5, 2.0]}")
    paths = list(params)
    arrays = []
    for p in paths:
        try:
            a = np.asarray(params[p], dtype=float).ravel()
        except (TypeError, ValueError):
            raise ModelError(f"the values of {p!r} are not numbers", field=f"{name}[{p!r}]",
                             fix="Give an array of numbers in the file's units") from None
        if not a.size or not np.all(np.isfinite(a)):
            raise ModelError(f"the values of {p!r} must be finite numbers, at least one",
                             field=f"{name}[{p!r}]", fix="Give finite numbers in the file's "
                                                          "units")
        arrays.append(a)
    if len({len(a) for a in arrays}) > 1:
        raise ModelError("the parameters have different numbers of values",
                         field=", ".join(map(str, paths)),
                         fix="Give one value per design for each parameter, or use "
                             "linkdyn.studies.grid({...}) for every combination")
    return paths, np.stack(arrays, axis=-1)
