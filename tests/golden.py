"""The stored golden outputs of the bundled examples (``tests/data/golden.npz``).

Every output column (``Solution.columns``) of every bundled example, at ``SAMPLES`` samples of
the example's default run (its ``[analysis]`` duration or cycles, else one cycle: the CLI's
``analyze`` times), recorded with the numpy backend. ``tests/test_golden.py`` holds both backends
to these numbers, so a refactoring of the core cannot change a result unnoticed.

Record a bundled example added since (the stored ones are kept as they are)::

    PYTHONPATH=src python tests/golden.py

Re-record every example (only when an output is meant to change; say why in the commit)::

    PYTHONPATH=src python tests/golden.py --all
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

import linkdyn
from linkdyn.cli import _times

SAMPLES = 61
PATH = Path(__file__).with_name("data") / "golden.npz"
EXAMPLES = sorted(p.stem for p in
                  Path(linkdyn.__file__).with_name("examples").glob("*.toml"))


def times(name: str) -> tuple[linkdyn.Model, np.ndarray]:
    """An example's model and its default run's ``SAMPLES`` sample times, s."""
    mech = linkdyn.load(linkdyn.example_path(name))
    return mech, _times(mech, SAMPLES, None, None)


def key(example: str, column: str) -> str:
    return f"{example}/{column}"


def record(names=EXAMPLES) -> dict[str, np.ndarray]:
    """Every column of the examples ``names``, keyed ``example/column``, on the numpy backend."""
    out = {}
    for name in names:
        mech, t = times(name)
        sol = linkdyn.analyze(mech, t, backend="numpy")
        for col, values in sol.columns.items():
            out[key(name, col)] = np.asarray(values, dtype=float)
    return out


if __name__ == "__main__":
    import sys
    stored = {} if "--all" in sys.argv[1:] or not PATH.exists() else dict(np.load(PATH))
    have = {k.split("/")[0] for k in stored}
    data = {**stored, **record([n for n in EXAMPLES if n not in have])}
    np.savez_compressed(PATH, **data)
    print(f"{PATH.name}: {len({k.split('/')[0] for k in data})} examples, {len(data)} columns, "
          f"{PATH.stat().st_size} bytes")
