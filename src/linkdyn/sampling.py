"""The sample times of a run: the rules by which the options and a model's ``[analysis]``
give them (``linkdyn analyze``, ``simulate``, ``sweep``, ``optimize``, ``compare``), and the
bound of the machine's memory on them."""

from __future__ import annotations

import os

import numpy as np

from .errors import ModelError

BYTES_PER_VALUE = 64   # peak memory of a run per result column and sample (measured ~32 B)


def memory() -> float:
    """Physical memory of this machine, bytes (inf if unknown)."""
    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not POSIX
        return float("inf")


def check_memory(mech, samples: int, field: str) -> None:
    """Raise, naming ``field`` and the limit, when ``samples`` samples of ``mech``'s results
    would not fit in this machine's memory."""
    columns = (2 + 5 * len(mech.joints) + 3 * len(mech.moving_bodies) + len(mech.drivers)
               + 2 * sum(len(b.points) for b in mech.moving_bodies))
    need = float(samples) * columns * BYTES_PER_VALUE
    if need > memory():
        raise ModelError(f"{samples} samples would need about {need / 1e9:.3g} GB of memory, more "
                         f"than this machine has ({memory() / 1e9:.3g} GB)", field=field,
                         fix="Give fewer samples, or split the run into parts with --duration")


def times(mech, samples, duration, cycles) -> np.ndarray:
    """Sample times: the options, else the model's [analysis], else 361 samples of one cycle.

    Each number is checked where it comes from (the option, or the model's ``analysis.*``
    field): at least 2 samples, and no more than the memory of the machine holds; a finite,
    positive duration; cycles only for a driver turning at constant speed.
    """
    n_field = "--samples" if samples is not None else "analysis.samples"
    if samples is None:
        samples = mech.samples or 361
    if samples < 2:
        raise ModelError(f"{n_field} must be at least 2, got {samples}", field=n_field,
                         fix="Give --samples 2 or more")
    check_memory(mech, samples, n_field)
    if duration is None and cycles is None:
        duration, cycles = mech.duration, mech.cycles
        d_field, c_field = "analysis.duration", "analysis.cycles"
    else:
        d_field, c_field = "--duration", "--cycles"
    if cycles is not None and not (cycles > 0 and np.isfinite(cycles)):
        raise ModelError(f"{c_field} must be a positive number, got {cycles}", field=c_field,
                         fix="Give a positive, finite number of driver turns")
    if duration is None:
        periods = [d.period for d in mech.drivers if d.period]
        if not periods:
            if cycles is not None:
                raise ModelError("a cycle is one turn of a driver turning at constant speed, and "
                                 "no driver of this model does", field=c_field,
                                 fix="Give --duration T (s) instead")
            raise ModelError("no duration: the drivers do not rotate at constant speed, so "
                             "a cycle is undefined", field="analysis.duration",
                             fix="Give --duration T (s) or [analysis] duration")
        duration = (1.0 if cycles is None else cycles) * periods[0]
        if not np.isfinite(duration):  # a speed so small that a turn takes forever
            k = next(k for k, d in enumerate(mech.drivers) if d.period)
            raise ModelError(f"a turn of driver {mech.drivers[k].joint} takes {periods[0]:.6g} "
                             "s at this speed, so a cycle cannot be sampled",
                             field=f"drivers[{k}].motion",
                             fix="Give --duration T (s), or a larger speed")
        d_field = c_field if cycles is not None else d_field
    if not (duration > 0 and np.isfinite(duration)):
        raise ModelError(f"the duration must be positive and finite (s), got "
                         f"{duration}", field=d_field, fix="Give a positive duration in s")
    return np.linspace(0.0, float(duration), int(samples))
