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
# the tests that take longest, each "file stem::test name" (every parametrization of it) with
# its seconds on one worker of a full run (pytest --durations, 2 workers, numba cache warm):
# queued before the other tests of their kind (numpy ones after the shared-fixture files,
# compiled ones at the head of the compiled tail), longest first, so that none of them starts
# last on one worker while the other has nothing left to run. Only the order depends on it: a
# test missing from here, or a figure out of date, still runs, perhaps later than it could.
HEAVY = {
    "test_cam_joint::test_both_backends_run_the_cam_follower": 20.0,
    "test_robustness::test_a_mutated_example_solves_finitely_or_names_the_field_or_time": 17.0,
    "test_compiled::test_bundled_examples[cam_flat_rocker]": 17.0,
    "test_bad_input_simulate::test_a_mutated_simulation_runs_finitely_or_names_the_field": 11.0,
    "test_simulate::test_the_energy_balance_sees_between_the_samples": 10.7,
    "test_cam_joint::test_simulate_finds_the_jump_speed_of_a_follower_speeding_up": 10.4,
    "test_spatial_free_body::test_a_hanging_body_bounces_as_the_mass_spring_closed_form": 8.3,
    "test_bad_input_simulate::test_outputs_leave_unrelated_files_and_lookalike_folders": 7.9,
    "test_spatial_studies::test_a_spatial_optimize_finds_the_design_of_the_per_design_path": 6.0,
    "test_bad_input_simulate::test_an_earlier_runs_report_is_removed_and_the_users_report": 5.5,
    ("test_bad_input_simulate::test_simulate_names_a_load_that_is_not_finite_not_the_"
     "mechanism[log"): 5.5,
    "test_equilibrium::test_a_small_motion_simulated_about_the_equilibrium_swings_at_the": 4.9,
    "test_simulate::test_cli_simulate_writes_results_and_summary": 4.7,
    "test_simulate::test_a_dead_point_of_the_free_coordinate_is_passed_by_switching": 4.4,
    "test_simulate::test_stiff_toggle_implicit_methods_agree": 4.0,
    "test_simulate::test_energy_kept_at_the_tolerance_shrinks_with_it": 4.0,
    "test_simulate::test_radau_keeps_the_energy_over_many_turns[Radau-compiled]": 3.9,
    "test_bad_input_simulate::test_simulate_tolerances_succeed_finitely_or_name_the_option": 3.8,
    "test_freed_yoke::test_freed_yoke_follows_its_equation_of_motion[numpy]": 3.7,
    "test_studies_inputs::test_an_earlier_runs_report_is_removed_and_a_users_file_of_its": 3.7,
    "test_cli::test_bad_input_in_a_subprocess": 3.6,
    "test_spatial_simulate::test_a_dead_point_of_the_free_coordinate_is_passed_by_switching": 3.5,
    "test_studies::test_a_sweep_killed_by_sigkill_resumes_from_its_chunks": 3.5,
    "test_writer::test_every_example_round_trips[cam_fourbar]": 3.5,
}


def weight(nodeid: str) -> float:
    """The seconds :data:`HEAVY` gives the test ``nodeid`` (the longest entry whose key begins
    its "file stem::name"), 0 for a test not in it."""
    path, _, name = nodeid.partition("::")
    key = f"{Path(path).stem}::{name}"
    return max((s for k, s in HEAVY.items() if key.startswith(k)), default=0.0)


def queue_order(units: list[str]) -> list[str]:
    """The order in which the work units ``units`` (each a node id, or the path of a file of
    :data:`SHARED_FIXTURE_FILES`) are handed out: the first compiled test (its worker compiles
    the kernels), the shared-fixture files, the other numpy tests, then the other compiled
    tests; within each, the :data:`HEAVY` ones first, longest first (the sort is stable:
    otherwise xdist's order)."""
    compiled = [u for u in units if uses_numba(u)]
    rest = [u for u in units if not uses_numba(u)]
    shared = [u for u in rest if "::" not in u]
    rest = [u for u in rest if "::" in u]
    by_weight = lambda us: sorted(us, key=lambda u: -weight(u))   # noqa: E731
    return compiled[:1] + shared + by_weight(rest) + by_weight(compiled[1:])


def uses_numba(nodeid: str) -> bool:
    """Whether the test ``nodeid`` compiles or runs numba kernels: a test of a file of compiled
    tests, one parametrized with the ``"compiled"`` backend, or one whose name says so."""
    path, _, name = nodeid.partition("::")
    return (Path(path).stem.startswith(NUMBA_FILES) or bool(COMPILED_PARAM.search(name))
            or bool(COMPILED_NAME.search(name.split("[")[0])))


@pytest.hookimpl(tryfirst=True, optionalhook=True)   # before xdist's own choice of scheduler
def pytest_xdist_make_scheduler(config, log):
    """Under ``--dist loadgroup``: each file of :data:`SHARED_FIXTURE_FILES` one unit of work,
    every other test a unit of its own, handed out in :func:`queue_order`: the first compiled
    test at the head of the queue (its worker compiles the kernels, :func:`numba_kernels`),
    the other compiled tests at its end, the heaviest of each kind first."""
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
                units = dict(self.workqueue)
                self.workqueue.clear()
                self.workqueue.update((u, units[u]) for u in queue_order(list(units)))
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
