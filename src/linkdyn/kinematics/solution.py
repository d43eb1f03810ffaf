"""``solve(model, t)``: the kinematics driven by time, a thin wrapper over the state stage.

The drivers' prescribed motions give the state at the sample times (the independent
coordinates, their rates and accelerations); the branch the mechanism follows from its assembly
at t = 0 (:func:`.positions.follow`) gives the positions' guess; :func:`.state.at_state` turns
both into the :class:`~.state.KinematicSolution` (rates ``J_dep qd_dep = -J_drv qd_drv``,
eqs. 4-5; accelerations ``J_dep qdd_dep = -b``, eqs. 6-7). On the compiled backend the kinematics
kernel (:mod:`.compiled`) is the state stage for the whole batch.
"""

from __future__ import annotations

from dataclasses import replace
from functools import partial

import numpy as np

from .. import joints as jk
from ..backend import Work, choose, mark_cached
from ..errors import ModelError
from ..model import Model
from . import compiled as kc
from . import compiled_nodes
from .layout import Layout, compile_designs, compile_layout
from .positions import ACCEPT, Branch, follow
from .recursion import Pose, motion_vectors
from .state import KinematicSolution, at_state, blanked, close


def solve(model, t, layout: Layout | None = None, backend: str | None = None,
          start: np.ndarray | None = None, run=None) -> KinematicSolution:
    """Positions, velocities and accelerations at the times ``t`` (T,) s.

    The drivers' motions give the state at ``t``; the mechanism is assembled at t = 0 on the
    branch of the ``[assembly]`` guess and the branch followed through continuation nodes
    (:func:`.positions.follow`); each sample's positions are closed from the branch (in closed
    form in the dyads' assembly modes, else by Newton's method from the nodes' cubic Hermite
    interpolation) by :func:`.state.at_state`, all samples at once. Samples where the loop
    does not close or ``J_dep`` is singular have ``valid = False`` and NaN values; nothing
    raises here except an assembly failure at t = 0.

    Parameters
    ----------
    model : Model or sequence of Model
        One mechanism, or D designs of the same topology, each with its own numbers (geometry,
        masses, gravity, loads' values, drivers' motions). With designs every array gains a
        leading axis D (a sequence of one model too), and a design that cannot be assembled is
        NaN instead of raising.
    t : array_like (T,)
        Sample times, s.
    backend : {'auto', 'numpy', 'compiled'} or linkdyn.backend.Backend, optional
        Run the per-sample work in numpy array passes or in the compiled kernels of
        :mod:`linkdyn.compiled` (default ``LINKDYN_BACKEND`` or ``'auto'``: the one expected
        to finish first, :func:`linkdyn.backend.choose`); ``analyze`` passes the backend it
        chose.
    start : ndarray (n, D), optional
        The designs' tree coordinates assembled at t = 0 (:func:`.positions.assemble`, NaN
        for a design that does not assemble), if already solved.
    run : callable, optional
        The compiled backend's kernel entry, :func:`.compiled.run` by default; a sweep passes
        :func:`linkdyn.dynamics.compiled.sweep`, which solves the dynamics in the same blocks
        and keeps less of the kinematics (a :class:`Swept` solution).
    """
    single = isinstance(model, Model)
    models = [model] if single else list(model)
    if not models:
        raise ModelError("no designs to solve", fix="Pass a model or a non-empty list of models")
    lay = layout or (compile_layout(model) if single else compile_designs(models))
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or len(t) < 1:
        raise ModelError("time samples must be a 1-D array with at least one sample",
                         fix="Pass t = numpy.linspace(0, duration, samples)")
    # the state: the drivers' coordinates, rates and accelerations, (n_drivers, T), with designs
    # (n_drivers, D, T)
    q_ind, qd_ind, qdd_ind = lay.driver_values(t)
    be = choose(backend, Work(t.size * len(models), len(models[0].bodies) - 1,
                              stages=("kinematics",)), [j.kind for j in models[0].joints])
    # the branch: the [assembly] guess describes the mechanism at t = 0; assembled there and
    # followed to the samples (on the compiled backend its nodes closed by its kernel)
    branch = follow(models, lay, t, single, start,
                    nodes=compiled_nodes.close if be.compiled else None,
                    newton_nodes=compiled_nodes.follow if be.compiled else None)
    if be.compiled:
        kin = _compiled(models[0], lay, t, q_ind, qd_ind, qdd_ind, branch, run or kc.run)
        if run is None or run is kc.run:
            mark_cached("kinematics")
        return kin
    kin = at_state(models[0], lay, t, q_ind, qd_ind, qdd_ind, branch.guess(lay, t), branch.modes)
    # the branch ends at the first sample past the last node that does not close
    ended = branch.ended(t, kin.residual)
    return kin if ended is None else blanked(kin, ended, np.where(ended, np.inf, kin.residual))


def reduced(models, lay: Layout, t, start, run) -> dict | None:
    """A batch's metrics by the sweep kernel's metrics-only form (``run``:
    :func:`linkdyn.dynamics.compiled.sweep` with its ``metrics``), on the branch :func:`solve`
    follows on the compiled backend, where every sample closes in closed form from its
    nearest node (a mechanism of dyads); None otherwise (``solve`` then).

    Returns
    -------
    dict
        ``run``'s outputs, its ``ok`` (D,) also False for a design whose branch was not
        followed, and ``q_drv`` (n_drivers, D, T) the drivers' coordinates, rad or m.
    """
    t = np.asarray(t, dtype=float)
    q_ind, qd_ind, qdd_ind = lay.driver_values(t)
    branch = follow(models, lay, t, False, start, nodes=compiled_nodes.close,
                    newton_nodes=compiled_nodes.follow)
    if branch.nodes is None or lay.dyads is None:
        return None
    lo, hi = branch.span
    out = run(lay, t, q_ind, qd_ind, qdd_ind, nodes=branch.nodes, Q=branch.Q,
              modes=branch.modes, lo=lo, hi=hi)
    out["ok"] = out["ok"] & np.reshape(branch.followed, -1)
    D = max(lay.designs, 1)
    out["q_drv"] = np.broadcast_to(np.reshape(q_ind, (len(q_ind), -1, len(t))),
                                   (len(q_ind), D, len(t)))
    mark_cached("sweep")
    return out


def _compiled(model, lay: Layout, t, q_ind, qd_ind, qdd_ind, branch: Branch, run=kc.run
              ) -> KinematicSolution:
    """:func:`solve`'s state stage by the compiled kernel ``run`` for the whole batch: it
    closes every sample in closed form from its nearest node (every loop a dyad), or takes the
    coordinates :func:`.state.close` closed (a mechanism of dyads), or closes them by Newton's
    method from the nodes' guess in its blocks (``newton=True``; :func:`.state.close` for the
    samples it leaves open, then the kernel again on the closed coordinates), then the rates
    and accelerations."""
    out = None  # the compiled kernel's arrays
    if branch.nodes is not None and lay.dyads is not None:
        lo, hi = branch.span
        how = {"nodes": branch.nodes, "Q": branch.Q, "modes": branch.modes, "lo": lo, "hi": hi}
        out = run(lay, t, q_ind, qd_ind, qdd_ind, **how)
        err = out["err"].reshape(lo.shape[:-1] + t.shape)
        unclosed = ~(err <= ACCEPT)
        if np.any(unclosed) and np.any(
                unclosed & np.all(np.isfinite(out["q"]), axis=0).reshape(err.shape)):
            out = None   # some sample needs the damped Newton retry of the numpy path
    if out is None and branch.modes is not None and lay.dyads is not None:
        # the dyads closed by numpy in closed form (with its damped retry)
        q, err, _ = close(lay, q_ind, branch.guess(lay, t), branch.modes)
        how = {"q": q}
        out = run(lay, t, q_ind, qd_ind, qdd_ind, **how)
    elif out is None:   # Newton's method in the kernel; numpy's (damped) for what it leaves
        guess = branch.guess(lay, t)
        how = {"q": guess, "newton": True}
        out = run(lay, t, q_ind, qd_ind, qdd_ind, **how)
        err = out["err"].reshape(guess.shape[1:])
        retry = ~(err <= ACCEPT)
        if np.any(retry):   # the samples it leaves open closed by numpy, then all again
            q = out["q"].reshape(guess.shape).copy()
            # from the cubic guess (the rates' alone): near a singular position the nodes'
            # accelerations are large and the quintic guess far off
            if branch.QDD is not None:
                guess = replace(branch, QDD=None).guess(lay, t)
            q_r, err_r, _ = close(lay, np.broadcast_to(q_ind, q_ind.shape[:1] + err.shape)[
                :, retry], np.broadcast_to(guess, q.shape)[:, retry], branch.modes)
            q[:, retry], err = q_r, err.copy()
            err[retry] = err_r
            how = {"q": q}
            out = run(lay, t, q_ind, qd_ind, qdd_ind, **how)
    # the branch ends at the first sample past the last node that does not close
    ended = branch.ended(t, err)
    if ended is not None:
        err = np.where(ended, np.inf, err)
    if run is kc.run:
        return _from_kernel(model, lay, t, out, err)
    # the full kernel on the same state, if what the sweep kernel left out is read
    full = partial(_full, model, lay, t, (q_ind, qd_ind, qdd_ind), how, err)
    return _from_kernel(model, lay, t, out, err, full)


def _full(model, lay, t, state, how, err) -> KinematicSolution:
    """The solution of :func:`.compiled.run` at the ``state`` (the drivers' coordinates, rates
    and accelerations) closed as ``how`` says, its samples ``err`` set to NaN as
    :func:`_compiled` does."""
    return _from_kernel(model, lay, t, kc.run(lay, t, *state, **how), err)


def _from_kernel(model, lay, t, out, err, full=None) -> KinematicSolution:
    """The solution from the compiled kernel's arrays (:func:`.compiled.run`), whose samples
    that do not close (``err``) or are singular are set to NaN in place. With ``full``, the
    arrays of :func:`linkdyn.dynamics.compiled.sweep` (no twists, twist rates or Jacobian):
    a :class:`Swept` solution that calls ``full`` (no argument) for those when first read."""
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
    p = motion_vectors(lay, pose)
    if not np.all(valid):  # the constant p_i of revolute joints too, as the numpy path does
        p = [None] + [np.where(valid, x, np.nan) for x in p[1:]]
    if full is not None:
        return Swept.of(full, out, layout=lay, t=t, joint_motion=tuple(cols), pose=pose,
                        motion=p, pivot=out["pivot"].reshape(shape), residual=err, valid=valid)
    J = out["J"].reshape((topo.n_rows, n - 1) + shape)
    return KinematicSolution(lay, t, tuple(cols), pose, p,
                             each("tw", (n, 3)), each("twd", (n, 3)), J,
                             out["pivot"].reshape(shape), err, valid, arrays=out)


def at_closed(model, lay: Layout, t, q, qd_ind, qdd_ind) -> KinematicSolution:
    """The kinematics stage by the compiled kernel at positions that already close the loops
    (as :func:`.state.at_state` after :func:`.state.close`): the rates ``J_dep qd_dep = -J_drv
    qd_drv`` (eqs. 4-5), accelerations ``J_dep qdd_dep = -b`` (eqs. 6-7), twists, their rates
    and every joint's motion.

    Parameters
    ----------
    model : Model
        The model whose drivers are the independent coordinates (``lay``'s model).
    lay : Layout
    t : ndarray (T,)
        s.
    q : ndarray (n, T)
        Tree coordinates closing the loops, rad or m.
    qd_ind, qdd_ind : ndarray (k, T)
        The independent coordinates' rates and accelerations, ``lay.topo.driven`` order.

    Returns
    -------
    KinematicSolution
        Samples whose closure residual (of ``q``, scaled) is above ``ACCEPT``, or whose rates or
        accelerations are not finite (``J_dep`` singular), NaN with ``valid = False``.
    """
    t = np.asarray(t, dtype=float)
    out = kc.run(lay, t, q[list(lay.topo.driven)], qd_ind, qdd_ind, q=q)
    mark_cached("kinematics")
    return _from_kernel(model, lay, t, out, out["err"].reshape(t.shape))


class Swept(KinematicSolution):
    """A :class:`~.state.KinematicSolution` of the sweep kernel
    (:func:`linkdyn.dynamics.compiled.sweep`): the joints' motion, the poses, ``p_i``, the
    pivots, the residual and ``valid`` as the kernel wrote them; the twists, their rates, the
    Jacobian and ``arrays`` computed by the full kernel on the same state when one of them is
    first read (then all four are kept). ``swept``: the sweep kernel's arrays, its dynamics
    among them (:func:`linkdyn.dynamics.compiled.swept`)."""

    LATER = ("twists", "rates", "jacobian", "arrays")

    @classmethod
    def of(cls, full, swept: dict, **fields) -> Swept:
        """The solution with ``fields`` (all of the dataclass's but ``LATER``), ``full()``
        giving the full solution."""
        self = object.__new__(cls)
        for k, v in dict(fields, _full=full, swept=swept).items():
            object.__setattr__(self, k, v)
        return self

    def __getattr__(self, name):   # only for an attribute not yet set
        if name not in Swept.LATER or "_full" not in self.__dict__:
            raise AttributeError(name)
        kin = self._full()
        for k in Swept.LATER:
            object.__setattr__(self, k, getattr(kin, k))
        return getattr(kin, name)
