"""Each compiled kernel compiles once: numba compiles a kernel again for every other
combination of its arguments' layouts ('C', 'A', 'F'), read-only flags and literal integers,
40 s and more each on a fresh machine. The entry points hand every kernel one array type
(``kinematics.compiled.fixed``) whatever their callers pass: one mechanism, a batch of designs,
a layout that went through pickle (as to a sweep's worker process), a sweep's fused kernel.
(Run on the compiled worker.)"""

from __future__ import annotations

import pickle

import numpy as np
import pytest

import linkdyn
from linkdyn import analysis
from linkdyn.kinematics.layout import compile_designs

pytest.importorskip("numba", reason="the compiled kernels need numba (the fast extra)")

from test_compiled_dynamics import hoeken_design  # noqa: E402


def test_each_kernel_compiles_once_whatever_its_callers_pass():
    from linkdyn.dynamics import compiled as dc
    from linkdyn.kinematics import compiled as kc
    from linkdyn.kinematics import compiled_nodes as kn

    one = hoeken_design(38.1)
    designs = [one, hoeken_design(42.0)]
    t = np.linspace(0.0, 4.0 / 3.0, 7)
    lay = compile_designs(designs)
    linkdyn.analyze(one, t, backend="compiled")
    linkdyn.analyze(designs, t, backend="compiled")
    analysis.analyze_layout(designs, pickle.loads(pickle.dumps(lay)), t, backend="compiled")
    # the sweep's fused kernel (reactions left to be read)
    lazy = analysis.analyze_layout(designs, lay, t, backend="compiled", reactions=False)
    assert np.all(np.isfinite(lazy.design(1).reactions.force))
    # the entry points, called from Python: one signature each, compiled or loaded from the cache
    for kernel in (kc.kernel, kn.kernel, dc._dynamics, dc._reactions, dc._sweep):
        assert len(kernel.signatures) == 1, (kernel.__name__, kernel.signatures)
    # block, called only inside kernel and _sweep: compiled once, or not at all when both were
    # loaded from numba's cache
    assert len(kc.block.signatures) <= 1, kc.block.signatures
