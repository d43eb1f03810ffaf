"""Suite-wide set-up: how pytest-xdist spreads the tests, and fixtures several files read.

``make test`` runs the suite on every core (``pytest -n auto --dist loadgroup``). The tests that
run the compiled (numba) backend all go to one worker, in collection order: on a fresh clone
the first of them compiles the kernels once (about 230 s of CPU measured in a full run on a
shared 2-core machine: analyze's kernels, the sweep's, simulate's right-hand side, friction's)
and writes them to numba's on-disk cache, and the rest load them from there, while the other
workers run the numpy, CLI and browser tests one test at a time as each worker frees up.
Spread over several workers, each worker would compile the same kernels at the same time. A
test that runs compiled code must say so in its name or parameters (:func:`uses_numba`),
``backend="auto"`` included where its work is large enough to switch to compiled: a test left
out compiles on another worker, cold, at the same time. The grouping is a scheduler of its own
(xdist's ``xdist_group`` mark sets ``item._nodeid``, which pytest 9.2 no longer reads). Without
xdist (``pytest`` alone) none of this applies.
"""

from __future__ import annotations

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

NUMBA_GROUP = "numba"
# files whose every test runs compiled code: the compiled backend, the sweep kernel or the
# benchmark scripts (a file of compiled tests left out compiles the kernels a second time, on
# another worker, at the same time)
NUMBA_FILES = ("test_compiled", "test_benchmarks", "test_sweep_kernel", "test_backend")
# a parametrized test whose id has the "compiled" backend among its parameters
COMPILED_PARAM = re.compile(r"\[(.*-)?compiled(-.*)?\]$")
# a test whose name says it runs the compiled backend, or compares the backends ("both_backends",
# "backends_agree": a test left out compiles the kernels on another worker, at the same time)
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
    """Under ``--dist loadgroup``: the numba tests as one unit of work, each file of
    :data:`SHARED_FIXTURE_FILES` one unit, every other test a unit of its own (xdist hands out
    the largest unit first)."""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadScopeScheduling

    class NumbaOnOneWorker(LoadScopeScheduling):
        def _split_scope(self, nodeid: str) -> str:
            if uses_numba(nodeid):
                return NUMBA_GROUP
            path = nodeid.partition("::")[0]
            return path if Path(path).stem in SHARED_FIXTURE_FILES else nodeid

    return NumbaOnOneWorker(config, log)


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
