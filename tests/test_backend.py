"""The backend chosen in one place (``linkdyn.backend``): explicit choices kept, ``auto`` by
the work to be done and by whether the kernels are already compiled, the same results whichever
runs, and every wrong choice a user error naming the field and the fix."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import linkdyn
from linkdyn import backend, compiled
from linkdyn.errors import ModelError

numba = pytest.mark.skipif(compiled.numba is None, reason="the compiled backend needs numba")
HOEKEN = linkdyn.example_path("hoeken")


def test_explicit_choices_and_the_environment(monkeypatch):
    monkeypatch.delenv("LINKDYN_BACKEND", raising=False)
    assert not backend.choose("numpy", backend.Work(10**9, 50)).compiled
    assert backend.choose(None).name == "numpy"          # auto without work: numpy
    monkeypatch.setenv("LINKDYN_BACKEND", "numpy")
    assert not backend.choose(None, backend.Work(10**9, 50)).compiled
    if compiled.numba is not None:
        assert backend.choose("compiled", backend.Work(1, 1)).compiled   # however small
        monkeypatch.setenv("LINKDYN_BACKEND", "Compiled")                # any case
        assert backend.choose(None, backend.Work(1, 1)).compiled
        # analyze then runs the compiled kernels (their arrays kept on the solution)
        assert linkdyn.analyze(linkdyn.load(HOEKEN), np.linspace(0, 1, 5)).kin.arrays is not None


@pytest.mark.parametrize("where", ["argument", "environment"])
def test_an_unknown_backend_names_its_field_and_the_choices(monkeypatch, where):
    arg = "gpu" if where == "argument" else None
    monkeypatch.setenv("LINKDYN_BACKEND", "bogus") if arg is None else \
        monkeypatch.delenv("LINKDYN_BACKEND", raising=False)
    field = "backend" if arg else "LINKDYN_BACKEND"
    model = linkdyn.load(HOEKEN)
    for run in (lambda: backend.choose(arg), lambda: linkdyn.analyze(model, [0.0], backend=arg),
                lambda: linkdyn.kinematics.solve(model, [0.0], backend=arg)):
        with pytest.raises(ModelError) as err:
            run()
        assert err.value.field == field and "auto, numpy, compiled" in err.value.fix
        assert isinstance(err.value, ValueError)


def test_the_estimates_grow_with_the_work_and_count_the_compilation():
    """numpy's estimate grows with samples, bodies and evaluations; the compiled one starts at
    its start-up, much less when the kernels are already in numba's cache."""
    base = backend.Work(1000, 3)
    for more in (backend.Work(2000, 3), backend.Work(1000, 6), backend.Work(1000, 3, 2)):
        assert more.numpy_seconds() > base.numpy_seconds()
        assert more.compiled_seconds(True) > base.compiled_seconds(True)
    empty = backend.Work(0, 3, 0)
    assert empty.numpy_seconds() == 0 < empty.compiled_seconds(True) < empty.compiled_seconds(False)
    # a middle-sized analysis pays only once compiled: a million samples of a four-bar
    mid = backend.Work(10**6, 3)
    assert mid.compiled_seconds(True) < mid.numpy_seconds() < mid.compiled_seconds(False)


@numba
def test_auto_picks_compiled_for_much_work_and_numpy_for_little(monkeypatch):
    monkeypatch.delenv("LINKDYN_BACKEND", raising=False)
    monkeypatch.setattr(backend, "IN_PROCESS", set())   # as in a process that has run none
    kinds = [j.kind for j in linkdyn.load(HOEKEN).joints]
    assert backend.choose("auto", backend.Work(10**9, 3), kinds).compiled
    assert not backend.choose("auto", backend.Work(100, 3), kinds).compiled
    # simulate's right-hand side: one state at a time, many evaluations of a long chain
    rhs = backend.Work(2, 81, 10**6, backend.SIMULATION)
    assert backend.choose("auto", rhs).compiled
    assert not backend.choose("auto", backend.Work(2, 3, 10, backend.SIMULATION)).compiled


@numba
def test_an_open_ended_run_switches_once_numpy_has_spent_the_start_up(monkeypatch):
    """``reconsider`` (simulate's): numpy until the evaluations made would have paid for the
    compiled start-up, compiled from there on, never back; explicit choices never change."""
    monkeypatch.setattr(backend, "IN_PROCESS", set())   # as in a process that has run none
    work = backend.Work(2, 3, 0, backend.SIMULATION)
    auto = backend.choose("auto", work)
    pays = auto.pays_after(work)
    assert not auto.compiled and 1 < pays < np.inf
    before = backend.Work(2, 3, pays - 1, work.stages)
    at = backend.Work(2, 3, pays, work.stages)
    assert before.numpy_seconds() < before.compiled_seconds()
    assert at.numpy_seconds() >= at.compiled_seconds()
    assert not auto.reconsider(before).compiled and auto.reconsider(at).compiled
    assert auto.reconsider(at).pays_after(work) == np.inf
    for name in ("numpy", "compiled"):
        fixed = backend.choose(name, work)
        assert fixed.reconsider(at).compiled == (name == "compiled")
        assert fixed.pays_after(work) == np.inf


@numba
def test_auto_runs_compiled_once_this_process_has_loaded_the_kernels(monkeypatch):
    """Kernels a process has run have no start-up left: "auto" then runs even a small analysis
    and a short simulation compiled from their first evaluation (with the start-up still to
    pay it ran numpy), with the numbers of numpy."""
    monkeypatch.delenv("LINKDYN_BACKEND", raising=False)
    monkeypatch.setattr(backend, "IN_PROCESS", set())
    small = backend.Work(100, 3)
    rhs = backend.Work(2, 3, 0, backend.SIMULATION)
    assert not backend.choose("auto", small).compiled
    assert not backend.choose("auto", rhs).compiled
    model = linkdyn.load(HOEKEN)
    t = np.linspace(0.0, 1.0, 7)
    ref = linkdyn.analyze(model, t, backend="numpy")
    assert ref.kin.arrays is None                       # numpy kept no kernel arrays
    linkdyn.analyze(model, t, backend="compiled")       # the analysis kernels now loaded
    assert set(backend.ANALYSIS) <= backend.IN_PROCESS
    assert backend.choose("auto", small).compiled
    auto = linkdyn.analyze(model, t)
    assert auto.kin.arrays is not None
    for key, col in ref.columns.items():
        scale = max(1.0, float(np.max(np.abs(col))))
        assert np.max(np.abs(auto.columns[key] - col)) <= 1e-12 * scale, key
    # simulate: numpy's right-hand side until its own kernel has run here (its start-up made
    # too dear to pay in this run, by the estimate or by the clock), then compiled at once
    monkeypatch.setattr(backend, "LOAD", dict.fromkeys(backend.LOAD, 1e6))
    monkeypatch.setattr(backend, "COMPILE", dict.fromkeys(backend.COMPILE, 1e6))
    motor = linkdyn.load(linkdyn.example_path("hoeken_motor"))
    ts = np.linspace(0.0, 0.05, 3)
    assert linkdyn.simulate(motor, ts).stats["backend"] == "numpy"
    linkdyn.simulate(motor, ts, backend="compiled")
    sim = linkdyn.simulate(motor, ts)
    assert sim.stats["backend"] == "compiled" and sim.stats["compiled_after"] == 0


@numba
def test_auto_gives_the_numbers_of_both_backends(monkeypatch):
    """Whichever auto runs, the analysis is the numpy reference's to rounding (here a batch
    large enough that auto compiles, and a small one that it does not)."""
    monkeypatch.delenv("LINKDYN_BACKEND", raising=False)
    model = linkdyn.load(HOEKEN)
    # the start-up made free: auto compiles
    monkeypatch.setattr(backend, "LOAD", dict.fromkeys(backend.LOAD, 0.0))
    monkeypatch.setattr(backend, "COMPILE", dict.fromkeys(backend.COMPILE, 0.0))
    t = np.linspace(0.0, 4 / 3, 61)
    ref = linkdyn.analyze(model, t, backend="numpy")
    auto = linkdyn.analyze(model, t)
    assert auto.kin.arrays is not None and ref.kin.arrays is None
    for key, col in ref.columns.items():
        scale = max(1.0, float(np.max(np.abs(col))))
        assert np.max(np.abs(auto.columns[key] - col)) <= 1e-12 * scale, key


def test_the_compiled_backend_without_numba_says_how_to_install_it(tmp_path):
    """A user error, exit 2, no traceback, from the API (a ModelError that is an ImportError)
    and the command line."""
    model = tmp_path / "hoeken.toml"
    model.write_text(HOEKEN.read_text())
    code = ("import sys; sys.modules['numba'] = None\n"
            "import numpy as np, linkdyn\n"
            "try:\n"
            "    linkdyn.analyze(linkdyn.load(sys.argv[1]), [0.0], backend='compiled')\n"
            "except linkdyn.ModelError as e:\n"
            "    assert isinstance(e, ImportError) and e.field == 'backend', e\n"
            "    print('api:', e)\n"
            "from linkdyn.cli import main\n"
            "sys.argv = ['linkdyn', 'analyze', sys.argv[1], '-o', sys.argv[2],"
            " '--backend', 'compiled']\n"
            "main()\n")
    res = subprocess.run([sys.executable, "-c", code, str(model), str(tmp_path / "out")],
                         capture_output=True, text=True, timeout=120)
    assert res.returncode == 2, res.stderr
    assert "api: " in res.stdout and "pip install 'linkdyn[fast]'" in res.stdout
    assert "Traceback" not in res.stderr and "pip install 'linkdyn[fast]'" in res.stderr
    assert not (tmp_path / "out").exists()


@numba
@numba
@pytest.mark.parametrize("user_folder", [False, True])
def test_the_kernels_caches_are_looked_for_where_numba_writes_them(tmp_path, user_folder):
    """numba writes a kernel's cache in ``__pycache__`` beside its source file, or, with
    ``NUMBA_CACHE_DIR`` set, in that folder's own subfolder per source folder (named after the
    source folder): linkdyn looks for the cached stages, and drops stale caches, in the same
    folders, one per source folder of the package."""
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    if user_folder:
        env["NUMBA_CACHE_DIR"] = str(tmp_path)
    code = "from linkdyn import compiled; print(*compiled.cache_dirs(), sep='\\n')"
    res = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    found = res.stdout.split("\n")[:-1]
    sources = sorted({p.parent for p in Path(linkdyn.__file__).parent.rglob("*.py")})
    assert len(found) == len(sources) > 3
    if user_folder:
        assert all(Path(f).parent == tmp_path for f in found)
        names = sorted(Path(f).name.rsplit("_", 1)[0] for f in found)
        assert names == sorted(s.name for s in sources)
    else:
        assert sorted(found) == sorted(str(s / "__pycache__") for s in sources)


def test_the_command_line_says_when_it_compiles_cold(monkeypatch, tmp_path):
    """Before kernels that numba's cache does not hold compile, one line on stderr naming
    them and that they are cached afterwards; none once they are cached."""
    from click.testing import CliRunner

    from linkdyn.cli import main

    monkeypatch.delenv("LINKDYN_BACKEND", raising=False)
    model = tmp_path / "hoeken.toml"
    model.write_text(HOEKEN.read_text())
    args = ["analyze", str(model), "--samples", "5", "--backend", "compiled", "-o"]
    warm = CliRunner().invoke(main, args + [str(tmp_path / "a")])
    assert warm.exit_code == 0, warm.output
    assert all(backend.cached(s) for s in backend.ANALYSIS)
    assert "compiling" not in warm.stderr
    monkeypatch.setattr(backend, "cached", lambda stage: False)   # as on a fresh install
    monkeypatch.setattr(backend, "_announced", set())
    cold = CliRunner().invoke(main, args + [str(tmp_path / "b")])
    assert cold.exit_code == 0, cold.output
    lines = [x for x in cold.stderr.splitlines() if "compiling" in x]
    assert len(lines) == 1 and "kinematics" in lines[0] and "cached" in lines[0], cold.stderr
