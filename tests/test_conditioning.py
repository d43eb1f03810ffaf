"""How well the free coordinates describe the motion (F10): ``forward.conditioning``'s growth,
from the null space of the closure by an SVD, against ``forward.closure_growth``, from the same null
space written in the free coordinates by a solve with ``J_dep``; at random closed states of a
five-bar with two free freedoms, a free slider-crank (a prismatic joint: the scaled rates) and
a chain of parallelogram windows."""

from __future__ import annotations

import tomllib

import numpy as np

import linkdyn
from linkdyn.forward import closure_growth, start_state, System, conditioning, partition

from builders import parallelogram_chain


def _free(name, initial):
    d = tomllib.loads(linkdyn.example_path(name).read_text())
    for key in ("analysis", "loads", "drivers"):
        d.pop(key, None)
    d["initial"] = {"q": initial}
    return linkdyn.model_from_dict(d)


def test_growth_of_the_free_coordinates_equals_the_null_space_s():
    rng = np.random.default_rng(5)
    models = (_free("fivebar", {"J5": 1.2, "J2": 2.0}), _free("slider_crank", {"J1": 30.0}),
              parallelogram_chain(4))
    seen = 0
    for model in models:
        part = partition(model)
        q0 = start_state(part)
        nf = len(part.free)
        system = System(part, q0, np.zeros(len(q0)))
        y0 = np.concatenate((q0[list(part.layout.topo.driven[part.n_drivers:])],
                             np.zeros(nf + 1)))
        for _ in range(5):
            y = y0 + np.concatenate((rng.uniform(-0.5, 0.5, nf), np.zeros(nf + 1)))
            J = system.accept(0.0, y)
            if J is None:
                continue
            seen += 1
            growth = conditioning(part, J)[0]
            # at least 1: the free coordinates' own rates per unit of theirs are the identity
            assert growth >= 1.0 - 1e-12
            assert abs(closure_growth(part, J) - growth) <= 1e-9 * growth, model.name
    assert seen >= 12
