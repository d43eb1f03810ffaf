"""Suite-wide set-up: how pytest-xdist spreads the tests, and fixtures several files read.

``make test`` runs the suite on every core (``pytest -n auto --dist loadgroup``). On a fresh
clone numba's cache is cold: the compiled (numba) kernels of every stage must compile once
(analyze's kernels, the sweep's, simulate's right-hand side, friction's), and two workers that
compile the same kernels at the same time each pay for it. So the scheduler below hands one
worker a compiled test first; before it runs, that worker compiles every stage's kernels on
bundled examples (:func:`numba_kernels`, under a file lock) and numba writes them to its
on-disk cache, while the other workers run the numpy, CLI and browser tests. The other
compiled tests come last in the queue and spread over every worker, each loading the kernels
from the cache (a worker that reaches one while the kernels still compile waits on the lock
instead of compiling them again). A test that runs compiled code must say so in its name or
parameters (:func:`uses_numba`), ``backend="auto"`` included where its work is large enough to
switch to compiled: a test left out may compile on another worker, cold, at the same time. The
grouping is a scheduler of its own (xdist's ``xdist_group`` mark sets ``item._nodeid``, which
pytest 9.2 no longer reads). Without xdist (``pytest`` alone) none of this applies.
"""

from __future__ import annotations

import dataclasses
import os
import re
from contextlib import contextmanager, nullcontext
from pathlib import Path

import pytest
from click.testing import CliRunner
from hypothesis import settings

import linkdyn
from linkdyn.cli import main

# under CI (CI=true, as .ci/run exports) every property test draws the same examples on every
# run: a landing is not decided by which rare case one run happens to draw (a developer's runs
# stay random, and find new cases)
if os.environ.get("CI", "").strip().lower() in ("true", "1", "yes"):
    settings.register_profile("ci-derandomized", derandomize=True)
    settings.load_profile("ci-derandomized")

# files whose every test runs compiled code: the compiled backend, the sweep kernel or the
# benchmark scripts (a compiled test left out may run before the kernels are in the cache, and
# compile them a second time, on another worker, at the same time)
NUMBA_FILES = ("test_compiled", "test_benchmarks", "test_sweep_kernel", "test_backend")
# a parametrized test whose id has the "compiled" backend among its parameters
COMPILED_PARAM = re.compile(r"\[(.*-)?compiled(-.*)?\]$")
# a test whose name says it runs the compiled backend, or compares the backends ("both_backends",
# "backends_agree": a test left out may compile the kernels on another worker, at the same time)
COMPILED_NAME = re.compile(r"compiled|backends")
# files whose tests share a costly module-scoped fixture: all on one worker, so that it runs once
# (test_simstats: the loaded five-bar simulated, 1201 samples over 1.5 s: 30 s CPU; test_report:
# its Chromium and each example's page, made again on each worker that runs its tests)
SHARED_FIXTURE_FILES = ("test_simstats", "test_report")


def uses_numba(nodeid: str) -> bool:
    """Whether the test ``nodeid`` compiles or runs numba kernels: a test of a file of compiled
    tests, one parametrized with the ``"compiled"`` backend, or one whose name says so."""
    path, _, name = nodeid.partition("::")
    return (Path(path).stem.startswith(NUMBA_FILES) or bool(COMPILED_PARAM.search(name))
            or bool(COMPILED_NAME.search(name.split("[")[0])))


@pytest.hookimpl(tryfirst=True, optionalhook=True)   # before xdist's own choice of scheduler
def pytest_xdist_make_scheduler(config, log):
    """Under ``--dist loadgroup``: each file of :data:`SHARED_FIXTURE_FILES` one unit of work,
    every other test a unit of its own; the first compiled test at the head of the queue (its
    worker compiles the kernels, :func:`numba_kernels`), the other compiled tests at its end,
    after the largest units (xdist's order otherwise)."""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class CompileFirst(LoadScopeScheduling):
        _ordered = False

        def _split_scope(self, nodeid: str) -> str:
            path = nodeid.partition("::")[0]
            return path if Path(path).stem in SHARED_FIXTURE_FILES else nodeid

        def _assign_work_unit(self, node) -> None:
            if not self._ordered:   # the first assignment: the queue is complete
                self._ordered = True
                units = list(self.workqueue.items())
                compiled = [u for u in units if uses_numba(u[0])]
                rest = [u for u in units if not uses_numba(u[0])]
                self.workqueue.clear()
                self.workqueue.update(compiled[:1] + rest + compiled[1:])
            super()._assign_work_unit(node)

    return CompileFirst(config, log)


def compile_kernels() -> None:
    """Run every stage of the compiled backend once on bundled examples, so that numba compiles
    their kernels and writes them to its on-disk cache: analyze's (kinematics with its
    continuation, dynamics, reactions, joint friction), simulate's right-hand side and the
    sweep's fused kernel."""
    import numpy as np

    from linkdyn.friction import joint_friction

    hoeken = linkdyn.load(linkdyn.example_path("hoeken"))
    t = np.linspace(0.0, 1.0, 20)
    linkdyn.analyze(hoeken, t, backend="compiled").reactions
    rough = dataclasses.replace(hoeken, loads=hoeken.loads + tuple(
        joint_friction(hoeken, j.name, 0.15, 0.008) for j in hoeken.joints[:2]))
    linkdyn.analyze(rough, t, backend="compiled").reactions
    motor = linkdyn.load(linkdyn.example_path("hoeken_motor"))
    linkdyn.simulate(motor, np.linspace(0.0, 0.05, 6), backend="compiled")
    linkdyn.sweep(hoeken, {"bodies.ground.points.O4[0]": np.linspace(85.0, 95.0, 4)}, t,
                  metrics=["peak_tau_J1"], backend="compiled")


@pytest.fixture(scope="session")
def numba_kernels(tmp_path_factory) -> None:
    """Under xdist: the compiled kernels in numba's on-disk cache before a worker's first
    compiled test (:func:`compile_kernels`, run once per session by the first worker that
    gets here; the others wait on the lock, then load them from the cache)."""
    session = tmp_path_factory.getbasetemp().parent      # under xdist: every worker's base
    with _one_at_a_time(session / "numba-kernels.lock"):
        done = session / "numba-kernels.done"
        if not done.exists():
            try:
                import numba  # noqa: F401
            except ImportError:   # the compiled tests skip themselves
                return
            compile_kernels()
            done.touch()


@pytest.fixture(autouse=True)
def _kernels_first(request) -> None:
    """A compiled test under xdist takes :func:`numba_kernels` first."""
    if os.environ.get("PYTEST_XDIST_WORKER") is not None and uses_numba(request.node.nodeid):
        request.getfixturevalue("numba_kernels")


@contextmanager
def _one_at_a_time(lock: Path):
    """Hold an exclusive lock on the file ``lock`` (POSIX ``flock``; without ``fcntl``, no lock:
    then each worker computes for itself)."""
    try:
        import fcntl
    except ImportError:
        yield False
        return
    with open(lock, "w") as f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield True
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


@pytest.fixture(scope="session")
def hoeken_report_run(tmp_path_factory) -> Path:
    """The output folder of ``linkdyn analyze hoeken.toml -o out --report`` (in process), run
    once per session for the files that read it: results.csv, summary.json, report.html and
    the plots. Read it; a test that writes copies it first. Under xdist the workers share it
    (it is written once, in the session's temporary folder that holds each worker's own)."""
    session = tmp_path_factory.getbasetemp().parent      # under xdist: every worker's base
    shared = os.environ.get("PYTEST_XDIST_WORKER") is not None
    lock = _one_at_a_time(session / "hoeken-report.lock") if shared else nullcontext(False)
    with lock as locked:
        folder = session / "hoeken-report" if locked else tmp_path_factory.mktemp("hoeken-report")
        done = folder / "done"
        if not done.exists():
            folder.mkdir(exist_ok=True)
            model = folder / "hoeken.toml"
            model.write_text(linkdyn.example_path("hoeken").read_text("utf-8"), "utf-8")
            res = CliRunner().invoke(main, ["analyze", str(model), "-o", str(folder / "out"),
                                            "--report"])
            assert res.exit_code == 0, res.output
            done.touch()
    return folder / "out"


@pytest.fixture(scope="session")
def rsur_report_run(tmp_path_factory) -> Path:
    """The output folder of ``linkdyn analyze rsur.toml -o out --report`` (the bundled spatial
    RSUR four-bar, in process), run once per session: results.csv, summary.json, report.html."""
    folder = tmp_path_factory.mktemp("rsur-report")
    model = folder / "rsur.toml"
    model.write_text(linkdyn.example_path("rsur").read_text("utf-8"), "utf-8")
    res = CliRunner().invoke(main, ["analyze", str(model), "-o", str(folder / "out"), "--report"])
    assert res.exit_code == 0, res.output
    return folder / "out"
