"""Position analysis: assembly at t = 0 and the branch followed to every sample.

The assembly solves the closure from the ``[assembly]`` guess (damped Newton, deterministic
restarts). The branch is then followed through continuation nodes at most ``STEP_ANGLE`` of
driver travel apart: in closed form when every loop is an RRR dyad (:mod:`.dyads`), else by a
predictor and a Newton corrector per node (a loop over driver steps, never over samples).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import AssemblyError
from ..io.units import LENGTH_UNITS
from .. import joints as jk
from ..model import Model
from ..units import joint_units
from ..planar import solve_small, wrap, wrapped
from ..steps import select, step
from . import dyads
from .layout import Layout, motion_steps, motion_values
from .recursion import (_cut_frames, closure_jacobian, closure_residual, dependent_rates,
                        forward_positions, motion_vectors)

TOL = 1e-12          # closure residual target, relative to the mechanism's size
ACCEPT = 1e-10       # largest residual accepted as closed
STEP_ANGLE = 0.1     # rad of driver travel between continuation nodes
STEP_LENGTH = 0.02   # fraction of the mechanism's size between continuation nodes
EPS = float(np.finfo(float).eps)   # the residual of a position closed to rounding
RESOLUTION = 100.0   # a position is singular where J_dep's conditioning is at or below this
#                      times the square root of its closure residual (:func:`singular`)


@step
def singular(conditioning, residual):
    """Where closed positions are singular: at a singular position or within the closure's
    resolution of one (..., bool): a step, which ``analyze`` calls on its samples and the sweep
    kernel's metrics-only form on each sample.

    Parameters
    ----------
    conditioning : ndarray (...) or float
        The dependent joints' Jacobian ``J_dep`` made dimensionless (lengths over the
        mechanism's size): its smallest singular value relative to its largest (or an
        estimate of it, a relative pivot); 0 or NaN where it has lost rank.
    residual : ndarray (...) or float
        The scaled closure residual the positions were closed to (dimensionless; machine
        epsilon is taken where it is smaller: rounding closes no better).

    Notes
    -----
    Near a singular position (a dead centre of the drivers) the loops close as ``g ~ a d^2 -
    b (s* - s)``, ``d`` the dependent coordinates' distance from the singular configuration,
    ``s*`` the driver's value there, and the smallest singular value is ``sigma ~ 2 a d``. A
    residual ``r`` cannot tell apart positions within ``d ~ sqrt(r / a)`` of the singular one,
    where ``sigma ~ 2 sqrt(a r)``; and the rates, efforts and reactions of a position closed to
    ``r`` are off by about ``r / sigma^2`` of their size. So ``sigma <= RESOLUTION sqrt(r)``
    is singular: a sample at the singular position, or as close to it as Newton's method can
    resolve (``a`` up to ``RESOLUTION^2 / 4``), is flagged, and every sample kept has its
    numbers to about ``1 / RESOLUTION^2`` relative at worst (at ``r`` = rounding, ``sigma``
    above about ``1.5e-6``), to rounding over ``sigma^2`` in general.
    """
    # sigma <= RESOLUTION sqrt(max(r, eps)); NaN in either: singular
    bound = RESOLUTION * np.sqrt(select(residual < EPS, EPS, residual))
    return (conditioning <= bound) | (conditioning != conditioning) | (bound != bound)


@step
def scaled_error(err, g, metres, size):
    """The scaled closure error ``err`` with one more residual row ``g`` (m if ``metres``, else
    rad): ``max(err, |g| / size)`` for a row in metres, ``max(err, |g|)`` otherwise; NaN if
    either is NaN (a row that cannot be evaluated leaves the sample open)."""
    # e = max(err, |g| / size  or  |g|)
    x = select(metres, np.abs(g) / size, np.abs(g))
    return select((x > err) | (x != x), x, err)


def _scaled(lay: Layout, g: np.ndarray) -> np.ndarray:
    """Closure residual (n_rows, ...) made dimensionless (lengths / size), max over rows
    (:func:`scaled_error` row by row)."""
    err, k = np.zeros(g.shape[1:]), 0
    for c in lay.cuts:
        for unit in jk.get(c.kind).row_units:
            err = scaled_error(err, g[k], unit == "m", lay.size)
            k += 1
    return err


def newton(lay: Layout, q: np.ndarray, maxiter: int = 12, damped: bool = False):
    """Solve the closure for the dependent tree coordinates of ``q`` (n, ...), on a copy.

    Returns ``(q, err)``: ``err`` (...) is the final scaled residual (NaN or large if it failed).
    With ``damped``, each step is halved until the residual decreases (for assembly).
    """
    dep = np.array(lay.topo.dependent, int)
    q = np.array(q, dtype=float)
    if len(dep) == 0:
        return q, np.zeros(q.shape[1:])
    pose = forward_positions(lay, q)
    g = closure_residual(lay, pose)
    err = _scaled(lay, g)
    stalled = np.zeros(err.shape, bool)  # damped: no step length decreased the residual
    for _ in range(maxiter):
        active = (err > TOL) & ~stalled
        if not np.any(active):
            break
        J = closure_jacobian(lay, pose, motion_vectors(lay, pose))[:, dep - 1]
        dx, _ = solve_small(J, -g)
        dx = np.where(np.isfinite(dx) & active, dx, 0.0)
        step = np.ones(err.shape)
        for _ in range(30 if damped else 1):
            trial = q.copy()
            trial[dep] += step * dx
            pose_t = forward_positions(lay, trial)
            g_t = closure_residual(lay, pose_t)
            err_t = _scaled(lay, g_t)
            worse = ~(err_t < err) & active
            if not damped or not np.any(worse):
                break
            step = np.where(worse, step / 2, step)
        if damped:
            # a point where 30 halvings do not decrease the residual stays as it is and drops out
            # (otherwise it would keep every other point of the batch iterating)
            stuck = ~(err_t < err) & active
            stalled |= stuck
            keep = stuck.reshape((1,) * (q.ndim - stuck.ndim) + stuck.shape)
            trial = np.where(keep, q, trial)
            if np.any(stuck):
                pose_t = forward_positions(lay, trial)
                g_t = closure_residual(lay, pose_t)
                err_t = _scaled(lay, g_t)
        q, pose, g, err = trial, pose_t, g_t, err_t
    return q, err


def assembly_guess(model: Model, lay: Layout) -> np.ndarray:
    """Tree coordinates (n,) near the ``[assembly]`` guess (absolute angles, joint values)."""
    topo = lay.topo
    phi = {"ground": 0.0, **model.assembly_phi}
    q = np.zeros(topo.n)
    for i in range(1, topo.n):
        jt = model.joints[topo.tree_joint[i]]
        if jt.name in model.assembly_q:
            q[i] = model.assembly_q[jt.name]
        elif jk.get(jt.kind).angular and jt.body_a in phi and jt.body_b in phi:
            q[i] = phi[jt.body_b] - phi[jt.body_a]
    return q


def _drivers_at(model: Model, lay: Layout, q_drv: np.ndarray) -> dict[str, float]:
    topo = lay.topo
    return {model.joints[topo.tree_joint[i]].name: float(q_drv[k])
            for k, i in enumerate(topo.driven)}


def not_assembled(model: Model, lay: Layout, q_drv0: np.ndarray, t0: float = 0.0,
                  design: int | None = None) -> AssemblyError:
    """The error of a design that cannot be assembled at ``t0`` (driver values ``q_drv0``)."""
    return AssemblyError(
        "the mechanism cannot be assembled: the loops do not close"
        + (f" (design {design})" if design is not None else ""),
        file=model.source, time=t0, drivers=_drivers_at(model, lay, q_drv0),
        units=joint_units(model),
        fix="Check the link lengths and the [assembly] guess")


def starts_singular(model: Model, lay: Layout) -> bool:
    """Whether ``model`` assembles at t = 0 (its loops close on the ``[assembly]`` branch) but
    sits there at a singular position: ``J_dep qd_dep = -J_ind qd_ind`` gives no dependent rates
    (a toggle or a dead centre, links in line), so no branch can be followed from it."""
    q_drv, qd_drv, _ = lay.driver_values(np.zeros(1))
    q = assemble([model], lay, q_drv[..., 0], 0.0, raise_error=False)   # (n, 1)
    if not lay.topo.dependent or not np.all(np.isfinite(q)):
        return False
    pose = forward_positions(lay, q)
    x, _ = dependent_rates(lay, closure_jacobian(lay, pose, motion_vectors(lay, pose)), qd_drv)
    return not bool(np.all(np.isfinite(x)))


def singular_start(model: Model, lay: Layout) -> AssemblyError:
    """The error of a mechanism that :func:`starts_singular`: named as such, not as a position
    it cannot reach."""
    q_drv = lay.driver_values(np.zeros(1))[0][:, 0]
    return AssemblyError(
        "the mechanism starts at a singular position (a toggle or dead centre: links in line): "
        "its loops close there, but the motion through it is not determined",
        file=model.source, time=0.0, drivers=_drivers_at(model, lay, q_drv),
        units=joint_units(model),
        fix="Start the driver away from it (its motion's start) or give an [assembly] guess "
            "with the links out of line")


FIT = 1e-6   # a kind's fit (a gear's centre distance) holds to this fraction of the size


def _misfit(models: list[Model], lay: Layout, q: np.ndarray, q_drv0, t0: float,
            raise_error: bool) -> np.ndarray:
    """Which designs (the batch shape of ``q`` (n, ...) but its first axis) assemble with a
    cut whose kind's fit fails (:attr:`~linkdyn.joints.JointKind.fit`: a gear pair whose
    centre distance is not its pitch radii's), or raise :class:`AssemblyError` naming the
    joint if ``raise_error``."""
    bad = np.zeros(q.shape[1:], bool)
    cuts = [c for c in lay.cuts if jk.get(c.kind).fit is not None]
    if not cuts:
        return bad
    with np.errstate(invalid="ignore"):
        pose = forward_positions(lay, q[..., None])
        for c in cuts:
            r_pa, r_pb, e_a = _cut_frames(lay, pose, c)
            err, want, what = jk.get(c.kind).fit(c.own, jk.frame(r_pa, r_pb, e_a))
            # |misfit| > FIT size, per design (the batch (..., 1) of the poses)
            off = np.broadcast_to(np.abs(err) > FIT * np.asarray(lay.size),
                                  bad.shape + (1,))[..., 0]
            if raise_error and np.any(off):
                d = int(np.argmax(off))
                m = models[min(d, len(models) - 1)]
                unit = m.length_unit
                scale = LENGTH_UNITS.get(unit, 1.0)
                have, wanted = (float(np.broadcast_to(x, bad.shape + (1,)).reshape(-1)[d])
                                for x in (err + want, want))
                jt = m.joints[c.joint]
                raise AssemblyError(
                    f"joint '{jt.name}' ({c.kind}): {what} is {have / scale:.6g} {unit}, not "
                    f"{wanted / scale:.6g} {unit}"
                    + (f" (design {d})" if len(models) > 1 else ""),
                    file=m.source, time=t0,
                    drivers=_drivers_at(m, lay, q_drv0[:, min(d, q_drv0.shape[1] - 1)]),
                    fix=f"Place the points of joint '{jt.name}' so that it meshes at its "
                        "pitch radii, or correct the radii")
            bad |= off
    return bad


def assemble(models: list[Model], lay: Layout, q_drv0: np.ndarray, t0: float = 0.0,
             raise_error: bool = True, closable: bool = False):
    """Assembled tree coordinates (n, D) of D designs at the first sample, on the branch of
    each design's ``[assembly]`` guess.

    A damped Newton solve from the guesses; designs where it fails get 64 deterministic
    restarts, solved at once, and the converged one nearest the guess is kept. A design that
    still does not close is NaN, or raises :class:`AssemblyError` if ``raise_error``. Designs
    whose dyads close in no assembly mode (:func:`.dyads.closable`) are not solved at all.

    With ``closable``, returns ``(q, can)``: ``can`` (D,) bool is False for the designs that
    no assembly mode closes (always True without a closed-form plan), so that a caller sorts
    them out without a second pass.
    """
    topo = lay.topo
    dep = list(topo.dependent)
    # batch shape (D, 1): the trailing axis stands for time, so design arrays broadcast
    guess = {id(m): assembly_guess(m, lay) for m in {id(m): m for m in models}.values()}  # once each
    q0 = np.stack([guess[id(m)] for m in models], axis=-1)[..., None]
    q_drv0 = np.reshape(q_drv0, (len(topo.driven), -1))   # (n_drivers, 1 or D)
    q0[list(topo.driven)] = q_drv0[..., None]
    # dyads that close in no assembly mode (circles apart, a line missing its circle) cannot be
    # assembled from any guess: no Newton solve and no restarts for them (NaN stays inactive)
    hopeless = (np.zeros(q0.shape[1:-1], bool) if lay.dyads is None else
                ~dyads.closable(lay, lay.dyads, q0, forward_positions)[..., 0])
    q, err = newton(lay, np.where(hopeless[..., None], np.nan, q0), maxiter=60, damped=True)
    q0, q, err = q0[..., 0], q[..., 0], err[..., 0]
    failed = ~(err <= ACCEPT)
    if np.any(failed & ~hopeless):
        rng = np.random.default_rng(0)
        # restart the failed designs only: their layout, batch (F, 64)
        idx = np.flatnonzero(failed & ~hopeless)
        lay_f = lay.take(idx) if lay.designs else lay
        starts = np.repeat(q0[:, idx, None], 64, axis=-1)
        for i in dep:
            starts[i] = (rng.uniform(-np.pi, np.pi, 64) if jk.get(lay.kind[i]).angular
                         else rng.uniform(-2, 2, 64) * lay_f.size)
        qs, errs = newton(lay_f, starts, maxiter=60, damped=True)
        ok = errs <= ACCEPT
        # distance to the guess: angles modulo 2 pi, slider travel relative to the design's size
        gap = qs[dep] - q0[dep][:, idx, None]
        rev = np.array([jk.get(lay.kind[i]).angular for i in dep]).reshape((-1,) + (1,) * (gap.ndim - 1))
        dist = np.sum(np.abs(np.where(rev, wrap(gap), gap / lay_f.size)), axis=0)
        best = np.argmin(np.where(ok, dist, np.inf), axis=-1)
        pick = np.take_along_axis(qs, best[None, :, None], axis=-1)[..., 0]
        rescued = np.any(ok, axis=-1)
        q[:, idx[rescued]] = pick[:, rescued]
        failed[idx[rescued]] = False
    misfit = _misfit(models, lay, q, q_drv0, t0, raise_error)
    failed |= misfit
    if np.any(failed):
        if raise_error:
            d = int(np.argmax(failed))
            raise not_assembled(models[d], lay, q_drv0[:, min(d, q_drv0.shape[1] - 1)], t0,
                                d if len(models) > 1 else None)
        q[:, failed] = np.nan
    q = _nearest_turn(lay, q, q0)
    return (q, ~hopeless) if closable else q


def _nearest_turn(lay: Layout, q: np.ndarray, q0: np.ndarray) -> np.ndarray:
    """``q`` (n, ...) with each dependent angle moved by whole turns so that every body's
    absolute angle lies within half a turn of the guess ``q0`` (of zero where the model gives
    no guess): Newton's steps may wind an angle by many turns, which closes the loops as well
    but is not the start the user described.

    Body by body in tree order: ``e_i = e_parent + sign_i (q_i - q0_i)`` is body i's angle
    minus its guess; a dependent revolute coordinate takes ``-round(e_i / 2 pi)`` turns. Not
    where a cut's kind is not periodic in the angles (:attr:`~linkdyn.joints.JointKind.periodic`,
    a gear): ``q`` is returned as it is.
    """
    topo = lay.topo
    dep = set(topo.dependent)
    q = np.array(q, dtype=float)
    if not all(jk.get(k).periodic for k in lay.cut_kind):
        return q   # a whole turn would open a loop (a gear's)
    e = [np.zeros(q.shape[1:])] * topo.n
    for i in range(1, topo.n):
        if not jk.get(lay.kind[i]).angular:
            e[i] = e[topo.parent[i]]
            continue
        s = topo.sign[i] or 1
        e_i = e[topo.parent[i]] + s * (q[i] - q0[i])
        if i in dep:
            turns = np.where(np.isfinite(e_i), np.round(e_i / (2 * np.pi)), 0.0)
            q[i] = q[i] - s * 2 * np.pi * turns
            e_i = e_i - 2 * np.pi * turns
        e[i] = e_i
    return q


def driver_values(source, t: np.ndarray):
    """Driver coordinates, rates, accelerations of a model or layout (:meth:`Layout.
    driver_values`): each (n_drivers, T), or (n_drivers, D, T) for a layout of D designs."""
    if isinstance(source, Layout):
        return source.driver_values(t)
    return motion_values(tuple((d.motion,) for d in source.drivers), t)


@step
def node_fraction(t_j, t_next, tc):
    """Where the time ``tc`` lies between the continuation nodes at ``t_j`` and ``t_next``:
    ``u = (tc - t_j) / (t_next - t_j)`` (0 at node j, 1 at node j + 1)."""
    return (tc - t_j) / (t_next - t_j)


@step
def nearest_node(j, t_j, t_next, tc):
    """The node nearer to ``tc`` of the bracketing nodes j (at ``t_j``) and j + 1."""
    return select(node_fraction(t_j, t_next, tc) < 0.5, j, j + 1)


@dataclass(frozen=True)
class Branch:
    """The branch of the assembly a run follows: the positions it gives every sample time.

    Attributes
    ----------
    start : ndarray (n,) or (n, D)
        Tree coordinates assembled at t = 0, rad or m (NaN for a design that did not assemble).
    modes : list of ndarray (..., 1), or None
        The dyads' assembly modes at the start (None unless every loop is a dyad).
    nodes : ndarray (K,) or None
        Continuation node times, s, ascending (None: not followed, as without dependent
        joints or with every sample at t = 0).
    Q, QD : ndarray (n, ..., K)
        Tree coordinates and rates at the nodes (NaN beyond a design's reach).
    reach : ndarray (..., 2)
        The time interval over which each design's branch was followed (empty if it was not).
    QDD : ndarray (n, ..., K) or None
        Their accelerations, where the continuation gives them (the compiled Newton
        continuation, :func:`.compiled_nodes.follow`): the guesses between the nodes are then
        quintic Hermite instead of cubic.
    """

    start: np.ndarray
    modes: list | None
    nodes: np.ndarray | None = None
    Q: np.ndarray | None = None
    QD: np.ndarray | None = None
    reach: np.ndarray | None = None
    QDD: np.ndarray | None = None

    @property
    def followed(self) -> np.ndarray:
        """(..., 1) bool: the branch was followed (False for a design that did not assemble)."""
        return self.reach[..., :1] <= self.reach[..., 1:]

    @property
    def span(self):
        """``lo``, ``hi`` (..., 1): the reach, (0, 0) for a design not followed, s."""
        ok = self.followed
        return np.where(ok, self.reach[..., :1], 0.0), np.where(ok, self.reach[..., 1:], 0.0)

    def guess(self, lay: Layout, t: np.ndarray) -> np.ndarray:
        """Tree coordinates (n, ..., T) near the branch at the times ``t``, from the nodes: the
        nearest node where every loop is a dyad (closed form: the guess only sets the winding
        of the angles), else Hermite from the bracketing nodes (for Newton's method): cubic
        from their coordinates and rates, quintic with their accelerations (``QDD``).
        Samples outside the reach start from its end; a design not followed from zeros."""
        if self.nodes is None:
            return self.start[..., None]
        nodes, (lo, hi) = self.nodes, self.span
        tc = np.clip(t, lo, hi)
        j = np.clip(np.searchsorted(nodes, tc, side="right") - 1, 0, len(nodes) - 2)

        def at(X, k):  # nodes not followed are zero: their weight is zero on the clamped span
            return np.take_along_axis(np.nan_to_num(X), k[None], axis=-1)
        if lay.dyads is not None:
            q = at(self.Q, nearest_node(j, nodes[j], nodes[j + 1], tc))
        elif self.QDD is None:
            # q(u) = h00 Q_j + h10 QD_j + h01 Q_j+1 + h11 QD_j+1, u the fraction of the span
            u, h = node_fraction(nodes[j], nodes[j + 1], tc), nodes[j + 1] - nodes[j]
            h00, h10 = 2 * u**3 - 3 * u**2 + 1, (u**3 - 2 * u**2 + u) * h
            h01, h11 = -2 * u**3 + 3 * u**2, (u**3 - u**2) * h
            q = (h00 * at(self.Q, j) + h10 * at(self.QD, j) + h01 * at(self.Q, j + 1)
                 + h11 * at(self.QD, j + 1))
        else:
            # quintic Hermite: the cubic's terms and the accelerations' h^2 terms
            u, h = node_fraction(nodes[j], nodes[j + 1], tc), nodes[j + 1] - nodes[j]
            u2, u3 = u * u, u * u * u
            w0, w1 = 1 - u3 * (10 - 15 * u + 6 * u2), u3 * (10 - 15 * u + 6 * u2)
            v0, v1 = (u - u3 * (6 - 8 * u + 3 * u2)) * h, -u3 * (4 - 7 * u + 3 * u2) * h
            a0 = 0.5 * u2 * (1 - u) ** 3 * h * h
            a1 = 0.5 * u3 * (1 - u) ** 2 * h * h
            q = (w0 * at(self.Q, j) + v0 * at(self.QD, j) + a0 * at(self.QDD, j)
                 + w1 * at(self.Q, j + 1) + v1 * at(self.QD, j + 1) + a1 * at(self.QDD, j + 1))
        return np.where(np.isfinite(q), q, 0.0)

    def ended(self, t: np.ndarray, err: np.ndarray):
        """Samples (..., T) past the branch's end, or None: the branch ends at the first
        sample beyond the reach whose loops do not close (``err`` above ``ACCEPT``); every
        sample of a design not followed."""
        if self.nodes is None:
            return None
        fails, followed = ~(err <= ACCEPT), self.followed
        if not np.any(fails) and np.all(followed):
            return None
        lo_ok, hi_ok = self.reach[..., :1], self.reach[..., 1:]
        hi_end = np.min(np.where(fails & (t > hi_ok), t, np.inf), axis=-1, keepdims=True)
        lo_end = np.max(np.where(fails & (t < lo_ok), t, -np.inf), axis=-1, keepdims=True)
        return (t >= hi_end) | (t <= lo_end) | ~followed


def follow(models: list[Model], lay: Layout, t: np.ndarray, single: bool = True,
           start: np.ndarray | None = None, nodes=None, newton_nodes=None) -> Branch:
    """Assemble at t = 0 on the branch of the ``[assembly]`` guess and follow it through
    continuation nodes over the times ``t`` (driver travel at most ``STEP_ANGLE`` rad or
    ``STEP_LENGTH`` of the size between nodes: a loop over driver steps, not samples).

    ``single``: one model, whose coordinates have no design axis and whose assembly failure
    raises :class:`AssemblyError`; else a design that cannot be assembled is NaN. ``start``
    (n, D): the designs' assembly, already solved by :func:`assemble` (a sweep assembles a
    chunk's designs at once, then solves them in batches; each design's assembly does not
    depend on the designs solved with it). ``nodes``: another backend's closing of a mechanism
    of dyads' nodes, ``nodes(lay, Q, QD_drv, modes, q0, k0) -> (Q, QD_dep, ok)`` as
    :func:`_follow_dyads` does it here (the compiled backend's
    :func:`.compiled_nodes.close`: the same steps, to rounding); default these numpy passes.
    ``newton_nodes``: another backend's Newton continuation through the nodes of a mechanism
    not all of dyads, ``newton_nodes(lay, q_start, times) -> (Q, QD, last)`` as
    :func:`_continuation` (:func:`.compiled_nodes.follow`, which also gives the nodes'
    accelerations); default the numpy one.
    """
    q_start = start if start is not None else assemble(
        models, lay, lay.driver_values(np.zeros(1))[0][..., 0], 0.0, raise_error=single)
    if single:
        q_start = q_start[:, 0]
    # the dyads' assembly modes, (..., 1) each: the branch along the nodes and the samples
    modes = (None if lay.dyads is None else
             dyads.sides(lay, lay.dyads, q_start[..., None], forward_positions))
    lo, hi = min(0.0, float(t.min())), max(0.0, float(t.max()))
    if not lay.topo.dependent or not hi > lo:
        return Branch(q_start, modes)
    return Branch(q_start, modes, *continuation(lay, q_start, lo, hi, modes, nodes,
                                                 newton_nodes))


def _travel_nodes(lay: Layout, start: float, end: float) -> np.ndarray:
    """Continuation times from ``start`` to ``end`` (either order): the drivers of every design
    move at most one step between consecutive nodes."""
    probe = np.linspace(start, end, 4097)
    step = np.array([STEP_ANGLE if jk.get(lay.kind[i]).angular else STEP_LENGTH * np.min(lay.size)
                     for i in lay.topo.driven])[:, None]
    # the largest driver travel between probes, over the drivers and the designs, in steps
    moves = (np.max(motion_steps(lay.motions, probe) / step, axis=0) if len(step)
             else np.zeros(4096))
    travel = np.concatenate(([0.0], np.cumsum(moves)))
    if not travel[-1] > 0:
        return np.array([start, end])
    n = int(np.clip(np.ceil(travel[-1]) + 1, 2, 20000))
    return np.interp(np.linspace(0, travel[-1], n), travel, probe)


def _at_node(x: np.ndarray, k: int, ndim: int) -> np.ndarray:
    """Driver values ``x`` (n_drivers, [D,] K) at node k, shaped to broadcast against
    coordinates of ``ndim`` axes ((n,), or (n, D, 1) for designs)."""
    x = x[..., k]
    return x.reshape(x.shape + (1,) * (ndim - x.ndim))


def continuation(lay: Layout, q0: np.ndarray, lo: float, hi: float, modes=None, nodes=None,
                 newton_nodes=None):
    """Continuation from the assembly ``q0`` (n,) or, for designs, (n, D) at t = 0, forwards
    to ``hi`` and backwards to ``lo``; ``modes``: the dyads' assembly modes.

    Returns ascending node times (K,), node coordinates and rates (n, ..., K), the time
    interval ``reach`` (..., 2) over which each branch was followed, and the node
    accelerations (n, ..., K) where the continuation gives them (else None)."""
    if lay.dyads is not None:
        return _follow_dyads(lay, q0, lo, hi, modes, nodes) + (None,)
    if q0.ndim == 1:
        return _follow_newton(lay, q0, lo, hi, newton_nodes)
    # designs: Newton's batch is (D, 1), the trailing axis standing for time
    nodes, Q, QD, reach, QDD = _follow_newton(lay, q0[..., None], lo, hi, newton_nodes)
    return (nodes, Q[..., 0, :], QD[..., 0, :], reach[..., 0, :],
            None if QDD is None else QDD[..., 0, :])


def _follow_newton(lay: Layout, q0: np.ndarray, lo: float, hi: float, run=None):
    """:func:`continuation` by Newton continuation, node by node (by :func:`_continuation`, or
    ``run`` with its arguments and results: the nodes' coordinates, rates, last node time and
    accelerations, or None for them)."""
    nodes, Q, reach = [np.zeros(1)], [q0[..., None]], []
    rates = {"QD": [None], "QDD": [None]}   # node 0's from the first run that reaches it
    for end in (hi, lo):
        if end == 0.0:
            reach.append(np.zeros(q0.shape[1:]))
            continue
        nd = _travel_nodes(lay, 0.0, end)
        Qe, QDe, last, QDDe = (run or _continuation)(lay, q0, nd)
        reach.append(last)
        if end < 0:
            nd, Qe = nd[::-1], Qe[..., ::-1]
            nodes, Q = [nd[:-1]] + nodes, [Qe[..., :-1]] + Q
        else:
            nodes, Q = nodes + [nd[1:]], Q + [Qe[..., 1:]]
        for key, x in (("QD", QDe), ("QDD", QDDe)):
            if x is None:
                rates[key] = None
            elif rates[key] is not None and end < 0:
                x = x[..., ::-1]
                rates[key] = [x[..., :-1]] + rates[key]
                rates[key][-1] = x[..., -1:] if rates[key][-1] is None else rates[key][-1]
            elif rates[key] is not None:
                rates[key] = rates[key] + [x[..., 1:]]
                rates[key][0 if lo == 0.0 else -2] = x[..., :1]
    QD, QDD = ((None if x is None else np.concatenate([y for y in x if y is not None], axis=-1))
               for x in (rates["QD"], rates["QDD"]))
    return (np.concatenate(nodes), np.concatenate(Q, axis=-1), QD,
            np.stack([reach[1], reach[0]], axis=-1), QDD)


@step
def unwrap_step(ok_a, ok_b, q_a, q_b):
    """The change of a dependent angle from a node (``q_a``) to the next (``q_b``), wrapped
    into (-pi, pi] (between nodes the driver moves at most ``STEP_ANGLE``, the angle less than
    half a turn); 0 unless both nodes close (``ok_a``, ``ok_b``). Their sum along the nodes
    unwinds the angle."""
    return select(ok_a & ok_b, wrapped(q_b - q_a), 0.0)


def _follow_dyads(lay: Layout, q0: np.ndarray, lo: float, hi: float, modes, close=None):
    """:func:`continuation` for mechanisms whose loops are all dyads: every node is solved at once
    in closed form in the assembly ``modes`` (by ``close`` if given: :func:`follow`'s
    ``nodes``), and the dependent angles are unwrapped along the nodes (which the driver
    crosses in steps of at most ``STEP_ANGLE``)."""
    topo = lay.topo
    dep, drv = list(topo.dependent), list(topo.driven)
    nodes = np.unique(np.concatenate((_travel_nodes(lay, 0.0, lo),
                                      _travel_nodes(lay, 0.0, hi))))
    k0 = int(np.searchsorted(nodes, 0.0))
    nq, nqd, _ = lay.driver_values(nodes)   # (n_drivers, [D,] K): the shape of Q[drv]
    shape = (len(drv),) + q0.shape[1:] + (len(nodes),)
    Q = np.repeat(q0[..., None], len(nodes), axis=-1)
    Q[drv] = nq.reshape(shape)
    if close is not None:   # closed, the rates solved and the angles unwrapped by another backend
        Q, x, ok = close(lay, Q, nqd.reshape(shape), modes, q0, k0)
    else:
        Q, pose = dyads.solve(lay, lay.dyads, Q, forward_positions, sides=modes)
        J = closure_jacobian(lay, pose, motion_vectors(lay, pose))
        x, _ = dependent_rates(lay, J, nqd.reshape(shape))
        ok = np.all(np.isfinite(Q[dep]), axis=0) & np.all(np.isfinite(x), axis=0)
        for i in dep:  # unwrap along the nodes, anchored at the assembly (t = 0)
            if jk.get(lay.kind[i]).angular:
                step = unwrap_step(ok[..., :-1], ok[..., 1:], Q[i][..., :-1], Q[i][..., 1:])
                path = np.concatenate((np.zeros(step.shape[:-1] + (1,)), np.cumsum(step, -1)),
                                      -1)
                Q[i] = np.where(ok, q0[i][..., None] + path - path[..., k0:k0 + 1], np.nan)
    QD = np.zeros(Q.shape)
    QD[drv], QD[dep] = nqd.reshape(shape), x
    # the branch is followed over the nodes that close, contiguous around t = 0
    up = np.cumprod(ok[..., k0:], axis=-1).sum(-1)
    down = np.cumprod(ok[..., k0::-1], axis=-1).sum(-1)
    reach = np.stack((np.where(down > 0, nodes[np.maximum(k0 - down + 1, 0)], np.inf),
                      np.where(up > 0, nodes[np.minimum(k0 + up - 1, len(nodes) - 1)], -np.inf)),
                     axis=-1)
    return nodes, Q, QD, reach


def _continuation(lay: Layout, q_start: np.ndarray, nodes: np.ndarray):
    """Follow the branch from ``q_start`` (n, ...) through the node times: a predictor
    ``q += qd dt`` and a Newton corrector per node. Returns node coordinates and rates
    (n, ..., K), the last node time (...) where the loops still close, and None (no node
    accelerations)."""
    topo = lay.topo
    dep, drv = list(topo.dependent), list(topo.driven)
    nq, nqd, _ = lay.driver_values(nodes)
    Q = np.full(q_start.shape + (len(nodes),), np.nan)
    QD = np.full(q_start.shape + (len(nodes),), np.nan)
    q = q_start.copy()
    last_ok = np.full(q_start.shape[1:], np.nan)
    alive = np.isfinite(q_start[0])
    for k in range(len(nodes)):
        q[drv] = _at_node(nq, k, q.ndim)
        if k:
            q[dep] = Q[dep, ..., k - 1] + QD[dep, ..., k - 1] * (nodes[k] - nodes[k - 1])
        q, err = newton(lay, q)
        pose = forward_positions(lay, q)
        J = closure_jacobian(lay, pose, motion_vectors(lay, pose))
        x, _ = dependent_rates(lay, J, _at_node(nqd, k, q.ndim))
        alive = alive & (err <= ACCEPT) & np.all(np.isfinite(x), axis=0)
        if not np.any(alive):
            break  # every branch ends here; samples beyond are flagged
        Q[..., k] = np.where(alive, q, np.nan)
        QD[..., k] = 0.0
        QD[drv, ..., k] = _at_node(nqd, k, q.ndim)
        QD[dep, ..., k] = np.where(alive, x, np.nan)
        last_ok = np.where(alive, nodes[k], last_ok)
        q = np.where(alive, q, np.nan)
    return Q, QD, last_ok, None
