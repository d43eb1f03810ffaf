"""``solve(model, t)``: positions, rates and accelerations of every joint and body.

Rates: ``J_dep qd_dep = -J_drv qd_drv`` (eqs. 4-5); accelerations: ``J_dep qdd_dep = -bias`` with
the bias the closure acceleration at ``qdd_dep = 0`` (eqs. 6-7).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .. import joints as jk
from ..errors import ModelError
from .. import compiled
from ..model import Model
from ..planar import last, shift_twist, solve_small, stack_last
from . import compiled as kc
from . import dyads
from .layout import Layout, compile_designs, compile_layout
from .positions import ACCEPT, _correct, _follow, assemble, nearest_node, newton, node_fraction
from .recursion import (Pose, _cut_frames, closure_bias, closure_jacobian, cut_coordinate,
                        dependent_rates, forward_positions, forward_twist_rates, forward_twists,
                        motion_vectors, point_acceleration)


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


def solve(model, t, layout: Layout | None = None, backend: str | None = None) -> KinematicSolution:
    """Positions, velocities and accelerations at the times ``t`` (T,) s.

    Assembles at ``t[0]`` on the branch of the ``[assembly]`` guess, follows the branch through
    continuation nodes (driver travel at most ``STEP_ANGLE`` rad between nodes: a loop over
    driver steps, not samples), interpolates the nodes to every sample with cubic Hermite
    polynomials and corrects all samples at once with Newton's method. Samples where the loop
    does not close or ``J_dep`` is singular have ``valid = False`` and NaN values; nothing
    raises here except an assembly failure at ``t[0]``.

    Parameters
    ----------
    model : Model or sequence of Model
        One mechanism, or D designs of the same topology, each with its own numbers (geometry,
        masses, gravity, loads' values, drivers' motions). With designs every array gains a
        leading axis D (a sequence of one model too), and a design that cannot be assembled is
        NaN instead of raising.
    t : array_like (T,)
        Sample times, s.
    backend : {'auto', 'numpy', 'compiled'}, optional
        Run the per-sample work in numpy array passes or in the compiled kernels of
        :mod:`linkdyn.compiled` (default ``LINKDYN_BACKEND`` or ``'auto'``: compiled when
        numba is installed and the batch is large).
    """
    single = isinstance(model, Model)
    models = [model] if single else list(model)
    if not models:
        raise ModelError("no designs to solve", fix="Pass a model or a non-empty list of models")
    lay = layout or (compile_layout(model) if single else compile_designs(models))
    topo = lay.topo
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or len(t) < 1:
        raise ModelError("time samples must be a 1-D array with at least one sample",
                         fix="Pass t = numpy.linspace(0, duration, samples)")
    dep, drv = list(topo.dependent), list(topo.driven)
    # driver coordinates, rates, accelerations: (n_drivers, T), with designs (n_drivers, D, T)
    qdrv, qddrv, qdddrv = lay.driver_values(t)
    fast = compiled.use_compiled(backend, t.size * len(models))   # the kernel runs every kind
    packed = compiled.pack(lay, len(models[0].joints)) if fast else None
    out = None  # the compiled kernel's arrays
    # the [assembly] guess describes the mechanism at t = 0: assemble there, then follow the
    # branch to the samples
    q_start = assemble(models, lay, lay.driver_values(np.zeros(1))[0][..., 0], 0.0,
                       raise_error=single)
    if single:
        q_start = q_start[:, 0]
    lo, hi = min(0.0, float(t.min())), max(0.0, float(t.max()))
    # the dyads' assembly modes, (..., 1) each: the branch along the nodes and the samples
    modes = (None if lay.dyads is None else
             dyads.sides(lay, lay.dyads, q_start[..., None], forward_positions))
    if dep and hi > lo:
        nodes, Q, QD, reach = _follow(lay, q_start, lo, hi, modes)
        # a guess for every sample from the nodes; samples past the last node followed start
        # from that node
        lo_ok, hi_ok = reach[..., :1], reach[..., 1:]
        followed = lo_ok <= hi_ok  # False for a design that did not assemble
        lo_c, hi_c = np.where(followed, lo_ok, 0.0), np.where(followed, hi_ok, 0.0)
        if packed is not None and lay.dyads is not None:
            # the kernel closes every sample in closed form from its nearest node
            out = kc.run(packed, t, qdrv, qddrv, qdddrv, nodes=nodes, Q=Q, modes=modes,
                         lo=lo_c, hi=hi_c)
            err = out["err"].reshape(followed.shape[:-1] + t.shape)
            unclosed = ~(err <= ACCEPT)
            if np.any(unclosed) and np.any(
                    unclosed & np.all(np.isfinite(out["q"]), axis=0).reshape(err.shape)):
                out = None   # some sample needs the damped Newton retry of the numpy path
        if out is None:
            tc = np.clip(t, lo_c, hi_c)
            j = np.clip(np.searchsorted(nodes, tc, side="right") - 1, 0, len(nodes) - 2)
            u = node_fraction(nodes[j], nodes[j + 1], tc)

            def at(X, k):  # nodes not followed are zero: their weight is zero on the clamped span
                return np.take_along_axis(np.nan_to_num(X), k[None], axis=-1)
            if lay.dyads is not None:
                # closed form in the assembly modes: the guess only sets the winding of the
                # angles, so the nearest node is enough
                q = at(Q, nearest_node(j, nodes[j], nodes[j + 1], tc))
            else:
                # cubic Hermite from the bracketing nodes for Newton's method
                h = nodes[j + 1] - nodes[j]
                h00, h10 = 2 * u**3 - 3 * u**2 + 1, (u**3 - 2 * u**2 + u) * h
                h01, h11 = -2 * u**3 + 3 * u**2, (u**3 - u**2) * h
                q = h00 * at(Q, j) + h10 * at(QD, j) + h01 * at(Q, j + 1) + h11 * at(QD, j + 1)
            q[drv] = qdrv
            q = np.where(np.isfinite(q), q, 0.0)
            q, pose, p, J, err = _correct(lay, q, modes)
        # the branch ends at the first sample past the last node that does not close
        fails = ~(err <= ACCEPT)
        if np.any(fails) or not np.all(followed):
            hi_end = np.min(np.where(fails & (t > hi_ok), t, np.inf), axis=-1, keepdims=True)
            lo_end = np.max(np.where(fails & (t < lo_ok), t, -np.inf), axis=-1, keepdims=True)
            cut_off = (t >= hi_end) | (t <= lo_end) | ~followed
            err = np.where(cut_off, np.inf, err)
    else:
        q = np.repeat(q_start[..., None], len(t), axis=-1)
        q[drv] = qdrv
        q, err = newton(lay, q)
        if packed is None:
            pose = forward_positions(lay, q)
            p = motion_vectors(lay, pose)
            J = closure_jacobian(lay, pose, p)
    if packed is not None:
        if out is None:   # the loops are closed: the kernel does the rest
            out = kc.run(packed, t, qdrv, qddrv, qdddrv, q=q)
        return _from_kernel(models[0], lay, t, out, err)
    return _rates_and_accelerations(models[0], lay, t, q, pose, p, J, qddrv, qdddrv, err)


def _rates_and_accelerations(model, lay, t, q, pose, p, J, qd_drv, qdd_drv, err):
    topo = lay.topo
    dep, drv = list(topo.dependent), list(topo.driven)
    # rates: J_dep qd_dep = -J_drv qd_drv                       (eqs. 4-5)
    qd = np.zeros(q.shape)
    qd[drv] = qd_drv
    pivot = np.ones(q.shape[1:])
    if dep:
        qd[dep], pivot = dependent_rates(lay, J, qd_drv)
    tw = forward_twists(lay, pose, p, qd)
    # accelerations: J_dep qdd_dep = -bias(qdd_dep = 0)          (eqs. 6-7)
    qdd = np.zeros(q.shape)
    qdd[drv] = qdd_drv
    twd = forward_twist_rates(lay, pose, p, tw, qd, qdd)
    if dep:
        qdd[dep], _ = solve_small(J[:, np.array(dep) - 1], -closure_bias(lay, pose, tw, twd))
        # td is linear in qdd: add the dependent accelerations' share, propagated like twists
        extra = np.zeros(q.shape)
        extra[dep] = qdd[dep]
        twd = [a + b for a, b in zip(twd, forward_twists(lay, pose, p, extra))]
    valid = (err <= ACCEPT) & np.all(np.isfinite(qd), axis=0) & np.all(np.isfinite(qdd), axis=0)
    if not np.all(valid):  # samples that do not close or are singular become NaN
        nan = ~valid

        def blank(x):
            return None if x is None else np.where(nan, np.nan, x)
        q, qd, qdd, J = blank(q), blank(qd), blank(qdd), blank(J)
        pose = Pose(*([blank(x) for x in field] for field in
                      (pose.phi, pose.c, pose.s, pose.r, pose.e)))
        p, tw, twd = ([blank(x) for x in y] for y in (p, tw, twd))
    return KinematicSolution(lay, t, joint_values(model, lay, pose, tw, twd, q, qd, qdd), pose, p,
                             tw, twd, J, pivot, err, valid)


def _from_kernel(model, lay, t, out, err) -> KinematicSolution:
    """The solution from the compiled kernel's arrays (:func:`.compiled.run`), whose samples
    that do not close (``err``) or are singular are set to NaN in place."""
    topo, shape = lay.topo, err.shape
    n, nc = topo.n, len(lay.cuts)
    valid = (err <= ACCEPT) & out["finite"].reshape(shape)
    if not np.all(valid):
        nan = ~valid.reshape(out["pivot"].shape)
        for key, x in out.items():
            if key not in ("pivot", "err", "finite"):
                x[..., nan] = np.nan

    def each(key, lead):  # per-entity views with the batch shape
        return list(out[key].reshape(lead + shape))
    q, qd, qdd = (each(k, (n,)) for k in ("q", "qd", "qdd"))
    e = [x if i and "axis" in jk.get(lay.kind[i]).keys else None
         for i, x in enumerate(each("e", (n, 2)))]
    pose = Pose(each("phi", (n,)), each("c", (n,)), each("s", (n,)), each("r", (n, 2)), e)
    cols = [[None] * len(model.joints) for _ in range(3)]
    for i in range(1, n):
        j = topo.tree_joint[i]
        cols[0][j], cols[1][j], cols[2][j] = q[i], qd[i], qdd[i]
    for c, motion in zip(lay.cuts, each("cut", (nc, 3))):
        cols[0][c.joint], cols[1][c.joint], cols[2][c.joint] = motion
    J = out["J"].reshape((topo.n_rows, n - 1) + shape)
    p = motion_vectors(lay, pose)
    if not np.all(valid):  # the constant p_i of revolute joints too, as the numpy path does
        p = [None] + [np.where(valid, x, np.nan) for x in p[1:]]
    return KinematicSolution(lay, t, tuple(cols), pose, p,
                             each("tw", (n, 3)), each("twd", (n, 3)), J,
                             out["pivot"].reshape(shape), err, valid, arrays=out)


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
        motion = cut_coordinate(jk.CODES[c.kind], e, pose.phi[a], tw[a], twd[a], pose.r[a],
                                pose.phi[b], tw[b], twd[b], pose.r[b], r_pa, r_pb)
        cols[0][c.joint], cols[1][c.joint], cols[2][c.joint] = motion
    return tuple(cols)
