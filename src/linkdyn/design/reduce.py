"""The sweep metrics' reductions one sample at a time: the steps (:mod:`linkdyn.steps`) of
:func:`linkdyn.design.overview.peak` and :func:`~linkdyn.design.overview.rms`, which those
functions call on arrays and the sweep kernel (:func:`linkdyn.dynamics.compiled.sweep` with
``metrics``) calls on each sample of a design as it solves it, keeping no sample."""

from __future__ import annotations

import numpy as np

from ..steps import select, step


@step
def larger_magnitude(acc, x):
    """:func:`~linkdyn.design.overview.peak` one sample at a time: the running largest ``|x|`` ``acc`` (from 0) with
    the sample ``x``; a NaN sample leaves it."""
    a = np.abs(x)
    return select(a > acc, a, acc)


@step
def plus_square(acc, x):
    """:func:`~linkdyn.design.overview.rms` one sample at a time: the running sum of squares ``acc`` (from 0) with the
    sample ``x``."""
    return acc + x * x


@step
def root_mean(sum_sq, n):
    """:func:`~linkdyn.design.overview.rms` of ``n`` samples from the sum of their squares."""
    return np.sqrt(sum_sq / n)
