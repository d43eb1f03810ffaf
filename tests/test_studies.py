"""Design studies: parameters named by field paths, metrics equal to analyze's, sweeps that resume
and give the same table in this process, in worker processes and on a Dask cluster."""

from __future__ import annotations

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
    with pytest.raises(ModelError, match=r"bodies.crank.mass = -1 kg .*must be positive"):
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


def test_a_design_with_an_invalid_model_is_kept_with_the_loaders_message():
    df = linkdyn.sweep(HOEKEN, {"bodies.crank.mass": [1.0, -1.0]}, T, metrics=["peak_tau_J1"])
    assert df.valid.tolist() == [True, False]
    assert df.reason[1].startswith("bodies.crank.mass: must be positive")


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
    distributed = pytest.importorskip("distributed")
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
