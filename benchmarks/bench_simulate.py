"""Work-precision of ``linkdyn.simulate`` beside MuJoCo on the same models, in the same run.

Four models:
  1. Hoeken's four-bar with its flywheel run up from rest by a motor's torque-speed line
     (the bundled ``hoeken_motor``; the motor torque is a joint_torque in qd_J1);
  2. a chain of N parallelogram windows (unit bars, 1 kg) falling under gravity from 45
     degrees, flat (a singular position) and through;
  3. the spatial RSUR four-bar released under gravity (the bundled ``rsur_release``);
  4. the spatial double-wishbone quarter car dropped onto its tyre (``quarter_car``: springs
     and a damper).
For each: a tight-tolerance linkdyn run is the reference; then linkdyn at several tolerances and
MuJoCo (linkdyn's own MJCF export, ``linkdyn export --to mjcf``, as tests/test_mujoco.py and
tests/test_mujoco_spatial.py load it: the same open tree closed by stiff ``connect``
constraints, RK4, driven from Python: the motor torque set every step) at several time steps,
each with its wall time, steps, right-hand side evaluations (linkdyn), energy drift, closure
and trajectory error: the largest deviation of the free coordinate from the reference at the
output samples, relative to its range. The energy drift is the same measure for both tools
(:func:`linkdyn.balance.energy_drift`: the largest ``|E - E(0) - W|`` over the run relative to
its largest energy, ``W`` the work of the motor and the dampers); linkdyn's from its own
balance (samples and steps), MuJoCo's at every second step from its ``energy`` (gravity and
the tendon springs) and the work integrated by Simpson's rule. The closure is the largest
loop error relative to the mechanism's size: linkdyn's ``closure_residual``, MuJoCo's
largest ``|efc_pos|`` of its connect rows at every step. The spatial models run on numpy (the
compiled backend does not take them yet). Then the energy drift of Hoeken's four-bar spinning freely (no drivers, no
loads, no gravity: a conservative closed loop whose crank speed fluctuates; by default with the
flywheel of ``hoeken_motor``) over ``--turns`` crank turns at each tolerance (F9, sampled once
per turn), without and with the energy projection (F11). Last, the time of one
right-hand-side evaluation of Hoeken.

Each run of the work-precision tables is timed ``--best`` times (default 3), both tools alike,
and its smallest wall time and smallest CPU time of this process printed (on a shared machine
the wall time counts the other jobs too); a linkdyn run's time is the whole ``simulate`` call
(set-up, integration, outputs), MuJoCo's its stepping loop.

Usage: python benchmarks/bench_simulate.py [--duration T] [--windows N] [--chain-duration T]
       [--tols 1e-4,1e-6,1e-8,1e-9,1e-10] [--steps 1e-3,1e-4] [--samples S] [--turns N]
       [--turn-tols 1e-6,1e-8] [--turn-model hoeken|hoeken_motor] [--best K]
       [--only planar|spatial] [--spatial-duration T] [--spatial-tols 1e-4,1e-6,1e-8]
       [--spatial-ref 1e-11]
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
import xml.etree.ElementTree as ET  # noqa: E402
from dataclasses import replace  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import linkdyn  # noqa: E402
from linkdyn.forward import System, partition, simulate, start_state  # noqa: E402
from linkdyn.model import Model  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
TARGET_RHS = 50e-6   # s per right-hand side of Hoeken (issue 13)


def chain(n: int, phi0: float = math.pi / 4) -> Model:
    """n parallelogram windows (tests/builders.py), cut at the B joints as MuJoCo's tree is."""
    from builders import parallelogram_chain

    return parallelogram_chain(n, phi0, cut=[f"B{k}" for k in range(1, n + 1)])


def timed(run, best: int):
    """``run()``'s result, and its smallest wall time and smallest CPU time (s) of ``best``
    calls."""
    wall = cpu = math.inf
    for _ in range(best):
        w0, c0 = time.perf_counter(), time.process_time()
        out = run()
        wall, cpu = min(wall, time.perf_counter() - w0), min(cpu, time.process_time() - c0)
    return out, wall, cpu


def mujoco_model(model, ref, dt):
    """MuJoCo's model and data of linkdyn's MJCF export of ``model`` at ``ref``'s first sample
    (its initial state in the keyframe), RK4 at the step ``dt``, the connects stiff."""
    import mujoco
    from linkdyn.io.mjcf import mjcf

    root = ET.fromstring(mjcf(model, sol=ref, at=float(ref.t[0])).text)
    option = root.find("option")
    option.set("timestep", repr(dt))
    option.set("integrator", "RK4")
    flag = option.find("flag")
    if flag is None:
        flag = ET.SubElement(option, "flag")
    flag.set("energy", "enable")
    for c in root.iter("connect"):
        c.set("solref", f"{2 * dt!r} 1")
        c.set("solimp", "0.9999 0.9999 0.001")
    m = mujoco.MjModel.from_xml_string(ET.tostring(root, encoding="unicode"))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)    # linkdyn's initial positions and rates
    return m, d


def mujoco_run(model, ref, t, dt, free, motor=None):
    """MuJoCo from linkdyn's initial state: the free coordinate at the times t, and the
    wall and CPU time of its stepping loop."""
    import mujoco

    m, d = mujoco_model(model, ref, dt)
    adr, dof = m.joint(free).qposadr[0], m.joint(free).dofadr[0]
    per = int(round((t[1] - t[0]) / dt))
    out = np.empty(len(t))
    start, cpu = time.perf_counter(), time.process_time()
    for k in range(len(t)):
        out[k] = d.qpos[adr]
        for _ in range(per if k < len(t) - 1 else 0):
            if motor is not None:
                d.qfrc_applied[dof] = motor(d.qvel[dof])
            mujoco.mj_step(m, d)
    return out, time.perf_counter() - start, time.process_time() - cpu


def mujoco_balance(model, ref, t, dt, free, size, motor=None):
    """The same MuJoCo run as :func:`mujoco_run`, untimed, with its energy balance and closure
    at every step: :func:`linkdyn.balance.energy_drift` of MuJoCo's kinetic and potential energy
    (gravity, tendon springs) and the work of the motor and the tendon dampers (Simpson's rule
    at every second step; the trapezoidal rule for an odd number of steps), and the largest ``|efc_pos|`` of the equality rows over ``size`` (m)."""
    import mujoco
    from linkdyn.balance import energy_drift

    m, d = mujoco_model(model, ref, dt)
    dof = m.joint(free).dofadr[0]
    steps = int(round((t[-1] - t[0]) / dt))

    def state():
        """Kinetic, potential energy, power of the motor and dampers, closure at d's state."""
        if motor is not None:
            d.qfrc_applied[dof] = motor(d.qvel[dof])
        mujoco.mj_forward(m, d)
        power = float(d.qfrc_applied @ d.qvel
                      - np.sum(m.tendon_damping * d.ten_velocity ** 2))
        eq = d.efc_type[:d.nefc] == mujoco.mjtConstraint.mjCNSTR_EQUALITY
        closure = float(np.max(np.abs(d.efc_pos[:d.nefc][eq]), initial=0.0))
        return d.energy[1], d.energy[0], power, closure

    rows = [state()]
    for _ in range(steps):
        mujoco.mj_step(m, d)
        rows.append(state())
    ke, pe, power, closure = (np.array(x) for x in zip(*rows))
    if steps % 2 == 0:   # Simpson's rule over pairs of steps, at every second step (O(dt^4))
        pairs = dt / 3 * (power[:-2:2] + 4 * power[1:-1:2] + power[2::2])
        work = np.concatenate(([0.0], np.cumsum(pairs)))
        ke, pe = ke[::2], pe[::2]
    else:
        work = np.concatenate(([0.0], np.cumsum(0.5 * dt * (power[1:] + power[:-1]))))
    return energy_drift(ke, pe, work), float(np.max(closure)) / size


def _columns(sol) -> dict:
    """A planar solution's ``columns`` (a property), a spatial one's (a method)."""
    return sol.columns() if callable(sol.columns) else sol.columns


def table(name, model, t, free, tols, steps, ref_tol, motor=None, best=3):
    print(f"\n{name}: {t[-1]:g} s, {len(t)} output samples; reference linkdyn DOP853 rtol "
          f"{ref_tol:g}")
    from linkdyn.model import point_spread

    spatial = model.space == "spatial"
    start = time.perf_counter()
    ref = simulate(model, t, rtol=ref_tol, atol=ref_tol * 1e-2, backend="numpy")
    print(f"  reference: {time.perf_counter() - start:.2f} s, {ref.stats['steps']} steps, "
          f"{ref.stats['rhs_evaluations']} RHS, energy drift {ref.energy_drift:.1e}, closure "
          f"{ref.stats['closure_residual']:.1e}")
    q_ref = _columns(ref)[f"q_{free}"]
    scale = float(np.ptp(q_ref)) or 1.0
    size = float(point_spread(np.array([p for b in model.bodies for p in b.points.values()])))
    print(f"  {'solver':34s} {'wall s':>8s} {'CPU s':>8s} {'steps':>7s} {'RHS':>7s} "
          f"{'energy':>9s} {'closure':>9s} {'error':>9s}")
    try:
        import numba  # noqa: F401
        backends = ("numpy",) if spatial else ("numpy", "compiled")
    except ImportError:
        backends = ("numpy",)
    fast = []   # the fastest backend's rows: (error, wall, CPU, rtol)
    for backend in backends:   # the right-hand side by numpy's stages, then compiled
        if backend == "compiled":   # compiled before the timing
            simulate(model, t[:2], rtol=1e-4, atol=1e-6, backend=backend)
        for tol in tols:
            # numpy's rows (seconds, not the comparison) timed once, unless numpy is the
            # fastest backend (spatial models)
            s, wall, cpu = timed(lambda: simulate(model, t, rtol=tol, atol=tol * 1e-2,
                                                  backend=backend),
                                 best if backend == backends[-1] else 1)
            err = float(np.max(np.abs(_columns(s)[f"q_{free}"] - q_ref))) / scale
            name = "linkdyn DOP853" if backend == "numpy" else "linkdyn compiled DOP853"
            print(f"  {name + ' rtol ' + format(tol, 'g'):34s} {wall:8.3f} {cpu:8.3f} "
                  f"{s.stats['steps']:7d} {s.stats['rhs_evaluations']:7d} "
                  f"{s.energy_drift:9.1e} {s.stats['closure_residual']:9.1e} {err:9.1e}")
            if backend == backends[-1]:
                fast.append((err, wall, cpu, tol))
    try:
        import mujoco  # noqa: F401
    except ImportError:
        print("  (MuJoCo not installed)")
        return
    rows = []
    for dt in steps:
        runs = [mujoco_run(model, ref, t, dt, free, motor) for _ in range(best)]
        q, wall, cpu = runs[0][0], min(r[1] for r in runs), min(r[2] for r in runs)
        drift, closure = mujoco_balance(model, ref, t, dt, free, size, motor)
        err = float(np.max(np.abs(q - q_ref))) / scale
        rows.append((err, wall, cpu, dt))
        print(f"  {'MuJoCo RK4 dt ' + format(dt, 'g'):34s} {wall:8.3f} {cpu:8.3f} "
              f"{int(round(t[-1] / dt)):7d} {'':>7s} {drift:9.1e} {closure:9.1e} {err:9.1e}")
    # the target: each accuracy MuJoCo reaches (1e-4 and tighter), reached by linkdyn's fastest
    # backend in less time (its fastest row at least as accurate); and, the spatial models'
    # bar, linkdyn at 100 times smaller error at least as fast
    what = "numpy" if spatial else "compiled"
    for err, wall, cpu, dt in rows:
        if not (fast and err <= 1e-4):
            continue
        for factor in (1, 100) if spatial else (1,):
            ok = [r for r in fast if r[0] <= err / factor]
            label = f"accuracy {err / factor:.1e}" + (f" (1/{factor} of MuJoCo's)"
                                                      if factor > 1 else "")
            if not ok:
                print(f"  {label}, MuJoCo dt {dt:g}: no {what} linkdyn row reaches it")
                continue
            by_wall, by_cpu = min(ok, key=lambda r: r[1]), min(ok, key=lambda r: r[2])
            print(f"  {label}, MuJoCo dt {dt:g} ({wall:.3f} s wall, {cpu:.3f} s CPU): "
                  f"{what} linkdyn {by_wall[1]:.3f} s wall (rtol {by_wall[3]:g}), "
                  f"{by_cpu[2]:.3f} s CPU (rtol {by_cpu[3]:g}): "
                  f"{'faster' if by_wall[1] < wall else 'NOT faster'} by wall "
                  f"({by_wall[1] / wall:.3g}x MuJoCo's), "
                  f"{'faster' if by_cpu[2] < cpu else 'NOT faster'} by CPU "
                  f"({by_cpu[2] / cpu:.3g}x)")


def energy_turns(turns: int, tols, method="DOP853", example="hoeken"):
    """Energy drift (F9) of Hoeken's four-bar spinning freely for ``turns`` crank turns at each
    relative tolerance of ``tols`` (absolute: 1e-2 of it); prints one row per tolerance.
    ``example``: ``hoeken`` (the bare four-bar, whose crank speed varies 2.5 to 1), or
    ``hoeken_motor`` (with its flywheel, the motor removed: within 2 %)."""
    driven = linkdyn.load(linkdyn.example_path("hoeken"))
    w0 = 2 * math.pi * 45 / 60                       # 45 rpm at the start
    if example != "hoeken":
        fly = linkdyn.load(linkdyn.example_path(example))
        driven = replace(driven, bodies=fly.bodies)
    model = replace(driven, drivers=(), loads=(), gravity=np.zeros(2), initial_q={"J1": 0.0},
                    initial_qd={"J1": w0})
    # the period: the crank's speed at angle th is w0 sqrt(I(0) / I(th)) (energy conserved),
    # I(th) from analyze's kinetic energy at the driver's constant speed
    th = np.linspace(0.0, 2 * math.pi, 721)
    ke = linkdyn.analyze(driven, th / w0).kinetic_energy
    period = float(np.trapezoid(np.sqrt(ke / ke[0]), th)) / w0
    t = np.linspace(0.0, turns * period, turns + 1)
    which = "no flywheel" if example == "hoeken" else f"with the flywheel of {example}"
    print(f"\n{method}, Hoeken spinning freely ({which}), {turns} crank turns "
          "(sampled once per turn)")
    marks = [n for n in (10, 100) if n < turns]
    print(f"  {'rtol':>8s} {'projected':>9s} {'turns':>7s} {'wall s':>8s} {'steps':>7s} "
          f"{'RHS':>8s} " + "".join(f"{f'drift {n}':>12s}" for n in marks)
          + f"{f'drift {turns}':>12s}")
    for tol in tols:
        for project in (False, True):   # the integrator alone, then with F11's projection
            start = time.perf_counter()
            s = simulate(model, t, rtol=tol, atol=tol * 1e-2, method=method, max_steps=10**7,
                         project=project)
            wall = time.perf_counter() - start
            done = (s.columns["q_J1"][-1] - s.columns["q_J1"][0]) / (2 * math.pi)
            # F9 over the first n turns (its scale, the largest kinetic energy, is the whole
            # run's)
            e = np.abs(s.energy - s.energy[0] - s.work) / np.max(s.kinetic_energy)
            print(f"  {tol:8.0e} {'yes' if project else 'no':>9s} {done:7.0f} {wall:8.1f} "
                  f"{s.stats['steps']:7d} {s.stats['rhs_evaluations']:8d} "
                  + "".join(f"{np.max(e[:n + 1]):12.1e}" for n in marks)
                  + f"{s.energy_drift:12.1e}")


def rhs_time(model, repeat=200, h=2e-3, fast=False):
    """Seconds of one right-hand side at a state an integrator would ask for: ``h`` after an
    accepted state (its closed positions the guess's reference), one Euler step away. CPU time
    of this process (best of three rounds): on a shared machine the wall time counts the other
    jobs too. ``fast``: the compiled right-hand side (compiled before the timing)."""
    part = partition(model)
    q0 = start_state(part)
    system = System(part, q0, np.zeros(len(q0)), fast)
    y = np.array([q0[part.layout.topo.driven[-1]], 3.0, 0.0])
    system.accept(0.0, y)
    y1 = y + h * system(0.0, y)
    best = math.inf
    for _ in range(3):
        start = time.process_time()
        for _ in range(repeat):
            system(h, y1)
        best = min(best, (time.process_time() - start) / repeat)
    return best


def spatial_rhs(model, repeat=20, h=2e-3):
    """Where one right-hand side of a spatial model's ``simulate`` spends its time (CPU time of
    this process, best of three rounds of ``repeat``), at a state an integrator would ask for
    (``h`` after the accepted start, one Euler step away): the whole evaluation, then its
    stages called alone with the same inputs as :meth:`linkdyn.spatial.forward.System.reduced`
    calls them: Newton's closure of the loops from the extrapolated guess (and one of its
    iterations: the tree's poses and the closure's rows and Jacobian), the kinematics of the
    1 + nf cases (rates and accelerations), and the loads and DeNOC efforts. Returns
    ``{stage: seconds}`` and how many times Newton's method evaluates the closure there (its
    steps and the last check)."""
    from linkdyn.spatial import dynamics as sd
    from linkdyn.spatial import forward as sf
    from linkdyn.spatial import kinematics as sk

    part = sf.partition(model)
    q0 = sf.start_state(part)
    system = sf.System(part, q0, np.zeros(len(q0)))
    nf = len(part.free)
    y = np.concatenate((q0[part.free_rows], np.full(nf, 3.0), [0.0]))
    system.accept(0.0, y)
    y1 = y + h * system(0.0, y)
    tt = np.array([h])
    q_ind = np.concatenate((sk.driver_motion(part.model, tt)[0][0], y1[:nf]))[:, None]
    guess = system.guess(tt, q_ind)
    p, inner = system.p, system.model
    q = guess.T.copy()
    q[:, system.ind[system.nd:]] = y1[:nf]
    closed, _ = sk.newton(inner, p, q)
    K = 1 + nf
    unit = np.repeat(np.eye(nf + 1)[:, 1:], 1, axis=0)
    qd = np.tile(np.concatenate((sk.driver_motion(part.model, tt)[1], y1[None, nf:2 * nf]), 1),
                 (K, 1))
    qdd = np.concatenate((np.tile(sk.driver_motion(part.model, tt)[2], (K, 1)), unit), 1)
    m = sk.motion_at(inner, p, np.tile(tt, K), np.tile(closed, (K, 1)), qd, qdd)
    coords = sk.joint_coordinates(inner, p, m) if any(
        getattr(ld.value, "state_variables", ()) for ld in inner.loads) else {}
    calls = [0]
    plain = sk.closure

    def counted(*args):
        calls[0] += 1
        return plain(*args)

    sk.closure = counted
    try:
        sk.newton(inner, p, q)
    finally:
        sk.closure = plain

    def stages():
        applied = sd.loads(inner, p, m, coords)
        _, _, Q, _ = sd.generalized(inner, p, m, applied)
        sd.efforts(p, m, Q)

    work = {"whole right-hand side": lambda: system(h, y1),
            "Newton's closure": lambda: sk.newton(inner, p, q),
            "  one iteration: poses + closure": lambda: sk.closure(inner, p, sk.poses(p, q)),
            "rates and accelerations (motion_at)":
                lambda: sk.motion_at(inner, p, np.tile(tt, K), np.tile(closed, (K, 1)), qd, qdd),
            "loads, DeNOC, efforts": stages}
    out = {}
    for name, run in work.items():
        best = math.inf
        for _ in range(3):
            start = time.process_time()
            for _ in range(repeat):
                run()
            best = min(best, (time.process_time() - start) / repeat)
        out[name] = best
    return out, calls[0]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=2.0, help="Hoeken run-up, s")
    ap.add_argument("--windows", type=int, default=20)
    ap.add_argument("--chain-duration", type=float, default=0.6)
    ap.add_argument("--tols", default="1e-4,1e-6,1e-8,1e-9,1e-10")
    ap.add_argument("--steps", default="1e-3,1e-4", help="MuJoCo time steps, s")
    ap.add_argument("--samples", type=int, default=21)
    ap.add_argument("--repeat", type=int, default=200)
    ap.add_argument("--turns", type=int, default=100, help="crank turns of the energy run")
    ap.add_argument("--turn-tols", default="1e-6,1e-8")
    ap.add_argument("--best", type=int, default=3,
                    help="times each work-precision run is timed (the smallest is printed)")
    ap.add_argument("--turn-model", default="hoeken_motor", choices=("hoeken", "hoeken_motor"),
                    help="the bare four-bar, or with hoeken_motor's flywheel (fewer steps a turn)")
    ap.add_argument("--only", choices=("planar", "spatial"),
                    help="run only the planar models' tables (with the energy turns and the "
                         "right-hand side's time) or only the spatial models' tables")
    ap.add_argument("--spatial-duration", type=float, default=0.5,
                    help="s, of the spatial models' runs")
    ap.add_argument("--spatial-tols", default="1e-4,1e-6,1e-8",
                    help="linkdyn's tolerances on the spatial models (numpy: slow)")
    ap.add_argument("--spatial-ref", type=float, default=1e-11,
                    help="rtol of the spatial models' linkdyn reference")
    a = ap.parse_args()
    tols = [float(x) for x in a.tols.split(",")]
    steps = [float(x) for x in a.steps.split(",")]

    if a.only != "planar":
        stols = [float(x) for x in a.spatial_tols.split(",")]
        ts = np.linspace(0.0, a.spatial_duration, a.samples)
        table("RSUR four-bar released under gravity (spatial)",
              linkdyn.load(linkdyn.example_path("rsur_release")), ts, "J1", stols, steps,
              a.spatial_ref, best=a.best)
        table("double-wishbone quarter car dropped (spatial: springs, damper)",
              linkdyn.load(linkdyn.example_path("quarter_car")), ts, "JL", stols, steps,
              a.spatial_ref, best=a.best)
        for example in ("rsur_release", "quarter_car"):
            parts, evaluations = spatial_rhs(linkdyn.load(linkdyn.example_path(example)),
                                             max(1, a.repeat // 10))
            whole = parts["whole right-hand side"]
            print(f"\none right-hand side of {example} (numpy, CPU time; Newton's method "
                  f"evaluates the closure {evaluations} times from the extrapolated guess):")
            for name, sec in parts.items():
                print(f"  {name:38s} {sec * 1e3:8.3f} ms  {sec / whole:6.0%}")
        if a.only == "spatial":
            return
    hoeken = linkdyn.load(linkdyn.example_path("hoeken_motor"))
    hoeken = replace(hoeken, cut=("J4",))
    w0 = 270 * math.pi / 180
    table("Hoeken + flywheel run up by a motor line", hoeken,
          np.linspace(0.0, a.duration, a.samples), "J1", tols, steps, 1e-12,
          motor=lambda w: 3.2 * (1 - w / w0), best=a.best)
    table(f"{a.windows}-window parallelogram chain under gravity", chain(a.windows),
          np.linspace(0.0, a.chain_duration, a.samples), "G0", tols, steps, 1e-12,
          best=a.best)
    energy_turns(a.turns, [float(x) for x in a.turn_tols.split(",")], example=a.turn_model)
    rhs = rhs_time(hoeken, a.repeat)
    print(f"\none right-hand side of Hoeken (CPU time, target {TARGET_RHS * 1e6:.0f} us):")
    print(f"  numpy:    {rhs * 1e6:7.1f} us")
    try:
        fast = rhs_time(hoeken, 10 * a.repeat, fast=True)
    except ImportError:
        print("  compiled: (numba not installed)")
    else:
        print(f"  compiled: {fast * 1e6:7.1f} us "
              f"({'met' if fast < TARGET_RHS else 'NOT met'}; {rhs / fast:.0f}x numpy)")


if __name__ == "__main__":
    main()
