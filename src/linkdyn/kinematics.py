"""Recursive kinematics of a planar closed-loop mechanism (seed paper, eqs. 1-7).

The loops are cut at the topology's cut joints, leaving a tree. Along the tree,

- positions:      phi_i = phi_p + s q_i,   O_i = joint point (+ s q_i e for a slider),
- twists (eq. 2): t_i = A(r_i - r_p) t_p + p_i qd_i,
- twist rates:    td_i = A(r_i - r_p) td_p + [0, w_p perp(v_i - v_p)] + p_i qdd_i + pd_i qd_i.

At every cut joint the relative twist of its two bodies, taken at the cut point and reduced by
the cut-row selection S, must vanish: ``J qd = 0``. Its rows split into the driven and the
dependent joints, so ``J_dep qd_dep = -J_drv qd_drv`` (eqs. 4-5); differentiating,
``J_dep qdd_dep = -(bias)`` (eqs. 6-7), the bias being the closure acceleration computed with
``qdd_dep = 0``. Positions solve the closure residual with Newton's method, whose Jacobian is the
same ``J_dep``.

Every function works on arrays with any leading batch axes ``(...)``; the loops run over bodies.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from . import dyads
from . import joints as jk
from .errors import AssemblyError, ModelError
from .model import PRISMATIC, REVOLUTE, Model
from .planar import dot, last, perp, rotate, rotate_cs, shift_twist, solve_small, twist, wrap
from .topology import Topology, build

TOL = 1e-12          # closure residual target, relative to the mechanism's size
ACCEPT = 1e-10       # largest residual accepted as closed
STEP_ANGLE = 0.1     # rad of driver travel between continuation nodes
STEP_LENGTH = 0.02   # fraction of the mechanism's size between continuation nodes


@dataclass(frozen=True)
class Cut:
    """Geometry of one cut joint: bodies ``a``, ``b`` (tree indices), points relative to O_a, O_b
    in the bodies' frames."""

    joint: int
    kind: str
    a: int
    b: int
    pa: np.ndarray
    pb: np.ndarray
    axis: np.ndarray
    angle: float


@dataclass(frozen=True)
class Layout:
    """Geometry compiled from a model for its topology, SI, in tree order (index 0 = ground).

    ``joint_point[i]``: body i's parent's joint point relative to O_parent, parent frame, (2,).
    ``points[i]``: dict of body i's named points relative to O_i, body frame.
    ``axis[i]``: slider axis of body i's tree joint in the parent's frame.
    ``origin[i]``: O_i in body i's own frame. ``size``: characteristic length, m.
    """

    topo: Topology
    kind: tuple[str, ...]
    joint_point: tuple[np.ndarray, ...]
    axis: tuple[np.ndarray, ...]
    angle: tuple[float, ...]
    origin: tuple[np.ndarray, ...]
    points: tuple[dict, ...]
    com: tuple[np.ndarray, ...]
    mass: tuple[float, ...]
    inertia: tuple[float, ...]
    cuts: tuple[Cut, ...]
    size: float
    dyads: tuple | None = None  # closed-form plan (linkdyn.dyads), None: Newton's method


def compile_layout(model: Model, topo: Topology | None = None) -> Layout:
    """Geometry of ``model`` arranged along the tree of ``topo`` (built if not given)."""
    topo = topo or build(model)
    bodies = [model.body(name) for name in topo.bodies]
    pos = {name: k for k, name in enumerate(topo.bodies)}

    def own_point(j, i):
        jt = model.joints[j]
        return bodies[i].points[jt.point_b if topo.bodies[i] == jt.body_b else jt.point_a]

    origin = [np.zeros(2)] + [np.asarray(own_point(topo.tree_joint[i], i), float)
                              for i in range(1, topo.n)]
    kind, joint_point, axis, angle = [""], [np.zeros(2)], [np.zeros(2)], [0.0]
    for i in range(1, topo.n):
        jt, p = model.joints[topo.tree_joint[i]], topo.parent[i]
        kind.append(jt.kind)
        joint_point.append(np.asarray(own_point(topo.tree_joint[i], p), float) - origin[p])
        # a slider's axis is fixed in the joint's first body; store it in the parent's frame
        ax = np.asarray(jt.axis, float)
        if topo.sign[i] < 0:
            ax = rotate(np.asarray(-jt.angle), ax)
        axis.append(ax)
        angle.append(float(jt.angle))
    cuts = []
    for j in topo.cut:
        jt = model.joints[j]
        a, b = pos[jt.body_a], pos[jt.body_b]
        cuts.append(Cut(j, jt.kind, a, b, np.asarray(bodies[a].points[jt.point_a], float) - origin[a],
                        np.asarray(bodies[b].points[jt.point_b], float) - origin[b],
                        np.asarray(jt.axis, float), float(jt.angle)))
    points = tuple({k: np.asarray(v, float) - origin[i] for k, v in b.points.items()}
                   for i, b in enumerate(bodies))
    com = tuple(np.asarray(b.com, float) - origin[i] for i, b in enumerate(bodies))
    allpts = np.array([v for b in model.bodies for v in b.points.values()], float)
    size = float(np.max(np.ptp(allpts, axis=0))) if len(allpts) > 1 else 1.0
    lay = Layout(topo, tuple(kind), tuple(joint_point), tuple(axis), tuple(angle), tuple(origin),
                 points, com, tuple(float(b.mass) for b in bodies),
                 tuple(float(b.inertia) for b in bodies), tuple(cuts), size if size > 0 else 1.0)
    return replace(lay, dyads=dyads.plan(lay))


def stack_layouts(layouts: list[Layout]) -> Layout:
    """One layout for several designs of the same topology: every number gains a design axis,
    shaped to broadcast against ``(D, T)`` batches (vectors ``(2, D, 1)``, scalars ``(D, 1)``).
    """
    first = layouts[0]
    topo = first.topo
    for k, lay in enumerate(layouts[1:], 1):
        same = (lay.topo.bodies, lay.topo.parent, lay.topo.tree_joint, lay.topo.sign,
                lay.topo.cut, lay.kind) == (topo.bodies, topo.parent, topo.tree_joint, topo.sign,
                                            topo.cut, first.kind)
        if not same:
            raise ModelError(f"design {k} has a different topology from design 0",
                             field="designs", fix="Vary numbers only, not bodies or joints")

    def vec(xs):
        return np.stack([np.asarray(x, float) for x in xs], axis=-1)[..., None]

    def num(xs):
        return np.asarray(xs, float)[:, None]

    def per_body(name):
        return tuple(vec([getattr(l, name)[i] for l in layouts]) for i in range(topo.n))

    def per_body_num(name):
        return tuple(num([getattr(l, name)[i] for l in layouts]) for i in range(topo.n))

    cuts = tuple(Cut(c.joint, c.kind, c.a, c.b, vec([l.cuts[k].pa for l in layouts]),
                     vec([l.cuts[k].pb for l in layouts]), vec([l.cuts[k].axis for l in layouts]),
                     num([l.cuts[k].angle for l in layouts]))
                 for k, c in enumerate(first.cuts))
    points = tuple({name: vec([l.points[i][name] for l in layouts]) for name in first.points[i]}
                   for i in range(topo.n))
    return Layout(topo, first.kind, per_body("joint_point"), per_body("axis"),
                  per_body_num("angle"), per_body("origin"), points, per_body("com"),
                  per_body_num("mass"), per_body_num("inertia"), cuts,
                  num([l.size for l in layouts]), first.dyads)


@dataclass(frozen=True)
class Pose:
    """Poses of all bodies, one entry per body in tree order (index 0 = ground).

    ``phi[i]`` (...) absolute angle, ``c[i]``, ``s[i]`` its cosine and sine, ``r[i]`` (2, ...)
    reference point O_i, ``e[i]`` (2, ...) global axis of a prismatic tree joint (else None).
    """

    phi: list
    c: list
    s: list
    r: list
    e: list

    def rotate(self, i: int, local: np.ndarray) -> np.ndarray:
        """Body i's local vector (2,) in the global frame, (2, ...)."""
        return rotate_cs(self.c[i], self.s[i], local)

    def point(self, i: int, local: np.ndarray) -> np.ndarray:
        """Global position (2, ...) of a point of body i given relative to O_i in its frame."""
        return self.r[i] + self.rotate(i, local)


def forward_positions(lay: Layout, q: np.ndarray) -> Pose:
    """Poses of all bodies from the tree joint coordinates ``q`` (n, ...) (``q[0]`` unused)."""
    topo, shape = lay.topo, q.shape[1:]
    phi, c, s = [np.zeros(shape)], [np.ones(shape)], [np.zeros(shape)]
    r, e = [np.zeros((2,) + shape)], [None]
    for i in range(1, topo.n):
        k = topo.parent[i]
        # joint point on the parent, then the child placed by the joint kind
        r_joint = r[k] + rotate_cs(c[k], s[k], lay.joint_point[i])
        phi_i, c_i, s_i, r_i, e_i = jk.place_child(
            lay.kind[i], topo.sign[i], q[i], lay.angle[i], lay.axis[i], phi[k], c[k], s[k],
            r_joint)
        phi.append(phi_i), c.append(c_i), s.append(s_i), r.append(r_i), e.append(e_i)
    return Pose(phi, c, s, r, e)


def _cut_frames(lay: Layout, pose: Pose, c: Cut):
    """Cut point positions on both bodies and the cut's axis, global, (2, ...) each."""
    return pose.point(c.a, c.pa), pose.point(c.b, c.pb), pose.rotate(c.a, c.axis)


def closure_residual(lay: Layout, pose: Pose) -> np.ndarray:
    """Loop-closure residual of all cuts (2 n_cut, ...): m for positions, rad for angles."""
    out = []
    for c in lay.cuts:
        r_pa, r_pb, e_a = _cut_frames(lay, pose, c)
        out.append(jk.cut_residual(c.kind, c.angle, pose.phi[c.a], pose.phi[c.b], e_a, r_pa, r_pb))
    return np.concatenate(out) if out else np.zeros((0,) + pose.phi[0].shape)


def motion_vectors(lay: Layout, pose: Pose) -> list:
    """Joint-motion propagation vectors ``p_i`` (3, ...) of all tree joints (eq. 3)."""
    topo, ndim = lay.topo, pose.phi[0].ndim
    return [None] + [jk.motion_vector(lay.kind[i], topo.sign[i], pose.e[i], ndim)
                     for i in range(1, topo.n)]


def closure_jacobian(lay: Layout, pose: Pose, p: list) -> np.ndarray:
    """Loop-closure Jacobian ``J`` (2 n_cut, n - 1, ...): tree joint rates to the cut rows.

    Column k of cut c is ``S_c A(r_Pb - r_k) p_k``, with sign +1 if joint k is on the path to
    the cut's second body, -1 if on the path to its first, 0 if on both or neither (eqs. 20-24).
    """
    topo, shape = lay.topo, pose.phi[0].shape
    rows = []
    for c in lay.cuts:
        r_pa, r_pb, e_a = _cut_frames(lay, pose, c)
        side = topo.ancestors[c.b].astype(int) - topo.ancestors[c.a].astype(int)
        cols = []
        for k in range(1, topo.n):
            if side[k] == 0:
                cols.append(np.zeros((2,) + shape))
                continue
            x = side[k] * shift_twist(np.broadcast_to(p[k], (3,) + shape), r_pb - pose.r[k])
            cols.append(jk.cut_rows(c.kind, e_a, x))
        rows.append(np.stack(cols, axis=1))
    return np.concatenate(rows) if rows else np.zeros((0, topo.n - 1) + shape)


def forward_twists(lay: Layout, pose: Pose, p: list, qd: np.ndarray) -> list:
    """Twists ``t_i`` (3, ...) of all bodies at their O_i from tree joint rates ``qd`` (n, ...)."""
    topo = lay.topo
    tw = [np.zeros((3,) + qd.shape[1:])]
    for i in range(1, topo.n):
        k = topo.parent[i]
        # t_i = A(r_i - r_p) t_p + p_i qd_i      (eq. 2)
        tw.append(shift_twist(tw[k], pose.r[i] - pose.r[k]) + p[i] * qd[i])
    return tw


def forward_twist_rates(lay: Layout, pose: Pose, p: list, tw: list, qd: np.ndarray,
                        qdd: np.ndarray) -> list:
    """Twist rates ``td_i`` (3, ...): angular acceleration and acceleration of O_i."""
    topo = lay.topo
    td = [np.zeros_like(tw[0])]
    for i in range(1, topo.n):
        k = topo.parent[i]
        # td_i = A td_p + [0, w_p perp(v_i - v_p)] + p_i qdd_i + pd_i qd_i
        td_i = shift_twist(td[k], pose.r[i] - pose.r[k]) + p[i] * qdd[i]
        w_k = tw[k][0]
        td_i[1] -= w_k * (tw[i][2] - tw[k][2])
        td_i[2] += w_k * (tw[i][1] - tw[k][1])
        w_axis = tw[k if topo.sign[i] > 0 else i][0]
        pd = jk.motion_vector_rate(lay.kind[i], topo.sign[i], pose.e[i], w_axis)
        if pd is not None:
            td_i += pd * qd[i]
        td.append(td_i)
    return td


def _at_point(t_x, td_x, r_x, r_pt, v_pt):
    """Twist and twist rate of body x taken at a point moving with velocity v_pt (2, ...)."""
    a = r_pt - r_x
    t_at = shift_twist(t_x, a)
    # d/dt [w, v + w perp(a)] with the point moving at v_pt
    acc = td_x[1:] + td_x[0] * perp(a) + t_x[0] * perp(v_pt - t_x[1:])
    return t_at, twist(td_x[0], acc)


def closure_bias(lay: Layout, pose: Pose, tw: list, td: list) -> np.ndarray:
    """Rate of the cut rows ``d/dt (S x)`` (2 n_cut, ...) for the given twist rates, ``x`` being
    the relative twist of the cut's second body to its first at the cut point."""
    out = []
    for c in lay.cuts:
        r_pa, r_pb, e_a = _cut_frames(lay, pose, c)
        v_pb = shift_twist(tw[c.b], r_pb - pose.r[c.b])[1:]
        tb, ab = _at_point(tw[c.b], td[c.b], pose.r[c.b], r_pb, v_pb)
        ta, aa = _at_point(tw[c.a], td[c.a], pose.r[c.a], r_pb, v_pb)
        out.append(jk.cut_rows(c.kind, e_a, ab - aa)
                   + jk.cut_rows_rate(c.kind, e_a, tw[c.a][0], tb - ta))
    return np.concatenate(out) if out else np.zeros((0,) + tw[0].shape[1:])


# ----------------------------------------------------------------------------------------------
# position analysis


def _scaled(lay: Layout, g: np.ndarray) -> np.ndarray:
    """Closure residual (2 n_cut, ...) made dimensionless (lengths / size), max over rows."""
    rows = []
    for k, c in enumerate(lay.cuts):
        rows += [g[2 * k] / (lay.size if c.kind == REVOLUTE else 1.0), g[2 * k + 1] / lay.size]
    if not rows:
        return np.zeros(g.shape[1:])
    return np.max(np.abs(np.stack(rows)), axis=0)


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
    for _ in range(maxiter):
        active = err > TOL
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
        q, pose, g, err = trial, pose_t, g_t, err_t
    return q, err


def _guess(model: Model, lay: Layout) -> np.ndarray:
    """Tree coordinates (n,) near the ``[assembly]`` guess (absolute angles, joint values)."""
    topo = lay.topo
    phi = {"ground": 0.0, **model.assembly_phi}
    q = np.zeros(topo.n)
    for i in range(1, topo.n):
        jt = model.joints[topo.tree_joint[i]]
        if jt.name in model.assembly_q:
            q[i] = model.assembly_q[jt.name]
        elif jt.kind == REVOLUTE and jt.body_a in phi and jt.body_b in phi:
            q[i] = phi[jt.body_b] - phi[jt.body_a]
    return q


def _drivers_at(model: Model, lay: Layout, q_drv: np.ndarray) -> dict[str, float]:
    topo = lay.topo
    return {model.joints[topo.tree_joint[i]].name: float(q_drv[k])
            for k, i in enumerate(topo.driven)}


def assemble(models: list[Model], lay: Layout, q_drv0: np.ndarray, t0: float = 0.0,
             raise_error: bool = True) -> np.ndarray:
    """Assembled tree coordinates (n, D) of D designs at the first sample, on the branch of
    each design's ``[assembly]`` guess.

    A damped Newton solve from the guesses; designs where it fails get 64 deterministic
    restarts, solved at once, and the converged one nearest the guess is kept. A design that
    still does not close is NaN, or raises :class:`AssemblyError` if ``raise_error``.
    """
    topo = lay.topo
    dep = list(topo.dependent)
    # batch shape (D, 1): the trailing axis stands for time, so design arrays broadcast
    q0 = np.stack([_guess(m, lay) for m in models], axis=-1)[..., None]
    q0[list(topo.driven)] = q_drv0[:, None, None]
    q, err = newton(lay, q0, maxiter=60, damped=True)
    q0, q, err = q0[..., 0], q[..., 0], err[..., 0]
    failed = ~(err <= ACCEPT)
    if np.any(failed):
        rng = np.random.default_rng(0)
        starts = np.repeat(q0[..., None], 64, axis=-1)
        for i in dep:
            starts[i] = (rng.uniform(-np.pi, np.pi, 64) if lay.kind[i] == REVOLUTE
                         else rng.uniform(-2, 2, 64) * lay.size)
        qs, errs = newton(lay, starts, maxiter=60, damped=True)  # batch (D, 64)
        ok = errs <= ACCEPT
        # distance to the guess: angles modulo 2 pi, slider travel relative to the size
        gap = qs[dep] - q0[dep, :, None]
        rev = np.array([lay.kind[i] == REVOLUTE for i in dep]).reshape((-1,) + (1,) * (gap.ndim - 1))
        dist = np.sum(np.abs(np.where(rev, wrap(gap), gap / np.min(lay.size))), axis=0)
        best = np.argmin(np.where(ok, dist, np.inf), axis=-1)
        pick = np.take_along_axis(qs, best[None, :, None], axis=-1)[..., 0]
        rescued = failed & np.any(ok, axis=-1)
        q[:, rescued] = pick[:, rescued]
        failed &= ~rescued
        if np.any(failed):
            if raise_error:
                d = int(np.argmax(failed))
                raise AssemblyError(
                    "the mechanism cannot be assembled: the loops do not close"
                    + (f" (design {d})" if len(models) > 1 else ""),
                    file=models[d].source, time=t0, drivers=_drivers_at(models[d], lay, q_drv0),
                    fix="Check the link lengths and the [assembly] guess")
            q[:, failed] = np.nan
    return q


# ----------------------------------------------------------------------------------------------
# the kinematic solution


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
    q, qd, qdd : ndarray (T, n_joints)
        Joint coordinates (rad or m), rates, accelerations, model joint order.
    pose : Pose
        Per-body angles, reference points O_i and slider axes.
    motion : list of ndarray (3, T)
        Joint-motion propagation vectors ``p_i`` of the tree joints.
    twists, rates : list of ndarray (3, T)
        Twists ``[w, vx, vy]`` at O_i and their time derivatives.
    jacobian : ndarray (2 n_cut, n - 1, T)
        Loop-closure Jacobian.
    pivot : ndarray (T,)
        Smallest relative pivot of ``J_dep`` (~0 at a singular position).
    residual : ndarray (T,)
        Closure residual relative to ``layout.size``.
    valid : ndarray (T,) bool
    """

    layout: Layout
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    pose: Pose
    motion: list
    twists: list
    rates: list
    jacobian: np.ndarray
    pivot: np.ndarray
    residual: np.ndarray
    valid: np.ndarray

    @property
    def shape(self) -> tuple[int, ...]:
        """Batch shape of every per-sample array: ``(T,)``, or ``(D, T)`` for D designs."""
        return self.pose.phi[0].shape

    # stacked, components-last views ------------------------------------------------------
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
        return np.stack([last(x) for x in self.twists], axis=-2)

    @cached_property
    def twd(self) -> np.ndarray:
        """Twist rates (T, n, 3), tree order."""
        return np.stack([last(x) for x in self.rates], axis=-2)

    @cached_property
    def p(self) -> np.ndarray:
        """Joint-motion propagation vectors (T, n, 3), tree order (zeros for the ground)."""
        shape = self.shape
        return np.stack([np.zeros(shape + (3,))] + [
            last(np.broadcast_to(x, (3,) + shape)) for x in self.motion[1:]], axis=-2)

    @cached_property
    def J(self) -> np.ndarray:
        """Loop-closure Jacobian (T, 2 n_cut, n - 1)."""
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
        return last(_point_acc(self.twists[i], self.rates[i], a))


def driver_values(model: Model, t: np.ndarray):
    """Driver coordinates, rates, accelerations, each (n_drivers, T)."""
    vals = [d.motion.evaluate(t) for d in model.drivers]
    if not vals:
        z = np.zeros((0,) + t.shape)
        return z, z, z
    return tuple(np.stack([np.broadcast_to(v[k], t.shape) for v in vals]) for k in range(3))


def _travel_nodes(model: Model, lay: Layout, start: float, end: float) -> np.ndarray:
    """Continuation times from ``start`` to ``end`` (either order): the drivers move at most one
    step between consecutive nodes."""
    probe = np.linspace(start, end, 4097)
    qp, _, _ = driver_values(model, probe)
    step = np.array([STEP_ANGLE if lay.kind[i] == REVOLUTE else STEP_LENGTH * np.min(lay.size)
                     for i in lay.topo.driven])[:, None]
    moves = np.max(np.abs(np.diff(qp, axis=1)) / step, axis=0) if len(step) else np.zeros(4096)
    travel = np.concatenate(([0.0], np.cumsum(moves)))
    if not travel[-1] > 0:
        return np.array([start, end])
    n = int(np.clip(np.ceil(travel[-1]) + 1, 2, 20000))
    return np.interp(np.linspace(0, travel[-1], n), travel, probe)


def _rates(lay: Layout, J: np.ndarray, q_rates_drv: np.ndarray):
    """Dependent joint rates from the driven ones: ``J_dep x = -J_drv qd_drv`` (eqs. 4-5)."""
    topo = lay.topo
    dep, drv = np.array(topo.dependent, int), np.array(topo.driven, int)
    rhs = -np.einsum("ij...,j...->i...", J[:, drv - 1], q_rates_drv)
    return solve_small(J[:, dep - 1], rhs)


def solve(model, t, layout: Layout | None = None) -> KinematicSolution:
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
        One mechanism, or D designs of the same topology (their numbers may differ; drivers and
        loads are those of the first). With designs every array gains a leading axis D, and a
        design that cannot be assembled is NaN instead of raising.
    t : array_like (T,)
        Sample times, s.
    """
    models = [model] if isinstance(model, Model) else list(model)
    lay = layout or (compile_layout(models[0]) if len(models) == 1 else
                     stack_layouts([compile_layout(m) for m in models]))
    topo = lay.topo
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or len(t) < 1:
        raise ModelError("time samples must be a 1-D array with at least one sample",
                         fix="Pass t = numpy.linspace(0, duration, samples)")
    n, dep, drv = topo.n, list(topo.dependent), list(topo.driven)
    qdrv, qddrv, qdddrv = driver_values(models[0], t)
    # the [assembly] guess describes the mechanism at t = 0: assemble there, then follow the
    # branch to the samples
    q_start = assemble(models, lay, driver_values(models[0], np.zeros(1))[0][:, 0], 0.0,
                       raise_error=len(models) == 1)
    single = len(models) == 1
    if single:
        q_start = q_start[:, 0]
    lay_q = np.zeros(0) if single else np.zeros((len(models), 1))  # design axis vs (D, T)
    lo, hi = min(0.0, float(t.min())), max(0.0, float(t.max()))
    if dep and hi > lo:
        nodes, Q, QD, reach = _follow(models[0], lay, q_start if single else q_start[..., None],
                                      lo, hi)
        if not single:
            Q, QD, reach = Q[..., 0, :], QD[..., 0, :], reach[..., 0, :]
        # cubic Hermite guess for every sample from the bracketing nodes; samples past the
        # last node followed start from that node
        lo_ok, hi_ok = reach[..., :1], reach[..., 1:]
        followed = lo_ok <= hi_ok  # False for a design that did not assemble
        tc = np.clip(t, np.where(followed, lo_ok, 0.0), np.where(followed, hi_ok, 0.0))
        j = np.clip(np.searchsorted(nodes, tc, side="right") - 1, 0, len(nodes) - 2)
        h = nodes[j + 1] - nodes[j]
        u = (tc - nodes[j]) / h
        h00, h10 = 2 * u**3 - 3 * u**2 + 1, (u**3 - 2 * u**2 + u) * h
        h01, h11 = -2 * u**3 + 3 * u**2, (u**3 - u**2) * h

        def at(X, k):  # nodes not followed are zero: their weight is zero on the clamped span
            return np.take_along_axis(np.nan_to_num(X), k[None], axis=-1)
        q = h00 * at(Q, j) + h10 * at(QD, j) + h01 * at(Q, j + 1) + h11 * at(QD, j + 1)
        q[drv] = qdrv if single else qdrv[:, None] + lay_q
        q = np.where(np.isfinite(q), q, 0.0)
        modes = None
        if lay.dyads is not None:  # the assembly modes, as along the continuation nodes
            modes = dyads.sides(lay, lay.dyads, q_start[..., None], forward_positions)
        q, pose, p, J, err = _correct(lay, q, modes)
        # the branch ends at the first sample past the last node that does not close
        fails = ~(err <= ACCEPT)
        hi_end = np.min(np.where(fails & (t > hi_ok), t, np.inf), axis=-1, keepdims=True)
        lo_end = np.max(np.where(fails & (t < lo_ok), t, -np.inf), axis=-1, keepdims=True)
        cut_off = (t >= hi_end) | (t <= lo_end) | ~followed
        err = np.where(cut_off, np.inf, err)
    else:
        q = np.repeat(q_start[..., None], len(t), axis=-1)
        q[drv] = qdrv if single else qdrv[:, None] + lay_q
        q, err = newton(lay, q)
        pose = forward_positions(lay, q)
        p = motion_vectors(lay, pose)
        J = closure_jacobian(lay, pose, p)
    qd_drv, qdd_drv = (x if single else x[:, None] + lay_q for x in (qddrv, qdddrv))
    return _rates_and_accelerations(models[0], lay, t, q, pose, p, J, qd_drv, qdd_drv, err)


def _follow(model: Model, lay: Layout, q0: np.ndarray, lo: float, hi: float):
    """Continuation from the assembly at t = 0 forwards to ``hi`` and backwards to ``lo``.

    Returns ascending node times (K,), node coordinates and rates (n, ..., K), and the time
    interval ``reach`` (..., 2) over which each branch was followed."""
    if lay.dyads is not None and q0.ndim == 1:
        return _follow_dyads(model, lay, q0, lo, hi)
    if lay.dyads is not None:  # designs (n, D, 1): the nodes take the place of the time axis
        nodes, Q, QD, reach = _follow_dyads(model, lay, q0[..., 0], lo, hi)
        return nodes, Q[..., None, :], QD[..., None, :], reach[..., None, :]
    nodes, Q, QD, reach = [np.zeros(1)], [q0[..., None]], [None], []
    for end in (hi, lo):
        if end == 0.0:
            reach.append(np.zeros(q0.shape[1:]))
            continue
        nd = _travel_nodes(model, lay, 0.0, end)
        Qe, QDe, last = _continuation(model, lay, q0, nd)
        reach.append(last)
        if end < 0:
            nd, Qe, QDe = nd[::-1], Qe[..., ::-1], QDe[..., ::-1]
            nodes, Q, QD = [nd[:-1]] + nodes, [Qe[..., :-1]] + Q, [QDe[..., :-1]] + QD
            QD[-1] = QDe[..., -1:] if QD[-1] is None else QD[-1]
        else:
            nodes, Q, QD = nodes + [nd[1:]], Q + [Qe[..., 1:]], QD + [QDe[..., 1:]]
            QD[0 if lo == 0.0 else -2] = QDe[..., :1]
    QD = [x for x in QD if x is not None]
    return (np.concatenate(nodes), np.concatenate(Q, axis=-1), np.concatenate(QD, axis=-1),
            np.stack([reach[1], reach[0]], axis=-1))


def _follow_dyads(model: Model, lay: Layout, q0: np.ndarray, lo: float, hi: float):
    """:func:`_follow` for mechanisms whose loops are all RRR dyads: every node is solved at
    once in closed form in the assembly mode of ``q0``, and the dependent angles are unwrapped
    along the nodes (which the driver crosses in steps of at most ``STEP_ANGLE``)."""
    topo = lay.topo
    dep, drv = list(topo.dependent), list(topo.driven)
    nodes = np.unique(np.concatenate((_travel_nodes(model, lay, 0.0, lo),
                                      _travel_nodes(model, lay, 0.0, hi))))
    k0 = int(np.searchsorted(nodes, 0.0))
    nq, nqd, _ = driver_values(model, nodes)
    shape = (-1,) + (1,) * (q0.ndim - 1) + (len(nodes),)
    Q = np.repeat(q0[..., None], len(nodes), axis=-1)
    Q[drv] = nq.reshape(shape)
    modes = dyads.sides(lay, lay.dyads, q0[..., None], forward_positions)  # (..., 1) each
    Q, pose = dyads.solve(lay, lay.dyads, Q, forward_positions, sides=modes)
    J = closure_jacobian(lay, pose, motion_vectors(lay, pose))
    x, _ = _rates(lay, J, nqd.reshape(shape))
    ok = np.all(np.isfinite(Q[dep]), axis=0) & np.all(np.isfinite(x), axis=0)
    for i in dep:  # unwrap along the nodes, anchored at the assembly (t = 0)
        if lay.kind[i] == REVOLUTE:
            step = np.where(ok[..., 1:] & ok[..., :-1], wrap(np.diff(Q[i], axis=-1)), 0.0)
            path = np.concatenate((np.zeros(step.shape[:-1] + (1,)), np.cumsum(step, -1)), -1)
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


def _continuation(model: Model, lay: Layout, q_start: np.ndarray, nodes: np.ndarray):
    """Follow the branch from ``q_start`` (n, ...) through the node times: a predictor
    ``q += qd dt`` and a Newton corrector per node. Returns node coordinates and rates
    (n, ..., K) and the last node time (...) where the loops still close."""
    topo = lay.topo
    dep, drv = list(topo.dependent), list(topo.driven)
    nq, nqd, _ = driver_values(model, nodes)
    Q = np.full(q_start.shape + (len(nodes),), np.nan)
    QD = np.full(q_start.shape + (len(nodes),), np.nan)
    q = q_start.copy()
    last_ok = np.full(q_start.shape[1:], np.nan)
    alive = np.isfinite(q_start[0])
    for k in range(len(nodes)):
        q[drv] = nq[:, k].reshape((-1,) + (1,) * (q.ndim - 1))
        if k:
            q[dep] = Q[dep, ..., k - 1] + QD[dep, ..., k - 1] * (nodes[k] - nodes[k - 1])
        q, err = newton(lay, q)
        pose = forward_positions(lay, q)
        J = closure_jacobian(lay, pose, motion_vectors(lay, pose))
        x, _ = _rates(lay, J, nqd[:, k].reshape((-1,) + (1,) * (q.ndim - 1)))
        alive = alive & (err <= ACCEPT) & np.all(np.isfinite(x), axis=0)
        if not np.any(alive):
            break  # every branch ends here; samples beyond are flagged
        Q[..., k] = np.where(alive, q, np.nan)
        QD[..., k] = 0.0
        QD[drv, ..., k] = nqd[:, k].reshape((-1,) + (1,) * (q.ndim - 1))
        QD[dep, ..., k] = np.where(alive, x, np.nan)
        last_ok = np.where(alive, nodes[k], last_ok)
        q = np.where(alive, q, np.nan)
    return Q, QD, last_ok


def _correct(lay: Layout, q: np.ndarray, modes=None):
    """Close the loops of a close guess for all samples at once: in closed form when every loop
    is an RRR dyad, else by one Newton step; then Newton steps for samples whose residual is
    still above ``ACCEPT``. ``modes``: the dyads' assembly modes (default: the guess's).
    Returns q, pose, p, J, err."""
    dep = np.array(lay.topo.dependent)
    guess = q
    if lay.dyads is not None:
        # every loop is an RRR dyad: close it exactly on the guess's branch
        q, pose = dyads.solve(lay, lay.dyads, q, forward_positions, sides=modes)
    else:
        pose = forward_positions(lay, q)
        J = closure_jacobian(lay, pose, motion_vectors(lay, pose))
        dx, _ = solve_small(J[:, dep - 1], -closure_residual(lay, pose))
        q = q.copy()
        q[dep] += np.where(np.isfinite(dx), dx, 0.0)
        pose = forward_positions(lay, q)
    err = _scaled(lay, closure_residual(lay, pose))
    retry = ~(err <= ACCEPT) & np.all(np.isfinite(q), axis=0)
    if np.any(retry):  # damped Newton from the guess; only samples above TOL move
        q, err = newton(lay, np.where(retry, guess, q), maxiter=30, damped=True)
        pose = forward_positions(lay, q)
    p = motion_vectors(lay, pose)
    return q, pose, p, closure_jacobian(lay, pose, p), err


def _rates_and_accelerations(model, lay, t, q, pose, p, J, qd_drv, qdd_drv, err):
    topo = lay.topo
    dep, drv = list(topo.dependent), list(topo.driven)
    # rates: J_dep qd_dep = -J_drv qd_drv                       (eqs. 4-5)
    qd = np.zeros(q.shape)
    qd[drv] = qd_drv
    pivot = np.ones(q.shape[1:])
    if dep:
        qd[dep], pivot = _rates(lay, J, qd_drv)
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
    jq, jqd, jqdd = joint_values(model, lay, pose, tw, twd, q, qd, qdd)
    return KinematicSolution(lay, t, jq, jqd, jqdd, pose, p, tw, twd, J, pivot, err, valid)


def joint_values(model, lay, pose, tw, twd, q, qd, qdd):
    """Coordinates, rates, accelerations (T, n_joints) of all joints in model order: tree
    joints from the tree arrays, cut joints from their bodies' motion."""
    topo = lay.topo
    cols = [[None] * len(model.joints) for _ in range(3)]
    for i in range(1, topo.n):
        j = topo.tree_joint[i]
        cols[0][j], cols[1][j], cols[2][j] = q[i], qd[i], qdd[i]
    for c in lay.cuts:
        a, b = c.a, c.b
        if c.kind == REVOLUTE:
            # q = phi_b - phi_a and its derivatives
            cols[0][c.joint] = pose.phi[b] - pose.phi[a]
            cols[1][c.joint] = tw[b][0] - tw[a][0]
            cols[2][c.joint] = twd[b][0] - twd[a][0]
            continue
        # slider: s = d . e with d = r_Pb - r_Pa and e fixed in body a
        r_pa, r_pb, e = _cut_frames(lay, pose, c)
        wa, al = tw[a][0], twd[a][0]
        va = shift_twist(tw[a], r_pa - pose.r[a])[1:]
        vb = shift_twist(tw[b], r_pb - pose.r[b])[1:]
        aa = _point_acc(tw[a], twd[a], r_pa - pose.r[a])
        ab = _point_acc(tw[b], twd[b], r_pb - pose.r[b])
        d, dd, ddd = r_pb - r_pa, vb - va, ab - aa
        ed = wa * perp(e)
        edd = al * perp(e) - wa ** 2 * e
        cols[0][c.joint] = dot(d, e)
        cols[1][c.joint] = dot(dd, e) + dot(d, ed)
        cols[2][c.joint] = dot(ddd, e) + 2 * dot(dd, ed) + dot(d, edd)
    return tuple(np.stack(x, axis=-1) for x in cols)


def _point_acc(tw, twd, a):
    """Acceleration (2, ...) of the body point at offset ``a`` from O: ``a_O + al perp(a) - w^2 a``."""
    return twd[1:] + twd[0] * perp(a) - tw[0] ** 2 * a
