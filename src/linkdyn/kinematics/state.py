"""Kinematics at a state of the independent coordinates: the kinematics stage.

The state is the independent coordinates (the drivers' and the free degrees of freedom's, in
the topology's ``driven`` order) with their rates and accelerations, at some times.
:func:`at_state` turns it into a :class:`KinematicSolution`: it closes the loops for the
dependent coordinates (:func:`close`: in closed form in the dyads' assembly modes, or by
Newton's method from a guess, so it stays on the branch the motion is on), then solves the
dependent rates ``J_dep qd_dep = -J_ind qd_ind`` (eqs. 4-5) and accelerations
``J_dep qdd_dep = -b`` (eqs. 6-7) and propagates the twists and their rates (eq. 2).

Two callers give the state: :func:`.solution.solve` from the drivers' prescribed motion at the
sample times, with the branch it followed from the assembly as the guess; forward dynamics
(:mod:`linkdyn.forward`) from the integrator's state, with the previous state extrapolated.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from ..brief import brief_repr

from .. import joints as jk
from ..planar import last, shift_twist, solve_small, stack_last
from . import dyads
from .layout import Layout
from .positions import ACCEPT, _scaled, newton
from .recursion import (Pose, _cut_frames, closure_bias, closure_jacobian, closure_residual,
                        cut_coordinate, dependent_rates, forward_positions, forward_twist_rates,
                        forward_twists, motion_vectors, point_acceleration)


@dataclass(frozen=True)
class KinematicSolution:
    """Positions, rates and accelerations of every joint and body at every sample.

    The solvers keep one component-first array per body (``pose``, ``twists``, ``rates``,
    ``motion``: lists in tree order, ``layout.topo.bodies``, index 0 = ground). The stacked
    properties give the users' layout, components last.

    Attributes
    ----------
    t : ndarray (T,)
        s.
    joint_motion : (list, list, list)
        Coordinates (rad or m), rates and accelerations of every joint, (T,) arrays in model
        joint order; ``q``, ``qd``, ``qdd`` stack them as (T, n_joints).
    pose : Pose
        Per-body angles, reference points O_i and slider axes.
    motion : list of ndarray (3, T)
        Joint-motion propagation vectors ``p_i`` of the tree joints.
    twists, rates : list of ndarray (3, T)
        Twists ``[w, vx, vy]`` at O_i and their time derivatives.
    jacobian : ndarray (n_rows, n - 1, T)
        Loop-closure Jacobian, each cut joint's rows (``layout.topo.rows``) in turn.
    pivot : ndarray (T,)
        Smallest relative pivot of ``J_dep`` (~0 at a singular position).
    residual : ndarray (T,)
        Closure residual relative to ``layout.size``.
    valid : ndarray (T,) bool
    arrays : dict or None
        Set by the compiled kernels (:mod:`linkdyn.compiled`): the contiguous arrays the
        per-body lists above are views of, batch flattened to (D, T): ``c``, ``s`` (n, D, T),
        ``r``, ``e`` (n, 2, D, T), ``tw``, ``twd`` (n, 3, D, T), ``J`` (n_rows, n - 1, D, T).
    """

    __repr__ = brief_repr   # shapes, not every number (linkdyn.brief)

    layout: Layout
    t: np.ndarray
    joint_motion: tuple
    pose: Pose
    motion: list
    twists: list
    rates: list
    jacobian: np.ndarray
    pivot: np.ndarray
    residual: np.ndarray
    valid: np.ndarray
    arrays: dict | None = None

    @property
    def shape(self) -> tuple[int, ...]:
        """Batch shape of every per-sample array: ``(T,)``, or ``(D, T)`` for D designs."""
        return self.pose.phi[0].shape

    # stacked, components-last views (built on first use) -----------------------------------
    @cached_property
    def q(self) -> np.ndarray:
        """Joint coordinates (T, n_joints), rad or m, model joint order."""
        return np.stack(self.joint_motion[0], axis=-1)

    @cached_property
    def qd(self) -> np.ndarray:
        """Joint rates (T, n_joints)."""
        return np.stack(self.joint_motion[1], axis=-1)

    @cached_property
    def qdd(self) -> np.ndarray:
        """Joint accelerations (T, n_joints)."""
        return np.stack(self.joint_motion[2], axis=-1)

    @cached_property
    def phi(self) -> np.ndarray:
        """Absolute body angles (T, n), tree order."""
        return np.stack(self.pose.phi, axis=-1)

    @cached_property
    def r(self) -> np.ndarray:
        """Body reference points O_i (T, n, 2), tree order."""
        return last(np.stack(self.pose.r, axis=1), 2).swapaxes(-1, -2)

    @cached_property
    def tw(self) -> np.ndarray:
        """Twists (T, n, 3) ``[w, vx, vy]`` at O_i, tree order."""
        return stack_last(self.twists)

    @cached_property
    def twd(self) -> np.ndarray:
        """Twist rates (T, n, 3), tree order."""
        return stack_last(self.rates)

    @cached_property
    def p(self) -> np.ndarray:
        """Joint-motion propagation vectors (T, n, 3), tree order (zeros for the ground)."""
        shape = self.shape
        return np.stack([np.zeros(shape + (3,))] + [
            last(np.broadcast_to(x, (3,) + shape)) for x in self.motion[1:]], axis=-2)

    @cached_property
    def J(self) -> np.ndarray:
        """Loop-closure Jacobian (T, n_rows, n - 1)."""
        return last(self.jacobian, 2)

    def point(self, body: str, name: str) -> np.ndarray:
        """Path (T, 2) of a named point of a body, m."""
        i = self.layout.topo.bodies.index(body)
        return last(self.pose.point(i, self.layout.points[i][name]))

    def point_velocity(self, body: str, name: str) -> np.ndarray:
        """Velocity (T, 2) of a named point of a body, m/s."""
        i = self.layout.topo.bodies.index(body)
        a = self.pose.rotate(i, self.layout.points[i][name])
        return last(shift_twist(self.twists[i], a)[1:])

    def point_acceleration(self, body: str, name: str) -> np.ndarray:
        """Acceleration (T, 2) of a named point of a body, m/s^2."""
        i = self.layout.topo.bodies.index(body)
        a = self.pose.rotate(i, self.layout.points[i][name])
        return last(point_acceleration(self.twists[i], self.rates[i], a))


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


def close(lay: Layout, q_ind: np.ndarray, guess: np.ndarray, modes=None):
    """Dependent tree coordinates closing every loop, on the branch of ``guess`` or ``modes``.

    Parameters
    ----------
    lay : Layout
    q_ind : ndarray (k, ...)
        Independent joint coordinates in ``lay.topo.driven`` order, rad or m.
    guess : ndarray (n, ...)
        Tree coordinates near the solution (its independent rows are replaced), rad or m.
    modes : list of ndarray, optional
        The dyads' assembly modes (+1/-1, :func:`.dyads.sides`) when every loop is a dyad
        (``lay.dyads``): the loops are then closed in closed form on that branch, the guess
        only setting the winding of the angles. Without them, Newton's method from ``guess``.

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
    if modes is not None and lay.dyads is not None:
        # every loop is an RRR dyad: closed exactly in its assembly mode
        q, pose = dyads.solve(lay, lay.dyads, q, forward_positions, sides=modes)
        err = _scaled(lay, closure_residual(lay, pose))
        # a dyad that cannot close is NaN; one closed inaccurately (near a dead point) is
        # corrected by the damped Newton's method from the guess (only samples above TOL move)
        retry = ~(err <= ACCEPT) & np.all(np.isfinite(q), axis=0)
        if np.any(retry):
            q, err = newton(lay, np.where(retry, start, q), maxiter=30, damped=True)
            pose = forward_positions(lay, q)
        return q, err, pose
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


def at_state(model, lay: Layout, t, q_ind, qd_ind, qdd_ind, guess,
             modes=None) -> KinematicSolution:
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
        Tree coordinates near the positions sought (e.g. the previous state extrapolated, or
        the branch :func:`.solution.solve` followed).
    modes : list of ndarray, optional
        The dyads' assembly modes: close the loops in closed form on that branch (when every
        loop is a dyad); else Newton's method from ``guess`` (:func:`close`).

    Returns
    -------
    KinematicSolution
        Every joint's and body's motion at the state; samples that do not close or where ``J_dep`` is
        singular are NaN with ``valid = False``.
    """
    q_ind, qd_ind, qdd_ind = (np.asarray(x, dtype=float) for x in (q_ind, qd_ind, qdd_ind))
    # the positions closed at the batch's whole shape (samples differing only in rates or
    # accelerations cost no more: the arrays are small, the operations' overhead dominates)
    shape = np.broadcast_shapes(q_ind.shape[1:], np.shape(guess)[1:], qd_ind.shape[1:],
                                qdd_ind.shape[1:])
    q, err, pose = close(lay, np.broadcast_to(q_ind, (len(q_ind),) + shape),
                         np.broadcast_to(guess, (len(guess),) + shape), modes)
    p = motion_vectors(lay, pose)
    J = closure_jacobian(lay, pose, p)
    # rates and accelerations: J_dep qd_dep = -J_ind qd_ind, J_dep qdd_dep = -bias   (eqs. 4-7)
    return rates_and_accelerations(model, lay, np.asarray(t, dtype=float), q, pose, p, J,
                                    np.broadcast_to(qd_ind, (len(qd_ind),) + shape),
                                    np.broadcast_to(qdd_ind, (len(qdd_ind),) + shape), err)


def rates_and_accelerations(model, lay: Layout, t, q, pose, p, J, qd_ind, qdd_ind, err
                            ) -> KinematicSolution:
    """The kinematics at closed positions: dependent rates and accelerations, twists and their
    rates, every joint's motion; samples that do not close (``err``) or where ``J_dep`` is
    singular are NaN with ``valid = False``.

    ``q`` (n, ...) tree coordinates closed by :func:`close`, ``pose`` their poses, ``p`` the
    motion vectors, ``J`` (n_rows, n - 1, ...) the closure Jacobian; ``qd_ind``, ``qdd_ind``
    (k, ...) the independent rates and accelerations, ``lay.topo.driven`` order.
    """
    topo = lay.topo
    dep, drv = list(topo.dependent), list(topo.driven)
    # rates: J_dep qd_dep = -J_ind qd_ind                       (eqs. 4-5)
    qd = np.zeros(q.shape)
    qd[drv] = qd_ind
    pivot = np.ones(q.shape[1:])
    if dep:
        qd[dep], pivot = dependent_rates(lay, J, qd_ind)
    tw = forward_twists(lay, pose, p, qd)
    # accelerations: J_dep qdd_dep = -bias(qdd_dep = 0)          (eqs. 6-7)
    qdd = np.zeros(q.shape)
    qdd[drv] = qdd_ind
    twd = forward_twist_rates(lay, pose, p, tw, qd, qdd)
    if dep:
        qdd[dep], _ = solve_small(J[:, np.array(dep) - 1], -closure_bias(lay, pose, tw, twd))
        # td is linear in qdd: add the dependent accelerations' share, propagated like twists
        extra = np.zeros(q.shape)
        extra[dep] = qdd[dep]
        twd = [a + b for a, b in zip(twd, forward_twists(lay, pose, p, extra))]
    valid = (err <= ACCEPT) & np.all(np.isfinite(qd), axis=0) & np.all(np.isfinite(qdd), axis=0)
    kin = KinematicSolution(lay, t, joint_values(model, lay, pose, tw, twd, q, qd, qdd), pose,
                            p, tw, twd, J, pivot, err, valid)
    return kin if np.all(valid) else blanked(kin, ~valid, err)


def blanked(kin: KinematicSolution, nan: np.ndarray, err: np.ndarray) -> KinematicSolution:
    """``kin`` with NaN at the samples ``nan`` (...) in every per-sample array, ``valid``
    False there and the closure residual ``err`` (numpy solutions: ``kin.arrays`` is None)."""
    def blank(x):
        return None if x is None else np.where(nan, np.nan, x)
    pose = kin.pose
    return replace(kin, joint_motion=tuple([blank(x) for x in col] for col in kin.joint_motion),
                   pose=Pose(*([blank(x) for x in field] for field in
                               (pose.phi, pose.c, pose.s, pose.r, pose.e))),
                   motion=[blank(x) for x in kin.motion], twists=[blank(x) for x in kin.twists],
                   rates=[blank(x) for x in kin.rates], jacobian=blank(kin.jacobian),
                   residual=err, valid=kin.valid & ~nan)


def joint_values(model, lay, pose, tw, twd, q, qd, qdd):
    """Coordinates, rates, accelerations of all joints, three lists of (T,) arrays in model
    order: tree joints from the tree arrays, cut joints from their bodies' motion."""
    topo = lay.topo
    cols = [[None] * len(model.joints) for _ in range(3)]
    for i in range(1, topo.n):
        j = topo.tree_joint[i]
        cols[0][j], cols[1][j], cols[2][j] = q[i], qd[i], qdd[i]
    for c in lay.cuts:
        a, b = c.a, c.b
        r_pa, r_pb, e = _cut_frames(lay, pose, c)
        # the kind's coordinate from the bodies' motion (cut_coordinate)
        motion = cut_coordinate(jk.CODES[c.kind], c.own, e, pose.phi[a], tw[a], twd[a], pose.r[a],
                                pose.phi[b], tw[b], twd[b], pose.r[b], r_pa, r_pb)
        cols[0][c.joint], cols[1][c.joint], cols[2][c.joint] = motion
    return tuple(cols)
