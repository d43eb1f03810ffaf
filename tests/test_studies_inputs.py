"""Bad input to sweep, optimize and compare (issue 22): each reproducer exits 0 with a correct
result or 2 with one message naming the option, field or file, no traceback and nothing written;
a sweep removes only what it wrote; property tests over the options and damaged sweep folders.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import linkdyn
from linkdyn import LinkdynError, ModelError
from linkdyn.cli import main
from linkdyn.studies.optimize import parse_constraint

HOEKEN = linkdyn.example_path("hoeken")
O4 = "bodies.ground.points.O4[0]"
VARY = ["--vary", f"{O4}=85:95:3", "--samples", "11", "--backend", "numpy"]
T = np.linspace(0.0, 4.0 / 3.0, 11)

IN_CI = os.environ.get("CI", "").strip().lower() in ("true", "1", "yes")
# CI draws more examples than a developer's run, as many as the suite's 3 minutes allow
settings.register_profile("studies-ci", max_examples=100, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow,
                                                 HealthCheck.function_scoped_fixture])
settings.register_profile("studies-dev", max_examples=30, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow,
                                                 HealthCheck.function_scoped_fixture])
PROFILE = settings.get_profile("studies-ci" if IN_CI else "studies-dev")


def cli(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def refused(res, *fragments) -> str:
    """The one-line message of an exit-2 user error holding every fragment."""
    assert res.exit_code == 2, res.output
    assert "Traceback" not in res.output and res.exception is None or \
        isinstance(res.exception, SystemExit), res.output
    text = res.output.strip()
    assert text.startswith("error: ") and len(text.splitlines()) == 1, text
    for f in fragments:
        assert f in text, (f, text)
    return text


def snapshot(folder: Path) -> dict:
    """Every file and folder below ``folder``: its bytes (None for a folder)."""
    return {p.relative_to(folder).as_posix(): (None if p.is_dir() else p.read_bytes())
            for p in sorted(folder.rglob("*"))}


@pytest.fixture(scope="module")
def model_dir(tmp_path_factory) -> Path:
    """A folder with hoeken.toml and a finished 3-design sweep of it in ``sweep/``."""
    folder = tmp_path_factory.mktemp("study")
    (folder / "hoeken.toml").write_text(HOEKEN.read_text("utf-8"), "utf-8")
    res = cli("sweep", folder / "hoeken.toml", *VARY, "-o", folder / "sweep")
    assert res.exit_code == 0, res.output
    return folder


# --- each reproducer --------------------------------------------------------------------------

SWEEP_BAD = [
    (["--vary", f"{O4}=85:95", "--designs", "0"], ["--designs", "at least 1"]),
    (["--vary", f"{O4}=85:95", "--designs", "1000000000"], ["--designs", "GB", "machine has"]),
    (["--vary", f"{O4}=85:95:100000", "--vary", "bodies.coupler.points.O3[0]=110:120:100000"],
     ["--vary", "10,000,000,000 designs", "GB"]),
    ([*VARY, "--workers", "100000"], ["--workers", "per core"]),
    ([*VARY, "--workers", "0"], ["--workers"]),
    ([*VARY, "--chunk", "0"], ["--chunk", "at least 1"]),
    ([*VARY, "--chunk", "-1"], ["--chunk", "at least 1"]),
    ([*VARY, "--fluctuation", "0"], ["--fluctuation", "positive, finite"]),
    ([*VARY, "--fluctuation", "-1"], ["--fluctuation"]),
    ([*VARY, "--fluctuation", "nan"], ["--fluctuation"]),
    ([*VARY, "--fluctuation", "inf"], ["--fluctuation"]),
    ([*VARY, "--scheduler", "tcp://127.0.0.1:1"], ["--scheduler", "no Dask scheduler answers"]),
    ([*VARY, "--scheduler", "bogus://x"], ["--scheduler", "unknown scheduler address scheme"]),
    ([*VARY, "--scheduler", ""], ["--scheduler", "cannot read the scheduler address"]),
    (["--vary", f"{O4}=85:95", "--samples", "11", "--designs", "4", "--method", "random",
      "--seed", "-1"], ["--seed", "from 0 to"]),
    (["--vary", f"{O4}=85:95", "--samples", "11", "--designs", "4", "--method", "lhs",
      "--seed", "-1"], ["--seed"]),
    (["--vary", f"{O4}=85:95", "--samples", "11", "--designs", "4", "--method", "sobol",
      "--seed", "-1"], ["--seed"]),
    # at least a day at the fastest rate measured, or more memory than the machine has
    (["--vary", f"{O4}=85:95", "--designs", "10000000", "--samples", "100000"], ["--designs"]),
]


@pytest.mark.parametrize("args, words", SWEEP_BAD)
def test_a_bad_sweep_option_exits_2_naming_it_and_writes_nothing(args, words, tmp_path):
    res = cli("sweep", HOEKEN, *args, "-o", tmp_path / "o")
    refused(res, *words)
    assert not (tmp_path / "o").exists()


def test_a_designs_csv_that_is_a_fifo_is_refused_at_once(tmp_path):
    fifo = tmp_path / "designs.csv"
    os.mkfifo(fifo)
    refused(cli("sweep", HOEKEN, "--designs-csv", fifo, "--samples", 11, "-o", tmp_path / "o"),
            "--designs-csv", "named pipe")
    assert not (tmp_path / "o").exists()


def test_a_designs_csv_of_too_many_columns_is_refused(tmp_path):
    csv = tmp_path / "designs.csv"
    csv.write_text(",".join([O4] * 5000) + "\n" + ",".join(["90"] * 5000) + "\n")
    refused(cli("sweep", HOEKEN, "--designs-csv", csv, "--samples", 11, "-o", tmp_path / "o"),
            "--designs-csv", "5,000 columns", "limit")


OPT = ["--vary", f"{O4}=85:95", "--minimize", "peak_tau_J1", "--samples", "11",
       "--popsize", "3", "--maxiter", "2", "--backend", "numpy"]


@pytest.mark.parametrize("args, words", [
    (["--constraint", "peak_tau_J1<1"], ["--constraint", "strict", "<="]),
    (["--constraint", "peak_tau_J1<=1mm"], ["--constraint", "peak_tau_J1 is in N m", "'mm'"]),
    (["--constraint", "min_transmission_angle>=30N"], ["--constraint", "in rad", "deg"]),
    (["--constraint", "peak_tau_J1<=1e999"], ["--constraint", "not finite"]),
    (["--seed", "-1"], ["--seed"]),
    (["--fluctuation", "nan"], ["--fluctuation"]),
    (["--fluctuation", "0"], ["--fluctuation"]),
    (["--popsize", "0"], ["--popsize"]),
    (["--popsize", "1000000000"], ["--popsize", "GB"]),
])
def test_a_bad_optimize_option_exits_2_naming_it(args, words, tmp_path):
    refused(cli("optimize", HOEKEN, *OPT, *args, "-o", tmp_path / "o"), *words)
    assert not (tmp_path / "o").exists()


def test_an_unknown_metric_to_minimize_names_minimize(tmp_path):
    args = [a if a != "peak_tau_J1" else "bogus" for a in OPT]
    text = refused(cli("optimize", HOEKEN, *args, "-o", tmp_path / "o"), "--minimize",
                   "no metric 'bogus'")
    assert "--metric" not in text


def test_constraint_units_follow_the_metrics_quantity():
    assert parse_constraint("path_deviation<=0.1 mm").value == pytest.approx(1e-4)
    assert parse_constraint("peak_tau_J1 <= 2 N m").value == 2.0
    assert parse_constraint("peak_F_J2<=30N").value == 30.0
    assert parse_constraint("flywheel_inertia<=0.5 kg m^2").value == 0.5
    c = parse_constraint("min_transmission_angle>=30deg")
    assert (c.upper, c.value) == (False, pytest.approx(np.pi / 6))
    for bad, word in [("peak_F_J2<=3mm", "in N"), ("path_deviation<=1deg", "in m"),
                      ("flywheel_inertia<=1N", r"kg m\^2"), ("peak_tau_J1>2", "strict")]:
        with pytest.raises(ModelError, match=word) as e:
            parse_constraint(bad)
        assert e.value.field == "--constraint"


@pytest.mark.parametrize("call, field", [
    (lambda: linkdyn.sweep(HOEKEN, {}, T), "params"),
    (lambda: linkdyn.sweep(HOEKEN, {O4: [90.0]}, np.array([0.0, np.nan, 1.0])), "t"),
    (lambda: linkdyn.sweep(HOEKEN, {O4: [90.0]}, "0:1"), "t"),
    (lambda: linkdyn.sweep(HOEKEN, {O4: [90.0]}, T, path_range=(1, 2, 3)), "path_range"),
    (lambda: linkdyn.sweep(HOEKEN, {O4: [90.0, np.inf]}, T), "params"),
    (lambda: linkdyn.sweep(HOEKEN, {O4: ["a"]}, T), "params"),
    (lambda: linkdyn.sweep(HOEKEN, {O4: [90.0]}, T, fluctuation=-1), "--fluctuation"),
    (lambda: linkdyn.sweep(HOEKEN, {O4: [90.0]}, T, chunk=0), "--chunk"),
    (lambda: linkdyn.sweep(HOEKEN, {O4: [90.0]}, T, workers=-3), "--workers"),
    (lambda: linkdyn.optimize(HOEKEN, {}, T, "peak_tau_J1"), "bounds"),
    (lambda: linkdyn.optimize(HOEKEN, {O4: (85, 90, 95)}, T, "peak_tau_J1"), "bounds"),
    (lambda: linkdyn.optimize(HOEKEN, {O4: (85, np.nan)}, T, "peak_tau_J1"), "bounds"),
    (lambda: linkdyn.optimize(HOEKEN, {O4: (85, 95)}, T, "peak_tau_J1", seed=-1), "--seed"),
    (lambda: linkdyn.optimize(HOEKEN, {O4: (85, 95)}, T, "peak_tau_J1", fluctuation=np.inf),
     "--fluctuation"),
    (lambda: linkdyn.studies.sample([(0, 1)], "sobol", 4, seed=-1), "--seed"),
    (lambda: linkdyn.studies.sample([(0, 1)], "random", 0), "--designs"),
])
def test_api_misuse_is_a_model_error_naming_the_argument(call, field):
    with pytest.raises(ModelError) as e:
        call()
    assert field in e.value.field


# --- the chunks folder and the files a command did not write -----------------------------------

def user_files(folder: Path) -> None:
    """Unrelated files and folders named like a study's own."""
    (folder / "chunks" / "sub").mkdir(parents=True)
    (folder / "chunks" / "mine.txt").write_text("mine")
    (folder / "chunks" / "summary.json").write_text("{\"mine\": 1}")
    (folder / "chunks" / "sub" / "designs.parquet").write_bytes(b"not a table")
    (folder / "results.csv").write_text("t,x\n0,1\n")
    (folder / "report.html").write_text("<p>my report</p>")
    (folder / "design-notes.html").write_text("<p>notes</p>")
    (folder / "plot_mine.png").write_bytes(b"\x89PNG mine")
    (folder / "summary.json.d").mkdir()
    (folder / "summary.json.d" / "x").write_text("x")


def test_sweep_optimize_and_compare_leave_what_they_did_not_write_byte_for_byte(model_dir,
                                                                              tmp_path):
    model = model_dir / "hoeken.toml"
    runs = {
        "sweep": (["sweep", model, *VARY], {"designs.parquet", "summary.json"}),
        "sweep --resume": (["sweep", model, *VARY, "--resume"],
                           {"designs.parquet", "summary.json"}),
        "optimize": (["optimize", model, *OPT],
                     {"best.toml", "optimize.json", "summary.json", "results.csv"}),
        "compare": (["compare", model, model, "--samples", 11, "--backend", "numpy"],
                    {"compare.html", "compare.json", "compare.csv"}),
    }
    for name, (args, own) in runs.items():
        out = tmp_path / name.replace(" ", "_")
        out.mkdir()
        user_files(out)
        before = snapshot(out)
        res = cli(*args, "-o", out)
        assert res.exit_code == 0, (name, res.output)
        after = snapshot(out)
        assert own <= set(after), name
        assert {k: v for k, v in after.items() if k not in own} == \
            {k: v for k, v in before.items() if k not in own}, name


def test_an_earlier_runs_report_is_removed_and_a_users_file_of_its_family_is_kept(model_dir,
                                                                                tmp_path):
    model, out = model_dir / "hoeken.toml", tmp_path / "o"
    assert cli("sweep", model, *VARY, "--report", "-o", out).exit_code == 0
    pages = sorted(p.name for p in out.glob("design-*.html"))
    assert pages and (out / "sweep.html").is_file()
    (out / "design-notes.html").write_text("mine")
    assert cli("sweep", model, *VARY, "-o", out).exit_code == 0
    assert sorted(p.name for p in out.glob("*.html")) == ["design-notes.html"]
    assert json.loads((out / "summary.json").read_text())["files"] == ["designs.parquet",
                                                                       "summary.json"]
    # optimize: its report of an earlier --report run goes, the user's report.html stays
    res = cli("optimize", model, *OPT, "--report", "-o", tmp_path / "p")
    assert res.exit_code == 0, res.output
    assert (tmp_path / "p" / "report.html").is_file()
    assert cli("optimize", model, *OPT, "-o", tmp_path / "p").exit_code == 0
    assert not (tmp_path / "p" / "report.html").exists()
    (tmp_path / "p" / "report.html").write_text("mine")
    assert cli("optimize", model, *OPT, "-o", tmp_path / "p").exit_code == 0
    assert (tmp_path / "p" / "report.html").read_text() == "mine"


@pytest.mark.parametrize("damage", ["truncated", "junk", "empty", "columns"])
def test_resume_computes_a_damaged_chunk_again(model_dir, tmp_path, damage):
    model, out = model_dir / "hoeken.toml", tmp_path / "o"
    args = ["sweep", model, *VARY, "--chunk", 1, "-o", out]
    fresh = pd.read_parquet(model_dir / "sweep" / "designs.parquet")
    from linkdyn.sampling import times as sample_times
    from linkdyn.studies import runner
    with pytest.raises(KeyboardInterrupt):   # the same sweep, stopped after its first chunk
        sp = linkdyn.studies.space(model, [O4])
        task = runner.Task(sp, sample_times(sp.model(), 11, None, None),
                           tuple(json.loads((model_dir / "sweep" / "summary.json").read_text())
                                 ["metrics"]), "numpy", None, None, 0.02)
        runner.run(task, np.array([[85.0], [90.0], [95.0]]), outdir=out, chunk=1,
                   _stop_after=1)
    chunk = out / "chunks" / "chunk-000000.parquet"
    data = chunk.read_bytes()
    chunk.write_bytes({"truncated": data[:len(data) // 2], "junk": b"junk", "empty": b"",
                       "columns": pd.DataFrame({"x": [1]}).to_parquet()}[damage])
    res = cli(*args, "--resume")
    assert res.exit_code == 0, res.output
    assert pd.read_parquet(out / "designs.parquet").equals(fresh)
    assert not (out / "chunks").exists()


@pytest.mark.parametrize("setup, words", [
    (lambda c: c.mkdir() or (c / "study.json").write_text("{"), ["study.json", "not the state"]),
    (lambda c: (c / "study.json").mkdir(parents=True), ["study.json", "not the state"]),
    (lambda c: c.write_text("mine"), ["chunks", "not a folder"]),
    (lambda c: c.mkdir() or (c / "chunk-000000.parquet").write_text("mine"),
     ["chunk-000000.parquet", "not a chunk of a sweep"]),
])
@pytest.mark.parametrize("resume", [False, True])
def test_a_chunks_folder_that_is_not_a_sweeps_is_refused_and_left_alone(setup, words, resume,
                                                                        tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    setup(out / "chunks")
    before = snapshot(out)
    refused(cli("sweep", HOEKEN, *VARY, "-o", out, *(["--resume"] if resume else [])),
            "-o", *words)
    assert snapshot(out) == before


# --- compare --sweep of damaged sweep folders --------------------------------------------------

def _json(path: Path, edit) -> None:
    data = json.loads(path.read_text())
    edit(data)
    path.write_text(json.dumps(data))


def _table(path: Path, edit) -> None:
    df = pd.read_parquet(path)
    path.write_bytes(edit(df).to_parquet())


DAMAGES = {
    "summary junk": lambda d: (d / "summary.json").write_text("junk"),
    "summary empty": lambda d: (d / "summary.json").write_text(""),
    "summary partial": lambda d: (d / "summary.json").write_bytes(
        (d / "summary.json").read_bytes()[:100]),
    "summary not UTF-8": lambda d: (d / "summary.json").write_bytes(b"\xff\xfe{}"),
    "summary a list": lambda d: (d / "summary.json").write_text("[]"),
    "summary model a number": lambda d: _json(d / "summary.json", lambda s: s.update(model=3)),
    "summary parameters junk": lambda d: _json(d / "summary.json",
                                               lambda s: s.update(parameters=[1])),
    "summary metrics null": lambda d: _json(d / "summary.json", lambda s: s.update(metrics=None)),
    "summary unknown path": lambda d: _json(
        d / "summary.json", lambda s: s["parameters"][0].update(path="bodies.crank.mas")),
    "table junk": lambda d: (d / "designs.parquet").write_bytes(b"junk"),
    "table empty": lambda d: (d / "designs.parquet").write_bytes(b""),
    "table truncated": lambda d: (d / "designs.parquet").write_bytes(
        (d / "designs.parquet").read_bytes()[:500]),
    "table without valid": lambda d: _table(d / "designs.parquet",
                                            lambda df: df.drop(columns=["valid"])),
    "design as text": lambda d: _table(d / "designs.parquet",
                                       lambda df: df.assign(design=df["design"].astype(str))),
    "metric as text": lambda d: _table(d / "designs.parquet", lambda df: df.assign(
        peak_tau_J1="x")),
    "parameter NaN": lambda d: _table(d / "designs.parquet", lambda df: df.assign(
        **{O4: np.nan})),
    "summary a folder": lambda d: ((d / "summary.json").unlink(),
                                   (d / "summary.json").mkdir()),
}


@pytest.mark.parametrize("damage", list(DAMAGES))
def test_compare_of_a_damaged_sweep_folder_exits_2_naming_it(damage, model_dir, tmp_path):
    import shutil
    folder = tmp_path / "sweep"
    shutil.copytree(model_dir / "sweep", folder)
    DAMAGES[damage](folder)
    res = cli("compare", model_dir / "hoeken.toml", "--sweep", folder, "--by", "peak_tau_J1",
              "--samples", 11, "-o", tmp_path / "c")
    text = refused(res)
    assert "--sweep" in text or O4 in text, text
    assert not (tmp_path / "c").exists()


def test_compare_of_a_sweep_gives_its_best_designs(model_dir, tmp_path):
    """The designs compared are the sweep's lowest peak torques, each as analyze gives it."""
    res = cli("compare", model_dir / "hoeken.toml", "--sweep", model_dir / "sweep", "--by",
              "peak_tau_J1", "--best", 2, "--samples", 11, "--backend", "numpy",
              "-o", tmp_path / "c")
    assert res.exit_code == 0, res.output
    df = pd.read_parquet(model_dir / "sweep" / "designs.parquet").sort_values("peak_tau_J1")
    data = json.loads((tmp_path / "c" / "compare.json").read_text())
    rows = [v["sweep"] for v in data.values() if "sweep" in v]
    assert [r["design"] for r in rows] == df["design"].tolist()[:2]
    sp = linkdyn.studies.space(model_dir / "hoeken.toml", [O4])
    for r in rows:   # the design analyzed alone: its peak torque is the sweep's
        sol = linkdyn.analyze(sp.model([r["parameters"][O4]]), T, backend="numpy")
        assert np.max(np.abs(sol.dyn.tau[:, 0])) == pytest.approx(r["peak_tau_J1"], rel=1e-9)


# --- property tests ---------------------------------------------------------------------------

NUMBERS = st.sampled_from(["0", "-1", "1", "3", "nan", "inf", "-inf", "1e300", "2.5", "x", "",
                           "4294967296", "1000000000000"])


@st.composite
def sweep_args(draw):
    """A sweep command line of small valid options with one to three replaced by odd values
    (``--designs`` small too: a sampled method's default of 1024 designs with ``--chunk 1``
    drawn took 20 s CPU of 1024 chunk files)."""
    opts = {"--vary": f"{O4}=85:95:2", "--samples": "5", "--backend": "numpy", "--designs": "4"}
    odd = {"--vary": st.sampled_from([f"{O4}=85:95:0", f"{O4}=95:85", f"{O4}=nan:1", f"{O4}=",
                                      "bodies.crank.mass=0:1", f"{O4}=85:95:100000000",
                                      "x=1:2", f"{O4}=85:95"]),
           "--samples": NUMBERS, "--designs": NUMBERS, "--chunk": NUMBERS,
           "--workers": st.sampled_from(["0", "-1", "1", "x", "1000000000000", "nan"]),
           "--seed": NUMBERS, "--fluctuation": NUMBERS, "--duration": NUMBERS,
           "--method": st.sampled_from(["grid", "random", "lhs", "sobol", "bogus"]),
           "--path-range": st.sampled_from(["1:2", "1:2:3", "a:b", "nan:1", ""]),
           "--metric": st.sampled_from(["peak_tau_J1", "bogus", ""]),
           "--scheduler": st.sampled_from(["", "bogus://x", "tcp://127.0.0.1:1", "tcp://:x"])}
    for key in draw(st.lists(st.sampled_from(sorted(odd)), min_size=1, max_size=3, unique=True)):
        opts[key] = draw(odd[key])
    return [x for k, v in opts.items() for x in (k, v)]


def clear_answer(res, out: Path) -> None:
    """Exit 0 with finite metrics for the valid designs, or exit 2/3 with one line naming an
    option or field, and then nothing written."""
    assert "Traceback" not in res.output, res.output
    if res.exit_code == 2 and "Usage:" in res.output:   # click's own: not a number, a choice
        assert "Error: Invalid value for '--" in res.output, res.output
        assert not out.exists()
        return
    if res.exit_code == 0:
        df = pd.read_parquet(out / "designs.parquet")
        # efforts and forces finite; a metric the samples do not define (path_deviation
        # with fewer than 3 samples in its range, flywheel_inertia of a cycle not sampled) is
        # NaN, as analyze's summary gives null; never infinite
        ok = df.loc[df["valid"]]
        peaks = [c for c in df.columns if c.startswith(("peak_", "rms_"))]
        assert np.all(np.isfinite(ok[peaks].to_numpy(float)))
        metrics = [c for c in df.columns if c not in ("design", "valid", "reason")]
        assert not np.any(np.isinf(ok[metrics].to_numpy(float)))
        assert not (out / "chunks").exists()
        return
    assert res.exit_code in (2, 3), res.output
    assert res.exception is None or isinstance(res.exception, SystemExit), res.exception
    text = res.output.strip()
    assert len(text.splitlines()) == 1 and text.startswith("error: "), text
    assert "--" in text or "bodies." in text or ".toml" in text, text
    assert not out.exists(), text


@PROFILE
@given(sweep_args())
def test_any_sweep_command_line_gets_a_clear_answer(tmp_path_factory, args):
    out = tmp_path_factory.mktemp("sweep") / "o"
    clear_answer(cli("sweep", HOEKEN, *args, "-o", out), out)


@PROFILE
@given(st.lists(st.sampled_from(sorted(DAMAGES)), min_size=1, max_size=3, unique=True),
       st.sampled_from(["peak_tau_J1", "path_deviation", "bogus"]),
       st.sampled_from(["1", "0", "-2", "100"]))
def test_any_damaged_sweep_folder_gets_a_clear_answer(model_dir, tmp_path_factory, damages,
                                                      by, best):
    import shutil
    base = tmp_path_factory.mktemp("cmp")
    folder = base / "sweep"
    shutil.copytree(model_dir / "sweep", folder)
    for d in damages:
        try:
            DAMAGES[d](folder)
        except Exception:   # an earlier damage left nothing this one can read or edit
            pass
    res = cli("compare", model_dir / "hoeken.toml", "--sweep", folder, "--by", by, "--best",
              best, "--samples", 11, "--backend", "numpy", "-o", base / "c")
    assert res.exit_code == 2 and "Traceback" not in res.output, res.output
    assert res.output.startswith("error: ") and len(res.output.strip().splitlines()) == 1


@PROFILE
@given(st.sampled_from([{}, {O4: (85, 95, 1)}, {O4: (95, 85)}, {O4: "85:95"}, {O4: (85, 95)},
                        {"x": (0, 1)}, [O4]]),
       st.sampled_from(["peak_tau_J1", "bogus", None]),
       st.sampled_from([(), ("peak_tau_J1<=2",), ("peak_tau_J1<2",), ("path_deviation<=1N",),
                        (3,)]),
       st.sampled_from([0, -1, None, 2 ** 40]),
       st.sampled_from([0.02, 0.0, -1.0, np.nan, np.inf]))
def test_any_optimize_call_returns_a_finite_design_or_a_linkdyn_error(bounds, minimize,
                                                                      constraints, seed, fl):
    try:
        res = linkdyn.optimize(HOEKEN, bounds, T, minimize, constraints, seed=seed, popsize=2,
                               maxiter=1, polish=False, backend="numpy", fluctuation=fl)
    except LinkdynError as e:
        assert getattr(e, "field", "") or getattr(e, "time", None) is not None, str(e)
        return
    assert np.all(np.isfinite(list(res.metrics.values())))
    assert 85 <= res.values[O4] <= 95
