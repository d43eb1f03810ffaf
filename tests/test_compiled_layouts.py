"""The compiled kernels give numpy's numbers whatever array layouts their callers hand them:
one mechanism, a batch of designs, a layout that went through pickle (as to a sweep's worker
process), a layout whose arrays are read-only views or Fortran-ordered copies, and the sweep's
fused kernel with the reactions left to be read. (Behaviour only: how many signatures numba
compiles is its business; the compile time is measured in ``benchmarks/``.) Run on the
compiled worker."""

from __future__ import annotations

import dataclasses
import pickle

import numpy as np
import pytest

import linkdyn
from linkdyn import analysis
from linkdyn.kinematics.layout import compile_designs

pytest.importorskip("numba", reason="the compiled kernels need numba (the fast extra)")

from test_compiled_dynamics import hoeken_design  # noqa: E402
from test_golden import scales  # noqa: E402


def relayout(lay, how):
    """``lay`` with every array field read-only (a broadcast-like view) or Fortran-ordered."""
    def conv(x):
        if not isinstance(x, np.ndarray) or x.dtype == object:
            return x
        y = np.asfortranarray(x) if how == "F" else x.view()
        if how == "readonly":
            y.flags.writeable = False
        return y
    return dataclasses.replace(lay, **{f.name: conv(getattr(lay, f.name))
                                       for f in dataclasses.fields(lay)})


def assert_same(got, ref, what):
    cols, scale = got.columns, scales(ref.columns)
    bad = {c: float(np.max(np.abs(cols[c] - v))) / scale[c] for c, v in ref.columns.items()
           if not np.max(np.abs(cols[c] - v)) <= 1e-12 * scale[c]}
    assert not bad, f"{what}: {bad}"


@pytest.mark.parametrize("how", ["pickled", "readonly", "F"])
def test_compiled_equals_numpy_whatever_the_layout(how):
    designs = [hoeken_design(38.1), hoeken_design(42.0)]
    t = np.linspace(0.0, 4.0 / 3.0, 7)
    lay = compile_designs(designs)
    ref = analysis.analyze_layout(designs, lay, t, backend="numpy")
    other = (pickle.loads(pickle.dumps(lay)) if how == "pickled" else relayout(lay, how))
    sol = analysis.analyze_layout(designs, other, t, backend="compiled")
    for k in range(len(designs)):
        assert_same(sol.design(k), ref.design(k), f"{how} layout, design {k}")
    # the sweep's fused kernel, its reactions read afterwards
    lazy = analysis.analyze_layout(designs, other, t, backend="compiled", reactions=False)
    assert_same(lazy.design(1), ref.design(1), f"{how} layout, fused kernel")
    # one mechanism, as analyze is called
    assert_same(linkdyn.analyze(designs[0], t, backend="compiled"),
                linkdyn.analyze(designs[0], t, backend="numpy"), "one mechanism")
