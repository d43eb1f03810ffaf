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

from .layout import Layout
from ..planar import solve_small
from .positions import ACCEPT, _scaled, newton
from .recursion import closure_jacobian, closure_residual, forward_positions, motion_vectors
from .solution import KinematicSolution, _rates_and_accelerations


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
        Tree coordinates with the loops closed (residual <= ``TOL`` relative to the size).
    err : ndarray (...)
        Scaled closure residual (above ``ACCEPT`` where the loops do not close).
    """
    drv = list(lay.topo.driven)
    shape = np.broadcast_shapes(np.shape(q_ind)[1:], np.shape(guess)[1:])
    q = np.array(np.broadcast_to(guess, (lay.topo.n,) + shape), dtype=float)
    q[drv] = q_ind
    # Newton's method g(q_dep) = 0 from the guess: it converges to the nearest root, the branch
    # the motion is on; a damped restart for samples it leaves open
    q_new, err = newton(lay, q, maxiter=20)
    retry = ~(err <= ACCEPT)
    if np.any(retry):
        q_damped, err_damped = newton(lay, q, maxiter=60, damped=True)
        q_new = np.where(retry, q_damped, q_new)
        err = np.where(retry, err_damped, err)
    # one more Newton step past the tolerance: quadratic convergence leaves rounding only, so
    # the positions are a smooth function of the state (an integrator differentiates them)
    dep = np.array(lay.topo.dependent, int)
    if len(dep):
        pose = forward_positions(lay, q_new)
        J = closure_jacobian(lay, pose, motion_vectors(lay, pose))[:, dep - 1]
        dx, _ = solve_small(J, -closure_residual(lay, pose))
        q_new[dep] += np.where(np.isfinite(dx), dx, 0.0)
        err = np.where(err <= ACCEPT, _scaled(lay, closure_residual(lay, forward_positions(
            lay, q_new))), err)
    return q_new, err


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
    q, err = close(lay, q_ind, guess)
    # positions closed once; samples differing only in rates or accelerations share them
    shape = np.broadcast_shapes(q.shape[1:], qd_ind.shape[1:], qdd_ind.shape[1:])
    q = np.array(np.broadcast_to(q, (len(q),) + shape))
    err = np.broadcast_to(err, shape)
    pose = forward_positions(lay, q)
    p = motion_vectors(lay, pose)
    J = closure_jacobian(lay, pose, p)
    # rates and accelerations: J_dep qd_dep = -J_ind qd_ind, J_dep qdd_dep = -bias   (eqs. 4-7)
    return _rates_and_accelerations(model, lay, np.asarray(t, dtype=float), q, pose, p, J,
                                    np.broadcast_to(qd_ind, (len(qd_ind),) + shape),
                                    np.broadcast_to(qdd_ind, (len(qdd_ind),) + shape), err)
