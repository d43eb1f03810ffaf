"""Every bad input gets a clear answer (issue 11): a property test that mutates the bundled
examples, and each reproducer of the issue's run and output side run as a user would.

A clear answer is: exit 0 (``analyze`` returns) with every number finite, or a
:class:`~linkdyn.LinkdynError` whose message names the field (dotted path) or the time, exit 2
or 3 on the command line with one line on stderr, no traceback and no output file.
"""

from __future__ import annotations

import copy
import json
import math
import os
import re
import tomllib
import warnings
from pathlib import Path

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import linkdyn
from linkdyn import AssemblyError, LinkdynError, ModelError, design, model_from_dict
from linkdyn.cli import json_safe, example_names, example_text, main, summary_text

EXAMPLES = example_names()
DICTS = {name: tomllib.loads(example_text(name)) for name in EXAMPLES}
HOEKEN = example_text("hoeken")

# at least 1,000 mutants in CI (CI=true, as .ci/run exports); fewer on a developer's machine
settings.register_profile("robustness-ci", max_examples=1000, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
settings.register_profile("robustness-dev", max_examples=120, deadline=None,
                          suppress_health_check=[HealthCheck.too_slow])
IN_CI = os.environ.get("CI", "").strip().lower() in ("true", "1", "yes")
PROFILE = settings.get_profile("robustness-ci" if IN_CI else "robustness-dev")


# ------------------------------------------------------------------------------- mutants

def leaves(x, path=()):
    """Every (path, value) below ``x``: the paths of dict keys and list items."""
    yield path, x
    if isinstance(x, dict):
        for k, v in x.items():
            yield from leaves(v, path + (k,))
    elif isinstance(x, list):
        for k, v in enumerate(x):
            yield from leaves(v, path + (k,))


def names_in(d: dict) -> list[str]:
    """Names the model uses (bodies, points, joints, references): for swapped references."""
    return sorted({v for _, v in leaves(d) if isinstance(v, str) and len(v) < 40})


FORMULAS = ["1/0", "log(-1)", "9**9**9", "(-1)**t", "sqrt(-t)", "1/t", "1/(t-0.01)",
            "exp(1000*t)", "0.5*sin(20*t)", "t**2 - 3", "log(t)", "2**1024", "1e308*10"]
EXTREMES = [0, -1, 1e308, -1e308, 1e-300, -1e-300, math.inf, -math.inf, math.nan, 10 ** 400,
            2 ** 63, 5e-324, 1e15]
ODD = [True, "", "x", [], {}, [1.0], [1.0, 2.0, 3.0], {"a": 1}, "1/0", "log(-1)", "9**9**9",
       "(-1)**t", "sqrt(-t)", "t/(t-t)", "exp(1e6*t)", "sin(t", "__import__('os')", "0*t + 1e308"]


def scaled(value, factor):
    """``value * factor``, or ``value`` itself where that overflows (an earlier mutation may
    have left an integer of 400 digits)."""
    try:
        return value * factor
    except OverflowError:
        return value


@st.composite
def mutants(draw, dicts=None, extra=None):
    """A bundled example's parsed TOML with one to three mutations: a value replaced (extreme,
    non-finite, another type, a formula, another name of the model), a key removed or
    added, or a number scaled. ``dicts``: the models to start from (default: the examples
    for analyze); ``extra(draw, d)``: a further kind of mutation of ``d``, returning what it
    changed (drawn as often as a load)."""
    dicts = DICTS if dicts is None else dicts
    name = draw(st.sampled_from(sorted(dicts)))
    d = copy.deepcopy(dicts[name])
    changes = []
    for _ in range(draw(st.integers(1, 3))):
        how = draw(st.sampled_from(["extreme", "odd", "name", "delete", "add", "scale",
                                    "number", "number", "mild", "mild", "mild", "load", "load"]
                                   + ["extra"] * 3 * (extra is not None)))
        if how == "extra":
            changes.append(("extra", extra(draw, d)))
            continue
        if how == "load":   # a load whose formula may be undefined or overflow somewhere
            bodies = d.get("bodies") if isinstance(d.get("bodies"), list) else []
            body = draw(st.sampled_from([b["name"] for b in bodies if isinstance(b, dict)
                                         and b.get("name") not in (None, "ground")] or ["x"]))
            if not isinstance(d.get("loads", []), list):
                continue
            d.setdefault("loads", []).append(
                {"kind": "torque", "body": body, "value": draw(st.sampled_from(FORMULAS))})
            changes.append(("load", d["loads"][-1]["value"]))
            continue
        spots = [(p, v) for p, v in leaves(d) if p]
        numbers = [(p, v) for p, v in spots
                   if isinstance(v, (int, float)) and not isinstance(v, bool)]
        if how in ("number", "mild") and numbers:   # most of a model is numbers: hit them often
            spots, how = numbers, "extreme" if how == "number" else "mild"
        path, value = draw(st.sampled_from(spots))
        if isinstance(value, int) and not isinstance(value, bool) and abs(value) > 1e300:
            value = 1e300 if value > 0 else -1e300   # 10**400 from an earlier mutation: x * 0.5 overflows
        parent = d
        for k in path[:-1]:
            parent = parent[k]
        key = path[-1]
        if how == "extreme":
            new = draw(st.sampled_from(EXTREMES))
        elif how == "odd":
            new = draw(st.sampled_from(ODD))
        elif how == "name":
            new = draw(st.sampled_from(names_in(d)))
        elif how == "mild" and (not isinstance(value, (int, float)) or isinstance(value, bool)):
            new = draw(st.sampled_from(ODD))      # no number left to change mildly
        elif how == "mild":   # a plausible change that usually keeps the model valid
            new = draw(st.sampled_from([scaled(value, 0.5), scaled(value, 1.5), -value, 1e12,
                                        1e-30, 0.0]))
        elif how == "scale" and isinstance(value, (int, float)) and not isinstance(value, bool):
            new = scaled(value, draw(st.sampled_from([-1.0, 0.0, 1e-9, 1e6, 1e200])))
        elif how == "delete" and isinstance(parent, dict):
            del parent[key]
            changes.append(("delete", path))
            continue
        elif how == "add" and isinstance(value, dict):
            value[draw(st.sampled_from(["extra", "mass", "name", "q", "kind"]))] = copy.deepcopy(
                draw(st.sampled_from(EXTREMES + ODD)))
            changes.append(("add", path))
            continue
        else:
            new = draw(st.sampled_from(EXTREMES + ODD))
        parent[key] = new = copy.deepcopy(new)    # never share the ODD lists and tables
        changes.append((path, new))
    return name, d, changes


def run_times(m) -> np.ndarray:
    """A few samples over (part of) the model's run; a second when it gives none usable."""
    period = next((d.period for d in m.drivers if d.period), None)
    span = m.duration or (period and period * (m.cycles or 1.0)) or 1.0
    span = min(span, 0.3 * period) if period else span
    return np.linspace(0.0, span if 0 < span < 1e6 else 1.0, 4)


def names_a_field_or_time(err: LinkdynError) -> bool:
    if isinstance(err, ModelError):
        return bool(err.field)
    if isinstance(err, AssemblyError):
        return err.time is not None and f"at t = " in str(err)
    return False


@PROFILE
@given(mutants())
def test_a_mutated_example_solves_finitely_or_names_the_field_or_time(case):
    name, d, changes = case
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)   # none may escape to the user
            m = model_from_dict(d, source=f"{name}.toml")
            sol = linkdyn.analyze(m, run_times(m))
            summ = design.summary(sol)
            summary_text(summ)
            json.dumps(json_safe(summ), allow_nan=False)
    except LinkdynError as err:
        event(type(err).__name__)   # --hypothesis-show-statistics: how the mutants ended
        assert names_a_field_or_time(err), (changes, str(err))
        assert "Traceback" not in str(err) and len(str(err)) < 2000, changes
        return
    event("solved")
    for key, col in sol.columns.items():
        assert np.all(np.isfinite(col)), (changes, key)


# ------------------------------------------------------------------------------- reproducers

def run(*args, env=None):
    return CliRunner().invoke(main, [str(a) for a in args], env=env)


def model(tmp_path: Path, old: str = "", new: str = "", text: str = HOEKEN) -> Path:
    if old:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / "MODEL.toml"
    path.write_text(text, encoding="utf-8")
    return path


def user_error(res, code: int, *fragments: str) -> str:
    """Exit ``code``, one line on stderr holding every fragment, no traceback, nothing on
    stdout."""
    assert res.exception is None or isinstance(res.exception, SystemExit), res.exception
    assert res.exit_code == code, res.output
    assert "Traceback" not in res.output
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert len(lines) == 1, res.stderr
    for f in fragments:
        assert f in lines[0], f"{f!r} not in {lines[0]!r}"
    assert res.stdout == ""
    return lines[0]


def nothing_written(out: Path) -> None:
    assert not out.exists(), sorted(p.name for p in out.iterdir())
    assert not list(out.parent.glob(".linkdyn-*"))


CONST = 'motion = { kind = "constant_speed", rpm = 45.0, start = 0.0 }'
NO_CYCLES = HOEKEN.replace("cycles = 1\n", "")
EXPR = 'motion = { kind = "expression", q = "4.0*t" }'
TORQUE = '\n[[loads]]\nkind = "torque"\nbody = "coupler"\nvalue = "{}"\n'


@pytest.mark.parametrize("args,code,fragments", [
    (["--samples", 2], 0, []),
    (["--duration", "inf"], 2, ["--duration", "positive and finite", "inf"]),
    (["--cycles", "nan"], 2, ["--cycles"]),
    (["--samples", 1000000000000], 2, ["--samples", "memory"]),
    (["--path-range", "110:250", "--duration", 0.1], 2, ["--path-range", "110 .. 250 deg",
                                                         "covers 0 .. 27 deg"]),
    (["--path-range", "1:x"], 2, ["--path-range", "A:B"]),
])
def test_run_options(args, code, fragments, tmp_path):
    out = tmp_path / "out"
    res = run("analyze", model(tmp_path), "-o", out, *args)
    if code == 0:
        assert res.exit_code == 0, res.output
        assert "--path-range" not in res.output
        assert json.loads((out / "summary.json").read_text())["samples"] == 2
        return
    line = user_error(res, code, *fragments)
    assert "nan" not in line.replace("--cycles nan", "").replace("got nan", "")
    nothing_written(out)


def test_cycles_with_an_expression_driver_names_cycles(tmp_path):
    out = tmp_path / "out"
    res = run("analyze", model(tmp_path, CONST, EXPR, NO_CYCLES), "-o", out, "--cycles", 2)
    line = user_error(res, 2, "--cycles", "--duration")
    assert "analysis.duration" not in line
    nothing_written(out)


def test_samples_in_the_model_beyond_reach_names_analysis_samples(tmp_path):
    out = tmp_path / "out"
    res = run("analyze", model(tmp_path, "samples = 361", "samples = 1e15"), "-o", out)
    user_error(res, 2, "analysis.samples")
    nothing_written(out)


def test_an_unknown_backend_in_the_environment_exits_2(tmp_path):
    out = tmp_path / "out"
    res = run("analyze", model(tmp_path), "-o", out, "--samples", 5,
              env={"LINKDYN_BACKEND": "bogus"})
    user_error(res, 2, "LINKDYN_BACKEND", "'bogus'", "numpy")
    nothing_written(out)


@pytest.mark.parametrize("formula,t_bad", [("1/0", 0.0), ("log(-1)", 0.0), ("9**9**9", 0.0),
                                           ("(-1)**t", None)])
def test_a_load_formula_that_is_not_finite_exits_3_naming_the_load(formula, t_bad, tmp_path):
    out = tmp_path / "out"
    path = model(tmp_path, text=HOEKEN + TORQUE.format(formula))
    res = run("analyze", path, "-o", out, "--samples", 7)
    line = user_error(res, 3, str(path), "loads[0]", "not finite", "at t = ")
    if t_bad is not None:
        assert f"at t = {t_bad:g} s" in line
    else:   # (-1)**t: finite at t = 0 only
        assert "at t = 0 s" not in line
    nothing_written(out)


def test_allow_singular_keeps_non_finite_samples_as_flagged_nan_rows(tmp_path):
    m = linkdyn.load(model(tmp_path, text=HOEKEN + TORQUE.format("(-1)**(3*t)")))
    t = np.linspace(0.0, 1.0, 4)          # 3 t = 0, 1, 2, 3: finite at every sample
    assert np.all(linkdyn.analyze(m, t).valid)
    t = np.linspace(0.0, 1.0, 5)          # 3 t = 0.75, 1.5, 2.25: NaN there
    sol = linkdyn.analyze(m, t, allow_singular=True)
    assert sol.valid.tolist() == [True, False, False, False, True]
    assert np.all(np.isfinite(sol.columns["tau_J1"][sol.valid]))
    with pytest.raises(AssemblyError, match=r"at t = 0\.25 s .*loads\[0\]"):
        linkdyn.analyze(m, t)


SPRING = ('\n[[loads]]\nname = "{kind}"\nkind = "{kind}"\nbody = "crank"\npoint = "O1"\n'
          'body2 = "ground"\npoint2 = "O1"\n{extra}\n')


def test_a_spring_of_zero_free_length_between_coinciding_points_is_fine(tmp_path):
    # the crank's pivot and the ground's: always together; the force k d is zero
    path = model(tmp_path, text=HOEKEN + SPRING.format(
        kind="spring", extra="stiffness = 1000.0\nfree_length = 0.0"))
    sol = linkdyn.analyze(linkdyn.load(path), np.linspace(0.0, 1.0, 7))
    ref = linkdyn.analyze(linkdyn.load(model(tmp_path)), np.linspace(0.0, 1.0, 7))
    for key, col in ref.columns.items():
        assert np.all(np.isfinite(sol.columns[key]))
        np.testing.assert_allclose(sol.columns[key], col, rtol=1e-12,
                                   atol=1e-12 * np.max(np.abs(col)))


@pytest.mark.parametrize("kind,extra", [("spring", "stiffness = 1000.0\nfree_length = 10.0"),
                                        ("damper", "damping = 2.0")])
def test_a_spring_or_damper_between_coinciding_points_names_it(kind, extra, tmp_path):
    out = tmp_path / "out"
    path = model(tmp_path, text=HOEKEN + SPRING.format(kind=kind, extra=extra))
    res = run("analyze", path, "-o", out, "--samples", 5)
    user_error(res, 3, f"loads.{kind}", "coincide", "at t = 0 s")
    nothing_written(out)


@pytest.mark.parametrize("old,new,code,fragment", [
    ("com = [19.05, 0.0]", "com = [19.05, 1e308]", 2, "bodies.crank"),
    ("value = [-20.0, 35.0]", "value = [1e308, 1e308]", 2, "loads[0].value[0]"),
])
def test_huge_finite_inputs_get_a_clear_answer(old, new, code, fragment, tmp_path):
    text = HOEKEN if old in HOEKEN else HOEKEN + (
        '\n[[loads]]\nkind = "force"\nbody = "coupler"\npoint = "P"\nvalue = [-20.0, 35.0]\n')
    out = tmp_path / "out"
    res = run("analyze", model(tmp_path, old, new, text), "-o", out, "--samples", 5)
    user_error(res, code, fragment)
    nothing_written(out)


def test_an_overflow_from_huge_numbers_built_in_python_names_the_time():
    # model files bound their numbers; a Model built in Python can still hold 1e308
    from dataclasses import replace

    m = linkdyn.load(linkdyn.example_path("hoeken"))
    t = np.linspace(0.0, 1.0, 5)
    sol = linkdyn.analyze(replace(m, gravity=np.array([0.0, -1e300])), t)   # huge, finite
    assert all(np.all(np.isfinite(c)) for c in sol.columns.values())
    with pytest.raises(AssemblyError, match=r"at t = 0 s .*gravity"):
        linkdyn.analyze(replace(m, gravity=np.array([0.0, -1e308])), t)
    sol = linkdyn.analyze(replace(m, gravity=np.array([0.0, -1e308])), t, allow_singular=True)
    assert not np.any(sol.valid)


def test_a_driver_so_slow_gives_zero_efforts_and_no_flywheel(tmp_path):
    # speed = 1e-300: the flywheel's C_s w^2 underflows to zero (was ZeroDivisionError). A
    # model file bounds the speed (exit 2 naming it); a Model built in Python can hold it
    from dataclasses import replace

    from linkdyn.motion import ConstantSpeed

    path = model(tmp_path, CONST, 'motion = { kind = "constant_speed", speed = 1e-300 }')
    user_error(run("analyze", path, "-o", tmp_path / "out"), 2, "drivers[0].motion.speed")
    m = linkdyn.load(linkdyn.example_path("hoeken"))
    slow = ConstantSpeed(speed=1e-300)
    m = replace(m, drivers=(replace(m.drivers[0], motion=slow, period=slow.period),))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s = design.summary(linkdyn.analyze(m, np.linspace(0.0, 1.0, 5)))
    assert s["driver_energy"]["J1"]["flywheel"] is None
    assert s["drivers"]["J1"]["peak"] == 0.0
    summary_text(s)


def test_a_driver_motion_that_overflows_names_the_driver(tmp_path):
    path = model(tmp_path, CONST, 'motion = { kind = "expression", q = "exp(800*t)" }',
                 NO_CYCLES)
    with pytest.raises(AssemblyError, match=r"at t = 1 s.*driver J1 \(drivers\[0\]\.motion\)"):
        linkdyn.analyze(linkdyn.load(path), [0.0, 1.0])


def without_assembly(text: str) -> str:
    start = text.index("[assembly]")
    end = text.find("\n[", start + 1)
    return text[:start] + (text[end + 1:] if end > 0 else "")


@pytest.mark.parametrize("name", ["hoeken", "drag_link", "fivebar", "watt2", "stephenson",
                                  "inverted_slider_crank"])
def test_without_assembly_every_start_angle_is_within_half_a_turn(name, tmp_path):
    text = without_assembly(example_text(name))
    assert "[assembly]" not in text
    m = linkdyn.load(model(tmp_path, text=text))
    t = np.linspace(0.0, 0.2, 3)
    sol = linkdyn.analyze(m, t)
    starts = {d.joint: float(v) for d, v in zip(m.drivers, [sol.kin.q[0, m.joints.index(
        m.joint(d.joint))] for d in m.drivers])}
    bound = math.pi + sum(abs(v) for v in starts.values()) + 1e-9
    for b in m.moving_bodies:
        # angles of 3337.7 rad were reported before (Newton wound them by 530 turns)
        assert abs(sol.phi(b.name)[0]) <= bound, (b.name, sol.phi(b.name)[0])


def test_without_assembly_hoeken_starts_on_the_documented_branch_and_says_so(tmp_path):
    path = model(tmp_path, text=without_assembly(HOEKEN))
    ref = linkdyn.analyze(linkdyn.load(linkdyn.example_path("hoeken")), np.linspace(0, 1, 5))
    sol = linkdyn.analyze(linkdyn.load(path), np.linspace(0, 1, 5))
    for b in ("coupler", "rocker"):   # the same angles, not 530 turns away
        np.testing.assert_allclose(sol.phi(b), ref.phi(b), rtol=0, atol=1e-9)
    out = tmp_path / "out"
    res = run("analyze", path, "-o", out, "--samples", 5)
    assert res.exit_code == 0, res.output
    assert "assembly: no [assembly] guess" in res.output and "phi_coupler = 77.1" in res.output
    assert json.loads((out / "summary.json").read_text())["assembly"]["guess"] is False
    res = run("check", path)
    assert res.exit_code == 0 and "assembly: no [assembly] guess" in res.output
    res = run("analyze", linkdyn.example_path("hoeken"), "-o", out, "--samples", 5)
    assert "assembly:" not in res.output      # the model's guess chose it: nothing to say


def test_design_claims_come_from_the_motion(tmp_path):
    res = run("analyze", linkdyn.example_path("watt2"), "-o", tmp_path / "out")
    assert res.exit_code == 0, res.output
    line = next(ln for ln in res.output.splitlines() if "rocker1/coupler2/output" in ln)
    # the second loop can rotate its output (rocker-crank), but its input only rocks, so the
    # output swings: the run's figure, not the class's claim
    assert "rotates fully" not in line
    m = re.search(r"the output swings ([0-9.]+) deg", line)
    assert m, line
    sol = linkdyn.analyze(linkdyn.load(linkdyn.example_path("watt2")), np.linspace(0, 1, 361))
    swing = np.degrees(np.ptp(sol.phi("output")))     # ground frame: phi is relative to it
    assert float(m.group(1)) == pytest.approx(swing, rel=1e-3)
    assert swing < 180


# ------------------------------------------------------------------------------- Python API

def test_analyze_accepts_a_model_file_path(tmp_path):
    t = np.linspace(0.0, 1.0, 5)
    path = model(tmp_path)
    ref = linkdyn.analyze(linkdyn.load(path), t).columns["tau_J1"]
    for given_as in (str(path), path):
        np.testing.assert_array_equal(linkdyn.analyze(given_as, t).columns["tau_J1"], ref)
    with pytest.raises(ModelError, match="file not found"):
        linkdyn.analyze(str(tmp_path / "missing.toml"), t)


@pytest.mark.parametrize("call,error,fragment", [
    (lambda m: linkdyn.analyze([], [0.0, 1.0]), ModelError, "model"),
    (lambda m: linkdyn.analyze(3, [0.0, 1.0]), TypeError, "model"),
    (lambda m: linkdyn.analyze([m, "x"], [0.0, 1.0]), TypeError, "model[1]"),
    (lambda m: linkdyn.analyze(m, "0:1"), TypeError, "t must"),
    (lambda m: linkdyn.analyze(m, [0.0, math.inf]), ModelError, "t[1] = inf"),
    (lambda m: linkdyn.analyze(m, [math.nan]), ModelError, "t[0] = nan"),
    (lambda m: linkdyn.analyze(m, [[0.0, 1.0]]), ModelError, "t:"),
    (lambda m: linkdyn.analyze(m, [0.0, 1.0], allow_singular="yes"), TypeError,
     "allow_singular"),
    (lambda m: linkdyn.analyze(m, [0.0, 1.0], backend=1), TypeError, "backend"),
    (lambda m: linkdyn.analyze(m, [0.0, 1.0], backend="bogus"), ModelError, "backend"),
])
def test_wrong_arguments_name_the_parameter(call, error, fragment):
    m = linkdyn.load(linkdyn.example_path("hoeken"))
    with pytest.raises(error) as info:
        call(m)
    assert fragment in str(info.value)
    if error is ModelError:
        assert isinstance(info.value, LinkdynError)


def test_an_unknown_backend_in_the_environment_is_a_model_error(monkeypatch):
    monkeypatch.setenv("LINKDYN_BACKEND", "bogus")
    with pytest.raises(ModelError, match="LINKDYN_BACKEND"):
        linkdyn.analyze(linkdyn.load(linkdyn.example_path("hoeken")), [0.0, 1.0])


def test_no_runtime_warning_reaches_the_user(tmp_path):
    m = linkdyn.load(model(tmp_path, text=HOEKEN + TORQUE.format("log(-1)")))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(AssemblyError):
            linkdyn.analyze(m, np.linspace(0.0, 1.0, 5))
        sol = linkdyn.analyze(m, np.linspace(0.0, 1.0, 5), allow_singular=True)
        assert not np.any(sol.valid)


def test_the_ci_entry_point_says_it_is_ci():
    # whether the browser tests and the 1,000 mutants run must not depend on the machine
    lines = (Path(__file__).parents[1] / ".ci" / "run").read_text().splitlines()
    export = next(k for k, ln in enumerate(lines) if ln.strip() == "export CI=true")
    assert export < next(k for k, ln in enumerate(lines) if ln.strip().startswith("make test"))


def test_running_out_of_memory_names_samples(tmp_path, monkeypatch):
    import linkdyn.analysis

    def no_memory(*args, **kwargs):
        raise MemoryError

    monkeypatch.setattr(linkdyn.analysis, "analyze", no_memory)
    out = tmp_path / "out"
    user_error(run("analyze", model(tmp_path), "-o", out, "--samples", 5), 2, "--samples",
               "memory")
    nothing_written(out)
