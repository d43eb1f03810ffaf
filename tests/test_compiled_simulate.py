"""The compiled right-hand side of ``simulate`` (linkdyn.forward_compiled) against the numpy
one: at random states of mechanisms with one and two loops, revolute and prismatic joints,
drivers and one or two free freedoms, under gravity, formula loads of the joints' motion,
springs, dampers and loads of time without a formula; the formulas' op-code evaluator against
``Expr.evaluate``; and whole simulations on both backends. (Run on the compiled worker.)"""

from __future__ import annotations

import math
import tomllib
from dataclasses import replace

import numpy as np
import pytest

import linkdyn
from linkdyn import expr
from linkdyn.forward import start_state, System, partition, simulate

pytest.importorskip("numba", reason="the compiled right-hand side needs numba (the fast extra)")


def _dict(name):
    d = tomllib.loads(linkdyn.example_path(name).read_text())
    d.pop("analysis", None)
    d.pop("loads", None)
    return d


def hoeken_motor():
    return replace(linkdyn.load(linkdyn.example_path("hoeken_motor")), cut=("J4",))


def slider_crank():
    """A free slider-crank under gravity: a formula force on the piston, a force in the slide
    (joint_force), a spring and a damper."""
    d = _dict("slider_crank")
    d.pop("drivers")
    d["mechanism"]["gravity"] = [0.0, -9.81]
    d["initial"] = {"q": {"J1": 30.0}, "qd": {"J1": 900.0}}
    d["loads"] = [
        {"kind": "force", "body": "slider", "point": "F",
         "value": ["-0.05*qd_J4 + 20*sin(3*t)", "where(q_J1 > 90, 5, -5)"]},
        {"kind": "joint_force", "joint": "J4", "value": "clip(-0.5*q_J4, -10, 10)"},
        {"kind": "spring", "body": "ground", "point": "O", "body2": "slider", "point2": "F",
         "stiffness": 0.5, "free_length": 150.0},
        {"kind": "damper", "body": "crank", "point": "A", "body2": "ground", "point2": "G",
         "damping": 0.002}]
    return linkdyn.model_from_dict(d)


def stephenson():
    """The Stephenson six-bar (two loops) released, a torsion spring-damper in J5, a torque of
    formula and a torque of time without one (a Python function)."""
    d = _dict("stephenson")
    d.pop("drivers")
    d["mechanism"]["gravity"] = [0.0, -9.81]
    d["initial"] = {"q": {"J1": 20.0}, "qd": {"J1": 300.0}}
    d["loads"] = [
        {"kind": "joint_torque", "joint": "J5", "value": "-0.01*(q_J5 - 10) - 0.001*qd_J5"},
        {"kind": "torque", "body": "output", "value": "max(0.1*cos(t), -0.05)*sign(qd_J7)"},
        {"kind": "torque", "body": "crank", "value": 0.0}]
    m = linkdyn.model_from_dict(d)
    crank = replace(m.loads[2], value=lambda t: 0.2 * np.cos(3 * np.asarray(t, float)))
    return replace(m, loads=m.loads[:2] + (crank,))


def fivebar(drivers: int):
    """The five-bar with ``drivers`` of its two drivers (one free freedom, or two) and a
    spring."""
    d = _dict("fivebar")
    d["drivers"] = d["drivers"][:drivers]
    d["mechanism"]["gravity"] = [0.0, -9.81]
    free = ["J5", "J2"][:2 - drivers]
    d["initial"] = {"q": {j: v for j, v in zip(free, (1.2, 2.0))}, "qd": {j: 0.5 for j in free}}
    d["loads"] = [{"kind": "spring", "body": "link2", "point": "P", "body2": "ground",
                   "point2": "O5", "stiffness": 0.3, "free_length": 50.0}]
    return linkdyn.model_from_dict(d)


def stiffer(model, factor):
    """``model`` with its springs ``factor`` times stiffer: free accelerations of 1e6 rad/s^2
    and more, whose unit accelerations of F5 are sized (``forward.unit_scale``)."""
    return replace(model, loads=tuple(replace(x, stiffness=factor * x.stiffness)
                                      if x.kind == "spring" else x for x in model.loads))


MODELS = {"hoeken_motor": hoeken_motor, "slider_crank": slider_crank,
          "stephenson": stephenson, "fivebar_driven": lambda: fivebar(1),
          "fivebar_free": lambda: fivebar(0),
          # the bundled toggle at 20,000 N/mm, a five-bar's spring at 3e5 N/mm
          "stiff_toggle": lambda: stiffer(linkdyn.load(linkdyn.example_path("toggle_spring")),
                                          1e3),
          "stiff_fivebar": lambda: stiffer(fivebar(0), 1e6)}


@pytest.mark.parametrize("name", MODELS)
def test_compiled_rhs_equals_numpy_at_random_states(name):
    model = MODELS[name]()
    part = partition(model)
    q0 = start_state(part)
    nf = len(part.free)
    slow, fast = System(part, q0, np.zeros(len(q0))), System(part, q0, np.zeros(len(q0)), True)
    rng = np.random.default_rng(7)
    y = np.concatenate((q0[list(part.layout.topo.driven[part.n_drivers:])], np.zeros(nf + 1)))
    t, sizes = 0.0, []
    for _ in range(4):
        # an accepted state a little way on (closed by the numpy path), shared by both
        t += 0.05
        y = y + np.concatenate((rng.uniform(-0.15, 0.15, nf), rng.uniform(-3, 3, nf), [0.0]))
        assert slow.accept(t, y) is not None
        fast.ref = slow.ref
        # a state an integrator asks for from there: a step on (shorter under a stiff spring),
        # another rate
        f = slow(t, y)
        h = min(2e-3, 100.0 / np.max(np.abs(f[nf:2 * nf])))
        z = y + h * f + np.concatenate((np.zeros(nf), rng.uniform(-1, 1, nf), [0.0]))
        a, b = slow(t + h, z), fast(t + h, z)
        assert fast.kernel is not None and fast.last[2] is None   # the kernel ran
        sizes.append(np.max(slow.sizes()))
        scale = np.abs(a) + np.max(np.abs(a))
        assert np.all(np.abs(b - a) <= 1e-11 * scale), (a, b)   # measured: 4e-14 at most
        # the tree state and the Jacobian kept for the reference agree too
        Ja, Jb = slow.accept(t + h, z), fast.accept(t + h, z)
        assert np.allclose(Jb, Ja, rtol=1e-10, atol=1e-10 * np.max(np.abs(Ja)))
        for x, w in zip(slow.ref[1:4], fast.ref[1:4]):
            assert np.allclose(w, x, rtol=1e-9, atol=1e-9 * np.max(np.abs(x)))
    # the stiff springs' states have unit accelerations of F5 other than 1, the others not
    assert (max(sizes) > 1.0) == name.startswith("stiff"), sizes


def test_op_code_program_equals_expr_evaluate():
    """Every operator and function of the formulas, inside and outside its domain, a block of
    points at once."""
    from linkdyn.compiled.loads import run_program

    names = ("a", "b", "c")
    texts = ["a + b - c*a/b", "a**b", "-a", "abs(a) + sign(b)", "min(a, b)", "max(a, c)",
             "clip(a, b, c)", "where(a < b, a, c) + where(a <= b, 1, 2)",
             "where(a > c, b, 0) + where(a >= c, 3, 4)", "tanh(a) + sinh(b) + cosh(c)",
             "tan(a) + exp(b)", "atan(c) + 2*pi"]
    texts += [f"{f}(a)" for f in ("sin", "cos", "log", "sqrt", "asin", "acos")]
    forms = [expr.parse(s, names) for s in texts]
    code, value, roots = expr.flatten(forms + [2.5], {"a": (0, 1.0), "b": (1, 2.0), "c": (2, 0.5)})
    rng = np.random.default_rng(3)
    points = np.concatenate([rng.uniform(-3, 3, (40, 3)), [[0.0, 0.0, 0.0], [1.0, -1.0, 2.0],
                                                           [math.nan, 1.0, 0.5]]])
    x = np.ascontiguousarray(points.T)
    reg = np.empty((len(code), len(points) + 2))   # a block larger than the samples
    with np.errstate(all="ignore"):
        run_program(code, value, x, reg, len(points))
        want = [f.evaluate(a=x[0], b=x[1] / 2.0, c=x[2] / 0.5) for f in forms]
    want = [np.broadcast_to(w, len(points)) for w in want] + [np.full(len(points), 2.5)]
    got = reg[roots, :len(points)]
    assert np.allclose(got, want, rtol=1e-14, atol=1e-14, equal_nan=True)


def test_simulate_compiled_equals_numpy():
    """Whole runs on both backends agree to the integrator's tolerance."""
    t = np.linspace(0.0, 0.3, 7)
    for model in (hoeken_motor(), slider_crank()):
        a = simulate(model, t, rtol=1e-9, atol=1e-11, backend="numpy")
        b = simulate(model, t, rtol=1e-9, atol=1e-11, backend="compiled")
        for key, x in a.columns.items():
            scale = max(float(np.ptp(x)), float(np.max(np.abs(x))), 1e-12)
            assert np.max(np.abs(b.columns[key] - x)) <= 1e-6 * scale + 1e-12, key
        assert b.energy_drift < 1e-6


def test_compiled_run_outputs_equal_numpy_stages_at_the_same_states(monkeypatch):
    """A compiled run computes its outputs by the compiled stages: the free accelerations and
    closed positions by the compiled right-hand side, then the kinematics, dynamics and
    reactions kernels. Every column (joint motion, body motion, efforts, reactions, energies)
    within 1e-11 of its peak of numpy's stages at the same states (the samples' guesses and
    integrated states shared), of the columns of its unit; also where the right-hand side
    leaves every other sample open (numpy closes those loops, the kernels do the rest)."""
    from linkdyn import backend, forward
    from linkdyn.forward_compiled import Kernel

    class Half(Kernel):   # does not close every other sample
        calls = 0

        def __call__(self, *args):
            Half.calls += 1
            return None if Half.calls % 2 else super().__call__(*args)

    seen = []
    original = forward.Planar.outputs      # the planar stages' outputs, which simulate calls
    monkeypatch.setattr(forward.Planar, "outputs",
                        staticmethod(lambda *args: seen.append(args) or original(*args)))
    t = np.linspace(0.0, 0.3, 7)
    for model in (hoeken_motor(), slider_crank(), fivebar(1)):
        fast = simulate(model, t, rtol=1e-6, atol=1e-8, backend="compiled")
        parts, segment, tt, Y, guesses, stats, kernel, _, modes = seen.pop()
        assert kernel is not None
        slow = original(parts, segment, tt, Y, guesses, dict(stats), None,
                        backend.choose("numpy"), modes)
        half = original(parts, segment, tt, Y, guesses, dict(stats), Half(parts[0]),
                        backend.choose("compiled"), modes)
        assert Half.calls >= len(tt)
        assert "Fx_J2" in slow.columns                       # the reactions are compared
        # scale: the peak of the columns of the same unit (some columns are zero throughout)
        peak = {}
        for key, x in slow.columns.items():
            u = slow.units[key]
            peak[u] = max(peak.get(u, 0.0), float(np.nanmax(np.abs(x), initial=0.0)))
        for run in (fast, half):
            for key, x in slow.columns.items():
                x, y = np.asarray(x, float), np.asarray(run.columns[key], float)
                assert np.array_equal(np.isnan(x), np.isnan(y)), key
                err = float(np.nanmax(np.abs(y - x), initial=0.0))
                assert err <= 1e-11 * peak[slow.units[key]], key   # measured: 3e-13 (the five-bar)


def test_energy_projection_bounds_the_drift_over_many_turns():
    """(F11) Hoeken with the flywheel of hoeken_motor spinning freely (a conservative closed
    loop), 40 crank turns at rtol 1e-6: the integrator alone drifts turn after turn; projected
    after every step, the balance stays at the tolerance, the motion the same to the
    integrator's accuracy."""
    driven = linkdyn.load(linkdyn.example_path("hoeken"))
    fly = linkdyn.load(linkdyn.example_path("hoeken_motor"))
    model = replace(driven, bodies=fly.bodies, drivers=(), loads=(), gravity=np.zeros(2),
                    initial_q={"J1": 0.0}, initial_qd={"J1": 1.5 * math.pi})
    t = np.linspace(0.0, 40 * 60 / 45, 41)       # about a turn per sample at 45 rpm
    runs = [simulate(model, t, rtol=1e-6, atol=1e-8, backend="compiled", project=p)
            for p in (False, True)]
    drift = [np.abs(s.energy - s.energy[0]) / np.max(s.kinetic_energy) for s in runs]
    assert runs[0].stats["energy_projections"] == 0
    assert runs[1].stats["energy_projections"] >= runs[1].stats["steps"] // 2
    assert np.max(drift[1]) < 3e-6 and np.max(drift[1][20:]) < 2 * np.max(drift[1][:21])
    assert drift[0][-1] > 5 * np.max(drift[1]) and drift[0][-1] > 5 * drift[0][5]
    q = [s.columns["q_J1"] for s in runs]
    assert np.max(np.abs(q[1] - q[0])) < 1e-3 * np.ptp(q[0])


def test_energy_projection_with_a_driver_keeps_the_integrated_balance():
    """(F11) with a driver: T quadratic in the free rates' factor; the driver's work is in W."""
    model = fivebar(1)
    t = np.linspace(0.0, 1.0, 11)
    s = simulate(model, t, rtol=1e-7, atol=1e-9, backend="compiled")
    assert s.stats["energy_projections"] > 0 and np.max(np.abs(s.work)) > 0
    assert s.energy_drift < 1e-6
    ref = simulate(model, t, rtol=1e-7, atol=1e-9, backend="compiled", project=False)
    for key in ("q_J1", "q_J3", "qd_J5", "work"):
        x = ref.columns[key]
        assert np.max(np.abs(s.columns[key] - x)) <= 1e-5 * np.max(np.abs(x)), key


@pytest.mark.parametrize("by", ["estimate", "clock"])
def test_auto_backend_switches_once_the_compiled_start_up_has_paid(monkeypatch, by):
    """``backend="auto"``: numpy's right-hand side first, the compiled one once numpy's
    evaluations have paid for its start-up, by the cost model's estimate (its start-up set at
    4 s of CPU, which this run never spends, and numpy's evaluations made dear: the switch at
    the end of the step that reaches the evaluation the estimate names) or by the clock (the
    estimate never pays: numpy's evaluations made free; the start-up set at 20 ms of CPU,
    which this run spends), never back; the same motion as numpy throughout."""
    from linkdyn import backend

    monkeypatch.delenv("LINKDYN_BACKEND", raising=False)
    t = np.linspace(0.0, 1.0, 5)
    monkeypatch.setattr(backend, "IN_PROCESS", set())   # as in a process that has run none
    ref = simulate(hoeken_motor(), t, rtol=1e-9, atol=1e-11, backend="numpy")
    assert ref.stats["backend"] == "numpy" and ref.stats["compiled_after"] is None
    start = 1.0 if by == "estimate" else 5e-3           # s a stage, four stages
    monkeypatch.setattr(backend, "LOAD", dict.fromkeys(backend.LOAD, start))
    monkeypatch.setattr(backend, "COMPILE", dict.fromkeys(backend.COMPILE, start))
    monkeypatch.setattr(backend, "NUMPY_PASS", 0.05 if by == "estimate" else 0.0)
    monkeypatch.setattr(backend, "NUMPY_SAMPLE", 0.0)
    work = backend.Work(2, len(hoeken_motor().bodies) - 1, 0, backend.SIMULATION)
    pays = backend.choose("auto", work).pays_after(work)
    assert (pays < 100) if by == "estimate" else (pays == np.inf)
    auto = simulate(hoeken_motor(), t, rtol=1e-9, atol=1e-11, backend="auto")
    assert auto.stats["backend"] == "compiled"
    after = auto.stats["compiled_after"]
    assert 0 < after < auto.stats["rhs_evaluations"]
    if by == "estimate":   # at the end of the step that reached it
        assert pays <= after
    x = ref.columns["q_J1"]
    assert np.max(np.abs(auto.columns["q_J1"] - x)) <= 1e-7 * np.ptp(x)
