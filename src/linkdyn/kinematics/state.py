"""Kinematics at a given state of the independent coordinates (for forward dynamics).

``solve`` follows the drivers' prescribed motion over a whole run. An integrator instead asks
for the mechanism at one state at a time: the independent coordinates (the drivers' and the
free degrees of freedom's, in the topology's ``driven`` order) with their rates and
accelerations. :func:`at_state` closes the loops for the dependent coordinates by Newton's
method from a guess (the previous state, extrapolated), so it stays on the branch the motion
is on, then reuses the rate and acceleration stages of :func:`.solution.solve` (eqs. 4-7).
"""

from __future__ import annotations

import numpy as np

from .. import joints as jk
from .layout import Layout
from ..planar import solve_small
from .positions import ACCEPT, _scaled, newton
from .recursion import closure_jacobian, closure_residual, forward_positions, motion_vectors
from .solution import KinematicSolution, _rates_and_accelerations

MAXITER = 20         # Newton steps before the damped restart


STEP_TOL = 1e-8      # Newton's method stops after a step below this (scaled): the error left
#                      is then of its square, rounding


def _newton_step(J: np.ndarray, g: np.ndarray) -> np.ndarray:
    """``dx`` (m, ...) of ``J dx = -g`` (J (m, m, ...), g (m, ...)) by one batched LAPACK call
    (a few microseconds, where :func:`~linkdyn.planar.solve_small`'s loops cost a millisecond
    for one sample); non-finite where ``J`` is singular."""
    m, shape = len(g), g.shape[1:]
    A = np.moveaxis(J.reshape((m, m, -1)), -1, 0)
    b = np.moveaxis(g.reshape((m, -1)), -1, 0)[..., None]
    try:
        with np.errstate(all="ignore"):
            x = np.linalg.solve(A, -b)[..., 0]
    except np.linalg.LinAlgError:   # an exactly singular sample: the slower per-sample rule
        return solve_small(J, -g)[0]
    return np.moveaxis(x, 0, -1).reshape((m,) + shape)


def close(lay: Layout, q_ind: np.ndarray, guess: np.ndarray):
    """Dependent tree coordinates closing every loop, nearest to ``guess``.

    Parameters
    ----------
    lay : Layout
    q_ind : ndarray (k, ...)
        Independent joint coordinates in ``lay.topo.driven`` order, rad or m.
    guess : ndarray (n, ...)
        Tree coordinates near the solution (its independent rows are replaced), rad or m.

    Returns
    -------
    q : ndarray (n, ...)
        Tree coordinates with the loops closed (to rounding where Newton's method converges).
    err : ndarray (...)
        Scaled closure residual (above ``ACCEPT`` where the loops do not close).
    pose : Pose
        The bodies' poses at ``q``.
    """
    topo = lay.topo
    drv, dep = list(topo.driven), np.array(topo.dependent, int)
    shape = np.broadcast_shapes(np.shape(q_ind)[1:], np.shape(guess)[1:])
    q = np.array(np.broadcast_to(guess, (topo.n,) + shape), dtype=float)
    q[drv] = q_ind
    start = q.copy()
    pose = forward_positions(lay, q)
    if not len(dep):
        return q, np.zeros(shape), pose
    # Newton's method g(q_dep) = 0 from the guess: it converges to the nearest root, the branch
    # the motion is on. It runs until a step is below STEP_TOL: quadratic convergence leaves
    # rounding only, so the positions are a smooth function of the state (an integrator
    # differentiates them)
    unit = np.array([1.0 if jk.get(lay.kind[i]).angular else 1.0 / float(np.max(lay.size))
                     for i in dep]).reshape((-1,) + (1,) * len(shape))
    g = closure_residual(lay, pose)
    for _ in range(MAXITER):
        J = closure_jacobian(lay, pose, motion_vectors(lay, pose))[:, dep - 1]
        dx = _newton_step(J, g)
        step = np.max(np.abs(dx) * unit, axis=0)
        # a step of a radian or the mechanism's size is no correction of a nearby guess (a
        # singular J_dep): not taken, the sample is left to the damped restart
        dx = np.where(np.isfinite(dx) & (step < 1.0), dx, 0.0)
        q[dep] += dx
        pose = forward_positions(lay, q)
        g = closure_residual(lay, pose)
        if not np.any(step > STEP_TOL):        # NaN (singular) stops too
            break
    err = _scaled(lay, g)
    retry = ~(err <= ACCEPT)
    if np.any(retry):
        # a damped restart from the guess for samples left open
        q_damped, err_damped = newton(lay, start, maxiter=60, damped=True)
        q = np.where(retry, q_damped, q)
        err = np.where(retry, err_damped, err)
        pose = forward_positions(lay, q)
    return q, err, pose


def at_state(model, lay: Layout, t, q_ind, qd_ind, qdd_ind, guess) -> KinematicSolution:
    """Positions, twists, twist rates and closure Jacobian at a state of the independent
    coordinates.

    Parameters
    ----------
    model : Model
        The model whose drivers are the independent coordinates (``lay``'s model).
    lay : Layout
        Its layout; ``lay.topo.driven`` lists the bodies whose tree joints are independent.
    t : ndarray (T,)
        Times, s (carried into the solution for time-dependent loads).
    q_ind, qd_ind, qdd_ind : ndarray (k, ...)
        Independent coordinates (rad or m), their rates and accelerations, in
        ``lay.topo.driven`` order; the batch shape ``...`` ends with T.
    guess : ndarray (n, ...)
        Tree coordinates near the positions sought (e.g. the previous state extrapolated).

    Returns
    -------
    KinematicSolution
        As :func:`.solution.solve` returns; samples that do not close or where ``J_dep`` is
        singular are NaN with ``valid = False``.
    """
    q_ind, qd_ind, qdd_ind = (np.asarray(x, dtype=float) for x in (q_ind, qd_ind, qdd_ind))
    # the positions closed at the batch's whole shape (samples differing only in rates or
    # accelerations cost no more: the arrays are small, the operations' overhead dominates)
    shape = np.broadcast_shapes(q_ind.shape[1:], np.shape(guess)[1:], qd_ind.shape[1:],
                                qdd_ind.shape[1:])
    q, err, pose = close(lay, np.broadcast_to(q_ind, (len(q_ind),) + shape),
                         np.broadcast_to(guess, (len(guess),) + shape))
    p = motion_vectors(lay, pose)
    J = closure_jacobian(lay, pose, p)
    # rates and accelerations: J_dep qd_dep = -J_ind qd_ind, J_dep qdd_dep = -bias   (eqs. 4-7)
    return _rates_and_accelerations(model, lay, np.asarray(t, dtype=float), q, pose, p, J,
                                    np.broadcast_to(qd_ind, (len(qd_ind),) + shape),
                                    np.broadcast_to(qdd_ind, (len(qdd_ind),) + shape), err)
