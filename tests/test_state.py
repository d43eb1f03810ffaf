"""The kinematics stage at a state, ``kinematics.at_state``, by independent means.

- At the states ``solve`` produced (independent coordinates, rates and accelerations read back
  from its joint columns), with a guess thrown off the solution, Newton's method closes the
  loops again and every output agrees with ``solve`` (which closed the dyads in closed form).
- At a random state (coordinates off the drivers' path, random rates and accelerations) the
  rates and accelerations equal finite differences of the positions along the path
  ``q_ind(s) = q_ind + s qd_ind + s^2 / 2 qdd_ind``, for every joint and every body.

On one loop of dyads (slider-crank), two coupled loops (Stephenson), two independent
coordinates (five-bar) and a slot closed by Newton's method (Scotch yoke).
"""

from __future__ import annotations

import numpy as np
import pytest

import linkdyn
from linkdyn import joints as jk
from linkdyn import kinematics

CASES = ["slider_crank", "stephenson", "fivebar", "scotch_yoke"]


def solved(name, samples=25):
    mech = linkdyn.load(linkdyn.example_path(name))
    period = mech.duration or (mech.cycles or 1.0) * next(d.period for d in mech.drivers
                                                          if d.period)
    return mech, kinematics.solve(mech, np.linspace(0, period, samples), backend="numpy")


def tree(kin, x):
    """Joint columns ``x`` (T, n_joints) as tree coordinates (n, T), ground row zero."""
    topo = kin.layout.topo
    return np.stack([np.zeros(len(x))] + [x[:, topo.tree_joint[i]] for i in range(1, topo.n)])


def independent(kin, x):
    """The independent rows (k, T) of joint columns ``x`` (T, n_joints)."""
    return tree(kin, x)[list(kin.layout.topo.driven)]


def off(kin, rng, angle, fraction):
    """Random offsets (n, T) of the dependent tree coordinates: up to ``angle`` rad, or
    ``fraction`` of the mechanism's size for a sliding joint."""
    lay = kin.layout
    x = np.zeros((lay.topo.n, len(kin.t)))
    for i in lay.topo.dependent:
        scale = angle if jk.get(lay.kind[i]).angular else fraction * float(lay.size)
        x[i] = rng.uniform(-scale, scale, len(kin.t))
    return x


def peak(x):
    return max(float(np.max(np.abs(x))), 1e-300)


@pytest.mark.parametrize("name", CASES)
def test_at_state_reproduces_solve(name):
    mech, kin = solved(name)
    assert np.all(kin.valid)
    state = [independent(kin, x) for x in (kin.q, kin.qd, kin.qdd)]
    guess = tree(kin, kin.q) + off(kin, np.random.default_rng(1), 0.05, 0.01)
    got = kinematics.at_state(mech, kin.layout, kin.t, *state, guess)
    assert np.all(got.valid)
    for key in ("q", "qd", "qdd", "phi", "r", "tw", "twd", "J"):
        a, b = getattr(got, key), getattr(kin, key)
        assert np.max(np.abs(a - b)) <= 1e-11 * peak(b), key


@pytest.mark.parametrize("name", CASES)
def test_rates_are_derivatives_of_positions(name):
    mech, kin = solved(name, samples=7)
    rng = np.random.default_rng(2)
    k = 3
    driven = list(kin.layout.topo.driven)
    # a state off the drivers' path: coordinates moved, rates and accelerations at random
    q0 = independent(kin, kin.q)[:, k] + rng.uniform(-0.05, 0.05, len(driven))
    qd0, qdd0 = rng.normal(size=len(driven)), rng.normal(size=len(driven))
    h = 1e-3
    s = h * np.arange(-2, 3)
    path = [q0[:, None] + s * qd0[:, None] + s**2 / 2 * qdd0[:, None],
            (qd0[:, None] + s * qdd0[:, None]), np.repeat(qdd0[:, None], 5, axis=1)]
    got = kinematics.at_state(mech, kin.layout, np.zeros(5), *path, tree(kin, kin.q)[:, k:k + 1])
    assert np.all(got.valid)

    def derivatives(x):
        """First and second derivatives at s = 0 of x (5, ...) by 4th-order differences."""
        d = x - x[2]
        d = np.where(np.abs(d) > np.pi, (d + np.pi) % (2 * np.pi) - np.pi, d)  # angles wrap
        first = (-d[4] + 8 * d[3] - 8 * d[1] + d[0]) / (12 * h)
        second = (-d[4] + 16 * d[3] - 30 * d[2] + 16 * d[1] - d[0]) / (12 * h**2)
        return first, second

    # every joint's coordinate
    qd, qdd = derivatives(got.q)
    assert np.max(np.abs(qd - got.qd[2])) <= 1e-9 * peak(got.qd[2])
    assert np.max(np.abs(qdd - got.qdd[2])) <= 1e-7 * peak(got.qdd[2])
    # every body: angle and reference point against its twist and twist rate
    for x, tw_part in ((got.phi, 0), (got.r, slice(1, 3))):
        v, a = derivatives(x)
        assert np.max(np.abs(v - got.tw[2][:, tw_part])) <= 1e-9 * peak(got.tw[2])
        assert np.max(np.abs(a - got.twd[2][:, tw_part])) <= 1e-7 * peak(got.twd[2])
