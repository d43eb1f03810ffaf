"""Design studies: parameters named by field paths, metrics equal to analyze's, sweeps that resume
and give the same table in this process, in worker processes and on a Dask cluster."""

from __future__ import annotations

import re

import numpy as np
import pytest

import linkdyn
from linkdyn.design import summary
from linkdyn.errors import AssemblyError, ModelError
from linkdyn.studies import Task, evaluate_metrics, grid, metric_names, run, sample, space
from linkdyn.studies.params import check_ranges

HOEKEN = linkdyn.example_path("hoeken")
T = np.linspace(0.0, 4.0 / 3.0, 61)  # one crank turn
# ground distance and coupler pin: a box that holds valid designs and ones that cannot assemble
BOX = {"bodies.ground.points.O4[0]": (60.0, 120.0), "bodies.coupler.points.O3[0]": (90.0, 140.0)}


# --- parameters -------------------------------------------------------------------------------

def test_paths_resolve_in_the_files_units():
    sp = space(HOEKEN, ["bodies.ground.points.O4[0]", "bodies.coupler.points.P[1]",
                        "bodies.crank.mass", "drivers[0].motion.rpm", "drivers.J1.motion.start"])
    assert [p.base for p in sp.params] == [89.5, 0.0, 1.5, 45.0, 0.0]
    assert [p.unit for p in sp.params][:4] == ["mm", "mm", "kg", "rev/min"]
    m = sp.model([100.0, 2.0, 1.8, 30.0, 0.0])
    assert m.body("ground").points["O4"][0] == pytest.approx(0.1)
    assert m.body("coupler").points["P"][1] == pytest.approx(0.002)
    assert m.body("crank").mass == 1.8
    assert m.drivers[0].motion.speed == pytest.approx(np.pi)  # 30 rpm
    # the file's inertia about O1 now gives a different centroidal inertia with the new mass
    base = linkdyn.load(HOEKEN)
    assert m.body("crank").inertia == pytest.approx(725.80e-6 - 1.8 * 0.01905 ** 2)
    assert base.body("crank").inertia == pytest.approx(725.80e-6 - 1.5 * 0.01905 ** 2)


@pytest.mark.parametrize("path, words", [
    ("bodies.gruond.mass", ["no entry of bodies named 'gruond'", "Did you mean 'ground'"]),
    ("bodies.crank.mas", ["no field 'mas'", "Did you mean 'mass'"]),
    ("bodies.crank.points.O2", ["is a list", "bodies.crank.points.O2[0]"]),
    ("drivers[2].motion.rpm", ["drivers has 1 entry, no [2]"]),
    ("mechanism.name", ["is a string, not a number"]),
    ("bodies..mass", ["cannot read the field path"]),
])
def test_a_bad_path_names_itself_and_the_fix(path, words):
    with pytest.raises(ModelError) as e:
        space(HOEKEN, [path])
    assert e.value.field == path
    for w in words:
        assert w in str(e.value)


def test_ranges_are_checked_against_the_model():
    with pytest.raises(ModelError, match=r"bodies.crank.mass = -1 kg .*must not be negative"):
        check_ranges(space(HOEKEN, ["bodies.crank.mass"]), [(-1.0, 2.0)])
    # an inertia about O1 below m d^2 is infeasible: the loader's parallel-axis check names it
    with pytest.raises(ModelError, match=r"bodies.crank.inertia = 100 kg mm\^2.*parallel-axis"):
        check_ranges(space(HOEKEN, ["bodies.crank.inertia"]), [(100.0, 800.0)])
    with pytest.raises(ModelError, match="LO > HI"):
        check_ranges(space(HOEKEN, ["bodies.crank.mass"]), [(2.0, 1.0)])
    check_ranges(space(HOEKEN, list(BOX)), list(BOX.values()))  # a valid box passes


# --- metrics ----------------------------------------------------------------------------------

def test_metrics_of_one_design_are_the_summarys_numbers():
    m = linkdyn.load(HOEKEN)
    sol = linkdyn.analyze(m, np.linspace(0.0, 4.0 / 3.0, 361))
    s = summary(sol, default_range=m.path_range)
    got = evaluate_metrics(sol)
    assert list(got) == metric_names(m)
    assert got["peak_tau_J1"] == s["drivers"]["J1"]["peak"] == pytest.approx(1.119, abs=5e-4)
    assert got["rms_tau_J1"] == s["drivers"]["J1"]["rms"]
    for j in "J1 J2 J3 J4".split():
        assert got[f"peak_F_{j}"] == s["reactions"][j]["peak_force_N"]
    assert got["peak_shaking_force"] == s["shaking"]["force_N"]["peak"]
    assert got["path_deviation"] == s["path_straightness"]["max_deviation_m"]
    assert got["flywheel_inertia"] == s["driver_energy"]["J1"]["flywheel"]["inertia_kg_m2"]
    ta = s["four_bars"][0]["transmission_angle_deg"]
    assert np.degrees(got["min_transmission_angle"]) == pytest.approx(
        min(ta["min"], 180 - ta["max"]), rel=1e-12)


def _single(path, values, backend):
    """analyze of one design alone: its metrics, or the text of its error (file left out)."""
    sp = space(path, list(BOX))
    m = sp.model(values)
    try:
        sol = linkdyn.analyze(m, T, backend=backend)
    except AssemblyError as e:
        e.file = ""
        return False, str(e), None
    return True, "", evaluate_metrics(sol)


@pytest.mark.parametrize("backend", ["numpy", "compiled"])
def test_every_metric_of_a_sweep_is_analyzes_metric_of_that_design(backend):
    # random designs, one that cannot be assembled and one that assembles but cannot turn fully
    values = np.vstack([sample(list(BOX.values()), "random", 6, seed=3), [50.3, 83.7],
                        [150.0, 60.0]])
    df = linkdyn.sweep(HOEKEN, dict(zip(BOX, values.T)), T, backend=backend)
    assert "cannot be assembled" in df.reason[6] and "stop closing" in df.reason[7]
    for k, row in df.iterrows():
        ok, reason, single = _single(HOEKEN, values[k], backend)
        assert row.valid == ok and row.reason == reason
        if ok:
            for name, v in single.items():
                assert row[name] == pytest.approx(float(v), rel=1e-9, abs=1e-12), name
        else:
            assert np.all(np.isnan(row[metric_names(linkdyn.load(HOEKEN))].to_numpy(float)))
    # metrics that read no reaction: the sweep skips the reactions stage, the same rows
    few = ["valid", "reason", "peak_tau_J1", "path_deviation", "flywheel_inertia"]
    lean = linkdyn.sweep(HOEKEN, dict(zip(BOX, values.T)), T, metrics=few[2:], backend=backend)
    assert lean[few].equals(df[few])


def test_a_design_with_an_invalid_model_is_kept_with_the_loaders_message():
    df = linkdyn.sweep(HOEKEN, {"bodies.crank.mass": [1.0, -1.0]}, T, metrics=["peak_tau_J1"])
    assert df.valid.tolist() == [True, False]
    assert df.reason[1].startswith("bodies.crank.mass: must not be negative")


def test_unknown_metric_is_refused_with_the_closest():
    with pytest.raises(ModelError, match="Did you mean 'peak_tau_J1'"):
        linkdyn.sweep(HOEKEN, {"bodies.crank.mass": [1.0]}, T, metrics=["peak_tau_j1"])


# --- running ----------------------------------------------------------------------------------

def _task(metrics=("peak_tau_J1", "path_deviation")):
    return Task(space(HOEKEN, list(BOX)), T, metrics, "numpy")


def test_a_killed_sweep_resumes_without_recomputing_a_finished_chunk(tmp_path):
    values = sample(list(BOX.values()), "sobol", 12, seed=1)
    whole, _ = run(_task(), values, chunk=3)
    with pytest.raises(KeyboardInterrupt):
        run(_task(), values, outdir=tmp_path, chunk=3, _stop_after=2)
    done = sorted(p.name for p in (tmp_path / "chunks").glob("chunk-*.parquet"))
    assert len(done) == 2
    stamps = {n: (tmp_path / "chunks" / n).stat().st_mtime_ns for n in done}
    with pytest.raises(KeyboardInterrupt):  # killed again, one chunk later
        run(_task(), values, outdir=tmp_path, chunk=3, resume=True, _stop_after=1)
    assert {n: (tmp_path / "chunks" / n).stat().st_mtime_ns for n in done} == stamps
    df, stats = run(_task(), values, outdir=tmp_path, chunk=3, resume=True)
    assert (stats["chunks_reused"], stats["chunks_computed"]) == (3, 1)
    assert df.equals(whole)
    # another study in the same directory is not mixed in
    with pytest.raises(ModelError, match="different study"):
        run(_task(), values[:6], outdir=tmp_path, chunk=3, resume=True)


def test_worker_processes_give_the_same_table():
    values = sample(list(BOX.values()), "lhs", 8, seed=2)
    one, _ = run(_task(), values, chunk=2)
    two, stats = run(_task(), values, chunk=2, workers=2)
    assert stats["chunks_computed"] == 4
    assert two.equals(one)


def test_a_dask_cluster_gives_the_same_table():
    distributed = pytest.importorskip("distributed", reason="the scheduler test needs dask.distributed (the dask extra)")
    values = sample(list(BOX.values()), "sobol", 8, seed=4)
    local, _ = run(_task(), values, chunk=3)
    with distributed.LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                                  dashboard_address=None) as cluster, \
            distributed.Client(cluster) as client:
        on_dask, stats = run(_task(), values, chunk=3, scheduler=client)
    assert stats["chunks_computed"] == 3
    assert on_dask.equals(local)


def test_sample_methods_cover_the_box_and_repeat_with_a_seed():
    bounds = [(0.0, 1.0), (10.0, 20.0)]
    g = sample(bounds, "grid", counts=[3, 2])
    assert g.tolist() == [[0, 10], [0, 20], [0.5, 10], [0.5, 20], [1, 10], [1, 20]]
    for method in ("random", "lhs", "sobol"):
        a, b = sample(bounds, method, 16, seed=7), sample(bounds, method, 16, seed=7)
        assert a.shape == (16, 2) and np.array_equal(a, b)
        assert np.all((a >= [0, 10]) & (a <= [1, 20]))
    lhs = sample(bounds, "lhs", 10, seed=0)  # one point in each tenth of every axis
    assert sorted(np.floor(lhs[:, 0] * 10).astype(int)) == list(range(10))
    assert grid({"a": [1, 2], "b": [3, 4, 5]})["b"].tolist() == [3, 4, 5, 3, 4, 5]


# --- optimize ---------------------------------------------------------------------------------

def test_optimize_beats_a_sobol_sweep_of_the_same_space_with_fewer_designs():
    from linkdyn.studies.optimize import optimize
    box = {"bodies.ground.points.O4[0]": (80.0, 100.0),
           "bodies.coupler.points.O3[0]": (110.0, 125.0)}
    res = optimize(HOEKEN, box, T, "peak_tau_J1", ["path_deviation<=0.1mm"], seed=0,
                   popsize=8, maxiter=15, backend="numpy")
    values = sample(list(box.values()), "sobol", 1024, seed=0)
    df = linkdyn.sweep(HOEKEN, dict(zip(box, values.T)), T,
                       metrics=["peak_tau_J1", "path_deviation"], backend="numpy")
    feasible = df[df.valid & (df.path_deviation <= 1e-4)]
    assert len(feasible) > 0 and res.feasible
    assert res.metrics["path_deviation"] <= 1e-4
    assert res.metrics["peak_tau_J1"] <= feasible.peak_tau_J1.min()
    assert res.evaluations < len(df)
    # the reported design is the model written out: it analyzes to the reported metrics
    again = evaluate_metrics(linkdyn.analyze(
        linkdyn.model_from_dict(res.data, base_dir="."), T, backend="numpy"))
    assert again["peak_tau_J1"] == pytest.approx(res.metrics["peak_tau_J1"], rel=1e-12)
    # the same seed gives the same design
    res2 = optimize(HOEKEN, box, T, "peak_tau_J1", ["path_deviation<=0.1mm"], seed=0,
                    popsize=8, maxiter=15, backend="numpy")
    assert res2.values == res.values


def test_constraints_read_units_and_refuse_nonsense():
    from linkdyn.studies.optimize import parse_constraint
    c = parse_constraint("path_deviation<=0.1mm")
    assert (c.metric, c.upper, c.value) == ("path_deviation", True, pytest.approx(1e-4))
    c = parse_constraint("min_transmission_angle >= 40 deg")
    assert (c.upper, c.value) == (False, pytest.approx(np.radians(40)))
    with pytest.raises(ModelError, match="METRIC<=VALUE"):
        parse_constraint("path_deviation == 3")


# --- command line -----------------------------------------------------------------------------

def _cli(*args):
    from click.testing import CliRunner

    from linkdyn.cli import main
    return CliRunner().invoke(main, [str(a) for a in args])


def test_sweep_command_writes_the_table_and_summary(tmp_path):
    import json

    import pandas as pd
    r = _cli("sweep", HOEKEN, "--vary", "bodies.ground.points.O4[0]=80:100:3",
             "--vary", "bodies.coupler.points.O3[0]=110:120:2", "--samples", 61,
             "--metric", "peak_tau_J1", "--metric", "path_deviation", "-o", tmp_path)
    assert r.exit_code == 0, r.output
    df = pd.read_parquet(tmp_path / "designs.parquet")
    assert list(df.columns) == ["design", "bodies.ground.points.O4[0]",
                                "bodies.coupler.points.O3[0]", "valid", "reason", "peak_tau_J1",
                                "path_deviation"]
    assert df["bodies.ground.points.O4[0]"].tolist() == [80, 80, 90, 90, 100, 100]
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["designs"] == 6 and s["method"] == "grid"
    assert s["metrics"]["peak_tau_J1"]["min"] == df.peak_tau_J1.min()
    assert not (tmp_path / "chunks").exists()
    # the same designs from a CSV file give the same table
    csv = tmp_path / "designs.csv"
    df[["bodies.ground.points.O4[0]", "bodies.coupler.points.O3[0]"]].to_csv(csv, index=False)
    r = _cli("sweep", HOEKEN, "--designs-csv", csv, "--samples", 61, "--metric", "peak_tau_J1",
             "--metric", "path_deviation", "-o", tmp_path / "csv")
    assert r.exit_code == 0, r.output
    assert pd.read_parquet(tmp_path / "csv" / "designs.parquet").equals(df)


@pytest.mark.parametrize("args, words", [
    (["--vary", "bodies.crank.mass=1:2:3:4"], ["cannot read --vary"]),
    (["--vary", "bodies.crank.mas=1:2"], ["bodies.crank.mas", "Did you mean 'mass'"]),
    (["--vary", "bodies.crank.mass=-1:2"], ["must not be negative"]),
    (["--vary", "bodies.crank.mass=1:1.8", "--metric", "peak_tau"], ["no metric 'peak_tau'"]),
    ([], ["nothing to vary"]),
    # the crank pin may reach the crank's pivot: a link of zero length
    (["--vary", "bodies.crank.points.O2[0]=-10:10"],
     ["bodies.crank.points.O2[0]", "zero length", "Narrow the range"]),
])
def test_sweep_command_bad_input_exits_2_with_one_message(tmp_path, args, words):
    r = _cli("sweep", HOEKEN, *args, "--samples", 11, "-o", tmp_path / "o")
    assert r.exit_code == 2
    for w in words:
        assert w in r.output
    assert "Traceback" not in r.output
    assert not (tmp_path / "o" / "designs.parquet").exists()


def test_optimize_command_writes_a_model_that_analyzes_to_its_metrics(tmp_path):
    import json
    r = _cli("optimize", HOEKEN, "--vary", "bodies.ground.points.O4[0]=85:95",
             "--minimize", "peak_tau_J1", "--constraint", "path_deviation<=0.2mm",
             "--constraint", "min_transmission_angle>=10",
             "--samples", 61, "--popsize", 5, "--maxiter", 4, "--backend", "numpy", "-o", tmp_path)
    assert r.exit_code == 0, r.output
    info = json.loads((tmp_path / "optimize.json").read_text())
    best = linkdyn.load(tmp_path / "best.toml")
    got = evaluate_metrics(linkdyn.analyze(best, T, backend="numpy"),
                           ["peak_tau_J1", "path_deviation", "min_transmission_angle"])
    assert got["peak_tau_J1"] == pytest.approx(info["metrics"]["peak_tau_J1"], rel=1e-12)
    x = info["parameters"]["bodies.ground.points.O4[0]"]
    assert best.body("ground").points["O4"][0] == pytest.approx(x * 1e-3, rel=1e-15)
    assert (tmp_path / "summary.json").is_file()
    # each constraint's status: active when within 1 % of its bound (the design's own metrics,
    # analyzed again), shown in the file's unit; each parameter's change from the file's value
    dev, mu = got["path_deviation"], np.degrees(got["min_transmission_angle"])
    (c1, c2) = info["constraint_status"]
    assert c1["text"] == "path_deviation <= 0.2 mm" and c1["active"] == (abs(dev - 2e-4) <= 2e-6)
    assert c1["shown"] == f"{dev * 1e3:.4g} mm" and c1["slack"] == pytest.approx(2e-4 - dev, abs=1e-12)
    assert c2["text"] == "min_transmission_angle >= 10 deg" and c2["active"] == (abs(mu - 10) <= 0.1)
    (ch,) = info["changes"]
    assert (ch["base"], ch["best"]) == (89.5, x) and ch["change"] == pytest.approx(x - 89.5)
    assert info["objective_shown"] == f"{got['peak_tau_J1']:.6g} N m"
    # results.csv is the best design's run: its torque peaks at the objective
    head = (tmp_path / "results.csv").read_text().splitlines()[0].split(",")
    tau = np.loadtxt(tmp_path / "results.csv", delimiter=",", skiprows=1)[:, head.index("tau_J1")]
    assert len(tau) == 61 and np.max(np.abs(tau)) == pytest.approx(got["peak_tau_J1"], rel=1e-12)


def test_driver_speed_and_load_parameters_are_per_design():
    """Each design keeps its own driver motion and loads: the flywheel (per-design cycle) and
    the efforts equal analyze's of that design alone."""
    path = linkdyn.example_path("slider_crank")
    params = {"drivers[0].motion.rpm": [200.0, 300.0, 450.0], "loads[0].value[0]": [-100.0, -200.0,
                                                                                  -350.0]}
    t = np.linspace(0.0, 0.3, 61)
    df = linkdyn.sweep(path, params, t, backend="numpy")
    sp = space(path, list(params))
    for k in range(3):
        single = evaluate_metrics(linkdyn.analyze(sp.model([params[p][k] for p in params]), t,
                                                  backend="numpy"))
        for name, v in single.items():
            assert df[name][k] == pytest.approx(float(v), rel=1e-9, abs=1e-12), name
    assert len(set(df.peak_tau_J1.round(9))) == 3 and df.valid.all()


def test_a_sweep_killed_by_sigkill_resumes_from_its_chunks(tmp_path):
    """The command line killed mid-run (SIGKILL: no clean-up at all) and run again with --resume:
    the finished chunks are reused and the table is that of an uninterrupted run."""
    import json
    import os
    import signal
    import subprocess
    import sys
    import time

    import pandas as pd
    args = ["sweep", str(HOEKEN), "--vary", "bodies.ground.points.O4[0]=80:100",
            "--vary", "bodies.coupler.points.O3[0]=110:120", "--designs", "120", "--samples", "31",
            "--chunk", "2", "--metric", "peak_tau_J1", "--backend", "numpy", "--no-progress"]
    cmd = [sys.executable, "-c", "from linkdyn.cli import main; main()"]
    proc = subprocess.Popen(cmd + args + ["-o", str(tmp_path / "a")], stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, env=os.environ.copy())
    chunks = tmp_path / "a" / "chunks"
    deadline = time.monotonic() + 120
    while len(list(chunks.glob("chunk-*.parquet"))) < 3 and time.monotonic() < deadline:
        time.sleep(0.02)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    done = len(list(chunks.glob("chunk-*.parquet")))
    assert 3 <= done < 60 and not (tmp_path / "a" / "designs.parquet").exists()
    r = _cli(*args, "-o", tmp_path / "a", "--resume")
    assert r.exit_code == 0, r.output
    run_stats = json.loads((tmp_path / "a" / "summary.json").read_text())["run"]
    assert run_stats["chunks_reused"] >= done and run_stats["chunks"] == 60
    assert run_stats["chunks_computed"] == 60 - run_stats["chunks_reused"]
    r = _cli(*args, "-o", tmp_path / "b")
    assert r.exit_code == 0, r.output
    assert pd.read_parquet(tmp_path / "a" / "designs.parquet").equals(
        pd.read_parquet(tmp_path / "b" / "designs.parquet"))


def _front_brute(a, b):
    """The Pareto front (both minimized) by its definition, O(n^2): no other point is at most
    as large in both and smaller in one."""
    ok = np.isfinite(a) & np.isfinite(b)
    return [i for i in range(len(a)) if ok[i] and not any(
        ok[j] and a[j] <= a[i] and b[j] <= b[i] and (a[j] < a[i] or b[j] < b[i])
        for j in range(len(a)))]


@pytest.mark.parametrize("seed", range(6))
def test_pareto_front_is_the_brute_force_front(seed):
    from linkdyn.report.sweep import pareto_front
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 120))
    a, b = rng.normal(size=n), rng.normal(size=n)
    if seed % 2:  # ties, duplicates and gaps (the cases a sort gets wrong)
        a, b = np.round(a, 0), np.round(b, 0)
        a[rng.random(n) < 0.1] = np.nan
        b[rng.random(n) < 0.1] = np.inf
    got = pareto_front(a, b)
    assert got.tolist() == _front_brute(a, b)
    assert len(got) >= (1 if np.any(np.isfinite(a) & np.isfinite(b)) else 0)


def test_sweep_report_holds_every_design_and_nothing_is_written_on_failure(tmp_path, monkeypatch):
    import json

    import pandas as pd
    args = ["sweep", HOEKEN, "--vary", "bodies.ground.points.O4[0]=40:200:5",
            "--vary", "bodies.coupler.points.O3[0]=60:140:4", "--samples", 41,
            "--metric", "peak_tau_J1", "--metric", "path_deviation", "--backend", "numpy",
            "--report"]
    r = _cli(*args, "-o", tmp_path / "s")
    assert r.exit_code == 0, r.output
    df = pd.read_parquet(tmp_path / "s" / "designs.parquet")
    assert 0 < df.valid.sum() < len(df)  # both kinds of design on the page
    text = (tmp_path / "s" / "sweep.html").read_text("utf-8")
    assert "http://" not in text and "https://" not in text and "<script src" not in text
    blob = re.search(r'<script id="linkdyn-data" type="application/json">(.*?)</script>', text,
                     re.S).group(1)
    data = json.loads(blob)
    assert data["design"] == df.design.tolist() and data["valid"] == df.valid.tolist()
    # in the file's units (Hoeken's: mm): the deviation, SI in the table, in mm on the page
    for c, scale in [("bodies.ground.points.O4[0]", 1), ("bodies.coupler.points.O3[0]", 1),
                     ("peak_tau_J1", 1), ("path_deviation", 1000)]:
        want = df[c].to_numpy(float) * scale
        got = np.array([np.nan if v is None else v for v in data["cols"][c]])
        np.testing.assert_allclose(got, want, rtol=1e-14)
    from linkdyn.report.sweep import pareto_front
    v = df.valid.to_numpy()
    assert data["fronts"]["peak_tau_J1|path_deviation"] == pareto_front(
        np.where(v, df.peak_tau_J1, np.nan), np.where(v, df.path_deviation, np.nan)).tolist()
    # the best designs of each metric have their own report page (with its animation), which
    # the sweep page shows: each analyzed alone gives the sweep's batch metric
    from linkdyn.studies.runner import best_designs
    rows = best_designs(df, ["peak_tau_J1", "path_deviation"])
    assert 3 <= len(rows) <= 6
    assert sorted(data["previews"]) == sorted(str(df.design[k]) for k in rows)
    for k in rows:
        page_text = (tmp_path / "s" / data["previews"][str(df.design[k])]).read_text("utf-8")
        assert 'id="anim"' in page_text
        from test_report import page_blob
        own = page_blob(page_text)
        tau = np.array([v for v in own["series"]["tau:J1"] if v is not None])
        assert np.max(np.abs(tau)) == pytest.approx(df.peak_tau_J1[k], rel=1e-4)
    # a page that cannot be written leaves no file at all
    import linkdyn.report.sweep as page

    def boom(*a, **k):
        raise RuntimeError("page failed")
    monkeypatch.setattr(page, "render_sweep", boom)
    r = _cli(*args, "-o", tmp_path / "f")
    assert r.exit_code != 0
    assert not any((tmp_path / "f").glob("*.html")) and not any((tmp_path / "f").glob("*.parquet"))


DYAD_SPACES = pytest.mark.parametrize("example, path, lo, hi", [
    ("hoeken", "bodies.ground.points.O4[0]", 0.0, 400.0),        # RRR chain
    ("slider_crank", "bodies.ground.points.G[1]", -300.0, 300.0),  # RRP: the slide line's offset
    ("inverted_slider_crank", "bodies.ground.points.O4[1]", -400.0, 400.0),  # RPR: always
    ("watt2", "bodies.ground.points.O6[0]", 0.0, 600.0),           # two RRR dyads
])


def _dyad_designs(example, path, lo, hi):
    """24 random designs of ``example`` with ``path`` drawn in [lo, hi], and their layout."""
    from linkdyn.kinematics.layout import compile_designs

    models, _ = space(linkdyn.example_path(example), [path]).models(
        np.random.default_rng(1).uniform(lo, hi, (24, 1)))
    return models, compile_designs(models)


@DYAD_SPACES
def test_dyads_that_cannot_close_are_the_designs_no_newton_start_assembles(example, path, lo, hi):
    from linkdyn.kinematics import dyads, newton
    from linkdyn.kinematics.positions import assemble, assembly_guess
    from linkdyn.kinematics.recursion import forward_positions

    models, lay = _dyad_designs(example, path, lo, hi)
    q0 = np.stack([assembly_guess(m, lay) for m in models], axis=-1)[..., None]   # (n, D, 1)
    q0[list(lay.topo.driven)] = lay.driver_values(np.zeros(1))[0]
    can = dyads.closable(lay, lay.dyads, q0, forward_positions)[:, 0]
    # the independent answer: damped Newton from 48 random starts per design (of a design that
    # closes, at least 21 of them converge: watt2's fewest; hoeken's, every one)
    starts = np.repeat(q0, 48, axis=-1)
    starts[list(lay.topo.dependent)] = np.random.default_rng(2).uniform(-np.pi, np.pi, 48)
    with np.errstate(all="ignore"):
        _, err = newton(lay, starts, maxiter=60, damped=True)
    assert np.array_equal(can, np.any(err <= 1e-10, axis=-1))
    assert 0 < can.sum() < len(can) or example == "inverted_slider_crank"
    # the assembly reports the same designs (the sweep sorts them out by it) and solves the
    # others as it does alone: NaN exactly where no mode closes or no start converges
    q, closes = assemble(models, lay, lay.driver_values(np.zeros(1))[0][..., 0],
                         raise_error=False, closable=True)
    assert np.array_equal(closes, can) and np.all(np.isnan(q[:, ~can]))
    assert np.array_equal(q, assemble(models, lay, lay.driver_values(np.zeros(1))[0][..., 0],
                                      raise_error=False), equal_nan=True)
    assert np.array_equal(np.all(np.isfinite(q), axis=0), np.any(err <= 1e-10, axis=-1))
    if example == "hoeken":   # circles: |r1 - r2| <= d <= r1 + r2, crank pin at (38.1, 0)
        d = np.abs([m.body("ground").points["O4"][0] - 0.0381 for m in models])
        assert np.array_equal(can, (abs(0.1152 - 0.1152) <= d) & (d <= 0.2304))


# --- docs/design-studies.md: Hoeken with mass that follows the geometry -----------------------

HOEKEN_BARS = {   # the doc's bars for the bundled file's three moving bodies
    'mass = 1.5\ncom = [19.05, 0.0]\ninertia = 725.80\ninertia_about = "O1"':
        'bars = [{ between = ["O1", "O2"], mass_per_length = 0.03937008 }]',
    'mass = 5.0\ncom = [115.2, 0.0]\ninertia = 88473.60\ninertia_about = "O2"':
        'bars = [{ between = ["O2", "P"], mass_per_length = 0.02170139 }]',
    'mass = 3.0\ncom = [57.6, 0.0]\ninertia = 13271.76\ninertia_about = "O3"':
        'bars = [{ between = ["O3", "O4"], mass_per_length = 0.02604167 }]'}
FOUR = ["bodies.ground.points.O4[0]", "bodies.coupler.points.O3[0]", "bodies.coupler.points.P[0]",
        "bodies.rocker.points.O4[0]"]


def test_the_hoeken_study_with_mass_that_follows_the_geometry(tmp_path):
    # the table of docs/design-studies.md: each optimizer's design (optimize.json's values,
    # shown rounded there) analyzed again in each file, its peak torque as printed (4 digits)
    # and its path within 0.1 mm; the bars file gives the bundled file's run
    from linkdyn.sampling import times
    text = HOEKEN.read_text("utf-8")
    for old, new in HOEKEN_BARS.items():
        assert old in text
        text = text.replace(old, new)
    bars = tmp_path / "hoeken_bars.toml"
    bars.write_text(text, "utf-8")
    fixed_best = [105.1273642319959, 140.0, 277.7413442701448, 139.07504221142307]
    bars_best = [101.00190542458482, 112.82185536179979, 180.0, 137.31283331690975]

    def run(path, values=None):
        sp = space(path, FOUR)
        m = sp.model(values if values is not None else [p.base for p in sp.params])
        got = evaluate_metrics(linkdyn.analyze(m, times(m, None, None, None), backend="numpy"),
                               ["peak_tau_J1", "path_deviation"])
        return m, float(got["peak_tau_J1"]), float(got["path_deviation"])

    assert run(bars)[1] == pytest.approx(run(HOEKEN)[1], abs=1e-5)   # 1.11902 N m both
    for path, values, want in ((HOEKEN, fixed_best, 0.6869), (bars, fixed_best, 1.0302),
                               (bars, bars_best, 0.5932)):
        m, tau, dev = run(path, values)
        assert tau == pytest.approx(want, abs=5e-5), (path.name, values)
        assert dev <= 1e-4 * (1 + 1e-6)
    # with P fixed both files' optimizers find one design (only the rocker's mass moves)
    three = [103.29970514753767, 129.98886155498934, 230.4, 139.96768460416044]
    assert run(HOEKEN, three)[1] == pytest.approx(0.7712, abs=5e-5)
    assert run(bars, three)[1] == pytest.approx(0.7721, abs=5e-5)
    # the fixed-mass design's links weigh their lengths with bars: the coupler 6.03 kg
    m = space(bars, FOUR).model(fixed_best)
    assert m.body("coupler").mass == pytest.approx(0.02170139 * 277.7413442701448, rel=1e-12)
    assert round(m.body("coupler").mass, 2) == 6.03 and round(m.body("rocker").mass, 2) == 3.62


@DYAD_SPACES
def test_compiled_nodes_follow_the_branch_of_designs_that_cannot_all_close(example, path, lo,
                                                                          hi):
    """The branch of the designs above followed with its nodes closed by the compiled kernel
    (the compiled backend's path): numpy's nodes, reach and rates to rounding, the same nodes
    that do not close. (Its own test, named so that it runs on the compiled worker.)"""
    pytest.importorskip("numba", reason="the compiled nodes need numba")
    from linkdyn.kinematics import compiled_nodes
    from linkdyn.kinematics.positions import follow

    models, lay = _dyad_designs(example, path, lo, hi)
    t = np.linspace(-0.4, 2.5, 40)
    with np.errstate(all="ignore"):
        ref = follow(models, lay, t, single=False)
        got = follow(models, lay, t, single=False, nodes=compiled_nodes.close)
    assert np.array_equal(got.nodes, ref.nodes) and np.array_equal(got.reach, ref.reach)
    for a, b in ((got.Q, ref.Q), (got.QD, ref.QD)):
        assert np.array_equal(np.isnan(a), np.isnan(b)) and np.isfinite(b).any()
        assert np.allclose(a, b, rtol=0, atol=1e-12 * np.nanmax(np.abs(b)), equal_nan=True)
