"""The Scotch yoke (``linkdyn example scotch_yoke``) with its driver removed: one free degree of
freedom by the one Grübler–Kutzbach count (``topology.mobility``: a revolute and a prismatic
joint remove two rows each, the pin in the slot one), so ``simulate`` integrates it.

Validated against the yoke's own equation of motion, written here from its Lagrangian with no
linkdyn code: with the crank angle theta, the yoke's slide x = r cos(theta), so

    M(theta) theta'' + M'(theta) theta'^2 / 2 = Q(theta),
    M = I_O + m_y r^2 sin^2(theta),
    Q = -m_c g r_c cos(theta) + F r sin(theta)

(I_O the crank's inertia about its bearing, m_c g its weight at r_c, F = 150 N the working load
against the yoke's outward stroke; the yoke slides horizontally, so its weight does no work).
Started at 30 degrees and 360 deg/s, the load throws the crank past its dead point at 180
degrees (yoke fully in) to 330 degrees within 0.1 s.
"""

from __future__ import annotations

import tomllib

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import linkdyn
from linkdyn import compiled, forward, topology

BACKENDS = ["numpy", pytest.param("compiled", marks=pytest.mark.skipif(
    compiled.numba is None, reason="the compiled backend needs numba"))]

# the example's numbers, SI: crank (mass, mass centre radius, inertia about it), yoke mass,
# crank radius, gravity, working load
M_C, R_C, I_C, M_Y, R, G, F = 0.4, 0.030, 120e-6, 1.5, 0.060, 9.81, 150.0
I_O = I_C + M_C * R_C ** 2
THETA0, OMEGA0 = np.radians(30.0), np.radians(360.0)


def freed_yoke() -> linkdyn.Model:
    data = tomllib.loads(linkdyn.example_path("scotch_yoke").read_text("utf-8"))
    del data["drivers"], data["analysis"]         # (its cycles count the driver's turns)
    data["initial"] = {"q": {"J1": 30.0}, "qd": {"J1": 360.0}}     # deg, deg/s
    return linkdyn.model_from_dict(data, source="freed_yoke.toml")


def lagrange(t, y):
    """The yoke's equation of motion, y = (theta, theta')."""
    th, w = y
    M = I_O + M_Y * (R * np.sin(th)) ** 2
    dM = 2.0 * M_Y * R ** 2 * np.sin(th) * np.cos(th)
    Q = -M_C * G * R_C * np.cos(th) + F * R * np.sin(th)
    return [w, (Q - 0.5 * dM * w ** 2) / M]


def test_one_count_of_the_freedoms():
    model = freed_yoke()
    assert topology.mobility(model) == 1
    assert forward.partition(model).free == ("J1",)
    # the driven yoke: the same count, one driver for it
    driven = linkdyn.load(linkdyn.example_path("scotch_yoke"))
    assert topology.mobility(driven) == topology.build(driven).mobility == 1


@pytest.mark.parametrize("backend", BACKENDS)
def test_freed_yoke_follows_its_equation_of_motion(backend):
    t = np.linspace(0.0, 0.1, 21)
    rtol = 1e-8
    sol = linkdyn.simulate(freed_yoke(), t, rtol=rtol, atol=1e-10, backend=backend)
    c = sol.columns
    ref = solve_ivp(lagrange, (0.0, t[-1]), [THETA0, OMEGA0], t_eval=t, method="DOP853",
                    rtol=1e-12, atol=1e-12)
    assert c["q_J1"][-1] > np.radians(320.0)            # through the dead point at 180 deg
    # the motion, to the integrator's tolerance of each quantity's peak
    for col, y in (("q_J1", ref.y[0]), ("qd_J1", ref.y[1])):
        peak = np.max(np.abs(y))
        assert np.max(np.abs(c[col] - y)) <= 100 * rtol * peak, col
    # energy balance: kinetic + potential - work of the load stays put
    assert sol.energy_drift <= 10 * rtol
    # the slot holds the pin: the yoke's slide x = r cos(theta), the pin's place in the slot
    # r sin(theta), and their rates
    th, w = c["q_J1"], c["qd_J1"]
    assert np.max(np.abs(c["q_J2"] - R * np.cos(th))) <= 1e-12 * R
    assert np.max(np.abs(c["q_J3"] - R * np.sin(th))) <= 1e-12 * R
    assert np.max(np.abs(c["qd_J2"] + R * np.sin(th) * w)) <= 1e-12 * R * np.max(np.abs(w))
