"""``simulate`` with joint friction (docs/theory.md F13), by independent means.

a. closed forms: a block resting on an incline with a static coefficient above tan(alpha)
   stays put (its holding friction is m g sin alpha); pushed beyond the static capacity it
   slides with g (sin alpha - mu_d cos alpha) + F/m; under a force growing in time it starts
   to slide exactly when the force reaches mu_s m g cos alpha - m g sin alpha;
b. the energy balance counts the dissipation: mu_d N times the distance slid, and the
   integrated balance KE + PE - W to the integrator's tolerance;
c. a pendulum with pin friction decays, sticks and stays, against an independent
   ``solve_ivp`` of its own equation written here (the pin force from Newton's law, the
   couple mu r |F| against the swing, a stop where mu r |F| holds the weight's moment);
d. friction in a joint that is not a free coordinate creeps at v artanh(Q / C), the holding
   effort Q and the capacity C of the incline's closed form.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import linkdyn
from linkdyn.friction import joint_friction
from linkdyn.model import Body, Joint, Load, Model, REVOLUTE

from builders import pri, slot

G = 9.81
ALPHA, MASS = 0.3, 2.0          # tan(0.3) = 0.309


def along(alpha, force):
    """A force of ``force`` N down the incline, a load value of time."""
    def value(t):
        f = np.asarray(force(t) if callable(force) else force + 0.0 * np.asarray(t), float)
        return np.stack(np.broadcast_arrays(-f * math.cos(alpha), -f * math.sin(alpha)), -1)
    return value


def block(mu_static, mu, force=None, stiction=1e-6):
    """A block of MASS kg on a guide at ALPHA up from the horizontal (its coordinate up the
    guide), released at rest, friction mu (dynamic) and mu_static in the guide; ``force``
    (N, or a function of time) pushes it down the guide."""
    bodies = (Body("ground", {"O": np.zeros(2)}),
              Body("block", {"B": np.zeros(2)}, MASS, np.zeros(2), 0.01))
    joints = (pri("J1", "ground.O", "block.B", (math.cos(ALPHA), math.sin(ALPHA))),)
    m = Model("incline", bodies, joints, (), gravity=np.array([0.0, -G]),
              initial_q={"J1": 0.0})
    loads = (joint_friction(m, "J1", mu, static_coefficient=mu_static,
                            stiction_speed=stiction),)
    if force is not None:
        loads += (Load("force", "block", "B", value=along(ALPHA, force)),)
    return dataclasses.replace(m, loads=loads)


def motion(sol):
    return tuple(x[0] for x in sol.kin.joint_motion)   # q, qd, qdd of J1


def test_block_resting_on_an_incline_stays_put():
    sol = linkdyn.simulate(block(0.5, 0.3), np.linspace(0, 1, 11), backend="numpy")
    q, qd, _ = motion(sol)
    assert np.ptp(q) < 1e-9 and np.max(np.abs(qd)) < 1e-12
    # what holds it: the weight's share along the guide, up the guide
    np.testing.assert_allclose(sol.friction.effort[0], MASS * G * math.sin(ALPHA), rtol=1e-12)
    assert sol.stats["stick_slip"] == [(0.0, "J1", "sticks")]


def test_compiled_request_falls_back_to_numpy_with_friction():
    """The compiled right-hand side knows no friction: a run asking for it integrates on
    numpy's (the same motion), never a different answer."""
    t = np.linspace(0, 0.5, 6)
    a = linkdyn.simulate(block(0.2, 0.2), t, backend="numpy")
    b = linkdyn.simulate(block(0.2, 0.2), t, backend="compiled")
    assert b.stats["backend"] == "numpy"
    np.testing.assert_array_equal(motion(a)[0], motion(b)[0])


@pytest.mark.parametrize("push", [5.0, 0.0])
def test_block_beyond_the_static_capacity_slides_as_the_closed_form(push):
    """Pushed down (5 N beyond mu_s = 0.5's capacity), or resting with mu_s below tan(alpha):
    it slides down with g (sin a - mu_d cos a) + F/m once its speed is far above the stiction
    speed (1e-6 m/s), and its position follows the closed form within that speed times t."""
    mu_s = 0.5 if push else 0.2
    t = np.linspace(0, 1, 11)
    sol = linkdyn.simulate(block(mu_s, 0.3, push), t, backend="numpy")
    q, qd, qdd = motion(sol)
    a = G * (math.sin(ALPHA) - 0.3 * math.cos(ALPHA)) + push / MASS
    fast = np.abs(qd) > 1e-4
    assert np.sum(fast) == 10
    np.testing.assert_allclose(qdd[fast], -a, rtol=1e-10)
    np.testing.assert_allclose(q, -0.5 * a * t**2, rtol=0, atol=1e-6 * 3)
    assert sol.stats["stick_slip"] == []


def test_block_slips_when_a_growing_force_passes_the_static_capacity():
    """F = 4 t N down the guide: stuck until F = m g (mu_s cos a - sin a), then sliding."""
    rate, mu_s = 4.0, 0.5
    t_slip = MASS * G * (mu_s * math.cos(ALPHA) - math.sin(ALPHA)) / rate
    t = np.linspace(0, 1.2, 13)
    sol = linkdyn.simulate(block(mu_s, mu_s, lambda t: rate * np.asarray(t)), t,
                           backend="numpy")
    q, _, _ = motion(sol)
    events = sol.stats["stick_slip"]
    assert [e[1:] for e in events] == [("J1", "sticks"), ("J1", "slips")]
    assert events[1][0] == pytest.approx(t_slip, abs=1e-9)
    assert np.all(q[t < t_slip] == 0.0)
    # afterwards: a = (F(t) - F(t_slip)) / m, so q = -rate (t - t_s)^3 / (6 m)
    late = t > t_slip
    np.testing.assert_allclose(q[late], -rate * (t[late] - t_slip) ** 3 / (6 * MASS),
                               rtol=1e-7)


def test_energy_balance_counts_the_dissipation():
    """Sliding down at mu_s = mu_d: the friction dissipates mu N per metre (its power is
    linear in time, the trapezoid rule exact), the balance KE + PE - W closes to the
    tolerance, and the summary's energy account with it."""
    t = np.linspace(0, 1, 11)
    sol = linkdyn.simulate(block(0.1, 0.1), t, backend="numpy", rtol=1e-10, atol=1e-12)
    q, _, _ = motion(sol)
    account = linkdyn.design.energy_account(sol)
    N = MASS * G * math.cos(ALPHA)
    assert account["friction_dissipation"] == pytest.approx(0.1 * N * abs(q[-1]), rel=1e-9)
    assert sol.energy_drift < 1e-9
    assert abs(account["residual"]) < 1e-9 * account["friction_dissipation"]
    # W is the friction's work alone (no driver, no other load)
    assert sol.work[-1] == pytest.approx(-account["friction_dissipation"], rel=1e-9)


# ----------------------------------------------------------------------------------------------
# a pendulum with pin friction, against its own equation

L, MP, IC, MU, R = 0.5, 1.5, 0.02, 0.4, 0.05   # m, kg, kg m^2, 1, m


def pendulum(phi0):
    bodies = (Body("ground", {"O": np.zeros(2)}),
              Body("bar", {"P": np.zeros(2)}, MP, np.array([L, 0.0]), IC))
    m = Model("pendulum", bodies, (Joint("J1", REVOLUTE, "ground", "O", "bar", "P"),), (),
              gravity=np.array([0.0, -G]), initial_q={"J1": phi0})
    return dataclasses.replace(m, loads=(joint_friction(m, "J1", MU, R),))


def pendulum_reference(phi0, t):
    """phi(t) of I_O phi'' = -m g l cos(phi) - mu r |F| s, F = m a_G + (0, m g) the pin's force
    (a_G = l phi'' (-sin, cos) - l phi'^2 (cos, sin)), s the sense of the swing, solved by
    solve_ivp swing by swing: at each stop (phi' = 0) it sticks for good if mu r m g holds
    m g l |cos(phi)|, else it swings back."""
    I_O = IC + MP * L * L

    def accel(phi, w, s):
        a = 0.0
        for _ in range(15):   # fixed point (a contraction by 0.04): F depends on phi''
            F = MP * np.array([-L * a * math.sin(phi) - L * w * w * math.cos(phi),
                               L * a * math.cos(phi) - L * w * w * math.sin(phi) + G])
            a = (-MP * G * L * math.cos(phi) - MU * R * math.hypot(*F) * s) / I_O
        return a

    out = np.full(t.shape, np.nan)
    t0, y0 = 0.0, np.array([phi0, 0.0])
    while t0 < t[-1]:
        torque = -MP * G * L * math.cos(y0[0])
        if abs(torque) <= MU * R * MP * G:          # it holds: stuck for good
            out[t >= t0] = y0[0]
            break
        s = math.copysign(1.0, torque)

        def stop(_, y):
            return y[1]
        stop.terminal, stop.direction = True, -s
        pick = (t >= t0)
        r = solve_ivp(lambda _, y: [y[1], accel(y[0], y[1], s)], (t0, t[-1]), y0,
                      events=stop, dense_output=True, rtol=1e-12, atol=1e-14)
        end = r.t[-1]
        inside = pick & (t <= end)
        out[inside] = r.sol(t[inside])[0]
        t0, y0 = end, np.array([r.y[0, -1], 0.0])
        if r.status == 0:
            break
    return out


def test_pendulum_with_pin_friction_against_its_own_equation():
    phi0 = -math.pi / 2 + 0.25
    t = np.linspace(0, 2.5, 41)
    sol = linkdyn.simulate(pendulum(phi0), t, backend="numpy", rtol=1e-9, atol=1e-11)
    phi = motion(sol)[0]
    ref = pendulum_reference(phi0, t)
    np.testing.assert_allclose(phi, ref, rtol=0, atol=1e-7)
    kinds = [e[2] for e in sol.stats["stick_slip"]]
    assert kinds[-1] == "sticks" and "reverses" in kinds
    # it ends at rest where the pin's friction holds the weight's moment
    assert np.ptp(phi[t > sol.stats["stick_slip"][-1][0]]) == 0.0
    assert abs(math.cos(phi[-1])) * L <= MU * R
    assert sol.energy_drift < 1e-8


def test_cli_simulate_reports_the_friction(tmp_path):
    """``linkdyn simulate`` of a block that slips under a growing push: the friction's
    columns, its dissipation in the printed energy account, and the stick-slip events."""
    import json

    import pandas as pd
    from click.testing import CliRunner

    from linkdyn.cli import main
    m = block(0.5, 0.5, lambda t: 4.0 * np.asarray(t))
    p = tmp_path / "block.toml"
    linkdyn.save(dataclasses.replace(m, loads=m.loads[:1]), p)   # a formula push, written below
    text = p.read_text() + '\n[[loads]]\nkind = "force"\nbody = "block"\npoint = "B"\n' \
        f'value = ["-4*t*{math.cos(ALPHA)!r}", "-4*t*{math.sin(ALPHA)!r}"]\n'
    p.write_text(text)
    out = tmp_path / "out"
    res = CliRunner().invoke(main, ["simulate", str(p), "-o", str(out), "--duration", "1.2",
                                    "--samples", "7"])
    assert res.exit_code == 0, res.output
    assert " - friction " in res.output
    df = pd.read_csv(out / "results.csv")
    assert {"friction_J1", "friction_power_J1"} <= set(df.columns)
    s = json.loads((out / "summary.json").read_text())
    assert [e["event"] for e in s["simulation"]["stick_slip"]] == ["sticks", "slips"]
    t_slip = MASS * G * (0.5 * math.cos(ALPHA) - math.sin(ALPHA)) / 4.0
    assert s["simulation"]["stick_slip"][1]["t_s"] == pytest.approx(t_slip, abs=1e-9)
    # the dissipation: mu_d N times the distance slid (the trapezoid rule's, on 7 samples)
    lost = -np.trapezoid(df["friction_power_J1"], df["t"])
    assert s["energy_account_J"]["friction_dissipation"] == pytest.approx(lost, rel=1e-12)


def test_friction_newton_step_matches_lapack():
    """One step of friction's Newton's method (the elimination both backends run per sample):
    its residual, step and determinant against the friction law written out here and
    numpy.linalg (random J: row swaps at most samples)."""
    from linkdyn.friction import newton_step, residuals
    rng = np.random.default_rng(7)
    k, n = 4, 50
    F0, A = rng.normal(size=(k, 2, n)), rng.normal(size=(k, k, 2, n))
    c, v, pre, f = (rng.normal(size=(k, n)) for _ in range(4))
    # J = I - dg/dF A, g_j = -c_j (|F_j| + pre_j) - v_j, dg_j/dF_j = -c_j F_j / |F_j|
    F = F0 + np.einsum("jlcn,ln->jcn", A, f)
    size = np.hypot(F[:, 0], F[:, 1])
    g = -c * (size + pre) - v
    J = np.eye(k)[..., None] + np.einsum("jn,jcn,jlcn->jln", c / size, F, A)
    r = f - g
    new = f.copy()
    res, dg = np.zeros((k, n)), np.zeros((k, 2, n))
    big_r, big_g = residuals(F0, A, c, v, pre, new, res, dg)
    np.testing.assert_allclose(res, r, rtol=1e-14, atol=1e-14 * np.max(np.abs(r)))
    np.testing.assert_array_equal(new, f)   # the residuals leave the efforts as they are
    det = newton_step(A, dg, new, res, np.zeros((k, k + 1, n)), np.zeros((k, n)))
    Jn = np.moveaxis(J, -1, 0)
    ref = np.linalg.det(Jn)
    np.testing.assert_allclose(det, ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(ref)))
    np.testing.assert_allclose(big_r, np.max(np.abs(r), 0), rtol=1e-14)
    np.testing.assert_allclose(big_g, np.max(np.abs(g), 0), rtol=1e-14)
    step = np.linalg.solve(Jn, r.T[..., None])[..., 0].T
    np.testing.assert_allclose(new, f - step, rtol=1e-10, atol=1e-10 * np.max(np.abs(step)))


def block_held_by_an_arm(mu):
    """The block of :func:`block` (friction ``mu`` in its guide J2, one coefficient), its pin
    riding in the slot J3 of a light arm pivoted at 0.3 m below the guide's start (J1, the free
    coordinate): the guide's friction is in a dependent joint. The arm's mass centre is its
    pivot, so at rest no load turns it and the slot carries no force: the block alone rests on
    the incline."""
    q0, pivot = 0.2, np.array([0.0, -0.3])
    b0 = q0 * np.array([math.cos(ALPHA), math.sin(ALPHA)])
    phi = math.atan2(*(b0 - pivot)[::-1])
    bodies = (Body("ground", {"O": pivot, "G": np.zeros(2)}),
              Body("arm", {"O": np.zeros(2)}, 0.05, np.zeros(2), 1e-4),
              Body("block", {"B": np.zeros(2)}, MASS, np.zeros(2), 0.01))
    joints = (Joint("J1", REVOLUTE, "ground", "O", "arm", "O"),
              pri("J2", "ground.G", "block.B", (math.cos(ALPHA), math.sin(ALPHA))),
              slot("J3", "arm.O", "block.B"))
    m = Model("arm", bodies, joints, (), gravity=np.array([0.0, -G]),
              assembly_phi={"arm": phi, "block": 0.0},
              assembly_q={"J2": q0, "J3": float(np.linalg.norm(b0 - pivot))},
              initial_q={"J1": phi})
    return dataclasses.replace(m, loads=(joint_friction(m, "J2", mu),))


def test_friction_in_a_dependent_joint_creeps_at_the_documented_rate():
    """theory.md F13: friction in a joint that is not a free coordinate follows tanh(qd / v)
    and cannot hold the block: it creeps down at qd = v artanh(Q / C), Q = m g sin(alpha) the
    holding effort and C = mu m g cos(alpha) the capacity (closed forms of the incline), once
    the transient (time constant v / (mu g cos(alpha) (1 - (Q / C)^2)) ~ 0.35 ms) has died out."""
    mu = 0.5
    m = block_held_by_an_arm(mu)
    v = m.loads[0].transition_speed
    sol = linkdyn.simulate(m, np.array([0.0, 0.012, 0.016]), backend="numpy")
    j2 = [j.name for j in m.joints].index("J2")
    qd = sol.kin.joint_motion[1][j2]
    creep = -v * math.atanh(math.tan(ALPHA) / mu)
    np.testing.assert_allclose(qd[1:], creep, rtol=1e-6)   # the integrator's atol 1e-10 on qd
    np.testing.assert_allclose(sol.friction.effort[0][1:], MASS * G * math.sin(ALPHA),
                               rtol=1e-6)
