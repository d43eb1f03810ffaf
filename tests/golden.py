"""The stored golden outputs of the bundled examples and of short runs of every command.

- ``tests/data/golden.npz``: every output column (``Solution.columns``) of every bundled example,
  at ``SAMPLES`` samples of the example's default run (its ``[analysis]`` duration or cycles,
  else one cycle: the CLI's ``analyze`` times), keyed ``example/column``.
- ``tests/data/golden_runs.npz``: every output column of a short ``simulate`` run of every
  example in ``examples/simulate`` and of Hoeken's four-bar released from its driver
  (:data:`SIMULATE`: duration, samples, method and tolerances fixed here), keyed
  ``simulate/case/column``; every metric of every design of a seeded Sobol ``sweep`` of
  Hoeken's linkage (:data:`SWEEP`), keyed ``sweep/column``; and the best design of a seeded
  ``optimize`` (:data:`OPTIMIZE`), keyed ``optimize/values/path`` and ``optimize/metrics/name``.

All are recorded with the numpy backend; ``tests/test_golden.py`` holds both backends to these
numbers, so a refactoring of the core cannot change a result unnoticed.

Record what is missing (a bundled example or a run case added since; the stored ones are kept
as they are; with no stored file this records everything)::

    PYTHONPATH=src python tests/golden.py

Re-record everything (only when an output is meant to change; say why in the commit)::

    PYTHONPATH=src python tests/golden.py --all
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import linkdyn
from linkdyn.sampling import times as sample_times

SAMPLES = 61
DATA = Path(__file__).with_name("data")
PATH = DATA / "golden.npz"
RUNS = DATA / "golden_runs.npz"
EXAMPLES = sorted(p.stem for p in
                  Path(linkdyn.__file__).with_name("examples").glob("*.toml"))
SIMULATE_EXAMPLES = sorted(p.stem for p in
                           Path(linkdyn.__file__).with_name("examples").glob("simulate/*.toml"))


def times(name: str) -> tuple[linkdyn.Model, np.ndarray]:
    """An example's model and its default run's ``SAMPLES`` sample times, s."""
    mech = linkdyn.load(linkdyn.example_path(name))
    return mech, sample_times(mech, SAMPLES, None, None)


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


# ---------------------------------------------------------------------------- simulate

@dataclass(frozen=True)
class Run:
    """A short ``simulate`` run: its model and every setting that decides its numbers."""

    duration: float                  # s
    samples: int
    method: str = "DOP853"
    rtol: float = 1e-8
    atol: float = 1e-10


def released_hoeken() -> linkdyn.Model:
    """Hoeken's four-bar (``examples/hoeken.toml``) with its driver removed, set spinning at
    45 rpm from a crank angle of 30 degrees: it runs on under its coupler load alone."""
    path = linkdyn.example_path("hoeken")
    data = tomllib.loads(path.read_text("utf-8"))
    del data["drivers"], data["analysis"]        # (its cycles count the driver's turns)
    data["initial"] = {"q": {"J1": 30.0}, "qd": {"J1": 270.0}}       # deg, deg/s
    return linkdyn.model_from_dict(data, source="hoeken_released.toml")


# every example of examples/simulate, and the released Hoeken; each under ~2 s on numpy
SIMULATE = {
    "fourbar_release": Run(duration=0.3, samples=31),
    "hoeken_motor": Run(duration=1.0, samples=31),
    "toggle_spring": Run(duration=0.05, samples=21, method="Radau", rtol=1e-5, atol=1e-7),
    "hoeken_released": Run(duration=0.3, samples=31),
}


def simulate_model(case: str) -> linkdyn.Model:
    return released_hoeken() if case == "hoeken_released" else \
        linkdyn.load(linkdyn.example_path(case))


def simulate(case: str, backend: str = "numpy") -> dict[str, np.ndarray]:
    """Every output column of the run ``SIMULATE[case]``."""
    run = SIMULATE[case]
    t = np.linspace(0.0, run.duration, run.samples)
    sol = linkdyn.simulate(simulate_model(case), t, rtol=run.rtol, atol=run.atol,
                           method=run.method, backend=backend)
    return {c: np.asarray(v, dtype=float) for c, v in sol.columns.items()}


# ---------------------------------------------------------------------------- sweep, optimize

# Hoeken's linkage, its coupler point and its ground pivot moved (mm)
BOUNDS = {"bodies.coupler.points.P[0]": (200.0, 260.0),
          "bodies.ground.points.O4[0]": (80.0, 100.0)}
SWEEP = {"designs": 20, "method": "sobol", "seed": 7}
OPTIMIZE = {"minimize": "peak_tau_J1", "constraints": ("path_deviation<=0.5mm",),
            "seed": 3, "popsize": 4, "maxiter": 4}


def study_times() -> tuple[linkdyn.Model, np.ndarray]:
    """Hoeken's model and ``SAMPLES`` sample times of one crank turn, s."""
    return times("hoeken")


def sweep(backend: str = "numpy") -> dict[str, np.ndarray]:
    """Every numeric column (parameters, ``valid``, every metric) of every design of the
    seeded sweep :data:`SWEEP` over :data:`BOUNDS`."""
    from linkdyn.studies import sample
    _, t = study_times()
    values = sample(list(BOUNDS.values()), SWEEP["method"], SWEEP["designs"], seed=SWEEP["seed"])
    df = linkdyn.sweep(linkdyn.example_path("hoeken"),
                       {p: values[:, k] for k, p in enumerate(BOUNDS)}, t, backend=backend)
    return {c: df[c].to_numpy(float) for c in df.columns if c not in ("design", "reason")}


def optimize(backend: str = "numpy") -> dict[str, np.ndarray]:
    """The best design of the seeded :data:`OPTIMIZE` over :data:`BOUNDS`: its parameter
    values (``values/path``) and metrics (``metrics/name``)."""
    _, t = study_times()
    res = linkdyn.optimize(linkdyn.example_path("hoeken"), BOUNDS, t, OPTIMIZE["minimize"],
                           OPTIMIZE["constraints"], seed=OPTIMIZE["seed"],
                           popsize=OPTIMIZE["popsize"], maxiter=OPTIMIZE["maxiter"],
                           backend=backend)
    return ({f"values/{p}": np.float64(v) for p, v in res.values.items()}
            | {f"metrics/{m}": np.float64(v) for m, v in res.metrics.items()})


def record_runs(have=frozenset()) -> dict[str, np.ndarray]:
    """Every run not in ``have`` (``simulate/case``, ``sweep``, ``optimize``), keyed
    ``simulate/case/column``, ``sweep/column``, ``optimize/...``, on the numpy backend."""
    out = {}
    for case in SIMULATE:
        if f"simulate/{case}" not in have:
            out |= {f"simulate/{case}/{c}": v for c, v in simulate(case).items()}
    for name, run in (("sweep", sweep), ("optimize", optimize)):
        if name not in have:
            out |= {f"{name}/{c}": v for c, v in run().items()}
    return out


def run_of(k: str) -> str:
    """The run a key of ``golden_runs.npz`` belongs to: ``simulate/case``, ``sweep``, ``optimize``."""
    parts = k.split("/")
    return "/".join(parts[:2]) if parts[0] == "simulate" else parts[0]


if __name__ == "__main__":
    import sys
    again = "--all" in sys.argv[1:]
    DATA.mkdir(exist_ok=True)
    stored = {} if again or not PATH.exists() else dict(np.load(PATH))
    have = {k.split("/")[0] for k in stored}
    data = {**stored, **record([n for n in EXAMPLES if n not in have])}
    np.savez_compressed(PATH, **data)
    print(f"{PATH.name}: {len({k.split('/')[0] for k in data})} examples, {len(data)} columns, "
          f"{PATH.stat().st_size} bytes")
    stored = {} if again or not RUNS.exists() else dict(np.load(RUNS))
    data = {**stored, **record_runs(frozenset(run_of(k) for k in stored))}
    np.savez_compressed(RUNS, **data)
    print(f"{RUNS.name}: {len({run_of(k) for k in data})} runs, {len(data)} columns, "
          f"{RUNS.stat().st_size} bytes")
