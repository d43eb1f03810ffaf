"""Spatial kinematics: the tree's poses, twists and twist rates from the joint coordinates, the
loop closure by Newton's method with continuation, and the rates and accelerations.

The generalized coordinates ``q`` (T, n_q) are every tree joint's coordinates (its kind's
chain of elementary screws), body by body in tree order. The drivers prescribe some of them
(``Plan.driven``); the others (``Plan.dependent``) follow from the closure of the cut joints,
``g(q) = 0``, whose Jacobian ``J = dg/dq`` (T, rows, n_q) has the rows ``phi^T (s_B - s_A)``.
Redundant closure rows (a planar loop in space) are fine: every solve is least squares.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

import numpy as np

from .. import topology as topology_mod
from ..errors import AssemblyError, ModelError
from ..kinematics.positions import singular
from . import algebra as sa
from . import joints as sj

RANK = 1e-9          # a singular value below this fraction of the largest counts as zero
CLOSED = 1e-10       # closure: a residual row below this (times the size for a length) is closed
SINGULAR = ("the mechanism passes a singular position (the dependent joints' Jacobian loses "
            "rank there, or within the closure's resolution)")
SINGULAR_FIX = ("Limit the driver's range, or change the geometry so the loops do not reach a "
                "dead-centre or locked position")
ANGLE_STEP = 0.3     # rad, continuation step of an angular driver
LENGTH_STEP = 0.1    # of the mechanism's size, continuation step of a sliding driver


@dataclass(frozen=True)
class Plan:
    """The numeric form of a spatial model that the stages read: one design, or the rows of
    a batch of designs (:func:`designs`: every design's numbers repeated over its samples).

    Attributes
    ----------
    topo : Topology
    kinds : tuple[SpatialKind, ...]
        Each joint's kind (model order).
    geometry : tuple[joints.Geometry, ...]
        Each joint's constants.
    cols : tuple[slice, ...]
        The coordinates of body i's tree joint in ``q`` (``cols[0]`` empty).
    n_q : int
    driven, dependent : ndarray of int
        Indices in ``q`` of the drivers' coordinates (model's driver order) and the others.
    q0 : ndarray (n_q,)
        The coordinates at the design pose.
    mass : ndarray (n,)
    com : ndarray (n, 3)
        Mass centres, body frames.
    inertia : ndarray (n, 3, 3)
        Centroidal inertia tensors, body frames.
    size : float
        The mechanism's size (m), for tolerances.
    length_row : ndarray of bool (rows,)
        Closure rows that are lengths (else angles).
    length_coordinate : ndarray of bool (n_q,)
        Tree coordinates that are lengths (else angles).
    row : ndarray of int (N,) or None
        A batch's rows: the design (index in ``models``) of each row. Then the per-design
        numbers (``geometry``'s arrays, ``q0``, ``mass``, ``com``, ``inertia``, ``size``) have
        a leading row axis (N, ...), the stages' arrays the same rows (a design's samples one
        after another, design after design); None for one design (its numbers broadcast over
        the samples).
    models : tuple[Model, ...] or None
        A batch's designs, for the numbers the stages read from the model (loads, gravity).
    """

    topo: object
    kinds: tuple
    geometry: tuple
    cols: tuple
    n_q: int
    driven: np.ndarray
    dependent: np.ndarray
    q0: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    size: float
    length_row: np.ndarray
    length_coordinate: np.ndarray
    row: np.ndarray | None = None
    models: tuple | None = None


def plan(model) -> Plan:
    """The :class:`Plan` of a spatial ``model`` (topology from :func:`linkdyn.topology.build`)."""
    topo = topology_mod.build(model)
    bodies = {b.name: b for b in model.bodies}
    kinds = tuple(sj.get(j.kind) for j in model.joints)
    geometry, d0 = [], []
    for j, kind in zip(model.joints, kinds):
        a, b = bodies[j.body_a], bodies[j.body_b]
        e = j.axis if np.any(j.axis) else np.array([0.0, 0.0, 1.0])
        t1, t2 = sj.base.perpendiculars(e)
        geometry.append(sj.Geometry(p=a.points[j.point_a], q=b.points[j.point_b], e=e, t1=t1,
                                    t2=t2, e2=j.axis2, R0=a.rotation.T @ b.rotation))
        # B's point from A's at the design pose, A's frame
        d0.append(a.rotation.T @ (b.origin + b.rotation @ b.points[j.point_b]
                                  - a.origin - a.rotation @ a.points[j.point_a]))
    cols, q0, start, lengths = [slice(0, 0)], [], 0, []
    for i in range(1, topo.n):
        j = topo.tree_joint[i]
        f = kinds[j].freedoms
        cols.append(slice(start, start + f))
        lengths += [not angular for _, angular in kinds[j].coordinates_named]
        q0.append(kinds[j].design_coordinates(geometry[j], d0[j]))
        start += f
    driven = np.array([cols[i].start for i in topo.driven], dtype=int)
    dependent = np.array([k for k in range(start) if k not in set(driven.tolist())], dtype=int)
    ordered = [bodies[name] for name in topo.bodies]
    points = np.array([b.origin + b.rotation @ x for b in model.bodies for x in b.points.values()])
    size = float(np.max(np.ptp(points, axis=0))) if len(points) > 1 else 1.0
    length_row = np.array([lab.startswith("F") for j in topo.cut
                           for lab in kinds[j].row_labels], dtype=bool)
    return Plan(topo, kinds, tuple(geometry), tuple(cols), start, driven, dependent,
                np.concatenate(q0) if q0 else np.zeros(0),
                np.array([b.mass for b in ordered]), np.array([b.com for b in ordered]),
                np.array([b.inertia for b in ordered]), size if size > 0 else 1.0, length_row,
                np.array(lengths, dtype=bool))


_PER_DESIGN = ("q0", "mass", "com", "inertia", "size")


def designs(models, T: int) -> Plan:
    """The batch :class:`Plan` of D designs of one model (the same bodies, joints, kinds and
    drivers; other numbers) at T samples each: every design's :func:`plan`, its numbers
    repeated over its T rows (``Plan.row``). A ModelError where a design's topology differs
    from the first's."""
    plans = [plan(m) for m in models]
    first = plans[0]
    for m, q in zip(models[1:], plans[1:]):
        if (q.topo.tree_joint != first.topo.tree_joint or q.topo.cut != first.topo.cut
                or q.topo.parent != first.topo.parent or q.topo.sign != first.topo.sign
                or q.cols != first.cols or q.kinds != first.kinds):
            raise ModelError("a design's joints form another tree than the first design's",
                             file=m.source, field="joints",
                             fix="Vary numbers only, not the joints' kinds or connections")
    row = np.repeat(np.arange(len(plans)), T)
    geometry = tuple(sj.Geometry(*(np.stack([getattr(q.geometry[j], f.name) for q in plans])[row]
                                   for f in fields(sj.Geometry)))
                     for j in range(len(first.geometry)))
    per = {k: np.stack([np.asarray(getattr(q, k), float) for q in plans])[row]
           for k in _PER_DESIGN}
    return replace(first, geometry=geometry, row=row, models=tuple(models), **per)


def take(p: Plan, idx) -> Plan:
    """The batch plan ``p`` at its rows ``idx`` (int array); one design's plan as it is."""
    if p.row is None:
        return p
    geometry = tuple(sj.Geometry(*(getattr(g, f.name)[idx] for f in fields(sj.Geometry)))
                     for g in p.geometry)
    return replace(p, geometry=geometry, row=p.row[idx],
                   **{k: getattr(p, k)[idx] for k in _PER_DESIGN})


def _size(p: Plan) -> np.ndarray:
    """The size (..., 1): (1,) for one design, (N, 1) for a batch's rows."""
    return np.asarray(p.size, float)[..., None]


# ---------------------------------------------------------------- the tree
@dataclass(frozen=True)
class Tree:
    """Poses of every body at the samples: rotations ``R`` (T, n, 3, 3) (body to global),
    frame origins ``o`` (T, n, 3), each tree joint's point ``c`` (T, n, 3) (B's point q,
    global) and its screws signed for the child, ``S`` (list per body of (T, f, 6):
    ``V_i = V_parent + S_i qd_i``; times ``Topology.sign[i]`` the joint's own, A to B)."""

    R: np.ndarray
    o: np.ndarray
    c: np.ndarray
    S: list


def poses(p: Plan, q: np.ndarray) -> Tree:
    """The bodies' poses from the coordinates ``q`` (T, n_q): each child from its parent by
    its tree joint's chain, ``R_B = R_A R_rel``, ``r_Bq = r_Ap + R_A d`` (or the inverse when
    the child is the joint's first body)."""
    T, n = q.shape[0], p.topo.n
    R = np.zeros((T, n, 3, 3))
    o = np.zeros((T, n, 3))
    c = np.zeros((T, n, 3))
    R[:, 0] = np.eye(3)
    S = [np.zeros((T, 0, 6))]
    for i in range(1, n):
        j, par, s = p.topo.tree_joint[i], p.topo.parent[i], p.topo.sign[i]
        kind, g, qi = p.kinds[j], p.geometry[j], q[:, p.cols[i]]
        Rrel, d = kind.relative(g, qi)
        if s > 0:        # child B: R_B = R_A R_rel, r_Bq = r_Ap + R_A d
            RA = R[:, par]
            rp = o[:, par] + sa.matvec(RA, g.p)
            RB = RA @ Rrel
            rq = rp + sa.matvec(RA, d)
            R[:, i], o[:, i] = RB, rq - sa.matvec(RB, g.q)
        else:            # child A: R_A = R_B R_rel^T, r_Ap = r_Bq - R_A d
            RB = R[:, par]
            rq = o[:, par] + sa.matvec(RB, g.q)
            RA = RB @ np.swapaxes(Rrel, -1, -2)
            R[:, i], o[:, i] = RA, rq - sa.matvec(RA, d) - sa.matvec(RA, g.p)
        c[:, i] = rq
        S.append(s * kind.screws(g, RA, RB, rq, qi))
    return Tree(R, o, c, S)


def joint_pose(p: Plan, tree: Tree, j: int, model_joint) -> sj.Pose:
    """A joint's :class:`~linkdyn.spatial.joints.Pose` at the samples."""
    a, b = p.topo.bodies.index(model_joint.body_a), p.topo.bodies.index(model_joint.body_b)
    g = p.geometry[j]
    return sj.Pose(tree.R[:, a], tree.R[:, b], tree.o[:, a] + sa.matvec(tree.R[:, a], g.p),
                   tree.o[:, b] + sa.matvec(tree.R[:, b], g.q))


def twists(p: Plan, tree: Tree, qd: np.ndarray) -> np.ndarray:
    """Every body's twist (T, n, 6): ``V_i = V_parent + S_i qd_i``."""
    V = np.zeros(qd.shape[:1] + (p.topo.n, 6))
    for i in range(1, p.topo.n):
        V[:, i] = V[:, p.topo.parent[i]] + np.einsum("tks,tk->ts", tree.S[i], qd[:, p.cols[i]])
    return V


def twist_rates(p: Plan, tree: Tree, V: np.ndarray, qd: np.ndarray,
                qdd: np.ndarray) -> np.ndarray:
    """Every body's twist rate (T, n, 6), ``A_i = A_parent + S_i qdd_i + b_i``: along the
    chain from the joint's first body A, ``b = sign sum_k crm(V_A + sum_{m<=k} s_m qd_m)
    s_k qd_k`` (the screws' rates, each fixed in its intermediate body)."""
    A = np.zeros_like(V)
    for i in range(1, p.topo.n):
        par, s = p.topo.parent[i], p.topo.sign[i]
        bias = chain_bias(tree.S[i] * s, qd[:, p.cols[i]],         # unsigned screws, A to B
                          V[:, par] if s > 0 else V[:, i])          # from V_A
        A[:, i] = A[:, par] + np.einsum("tks,tk->ts", tree.S[i], qdd[:, p.cols[i]]) + s * bias
    return A


def chain_bias(S: np.ndarray, qd: np.ndarray, VA: np.ndarray) -> np.ndarray:
    """The screws' rates times the rates along a chain from A (T, 6): ``sum_k crm(V_k) s_k
    qd_k``, ``V_k = V_A + sum_{m<=k} s_m qd_m`` the k-th intermediate body's twist. ``S``
    (T, f, 6) unsigned screws, ``qd`` (T, f), ``VA`` (T, 6)."""
    v, bias = VA, np.zeros_like(VA)
    for k in range(S.shape[1]):
        v = v + S[:, k] * qd[:, k, None]
        bias = bias + sa.cross_twist(v, S[:, k] * qd[:, k, None])
    return bias


def joint_coordinates(model, p: Plan, m: "Motion") -> dict:
    """Every joint's ``(q, qd, qdd)``, each (T, f) (its kind's coordinates): a tree joint's
    from the tree coordinates; a cut joint's from its bodies' poses (``coordinates`` of the
    relative pose, angles unwrapped over the samples), its rates and accelerations by least
    squares from ``S qd = V_B - V_A`` and ``S qdd = A_B - A_A - chain_bias``."""
    tree_of = {p.topo.tree_joint[i]: i for i in range(1, p.topo.n)}
    out = {}
    for j, jt in enumerate(model.joints):
        if j in tree_of:
            c = p.cols[tree_of[j]]
            out[jt.name] = (m.q[:, c], m.qd[:, c], m.qdd[:, c])
            continue
        kind, g = p.kinds[j], p.geometry[j]
        pose = joint_pose(p, m.tree, j, jt)
        a, b = p.topo.bodies.index(jt.body_a), p.topo.bodies.index(jt.body_b)
        RAt = np.swapaxes(pose.RA, -1, -2)
        q = kind.coordinates(g, RAt @ pose.RB, sa.matvec(RAt, pose.rq - pose.rp))
        ang = np.array([x for _, x in kind.coordinates_named])
        if p.row is None:
            q[:, ang] = np.unwrap(q[:, ang], axis=0)
        elif np.any(ang):              # each design's samples apart
            T = int(np.sum(p.row == p.row[0]))
            q[:, ang] = np.unwrap(q[:, ang].reshape(-1, T, int(np.sum(ang))),
                                  axis=1).reshape(len(q), -1)
        S = kind.screws(g, pose.RA, pose.RB, pose.rq, q)
        St = np.swapaxes(S, -1, -2)
        solver = sa.Solver(St, 1e-12)
        qd = solver.solve(m.V[:, b] - m.V[:, a])
        rhs = m.A[:, b] - m.A[:, a] - chain_bias(S, qd, m.V[:, a])
        qdd = solver.solve(rhs)
        out[jt.name] = (q, qd, qdd)
    return out


# ---------------------------------------------------------------- closure
def closure(model, p: Plan, tree: Tree):
    """The cut joints' residual ``g`` (T, rows), constraint wrenches ``phi`` (T, rows, 6) and
    the Jacobian ``J`` (T, rows, n_q): ``J[:, r, k] = phi_r . s_k (anc(B, k) - anc(A, k))``."""
    T = tree.R.shape[0]
    gs, phis, Js = [], [], []
    anc = p.topo.ancestors
    for j in p.topo.cut:
        jt = model.joints[j]
        g, phi = p.kinds[j].closure(p.geometry[j], joint_pose(p, tree, j, jt))
        a, b = p.topo.bodies.index(jt.body_a), p.topo.bodies.index(jt.body_b)
        J = np.zeros((T, phi.shape[1], p.n_q))
        for i in range(1, p.topo.n):
            side = int(anc[b, i]) - int(anc[a, i])
            if side:
                J[:, :, p.cols[i]] = side * np.einsum("trs,tks->trk", phi, tree.S[i])
        gs.append(g), phis.append(phi), Js.append(J)
    if not gs:
        return np.zeros((T, 0)), np.zeros((T, 0, 6)), np.zeros((T, 0, p.n_q))
    return np.concatenate(gs, 1), np.concatenate(phis, 1), np.concatenate(Js, 1)


def closure_bias(model, p: Plan, tree: Tree, V: np.ndarray) -> np.ndarray:
    """``gamma = dphi/dt . (V_B - V_A)`` (T, rows) of every cut joint's rows."""
    out = []
    for j in p.topo.cut:
        jt = model.joints[j]
        pose = joint_pose(p, tree, j, jt)
        a, b = p.topo.bodies.index(jt.body_a), p.topo.bodies.index(jt.body_b)
        m = sj.Rates(V[:, a], V[:, b], sa.point_velocity(V[:, b], pose.rq))
        out.append(np.einsum("trs,ts->tr", p.kinds[j].closure_rate(p.geometry[j], pose, m),
                             V[:, b] - V[:, a]))
    return np.concatenate(out, 1) if out else np.zeros((V.shape[0], 0))


def scaled(p: Plan, g: np.ndarray) -> np.ndarray:
    """The residual with its length rows divided by the mechanism's size (dimensionless)."""
    return g / np.where(p.length_row, _size(p), 1.0)


def newton(model, p: Plan, q: np.ndarray, iterations: int = 30) -> tuple[np.ndarray, np.ndarray]:
    """Close the loops from the guess ``q`` (T, n_q), moving the dependent coordinates by
    Gauss-Newton steps (least squares, so redundant rows are fine); a sample stops when it is
    closed exactly, or closed and its error no longer halves (rounding). Returns ``(q,
    error)``, error (T,) the largest scaled residual."""
    q = q.copy()
    dep = p.dependent
    err = np.full(len(q), np.inf)
    active, pa = np.arange(len(q)), p
    for _ in range(iterations):
        g, _, J = closure(model, pa, poses(pa, q[active]))
        before, err[active] = err[active], np.max(np.abs(scaled(pa, g)), axis=1, initial=0.0)
        at_rounding = (err[active] == 0) | ((err[active] < CLOSED)
                                           & (err[active] > 0.5 * before))
        if np.any(at_rounding):
            active, g, J = active[~at_rounding], g[~at_rounding], J[~at_rounding]
            pa = take(p, active)
        if not len(active):
            break
        step, _ = sa.lstsq(J[:, :, dep], g, 1e-12)
        q[np.ix_(active, dep)] -= step
    else:
        g, _, _ = closure(model, pa, poses(pa, q[active]))
        err[active] = np.max(np.abs(scaled(pa, g)), axis=1, initial=0.0)
    return q, err


def rank_of(p: Plan, J: np.ndarray, cols=None) -> np.ndarray:
    """The numerical rank (T,) of each closure Jacobian (T, rows, k) (its columns ``cols`` of
    the tree coordinates, default all): of ``J`` made dimensionless (:func:`_singular_values`),
    counting singular values above ``RANK`` times the largest or 1, whichever is larger (a
    Jacobian of round-off alone, a wholly redundant loop, has rank 0)."""
    if J.shape[1] == 0 or J.shape[2] == 0:
        return np.zeros(len(J), dtype=int)
    s = _singular_values(p, J, cols)
    return np.sum(s > RANK * np.maximum(s[:, :1], 1.0), axis=1)


def conditioning(p: Plan, J: np.ndarray, cols=None) -> np.ndarray:
    """The conditioning (T,) of each closure Jacobian (T, rows, k) (its columns ``cols``):
    made dimensionless (:func:`_singular_values`), its k-th singular value over its largest
    or 1, whichever is larger (0 where it has fewer rows than columns; 1 without columns):
    ~0 where its columns lose rank, what :func:`~linkdyn.kinematics.positions.singular`
    weighs against the closure residual."""
    k = J.shape[2]
    if k == 0:
        return np.ones(len(J))
    if J.shape[1] < k:
        return np.zeros(len(J))
    s = _singular_values(p, J, cols)
    return s[:, k - 1] / np.maximum(s[:, 0], 1.0)


def _singular_values(p: Plan, J: np.ndarray, cols=None) -> np.ndarray:
    """The singular values (T, min(rows, k)) of the closure Jacobians ``J`` (T, rows, k) (the
    tree coordinates ``cols``, default all) made dimensionless: length rows over the
    mechanism's size, length columns times it."""
    lengths = p.length_coordinate if cols is None else p.length_coordinate[cols]
    Jn = ((J / np.where(p.length_row, _size(p), 1.0)[..., None])
          * np.where(lengths, _size(p), 1.0)[..., None, :])
    return np.linalg.svd(Jn, compute_uv=False)


# ---------------------------------------------------------------- following the drivers
def driver_units(model) -> dict:
    """Each joint's coordinate unit in the file, for the messages: (name, SI size)."""
    from ..io.units import ANGLE_UNITS, LENGTH_UNITS
    out = {}
    for j in model.joints:
        if sj.get(j.kind).angular:
            out[j.name] = (model.angle_unit, ANGLE_UNITS.get(model.angle_unit, 1.0))
        else:
            out[j.name] = (model.length_unit, LENGTH_UNITS.get(model.length_unit, 1.0))
    return out


def _fail(model, t, values, why: str, fix: str) -> AssemblyError:
    return AssemblyError(why, file=model.source, time=float(t),
                         drivers={d.joint: float(v) for d, v in zip(model.drivers, values)},
                         fix=fix, units=driver_units(model))


def driver_motion(model, t: np.ndarray):
    """The drivers' ``(q, qd, qdd)``, each (T, n_drivers)."""
    if not model.drivers:
        z = np.zeros((len(t), 0))
        return z, z, z
    out = [d.motion.evaluate(t) for d in model.drivers]
    return tuple(np.stack([np.broadcast_to(o[k], t.shape) for o in out], -1) for k in range(3))


def _scale(p: Plan) -> np.ndarray:
    """Each design's continuation step of each driver (D, n_drivers): ``ANGLE_STEP`` for an
    angle, ``LENGTH_STEP`` times the design's size for a length (one design: D = 1)."""
    angular = np.array([p.kinds[p.topo.tree_joint[i]].angular for i in p.topo.driven], bool)
    return np.where(angular, ANGLE_STEP, LENGTH_STEP * np.atleast_1d(p.size)[:, None])


def _steps(scale: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Continuation steps (...) from driver values ``a`` to ``b`` (..., n_drivers), each
    driver's step ``scale``."""
    if not a.shape[-1]:
        return np.ones(a.shape[:-1], dtype=int)
    return np.maximum(1, np.ceil(np.max(np.abs(b - a) / scale, -1))).astype(int)


def _nodes(scale: np.ndarray, qi: np.ndarray) -> list:
    """The continuation nodes of one design's driver values ``qi`` (T, n_drivers): the first
    sample, each sample where the drivers have moved by more than a step from the last node,
    and the last sample (each next node searched in windows of samples, not one by one)."""
    nodes, T = [0], len(qi)
    while nodes[-1] < T - 1:
        last, width = nodes[-1], 64
        while True:
            ahead = qi[last + 1:last + 1 + width]
            moved = np.flatnonzero(_steps(scale, qi[last], ahead) > 1)
            if len(moved) or last + width >= T - 1:
                nodes.append(last + 1 + int(moved[0]) if len(moved) else T - 1)
                break
            width *= 2
    return nodes


def assemble(model, p: Plan, t: np.ndarray, qi: np.ndarray) -> np.ndarray:
    """Coordinates (T, n_q) closing the loops at every sample, on the branch the design pose
    picks (:func:`assemble_designs` of this one design).

    Raises
    ------
    AssemblyError
        Naming the time and driver values where the loop stops closing or passes a singular
        position (the dependent coordinates' Jacobian loses rank).
    ModelError
        A mobility from the closure Jacobian's rank that differs from the number of drivers.
    """
    q, errors = assemble_designs([model], p, t, qi)
    if errors[0] is not None:
        raise errors[0]
    return q


def assemble_designs(models, p: Plan, t: np.ndarray, qi: np.ndarray):
    """Close the loops of D designs at the T samples ``t``, all designs together: continuation
    from each design's pose to its first sample, then from node to node along the samples (a
    node where its drivers have moved by a step), each sample then solved from its nodes'
    solutions, every design's samples in one Newton solve.

    Parameters
    ----------
    models : sequence of Model
        The D designs (one: ``p`` is its plan; more: ``p`` their batch plan, :func:`designs`).
    qi : ndarray (D T, n_drivers)
        The drivers' coordinates, design after design.

    Returns
    -------
    q : ndarray (D T, n_q)
        The tree coordinates: NaN for a design that fails, and for a design whose loops stop
        closing along the run at the samples from there on (its branch ends: the samples
        before it are closed, as a planar model's branch, ``positions.Branch.ended``).
    errors : list
        Per design None, or the AssemblyError or ModelError :func:`assemble` raises for it
        alone (each design's continuation is its own: its nodes, its steps).
    """
    D, T = len(models), len(t)
    model, dep, drv = models[0], p.dependent, p.driven
    pd = take(p, np.arange(D) * T)                      # one row per design
    q0 = np.broadcast_to(pd.q0, (D, p.n_q))
    scale = np.broadcast_to(_scale(pd), (D, len(drv)))
    Q = qi.reshape(D, T, len(drv))
    # each design's nodes: one list per distinct (driver history, step)
    if D == 1:
        keys, group = np.zeros(1), np.zeros(1, int)
    else:
        keys, group = np.unique(np.concatenate([Q.reshape(D, T * len(drv)), scale,
                                                np.zeros((D, 1))], 1), axis=0,
                                return_inverse=True)
        group = np.ravel(group)
    lists = [_nodes(scale[int(np.argmax(group == g))], Q[int(np.argmax(group == g))])
             for g in range(len(keys))]
    K = max(len(x) for x in lists)
    node = np.full((D, K), -1)
    for g, x in enumerate(lists):
        node[group == g, :len(x)] = x
    errors = [None] * D
    alive = np.ones(D, bool)
    end = np.full(D, T)         # each design's first sample whose loops do not close (T: none)
    q = np.repeat(q0, T, axis=0)
    q[:, drv] = qi
    here, last = q0.copy(), q0.copy()
    has_last = np.zeros(D, bool)
    start, previous = q0[:, drv].copy(), np.full(D, -1)
    for i in range(K):
        idx = np.flatnonzero(alive & (node[:, i] >= 0))
        k = node[idx, i]
        target = Q[idx, k]
        n = _steps(scale[idx], start[idx], target)
        for step in range(int(np.max(n, initial=0))):
            sub = np.flatnonzero(alive[idx] & (step < n))
            dd = idx[sub]
            if not len(dd):
                break
            u = (step + 1) / n[sub]
            guess = here[dd].copy()
            guess[:, drv] = start[dd] + u[:, None] * (target[sub] - start[dd])
            # secant predictor from the last two solutions
            new, old = guess[:, drv] - here[dd][:, drv], here[dd][:, drv] - last[dd][:, drv]
            den = np.sum(old * old, 1)
            ratio = np.where(has_last[dd] & (den > 0), np.sum(new * old, 1)
                             / np.where(den > 0, den, 1.0), 0.0)
            guess[:, dep] += ratio[:, None] * (here[dd][:, dep] - last[dd][:, dep])
            sol, err = newton(model, take(pd, dd), guess)
            bad = err > CLOSED
            for j in np.flatnonzero(bad):             # the designs that stop here: their error
                d = int(dd[j])
                if previous[d] < 0:
                    errors[d] = _fail(models[d], t[0], guess[j, drv], "the mechanism cannot be "
                                      "assembled from its design pose", "Check the geometry, or "
                                      "give a design pose nearer the first sample's")
                    end[d] = 0
                else:
                    errors[d], end[d] = _first_open(models[d], take(pd, [d]), t, Q[d],
                                                    int(previous[d]), int(node[d, i]), here[d])
                alive[d] = False
            ok = dd[~bad]
            last[ok], here[ok], has_last[ok] = here[ok], sol[~bad], True
        done = idx[alive[idx]]
        first = done[previous[done] < 0]
        if len(first):                                  # at the assembly: the mobility
            for d, e in zip(first, _mobility_errors([models[d] for d in first],
                                                    take(pd, first), here[first])):
                if e is not None:
                    errors[d], alive[d], end[d] = e, False, 0
            done = idx[alive[idx]]
        q[done * T + node[done, i]] = here[done]
        start[done], previous[done] = Q[done, node[done, i]], node[done, i]
    # every sample's guess from its nodes' solutions: between the node at or before it and the
    # next, in proportion to the drivers' travel (a branch that ends: from the last node it
    # reached)
    guess = np.full_like(q, np.nan)
    for g, x in enumerate(lists):
        ds = np.flatnonzero((end > 0) & (group == g))
        if not len(ds):
            continue
        x = np.asarray(x)
        a = x[np.searchsorted(x, np.arange(T), side="right") - 1]
        b = x[np.minimum(np.searchsorted(x, np.arange(T), side="left"), len(x) - 1)]
        b = np.where(b[None] > previous[ds, None], a[None], b[None])     # (designs, T)
        guess.reshape(D, T, -1)[ds] = _between(Q[ds], q.reshape(D, T, -1)[ds], drv, a, b)
    # then the samples before each branch's end level by level (:func:`_levels`): a coarse set
    # from those guesses, then each sample halfway between two closed ones from them (the same
    # rule: nearer, so Newton takes fewer steps), from its nodes where either did not close
    out = np.full((D, T, p.n_q), np.nan)
    err = np.full((D, T), np.inf)
    live = np.flatnonzero(end > 0)
    for k, lo, hi in _levels(T) if len(live) else ():
        g = guess.reshape(D, T, -1)[live][:, k]
        if lo is not None:
            near = (err[live][:, lo] <= CLOSED) & (err[live][:, hi] <= CLOSED)
            g = np.where(near[..., None], _between(Q[live], out[live], drv, lo, hi, k), g)
        dl, kl = np.nonzero(k[None] < end[live, None])     # the samples before the branch's end
        if not len(dl):
            continue
        sol, e = newton(model, take(p, live[dl] * T + k[kl]), g[dl, kl])
        out[live[dl], k[kl]] = sol
        err[live[dl], k[kl]] = e
    q = out.reshape(D * T, -1)
    bad = (np.arange(T)[None] < end[:, None]) & (err > CLOSED)
    for d in np.flatnonzero(np.any(bad, 1)):
        k = int(np.argmax(bad[d]))
        errors[d] = _fail(models[d], t[k], Q[d, k], "the loops stop closing",
                          "Check the driver's range: the mechanism cannot reach this "
                          "driver value")
        end[d] = k
    q[~(np.arange(T)[None] < end[:, None]).ravel()] = np.nan    # past each branch's end
    return q, errors


def _between(qi: np.ndarray, q: np.ndarray, drv, a, b, at=None) -> np.ndarray:
    """Guesses (D, K, n_q) at the samples ``at`` (K,) (default every sample) from the closed
    coordinates ``q`` (D, T, n_q) at the samples ``a`` and ``b`` (K,) or (D, K) around them, in
    proportion to the drivers' travel ``qi`` (D, T, n_drivers) from a towards b (the drivers'
    own coordinates exact)."""
    D = qi.shape[0]
    at = np.arange(qi.shape[1]) if at is None else at
    a, b, at = (np.broadcast_to(i, (D, np.shape(i)[-1])) for i in (a, b, at))

    def pick(x, i):   # x[d, i[d, k]]
        return np.take_along_axis(x, i[..., None], 1)

    span = pick(qi, b) - pick(qi, a)
    s2 = np.sum(span * span, -1)
    u = np.sum((pick(qi, at) - pick(qi, a)) * span, -1) / np.where(s2 > 0, s2, 1.0)
    qa = pick(q, a)
    out = qa + u[..., None] * (pick(q, b) - qa)
    out[..., drv] = pick(qi, at)
    return out


def _levels(T: int, first: int = 32):
    """The order :func:`assemble_designs` closes T samples in: ``(k, lo, hi)`` per level, the
    samples ``k`` (K,) and the closed samples around each (None at the first level: every
    ``S``-th sample and the last, ``S`` the power of two that makes about ``first`` of them),
    then at strides S/2, S/4, ..., 1 the samples halfway between closed ones (``lo = k - s``,
    ``hi = k + s`` or the last sample)."""
    if T < 1:
        return
    S = 1 << max(0, int(np.log2(max(T / first, 1.0))))
    yield np.unique(np.r_[np.arange(0, T, S), T - 1]), None, None
    s = S // 2
    while s >= 1:
        k = np.arange(s, T - 1, 2 * s)
        if len(k):
            yield k, k - s, np.minimum(k + s, T - 1)
        s //= 2


def _first_open(model, p: Plan, t, qi, previous: int, k: int, here: np.ndarray):
    """The AssemblyError of the first sample after node ``previous`` (solved: ``here``) up to
    node ``k`` where the loops stop closing, following them sample by sample (``p``: this
    design's plan, one row), and that sample's index (the branch's end: the samples before it
    close)."""
    for m in range(previous + 1, k + 1):
        guess = here.copy()
        guess[p.driven] = qi[m]
        sol, err = newton(model, p, guess[None])
        if err[0] > CLOSED:
            g, _, J = closure(model, p, poses(p, here[None]))
            if _singular(p, J, g)[0]:                   # stuck at a singular position
                return _fail(model, t[m - 1], qi[m - 1], SINGULAR, SINGULAR_FIX), m
            return _fail(model, t[m], qi[m], "the loops stop closing",
                         "Check the geometry and the driver's range: the mechanism cannot "
                         "reach this driver value (a limit position lies before it)"), m
        here = sol[0]
    return _fail(model, t[k], qi[k], "the loops stop closing",
                 "Check the geometry and the driver's range: the mechanism cannot reach this "
                 "driver value"), k


def _mobility_errors(models, p: Plan, q: np.ndarray) -> list:
    """At the assembly ``q`` (D, n_q) of designs ``models`` (``p``: their plan, a row each):
    the mobility from the closure Jacobian's rank, ``n_q - rank J``, must equal the number
    of drivers; per design None or the ModelError (exit 2)."""
    _, _, J = closure(models[0], p, poses(p, q))
    out = []
    for model, mob in zip(models, p.n_q - rank_of(p, J)):
        mob = int(mob)
        out.append(None if mob == len(model.drivers) else ModelError(
            f"the mechanism has mobility {mob} (from the closure Jacobian's rank at the "
            f"assembly; Grübler–Kutzbach gives {p.topo.mobility}) but "
            f"{len(model.drivers)} driver(s)", file=model.source, field="drivers",
            fix="Give one driver per degree of freedom" if mob > len(model.drivers) else
            "Remove drivers, or check the joints and axes"))
    return out


@dataclass(frozen=True)
class Motion:
    """The kinematics of a spatial model at the samples (SI, global).

    ``q``, ``qd``, ``qdd`` (T, n_q) tree coordinates; ``tree`` the poses; ``V``, ``A``
    (T, n, 6) twists and twist rates about O; ``phi`` (T, rows, 6) and ``J`` (T, rows, n_q)
    the closure rows and Jacobian; ``residual`` (T,) the scaled closure error."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tree: Tree
    V: np.ndarray
    A: np.ndarray
    phi: np.ndarray
    J: np.ndarray
    residual: np.ndarray


def solve(model, p: Plan, t: np.ndarray) -> Motion:
    """Positions, rates and accelerations at the times ``t`` (T,): the drivers' motion gives
    the independent coordinates; the dependent ones close the loops (:func:`assemble`), then
    :func:`motion_at`; exit 3 where ``J_dep`` loses rank (:func:`solve_designs` of this one
    design)."""
    m, _, errors = solve_designs([model], p, t)
    if errors[0] is not None:
        raise errors[0]
    return m


def solve_designs(models, p: Plan, t: np.ndarray):
    """:func:`solve` of D designs at once (``p``: their batch plan, :func:`designs`, or the
    one design's plan).

    Returns
    -------
    motion : Motion
        The kinematics at the rows of the designs ``kept`` (each design's T samples, design
        after design; ``t`` (T,) for one design, the rows' times for a batch).
    kept : ndarray of int
        The designs that assemble (a design that passes a singular position, or whose loops
        stop closing along the run, is kept, its error given; the samples where its loops do
        not close have an infinite ``Motion.residual``, their other numbers those of the
        design pose at the drivers' values, for :func:`singular_samples` to flag).
    errors : list
        Per design None, or the AssemblyError or ModelError :func:`solve` raises for it alone.
    """
    D, T = len(models), len(t)
    qi, qdi, qddi = driver_motions(models, t)
    q, errors = assemble_designs(models, p, t, qi)
    closed = np.all(np.isfinite(q), 1).reshape(D, T)
    kept = np.array([d for d in range(D) if errors[d] is None
                     or (isinstance(errors[d], AssemblyError) and closed[d, 0])], dtype=int)
    rows = (kept[:, None] * T + np.arange(T)).ravel()
    pr = take(p, rows)
    q, shut = q[rows], closed[kept].ravel()
    if not np.all(shut):       # past a branch's end: the design pose at the drivers' values
        q[~shut] = np.broadcast_to(pr.q0, q.shape)[~shut]
        q[np.ix_(~shut, p.driven)] = qi[rows][~shut]
    m = motion_at(models[0], pr, t if p.row is None else np.tile(t, len(kept)),
                  q, qdi[rows], qddi[rows])
    if not np.all(shut):
        m = replace(m, residual=np.where(shut, m.residual, np.inf))
    singular = singular_samples(pr, m).reshape(len(kept), T) & closed[kept]
    for j in np.flatnonzero(np.any(singular, 1)):
        k = int(np.argmax(singular[j]))
        d = int(kept[j])
        errors[d] = _fail(models[d], t[k], qi[d * T + k], SINGULAR, SINGULAR_FIX)
    return m, kept, errors


def singular_samples(p: Plan, m: Motion) -> np.ndarray:
    """The samples (T,) bool of ``m`` at a singular position, or within the closure's
    resolution of one: the dependent coordinates' closure Jacobian ``J_dep`` loses rank there,
    so their rates and accelerations are not determined by the drivers' (its
    :func:`conditioning` weighed against the sample's closure residual by
    :func:`linkdyn.kinematics.positions.singular`, the planar test)."""
    return _singular(p, m.J, residual=m.residual)


def _singular(p: Plan, J: np.ndarray, g: np.ndarray | None = None,
              residual: np.ndarray | None = None) -> np.ndarray:
    """:func:`singular_samples` of the closure Jacobians ``J`` (T, rows, n_q) closed to the
    residual rows ``g`` (T, rows) or the scaled ``residual`` (T,)."""
    if residual is None:
        residual = np.max(np.abs(scaled(p, g)), axis=1, initial=0.0)
    dep = p.dependent
    return singular(conditioning(p, J[:, :, dep], dep), residual)


def driver_motions(models, t: np.ndarray):
    """The drivers' ``(q, qd, qdd)`` of D designs, each (D T, n_drivers), design after design
    (:func:`driver_motion` once where every design has the first one's drivers)."""
    first = driver_motion(models[0], t)
    try:
        same = all(m.drivers == models[0].drivers for m in models[1:])
    except ValueError:      # drivers holding arrays: not comparable as a whole
        same = False
    if same:
        return tuple(np.tile(x, (len(models), 1)) for x in first)
    each = [first] + [driver_motion(m, t) for m in models[1:]]
    return tuple(np.concatenate([e[k] for e in each]) for k in range(3))


def motion_at(model, p: Plan, t: np.ndarray, q: np.ndarray, qdi: np.ndarray,
              qddi: np.ndarray) -> Motion:
    """The kinematics at closed coordinates ``q`` (T, n_q) with the independent coordinates'
    (``Plan.driven``) rates ``qdi`` and accelerations ``qddi`` (T, n_driven): the dependent
    rates and accelerations solve ``J_dep qd_dep = -J_ind qd_ind`` and ``J_dep qdd_dep =
    -(phi . (A_B - A_A) + gamma)`` with ``qdd_dep = 0`` in ``A``, least squares."""
    tree = poses(p, q)
    g, phi, J = closure(model, p, tree)
    dep = p.dependent
    qd = np.zeros_like(q)
    qd[:, p.driven] = qdi
    solver = sa.Solver(J[:, :, dep], 1e-12)           # J_dep factored once, solved twice
    qd[:, dep] = solver.solve(-np.einsum("trk,tk->tr", J, qd))
    V = twists(p, tree, qd)
    qdd = np.zeros_like(q)
    qdd[:, p.driven] = qddi
    A0 = twist_rates(p, tree, V, qd, qdd)
    # phi . (A_B - A_A) + gamma with qdd_dep = 0, then J_dep qdd_dep = -that
    rho = _relative(model, p, phi, A0) + closure_bias(model, p, tree, V)
    qdd[:, dep] = solver.solve(-rho)
    A = twist_rates(p, tree, V, qd, qdd)
    return Motion(t, q, qd, qdd, tree, V, A, phi, J, np.max(np.abs(scaled(p, g)), axis=1,
                                                             initial=0.0))


def _relative(model, p: Plan, phi: np.ndarray, X: np.ndarray) -> np.ndarray:
    """``phi . (X_B - X_A)`` (T, rows) of the cut joints' rows for body twists or rates X."""
    out, r = [], 0
    for j in p.topo.cut:
        jt = model.joints[j]
        a, b = p.topo.bodies.index(jt.body_a), p.topo.bodies.index(jt.body_b)
        k = p.kinds[j].rows
        out.append(np.einsum("trs,ts->tr", phi[:, r:r + k], X[:, b] - X[:, a]))
        r += k
    return np.concatenate(out, 1) if out else np.zeros((X.shape[0], 0))


def redundant_rows(model, p: Plan, J: np.ndarray) -> tuple:
    """The closure rows (``<joint>.<row label>``) that are combinations of the rows before
    them in the Jacobian ``J`` (rows, n_q) at one sample (rank as :func:`rank_of`
    counts it)."""
    labels = [f"{model.joints[j].name}.{lab}" for j in p.topo.cut for lab in p.kinds[j].row_labels]
    kept, out = [], []
    for r, label in enumerate(labels):
        trial = kept + [r]
        if int(rank_of(_rows(p, trial), J[None, trial])[0]) > len(kept):
            kept = trial
        else:
            out.append(label)
    return tuple(out)


def _rows(p: Plan, rows: list) -> sk.Plan:
    """``p`` seen through some of its closure rows (their length flags), for ranks."""
    from dataclasses import replace
    return replace(p, length_row=p.length_row[rows])
