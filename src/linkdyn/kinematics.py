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

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from . import joints as jk
from .errors import AssemblyError, ModelError
from .model import PRISMATIC, REVOLUTE, Model
from .planar import cross, perp, rotate, rotate_cs, shift_twist, solve_small, twist, wrap
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
    return Layout(topo, tuple(kind), tuple(joint_point), tuple(axis), tuple(angle), tuple(origin),
                  points, com, tuple(float(b.mass) for b in bodies),
                  tuple(float(b.inertia) for b in bodies), tuple(cuts), size if size > 0 else 1.0)


@dataclass(frozen=True)
class Pose:
    """Absolute angles ``phi`` (..., n), reference points ``r`` (..., n, 2) and prismatic tree-joint
    axes ``e`` (..., n, 2) (zero for revolute) of all bodies in tree order."""

    phi: np.ndarray
    r: np.ndarray
    e: np.ndarray

    @cached_property
    def cos_sin(self) -> tuple[np.ndarray, np.ndarray]:
        """Cosines and sines of ``phi`` (..., n), computed once."""
        return np.cos(self.phi), np.sin(self.phi)

    def rotate(self, i: int, local: np.ndarray) -> np.ndarray:
        """Body i's local vector ``local`` (2,) in the global frame, (..., 2)."""
        c, s = self.cos_sin
        return rotate_cs(c[..., i], s[..., i], local)

    def point(self, i: int, local: np.ndarray) -> np.ndarray:
        """Global position (..., 2) of a point of body i given relative to O_i in its frame."""
        return self.r[..., i, :] + self.rotate(i, local)


def forward_positions(lay: Layout, q: np.ndarray) -> Pose:
    """Poses of all bodies from the tree joint coordinates ``q`` (..., n) (``q[..., 0]`` unused)."""
    topo, shape = lay.topo, q.shape[:-1]
    phi, c, s = np.zeros(shape + (topo.n,)), np.ones(shape + (topo.n,)), np.zeros(shape + (topo.n,))
    r, e = np.zeros(shape + (topo.n, 2)), np.zeros(shape + (topo.n, 2))
    for i in range(1, topo.n):
        p = topo.parent[i]
        # joint point on the parent, then the child placed by the joint kind
        r_joint = r[..., p, :] + rotate_cs(c[..., p], s[..., p], lay.joint_point[i])
        phi[..., i], c[..., i], s[..., i], r[..., i, :], e_i = jk.place_child(
            lay.kind[i], topo.sign[i], q[..., i], lay.angle[i], lay.axis[i], phi[..., p],
            c[..., p], s[..., p], r_joint)
        if e_i is not None:
            e[..., i, :] = e_i
    pose = Pose(phi, r, e)
    pose.__dict__["cos_sin"] = (c, s)
    return pose


def _cut_frames(lay: Layout, pose: Pose, c: Cut):
    """Cut point positions on both bodies and the cut's axis in the global frame."""
    r_pa, r_pb = pose.point(c.a, c.pa), pose.point(c.b, c.pb)
    e_a = pose.rotate(c.a, c.axis)
    return r_pa, r_pb, e_a


def closure_residual(lay: Layout, pose: Pose) -> np.ndarray:
    """Loop-closure residual of all cuts (..., 2 n_cut): m for positions, rad for angles."""
    out = []
    for c in lay.cuts:
        r_pa, r_pb, e_a = _cut_frames(lay, pose, c)
        out.append(jk.cut_residual(c.kind, c.angle, pose.phi[..., c.a], pose.phi[..., c.b],
                                   e_a, r_pa, r_pb))
    return np.concatenate(out, axis=-1)


def motion_vectors(lay: Layout, pose: Pose) -> np.ndarray:
    """Joint-motion propagation vectors ``p_i`` (..., n, 3) of all tree joints (eq. 3)."""
    topo, shape = lay.topo, pose.phi.shape[:-1]
    p = np.zeros(shape + (topo.n, 3))
    for i in range(1, topo.n):
        p[..., i, :] = jk.motion_vector(lay.kind[i], topo.sign[i], pose.e[..., i, :], shape)
    return p


def closure_jacobian(lay: Layout, pose: Pose, p: np.ndarray) -> np.ndarray:
    """Loop-closure Jacobian ``J`` (..., 2 n_cut, n - 1): rates of all tree joints to the cut rows.

    Column k of cut c is ``S_c A(r_Pb - r_k) p_k``, with sign +1 if joint k is on the path to
    the cut's second body, -1 if on the path to its first, 0 if on both or neither (eqs. 20-24).
    """
    topo = lay.topo
    rows = []
    for c in lay.cuts:
        r_pa, r_pb, e_a = _cut_frames(lay, pose, c)
        side = topo.ancestors[c.b].astype(int) - topo.ancestors[c.a].astype(int)
        cols = []
        for k in range(1, topo.n):
            x = side[k] * shift_twist(p[..., k, :], r_pb - pose.r[..., k, :])
            cols.append(jk.cut_rows(c.kind, e_a, x))
        rows.append(np.stack(cols, axis=-1))
    return np.concatenate(rows, axis=-2)


def forward_twists(lay: Layout, pose: Pose, p: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """Twists ``t`` (..., n, 3) of all bodies at their O_i from tree joint rates ``qd`` (..., n)."""
    topo = lay.topo
    t = np.zeros(p.shape)
    for i in range(1, topo.n):
        k = topo.parent[i]
        # t_i = A(r_i - r_p) t_p + p_i qd_i      (eq. 2)
        t[..., i, :] = (shift_twist(t[..., k, :], pose.r[..., i, :] - pose.r[..., k, :])
                        + p[..., i, :] * qd[..., i, None])
    return t


def forward_twist_rates(lay: Layout, pose: Pose, p: np.ndarray, t: np.ndarray,
                        qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
    """Twist rates ``td`` (..., n, 3) (angular acceleration; acceleration of O_i)."""
    topo = lay.topo
    td = np.zeros(t.shape)
    for i in range(1, topo.n):
        k = topo.parent[i]
        w_k, dv = t[..., k, 0], t[..., i, 1:] - t[..., k, 1:]
        # td_i = A td_p + [0, w_p perp(v_i - v_p)] + p_i qdd_i + pd_i qd_i
        td_i = (shift_twist(td[..., k, :], pose.r[..., i, :] - pose.r[..., k, :])
                + p[..., i, :] * qdd[..., i, None])
        td_i[..., 1:] += w_k[..., None] * perp(dv)
        w_axis = t[..., k if topo.sign[i] > 0 else i, 0]
        pd = jk.motion_vector_rate(lay.kind[i], topo.sign[i], pose.e[..., i, :], w_axis,
                                   w_k.shape)
        if pd is not None:
            td_i += pd * qd[..., i, None]
        td[..., i, :] = td_i
    return td


def _at_point(t_x, td_x, r_x, r_pt, v_pt):
    """Twist and twist rate of body x taken at a point moving with velocity v_pt (..., 2)."""
    t_at = shift_twist(t_x, r_pt - r_x)
    w, a = t_x[..., 0], td_x[..., 1:]
    # d/dt [w, v + w perp(r_pt - r_x)] with r_pt moving at v_pt
    acc = a + td_x[..., :1] * perp(r_pt - r_x) + w[..., None] * perp(v_pt - t_x[..., 1:])
    return t_at, twist(td_x[..., 0], acc)


def closure_bias(lay: Layout, pose: Pose, t: np.ndarray, td: np.ndarray) -> np.ndarray:
    """Rate of the cut rows ``d/dt (S x)`` (..., 2 n_cut) for the given twist rates, where ``x``
    is the relative twist of the cut's second body to its first at the cut point."""
    out = []
    for c in lay.cuts:
        r_pa, r_pb, e_a = _cut_frames(lay, pose, c)
        t_b, td_b = t[..., c.b, :], td[..., c.b, :]
        v_pb = t_b[..., 1:] + t_b[..., :1] * perp(r_pb - pose.r[..., c.b, :])
        tb, ab = _at_point(t_b, td_b, pose.r[..., c.b, :], r_pb, v_pb)
        ta, aa = _at_point(t[..., c.a, :], td[..., c.a, :], pose.r[..., c.a, :], r_pb, v_pb)
        x, xd = tb - ta, ab - aa
        out.append(jk.cut_rows(c.kind, e_a, xd) + jk.cut_rows_rate(c.kind, e_a, t[..., c.a, 0], x))
    return np.concatenate(out, axis=-1)


# ----------------------------------------------------------------------------------------------
# position analysis


def _scaled(lay: Layout, g: np.ndarray) -> np.ndarray:
    """Closure residual made dimensionless: lengths / size, angles as they are; max over rows."""
    scale = []
    for c in lay.cuts:
        scale += [lay.size, lay.size] if c.kind == REVOLUTE else [1.0, lay.size]
    return np.max(np.abs(g) / np.array(scale), axis=-1)


def newton(lay: Layout, q: np.ndarray, maxiter: int = 12, damped: bool = False):
    """Solve the closure for the dependent tree coordinates of ``q`` (..., n), in place of a copy.

    Returns ``(q, err)``: ``err`` (...) is the final scaled residual (NaN/inf if it failed).
    With ``damped``, each step is halved until the residual decreases (for assembly).
    """
    topo = lay.topo
    dep = np.array(topo.dependent)
    q = np.array(q, dtype=float)
    if len(dep) == 0:
        return q, np.zeros(q.shape[:-1])
    pose = forward_positions(lay, q)
    g = closure_residual(lay, pose)
    err = _scaled(lay, g)
    for _ in range(maxiter):
        if np.all(~(err > TOL)):
            break
        J = closure_jacobian(lay, pose, motion_vectors(lay, pose))[..., dep - 1]
        dx, _ = solve_small(J, -g)
        dx = np.where(np.isfinite(dx), dx, 0.0)
        if damped:
            step = np.ones(err.shape)
            for _ in range(30):
                trial = q.copy()
                trial[..., dep] += step[..., None] * dx
                pose_t = forward_positions(lay, trial)
                g_t = closure_residual(lay, pose_t)
                err_t = _scaled(lay, g_t)
                worse = ~(err_t < err) & (err > TOL)
                if not np.any(worse):
                    break
                step = np.where(worse, step / 2, step)
            q, pose, g, err = trial, pose_t, g_t, err_t
        else:
            active = err > TOL
            q[..., dep] += np.where(active[..., None], dx, 0.0)
            pose = forward_positions(lay, q)
            g = closure_residual(lay, pose)
            err = _scaled(lay, g)
    return q, err


def _guess(model: Model, lay: Layout) -> np.ndarray:
    """Tree coordinates near the ``[assembly]`` guess (absolute angles and joint values)."""
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


def assemble(model: Model, lay: Layout, q_drv0: np.ndarray, t0: float = 0.0) -> np.ndarray:
    """Assembled tree coordinates (n,) at the first sample, on the branch of the guess.

    A damped Newton solve from the ``[assembly]`` guess; if it fails, 64 deterministic
    restarts are solved at once and the converged one nearest the guess is kept.
    """
    topo = lay.topo
    q0 = _guess(model, lay)
    q0[list(topo.driven)] = q_drv0
    q, err = newton(lay, q0, maxiter=60, damped=True)
    if err <= ACCEPT:
        return q
    rng = np.random.default_rng(0)
    starts = np.tile(q0, (64, 1))
    dep = list(topo.dependent)
    for i in dep:
        starts[:, i] = (rng.uniform(-np.pi, np.pi, 64) if lay.kind[i] == REVOLUTE
                        else rng.uniform(-2, 2, 64) * lay.size)
    qs, errs = newton(lay, starts, maxiter=60, damped=True)
    ok = errs <= ACCEPT
    if not np.any(ok):
        drv = {model.joints[topo.tree_joint[i]].name: float(q_drv0[k])
               for k, i in enumerate(topo.driven)}
        raise AssemblyError(
            "the mechanism cannot be assembled: the loops do not close "
            f"(closest relative residual {np.nanmin(np.append(errs, err)):.2e})",
            file=model.source, time=t0, drivers=drv,
            fix="Check the link lengths and the [assembly] guess")
    dist = np.sum(np.abs(wrap(qs[:, dep] - q0[dep])), axis=-1)
    return qs[np.argmin(np.where(ok, dist, np.inf))]


# ----------------------------------------------------------------------------------------------
# the kinematic solution


@dataclass(frozen=True)
class KinematicSolution:
    """Positions, rates and accelerations of every joint and body at every sample.

    Body arrays are in tree order (``layout.topo.bodies``, index 0 = ground); joint arrays in the
    model's joint order. Batch shape ``(..., T)`` is the shape of the time array.

    Attributes
    ----------
    t : ndarray (..., T)
        s.
    q, qd, qdd : ndarray (..., T, n_joints)
        Joint coordinates (rad or m), rates, accelerations.
    pose : Pose
        ``phi`` (..., T, n), ``r`` (..., T, n, 2) reference points O_i, ``e`` slider axes.
    p : ndarray (..., T, n, 3)
        Joint-motion propagation vectors of the tree joints.
    tw, twd : ndarray (..., T, n, 3)
        Twists ``[w, vx, vy]`` at O_i and their rates.
    J : ndarray (..., T, 2 n_cut, n - 1)
        Loop-closure Jacobian.
    pivot : ndarray (..., T)
        Smallest relative pivot of ``J_dep`` (~0 at a singular position).
    residual : ndarray (..., T)
        Closure residual relative to ``layout.size``.
    valid : ndarray (..., T) bool
    """

    layout: Layout
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    pose: Pose
    p: np.ndarray
    tw: np.ndarray
    twd: np.ndarray
    J: np.ndarray
    pivot: np.ndarray
    residual: np.ndarray
    valid: np.ndarray

    def point(self, body: str, name: str) -> np.ndarray:
        """Path (..., T, 2) of a named point of a body, m."""
        i = self.layout.topo.bodies.index(body)
        return self.pose.point(i, self.layout.points[i][name])

    def point_velocity(self, body: str, name: str) -> np.ndarray:
        i = self.layout.topo.bodies.index(body)
        rp = self.point(body, name)
        return shift_twist(self.tw[..., i, :], rp - self.pose.r[..., i, :])[..., 1:]


def driver_values(model: Model, t: np.ndarray):
    """Driver coordinates, rates, accelerations, each (..., T, n_drivers)."""
    vals = [d.motion.evaluate(t) for d in model.drivers]
    if not vals:
        z = np.zeros(t.shape + (0,))
        return z, z, z
    return tuple(np.stack([v[k] for v in vals], axis=-1) for k in range(3))


def _travel_nodes(model: Model, lay: Layout, t: np.ndarray) -> np.ndarray:
    """Continuation times: the driver moves at most one step between consecutive nodes."""
    probe = np.linspace(t[0], t[-1], 4097)
    qp, _, _ = driver_values(model, probe)
    step = np.array([STEP_ANGLE if lay.kind[i] == REVOLUTE else STEP_LENGTH * lay.size
                     for i in lay.topo.driven])
    travel = np.concatenate(([0.0], np.cumsum(np.max(np.abs(np.diff(qp, axis=0)) / step, axis=-1)
                                              if len(step) else np.zeros(4096))))
    n = int(np.clip(np.ceil(travel[-1]) + 1, 2, 20000))
    return np.interp(np.linspace(0, travel[-1], n), travel, probe) if travel[-1] > 0 else \
        np.array([t[0], t[-1]])


def _rates(lay, pose, p, J, q_rates_drv):
    """Dependent joint rates from the driven ones: ``J_dep x = -J_drv qd_drv``."""
    topo = lay.topo
    dep, drv = np.array(topo.dependent, int), np.array(topo.driven, int)
    rhs = -np.einsum("...ij,...j->...i", J[..., drv - 1], q_rates_drv) if len(drv) else \
        np.zeros(J.shape[:-1])
    return solve_small(J[..., dep - 1], rhs)


def solve(model: Model, t, layout: Layout | None = None) -> KinematicSolution:
    """Positions, velocities and accelerations at the times ``t`` (T,) s.

    Assembles at ``t[0]`` on the branch of the ``[assembly]`` guess, follows the branch through
    continuation nodes (driver travel at most ``STEP_ANGLE`` rad between nodes), interpolates the
    nodes to every sample with cubic Hermite polynomials and corrects all samples at once with
    Newton's method. Samples where the loop does not close or ``J_dep`` is singular have
    ``valid = False`` and NaN values; nothing raises here.
    """
    lay = layout or compile_layout(model)
    topo = lay.topo
    t = np.asarray(t, dtype=float)
    if t.ndim != 1 or len(t) < 1:
        raise ModelError("time samples must be a 1-D array with at least one sample",
                         fix="Pass t = numpy.linspace(0, duration, samples)")
    n, dep, drv = topo.n, list(topo.dependent), list(topo.driven)
    qdrv, qddrv, qdddrv = driver_values(model, t)

    # continuation along the branch through the nodes (a loop over driver steps, not samples)
    q_start = assemble(model, lay, qdrv[0], float(t[0]))
    if len(dep) and len(t) > 1:
        nodes = _travel_nodes(model, lay, t)
        nq, nqd, _ = driver_values(model, nodes)
        Q = np.full((len(nodes), n), np.nan)
        QD = np.full((len(nodes), n), np.nan)
        q = q_start.copy()
        for k in range(len(nodes)):
            q[drv] = nq[k]
            if k:  # predictor: q_dep += qd_dep dt
                q[dep] = Q[k - 1, dep] + QD[k - 1, dep] * (nodes[k] - nodes[k - 1])
            q, err = newton(lay, q)
            pose = forward_positions(lay, q)
            p = motion_vectors(lay, pose)
            J = closure_jacobian(lay, pose, p)
            x, piv = _rates(lay, pose, p, J, nqd[k])
            if not err <= ACCEPT or not np.all(np.isfinite(x)):
                break  # the branch ends here; samples beyond are flagged below
            Q[k], QD[k] = q, 0.0
            QD[k, drv], QD[k, dep] = nqd[k], x
        # cubic Hermite guess for every sample from the bracketing nodes
        ok_nodes = np.isfinite(Q[:, 0])
        last = nodes[ok_nodes][-1] if np.any(ok_nodes) else t[0]
        j = np.clip(np.searchsorted(nodes, t, side="right") - 1, 0, len(nodes) - 2)
        h = nodes[j + 1] - nodes[j]
        s = ((t - nodes[j]) / h)[:, None]
        h = h[:, None]
        h00, h10, h01, h11 = 2*s**3 - 3*s**2 + 1, s**3 - 2*s**2 + s, -2*s**3 + 3*s**2, s**3 - s**2
        q = h00 * Q[j] + h10 * h * QD[j] + h01 * Q[j + 1] + h11 * h * QD[j + 1]
        q[:, drv] = qdrv
        beyond = t > last
        q[beyond] = np.nan
        q, err = newton(lay, np.where(np.isfinite(q), q, 0.0), maxiter=8)
        err = np.where(beyond, np.inf, err)
    else:
        q = np.tile(q_start, (len(t), 1))
        q[:, drv] = qdrv
        err = np.zeros(len(t))
        if len(dep):
            q, err = newton(lay, q)
    return _rates_and_accelerations(model, lay, t, q, qddrv, qdddrv, err)


def _rates_and_accelerations(model, lay, t, q, qd_drv, qdd_drv, err) -> KinematicSolution:
    topo = lay.topo
    dep, drv = list(topo.dependent), list(topo.driven)
    pose = forward_positions(lay, q)
    p = motion_vectors(lay, pose)
    J = closure_jacobian(lay, pose, p)
    # rates: J_dep qd_dep = -J_drv qd_drv                       (eqs. 4-5)
    qd = np.zeros(q.shape)
    qd[..., drv] = qd_drv
    if dep:
        qd[..., dep], pivot = _rates(lay, pose, p, J, qd_drv)
    else:
        pivot = np.ones(q.shape[:-1])
    tw = forward_twists(lay, pose, p, qd)
    # accelerations: J_dep qdd_dep = -bias(qdd_dep = 0)          (eqs. 6-7)
    qdd = np.zeros(q.shape)
    qdd[..., drv] = qdd_drv
    twd = forward_twist_rates(lay, pose, p, tw, qd, qdd)
    if dep:
        bias = closure_bias(lay, pose, tw, twd)
        qdd[..., dep], _ = solve_small(J[..., np.array(dep) - 1], -bias)
        twd = forward_twist_rates(lay, pose, p, tw, qd, qdd)
    valid = (err <= ACCEPT) & np.all(np.isfinite(qd), axis=-1) & np.all(np.isfinite(qdd), axis=-1)
    nan = ~valid
    q, qd, qdd = (np.where(nan[..., None], np.nan, x) for x in (q, qd, qdd))
    pose = Pose(*(np.where(nan.reshape(nan.shape + (1,) * (x.ndim - nan.ndim)), np.nan, x)
                  for x in (pose.phi, pose.r, pose.e)))
    tw, twd, p = (np.where(nan[..., None, None], np.nan, x) for x in (tw, twd, p))
    Jn = np.where(nan[..., None, None], np.nan, J)
    jq, jqd, jqdd = joint_values(model, lay, pose, tw, twd, q, qd, qdd)
    return KinematicSolution(lay, t, jq, jqd, jqdd, pose, p, tw, twd, Jn, pivot, err, valid)


def joint_values(model, lay, pose, tw, twd, q, qd, qdd):
    """Coordinates, rates, accelerations (..., n_joints) of all joints in model order: tree
    joints from the tree arrays, cut joints from their bodies' motion."""
    topo = lay.topo
    nj = len(model.joints)
    shape = q.shape[:-1]
    jq, jqd, jqdd = (np.zeros(shape + (nj,)) for _ in range(3))
    for i in range(1, topo.n):
        j = topo.tree_joint[i]
        jq[..., j], jqd[..., j], jqdd[..., j] = q[..., i], qd[..., i], qdd[..., i]
    for c in lay.cuts:
        a, b = c.a, c.b
        if c.kind == REVOLUTE:
            # q = phi_b - phi_a and its derivatives
            jq[..., c.joint] = pose.phi[..., b] - pose.phi[..., a]
            jqd[..., c.joint] = tw[..., b, 0] - tw[..., a, 0]
            jqdd[..., c.joint] = twd[..., b, 0] - twd[..., a, 0]
            continue
        # slider: s = d.e with d = r_Pb - r_Pa, e fixed in body a
        r_pa, r_pb, e = _cut_frames(lay, pose, c)
        wa, al = tw[..., a, 0], twd[..., a, 0]
        va = shift_twist(tw[..., a, :], r_pa - pose.r[..., a, :])[..., 1:]
        vb = shift_twist(tw[..., b, :], r_pb - pose.r[..., b, :])[..., 1:]
        aa = _point_acc(tw[..., a, :], twd[..., a, :], r_pa - pose.r[..., a, :])
        ab = _point_acc(tw[..., b, :], twd[..., b, :], r_pb - pose.r[..., b, :])
        d, dd, ddd = r_pb - r_pa, vb - va, ab - aa
        ed = wa[..., None] * perp(e)
        edd = al[..., None] * perp(e) - (wa ** 2)[..., None] * e
        jq[..., c.joint] = np.sum(d * e, -1)
        jqd[..., c.joint] = np.sum(dd * e + d * ed, -1)
        jqdd[..., c.joint] = np.sum(ddd * e + 2 * dd * ed + d * edd, -1)
    return jq, jqd, jqdd


def _point_acc(tw, twd, a):
    """Acceleration (..., 2) of the body point at offset ``a`` from O: a_O + al perp(a) - w^2 a."""
    return twd[..., 1:] + twd[..., :1] * perp(a) - (tw[..., :1] ** 2) * a


__all__ = ["Layout", "Pose", "KinematicSolution", "compile_layout", "solve", "forward_positions",
           "closure_residual", "closure_jacobian", "forward_twists", "forward_twist_rates",
           "closure_bias", "motion_vectors", "newton", "assemble", "driver_values", "cross"]
