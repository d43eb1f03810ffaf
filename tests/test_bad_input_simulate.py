"""Issue 22, part B: every bad input to ``simulate``, ``save``, ``analyze``/``check``/``load`` and
the Python API gets a clear answer (exit 0 with finite results, or exit 2/3 with one message
naming the file, option, field or time), and a run never touches what it did not write."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

import linkdyn
from linkdyn import LinkdynError, ModelError
from linkdyn.cli import example_text
from test_robustness import model, run, user_error, nothing_written

HOEKEN = example_text("hoeken")
RELEASE = example_text("fourbar_release")
AT_REST = RELEASE.replace("gravity = [0.0, -9.81]", "gravity = [0.0, 0.0]")
SCOTCH = example_text("scotch_yoke")


@pytest.mark.parametrize("text,args,code,fragments", [
    (RELEASE, ["--samples", 10_000_001], 2, ["--samples", "memory", "GB"]),
    (RELEASE, ["--samples", 1_000_000_000_000], 2, ["--samples", "memory"]),
    (RELEASE, ["--samples", "1e23"], 2, ["--samples"]),
    (RELEASE, ["--rtol", 1], 2, ["--rtol", "0.01"]),
    (RELEASE, ["--atol", 1e-300], 2, ["--atol", "1e-18"]),
    (RELEASE, ["--duration", "inf"], 2, ["--duration", "finite"]),
    (RELEASE, ["--duration", -1], 2, ["--duration"]),
])
def test_simulate_options_are_refused_naming_the_option(text, args, code, fragments, tmp_path):
    out = tmp_path / "out"
    res = run("simulate", model(tmp_path, text=text), "-o", out, *args)
    if "1e23" in args:   # click's own usage error (exit 2, names the option)
        assert res.exit_code == 2 and "--samples" in res.output
    else:
        user_error(res, code, *fragments)
    nothing_written(out)


def test_a_tiny_rtol_is_raised_to_scipys_floor_reported_and_without_warning(tmp_path):
    out = tmp_path / "out"
    res = run("simulate", model(tmp_path, text=RELEASE), "-o", out, "--rtol", 1e-20,
              "--duration", 0.05, "--samples", 3)
    assert res.exit_code == 0, res.output
    assert "Warning" not in res.output and "rtol is too small" not in res.output
    sim = json.loads((out / "summary.json").read_text())["simulation"]
    assert sim["rtol"] == pytest.approx(100 * np.finfo(float).eps)


def test_a_mechanism_that_does_not_move_is_summarized_and_written(tmp_path):
    # simulate: a four-bar at rest without gravity stays where it is, exactly
    out = tmp_path / "sim"
    res = run("simulate", model(tmp_path, text=AT_REST), "-o", out, "--duration", 0.2,
              "--samples", 5)
    assert res.exit_code == 0, res.output
    cols = np.genfromtxt(out / "results.csv", delimiter=",", names=True)
    assert np.all(cols["q_J1"] == cols["q_J1"][0]) and np.all(cols["qd_J1"] == 0.0)
    summ = json.loads((out / "summary.json").read_text())
    ma = summ["four_bars"][0]["mechanical_advantage"]
    assert ma["min"] is None and ma["max"] is None     # 0/0: not defined
    assert "n/a" in res.output
    # analyze: a driver at speed 0
    text = HOEKEN.replace("rpm = 45.0", "speed = 0.0").replace("cycles = 1", "duration = 1.0")
    out = tmp_path / "ana"
    res = run("analyze", model(tmp_path, text=text), "-o", out, "--samples", 5)
    assert res.exit_code == 0, res.output
    assert (out / "results.csv").is_file() and (out / "summary.json").is_file()


def test_a_path_point_that_does_not_exist_is_refused_with_or_without_a_range(tmp_path):
    for text in (HOEKEN, HOEKEN.replace("path_range = [110, 250]", "")):
        out = tmp_path / "out"
        res = run("analyze", model(tmp_path, text=text), "-o", out, "--path-point", "foo")
        user_error(res, 2, "--path-point", "foo")
        nothing_written(out)


JOINT_FORCE_ON_SLOT = '\n[[loads]]\nkind = "joint_force"\njoint = "J3"\nvalue = 1.0\n'


@pytest.mark.parametrize("command", ["check", "analyze"])
def test_a_joint_force_on_a_slot_is_refused_naming_the_field(command, tmp_path):
    path = model(tmp_path, text=SCOTCH + JOINT_FORCE_ON_SLOT)
    user_error(run(command, path, *(["-o", tmp_path / "out"] if command == "analyze" else [])),
               2, "loads[", ".joint", "slot")
    with pytest.raises(ModelError, match="slot"):
        linkdyn.load(path)


def test_save_writes_json_for_json_and_refuses_what_load_refuses(tmp_path):
    m = linkdyn.load(linkdyn.example_path("hoeken"))
    t = np.linspace(0.0, 1.0, 7)
    ref = linkdyn.analyze(m, t).columns["tau_J1"]
    p = linkdyn.save(m, tmp_path / "x.json")
    json.loads(p.read_text())                             # JSON, not TOML
    np.testing.assert_allclose(linkdyn.analyze(linkdyn.load(p), t).columns["tau_J1"], ref,
                               rtol=1e-12, atol=1e-12 * np.max(np.abs(ref)))
    for name in ("x", "x.yaml"):
        with pytest.raises(ModelError, match="path") as err:
            linkdyn.save(m, tmp_path / name)
        assert "toml" in str(err.value)
        assert not (tmp_path / name).exists()


@pytest.mark.parametrize("call,fragment", [
    (lambda m, p: linkdyn.simulate(None, [0.0, 1.0]), "model"),
    (lambda m, p: linkdyn.simulate({"bodies": []}, [0.0, 1.0]), "model"),
    (lambda m, p: linkdyn.simulate(m, [0.0, 0.1], atol=[1e-8, 1e-8]), "atol"),
    (lambda m, p: linkdyn.simulate(m, [0.0, 0.1], rtol="1e-8"), "rtol"),
    (lambda m, p: linkdyn.simulate(m, "0:1"), "t"),
    (lambda m, p: linkdyn.simulate(m, [0.0, math.inf]), "t"),
    (lambda m, p: linkdyn.simulate(m, [0.0, 0.1], method=3), "method"),
    (lambda m, p: linkdyn.simulate(m, [0.0, 0.1], method="Euler"), "method"),
    (lambda m, p: linkdyn.simulate(m, [0.0, 0.1], backend=1), "backend"),
    (lambda m, p: linkdyn.save(None, p / "x.toml"), "model"),
    (lambda m, p: linkdyn.save(m, 3), "path"),
    (lambda m, p: linkdyn.load(None), "path"),
    (lambda m, p: linkdyn.analyze(3, [0.0, 1.0]), "model"),
])
def test_api_misuse_is_a_linkdyn_error_naming_the_argument(call, fragment, tmp_path):
    m = linkdyn.load(linkdyn.example_path("fourbar_release"))
    with pytest.raises(LinkdynError) as err:
        call(m, tmp_path)
    assert isinstance(err.value, ModelError) and err.value.field.startswith(fragment)
    assert "Traceback" not in str(err.value)


def test_simulate_accepts_a_model_file_path(tmp_path):
    t = np.linspace(0.0, 0.05, 3)
    path = linkdyn.example_path("fourbar_release")
    ref = linkdyn.simulate(linkdyn.load(path), t, backend="numpy").columns["q_J1"]
    got = linkdyn.simulate(str(path), t, backend="numpy").columns["q_J1"]
    np.testing.assert_array_equal(got, ref)


@settings(max_examples=25, deadline=None)
@given(rtol=st.sampled_from([0.0, -1.0, 1e-30, 1e-8, 1e-3, 0.5, math.nan, math.inf, "x", None]),
       atol=st.sampled_from([0.0, 1e-300, 1e-20, 1e-10, 1e-6, math.inf, math.nan, [1e-8]]))
def test_simulate_tolerances_succeed_finitely_or_name_the_option(rtol, atol):
    m = linkdyn.load(linkdyn.example_path("fourbar_release"))
    try:
        sol = linkdyn.simulate(m, np.linspace(0.0, 0.02, 3), rtol=rtol, atol=atol,
                               backend="numpy")
    except ModelError as err:
        assert err.field in ("rtol", "atol"), str(err)
        return
    assert all(np.all(np.isfinite(c)) for c in sol.columns.values())
    assert sol.stats["rtol"] >= 100 * np.finfo(float).eps


def test_outputs_leave_unrelated_files_and_lookalike_folders_untouched(tmp_path):
    out = tmp_path / "out"
    (out / "chunks").mkdir(parents=True)
    (out / "results.csv.d").mkdir()
    mine = {out / "mine.txt": b"mine\n", out / "chunks" / "results.csv": b"not yours\n",
            out / "results.csv.d" / "summary.json": b"{}", out / "report.htm": b"<p>",
            out / "plot_notes.txt": b"notes"}
    for p, data in mine.items():
        p.write_bytes(data)
    res = run("analyze", model(tmp_path), "-o", out, "--report", "--samples", 9)
    assert res.exit_code == 0, res.output
    res = run("simulate", model(tmp_path, text=RELEASE), "-o", out, "--duration", 0.05,
              "--samples", 3)
    assert res.exit_code == 0, res.output
    for p, data in mine.items():
        assert p.read_bytes() == data, p
    assert (out / "results.csv").is_file() and (out / "summary.json").is_file()


LOAD = '\n[[loads]]\nkind = "torque"\nbody = "crank"\nvalue = "{}"\n'


@pytest.mark.parametrize("formula,t_bad", [("log(0.1 - t)", 0.1), ("3.2/qd_J1", 0.0)])
def test_simulate_names_a_load_that_is_not_finite_not_the_mechanism(formula, t_bad, tmp_path):
    # log(0.1 - t) is finite up to t = 0.1 s only: the steps shorten towards it (the loads'
    # fault, not a lock of the mechanism); 3.2/qd_J1 is infinite at rest, t = 0
    out = tmp_path / "out"
    path = model(tmp_path, text=RELEASE + LOAD.format(formula))
    res = run("simulate", path, "-o", out, "--duration", 0.2, "--samples", 5,
              "--backend", "numpy")
    line = user_error(res, 3, str(path), "loads[0]", "not finite", "at t = ")
    assert "locks" not in line
    with pytest.raises(linkdyn.AssemblyError) as err:
        linkdyn.simulate(linkdyn.load(path), np.linspace(0.0, 0.2, 5), backend="numpy")
    assert err.value.time == pytest.approx(t_bad, abs=1e-4)
    nothing_written(out)


def test_an_implicit_methods_jacobian_beyond_floating_point_is_exit_3_not_a_traceback(tmp_path):
    # 1e300 qd^2 is finite at rest, but BDF's finite-difference Jacobian of it is not: scipy's
    # LU refuses it (was a ValueError traceback, found by the mutation test below)
    out = tmp_path / "out"
    path = model(tmp_path, text=RELEASE + LOAD.format("1e300*qd_J1*qd_J1"))
    res = run("simulate", path, "-o", out, "--duration", 0.01, "--samples", 3, "--method", "BDF",
              "--backend", "numpy")
    user_error(res, 3, str(path), "at t = ", "Jacobian", "--method DOP853")
    nothing_written(out)


def test_a_duration_far_beyond_reach_is_refused_after_a_few_steps(tmp_path):
    import time

    m = linkdyn.load(model(tmp_path, text=RELEASE))
    start = time.process_time()
    with pytest.raises(linkdyn.AssemblyError, match="more steps of") as err:
        linkdyn.simulate(m, np.linspace(0.0, 1e300, 5), backend="numpy")
    # after about ten steps of the first second (was: 200 steps, several seconds)
    assert err.value.time < 1.0 and "--duration" in str(err.value)
    assert time.process_time() - start < 4.0
    out = tmp_path / "out"
    user_error(run("simulate", model(tmp_path, text=RELEASE), "-o", out, "--duration", 1e300,
                   "--samples", 5, "--backend", "numpy"), 3, "at t = ", "--duration")
    nothing_written(out)


def test_an_earlier_runs_report_is_removed_and_the_users_report_is_kept(tmp_path):
    out = tmp_path / "out"
    args = ["analyze", model(tmp_path), "-o", out, "--samples", 9]
    assert run(*args, "--report").exit_code == 0
    ours = {p.name for p in out.iterdir()}
    assert "report.html" in ours and any(n.startswith("plot_") for n in ours)
    assert set(json.loads((out / "summary.json").read_text())["files"]) == ours
    # the report and plots of the earlier run would describe another run: removed
    assert run(*args).exit_code == 0
    assert sorted(p.name for p in out.iterdir()) == ["results.csv", "summary.json"]
    # a report.html no run wrote is the user's: kept, and so is a user's plot
    (out / "report.html").write_text("mine")
    (out / "plot_mine.png").write_bytes(b"mine")
    for extra in ([], ["--format", "parquet"], []):
        assert run(*args, *extra).exit_code == 0
        assert (out / "report.html").read_text() == "mine"
        assert (out / "plot_mine.png").read_bytes() == b"mine"
    assert not (out / "results.parquet").exists()   # the run's own other format: removed
    res = run("simulate", model(tmp_path, text=RELEASE), "-o", out, "--duration", 0.05,
              "--samples", 3, "--backend", "numpy")
    assert res.exit_code == 0 and (out / "report.html").read_text() == "mine"


# --- property tests: simulate and save of mutated models (issue 22) ----------------------------

import copy                                                    # noqa: E402
import os                                                      # noqa: E402
import tomllib                                                 # noqa: E402
import warnings                                                # noqa: E402

from hypothesis import HealthCheck                             # noqa: E402

from test_robustness import DICTS, EXTREMES, ODD, mutants, names_a_field_or_time  # noqa: E402

IN_CI = os.environ.get("CI", "").strip().lower() in ("true", "1", "yes")
SIM_PROFILE = settings(max_examples=150 if IN_CI else 20, deadline=None,
                       suppress_health_check=[HealthCheck.too_slow])
SAVE_PROFILE = settings(max_examples=300 if IN_CI else 30, deadline=None,
                        suppress_health_check=[HealthCheck.too_slow,
                                               HealthCheck.function_scoped_fixture])


def _freed_yoke() -> dict:
    """The Scotch yoke without its driver, from [initial], with joint loads that read the state:
    a slot and a prismatic joint in a simulation."""
    d = tomllib.loads(SCOTCH)
    del d["drivers"], d["analysis"]
    d["initial"] = {"q": {"J1": 30.0}, "qd": {"J1": 360.0}}
    d.setdefault("loads", []).extend([
        {"kind": "joint_force", "joint": "J2", "value": "-0.05*qd_J2"},
        {"kind": "joint_torque", "joint": "J1", "value": "0.1*sin(q_J1/57.3) - 1e-4*qd_J1"}])
    return d


# models with [initial], state formulas and joint loads (toggle_spring is left out: stiff, each
# run of it takes a second)
SIM_DICTS = {"fourbar_release": tomllib.loads(RELEASE), "freed_yoke": _freed_yoke(),
             "hoeken_motor": tomllib.loads(example_text("hoeken_motor"))}
STATE_FORMULAS = ["3.2/qd_J1", "log(0.1 - t)", "-0.5*qd_J1", "where(qd_J1 > 0, -1, 1)",
                  "clip(q_J1, -1, 1)", "sqrt(q_J1)", "1e300*qd_J1*qd_J1", "exp(1000*q_J1)",
                  "q_J9", "qd_X", "sign(qd_J1)*2", "min(q_J1, 1) + max(qd_J1, -1)",
                  "1/(q_J1 - q_J1)", "2.5*(1 - qd_J1/1500)", "1e6*sin(t)"]


def simulation_change(draw, d):
    """One change of a model for simulate: its [initial] (a value, a joint's name, the
    section), or a load whose formula reads the state (on a body or inside a joint)."""
    how = draw(st.sampled_from(["initial", "initial", "initial name", "no initial", "load",
                                "load"]))
    joints = [j.get("name") for j in d.get("joints", []) if isinstance(j, dict)] or ["J1"]
    if how == "no initial":
        d.pop("initial", None)
        return how
    if how.startswith("initial"):
        if not isinstance(d.get("initial"), dict):
            d["initial"] = {}
        key = draw(st.sampled_from(["q", "qd"]))
        if not isinstance(d["initial"].get(key), dict):
            d["initial"][key] = {}
        section = d["initial"][key]
        joint = draw(st.sampled_from(joints + ["J9", ""]))
        if how == "initial name" and section:
            section[joint] = section.pop(next(iter(section)))
        else:
            section[joint] = copy.deepcopy(draw(st.sampled_from(
                EXTREMES + ODD + [0.0, 1.0, -45.0, 179.999, 1e3])))
        return how, key, joint
    kind = draw(st.sampled_from(["torque", "joint_torque", "joint_force", "force"]))
    value = draw(st.sampled_from(STATE_FORMULAS))
    bodies = [b.get("name") for b in d.get("bodies", []) if isinstance(b, dict)] or ["x"]
    load = {"kind": kind, "value": [value, 0.0] if kind == "force" else value}
    if kind.startswith("joint"):
        load["joint"] = draw(st.sampled_from(joints))
    else:
        load["body"] = draw(st.sampled_from(bodies))
        if kind == "force":
            load["point"] = "O2" if load["body"] == "crank" else "A"
    if isinstance(d.get("loads", []), list):
        d.setdefault("loads", []).append(load)
    return how, load


@st.composite
def simulation_mutants(draw):
    """A model for simulate with one or two of :func:`simulation_change` only."""
    name = draw(st.sampled_from(sorted(SIM_DICTS)))
    d = copy.deepcopy(SIM_DICTS[name])
    return name, d, [simulation_change(draw, d) for _ in range(draw(st.integers(1, 2)))]


OPTIONS = {"t": ["inf", "descending", "negative"], "rtol": [0.0, 2.0, math.nan, "1e-8"],
           "atol": [1e-300, -1.0, math.inf, [1e-8]], "method": ["Euler", 3]}


@SIM_PROFILE
@given(case=st.one_of(mutants(SIM_DICTS, simulation_change), simulation_mutants()),
       duration=st.sampled_from([0.005, 0.01, 0.02]),
       method=st.sampled_from(["DOP853", "DOP853", "RK45", "LSODA", "BDF"]),
       tols=st.sampled_from([(1e-8, 1e-10), (1e-5, 1e-6), (1e-20, 1e-10)]),
       odd=st.sampled_from([None] * 28 + [(k, v) for k, vs in OPTIONS.items() for v in vs]))
def test_a_mutated_simulation_runs_finitely_or_names_the_field_or_time(case, duration, method,
                                                                      tols, odd):
    name, d, changes = case
    t = np.linspace(0.0, duration, 3)
    args = {"t": t, "rtol": tols[0], "atol": tols[1], "method": method}
    if odd is not None:   # one option out of its range or of another type
        key, value = odd
        args[key] = {"inf": np.array([0.0, math.inf]), "descending": t[::-1],
                     "negative": t - 1.0}.get(value, value) if key == "t" else value
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)   # none may escape to the user
            m = linkdyn.model_from_dict(d, source=f"{name}.toml")
            # max_steps bounds the run (a mutated stiffness); past it: an error naming the time
            sol = linkdyn.simulate(m, args.pop("t"), **args, max_steps=60, backend="numpy")
    except LinkdynError as err:
        event(type(err).__name__ + (" (option)" if odd else ""))
        assert names_a_field_or_time(err), (changes, odd, str(err))
        if odd is not None and isinstance(err, ModelError) and err.field in OPTIONS:
            assert err.field == odd[0], (odd, str(err))
        assert "Traceback" not in str(err) and len(str(err)) < 2000, changes
        return
    event("simulated")
    assert odd is None, (odd, "accepted")
    for key, col in sol.columns.items():
        assert np.all(np.isfinite(col)), (changes, key)
    assert np.isfinite(sol.energy_drift)
    assert sol.stats["rtol"] >= 100 * np.finfo(float).eps


def _close(a, b) -> bool:
    """``a`` and ``b`` (a model's dict) equal, numbers to rounding."""
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_close(a[k], b[k]) for k in a)
    if isinstance(a, list):
        return isinstance(b, list) and len(a) == len(b) and all(map(_close, a, b))
    if isinstance(a, float) or isinstance(b, float):
        return math.isclose(a, b, rel_tol=1e-12, abs_tol=1e-300)
    return a == b


@SAVE_PROFILE
@given(case=mutants({**DICTS, **SIM_DICTS}),
       where=st.sampled_from(["x.toml", "x.toml", "x.json", "x.json", "x", "x.yaml", "X.TOML",
                              "missing/x.toml", "folder.toml", None, 3]),
       through=st.sampled_from(["model", "None", "dict"]))
def test_save_writes_what_load_reads_back_or_names_the_argument(tmp_path_factory, case, where,
                                                                through):
    from linkdyn.io.writer import model_to_dict

    name, d, changes = case
    folder = tmp_path_factory.mktemp("save")
    (folder / "folder.toml").mkdir()
    try:
        m = linkdyn.model_from_dict(d, source=f"{name}.toml")
    except LinkdynError as err:
        assert names_a_field_or_time(err), (changes, str(err))
        return
    path = where if where in (None, 3) else folder / where
    before = sorted(p.name for p in folder.iterdir())
    try:
        written = linkdyn.save({"model": m, "None": None, "dict": d}[through], path)
    except LinkdynError as err:
        assert isinstance(err, ModelError) and err.field in ("model", "path"), str(err)
        assert sorted(p.name for p in folder.iterdir()) == before   # nothing written half
        return
    assert through == "model" and str(where).lower().endswith((".toml", ".json"))
    back = linkdyn.load(written)
    assert _close(model_to_dict(back), model_to_dict(m)), changes
    if str(where).endswith(".json"):
        json.loads(written.read_text())


# --- what a command did not write stays byte for byte -------------------------------------------

@pytest.mark.parametrize("command", ["analyze", "simulate", "save", "example"])
def test_each_command_leaves_what_it_did_not_write_byte_for_byte(command, tmp_path,
                                                                 monkeypatch):
    # sweep, optimize and compare: tests/test_studies_inputs.py, with the same files
    from test_studies_inputs import snapshot, user_files

    out = tmp_path / "out"
    out.mkdir()
    user_files(out)      # chunks/ with the user's files, results.csv, report.html, plot_mine.png
    (out / "model.toml.d").mkdir()
    (out / "model.toml.d" / "x").write_text("x")
    before = snapshot(out)
    if command == "analyze":
        res, own = run("analyze", model(tmp_path), "-o", out, "--samples", 9), {
            "results.csv", "summary.json"}
    elif command == "simulate":
        res, own = run("simulate", model(tmp_path, text=RELEASE), "-o", out, "--duration",
                       0.05, "--samples", 3, "--backend", "numpy"), {"results.csv",
                                                                     "summary.json"}
    elif command == "save":
        linkdyn.save(linkdyn.load(linkdyn.example_path("hoeken")), out / "model.toml")
        res, own = None, {"model.toml"}
    else:
        monkeypatch.chdir(out)
        res, own = run("example", "hoeken"), set()
        assert res.output == HOEKEN
    assert res is None or res.exit_code == 0, res.output
    after = snapshot(out)
    assert own <= set(after)
    assert {k: v for k, v in after.items() if k not in own} == \
        {k: v for k, v in before.items() if k not in own}
