"""Spatial kinematics: the tree's poses, twists and twist rates from the joint coordinates, the
loop closure by Newton's method with continuation, and the rates and accelerations.

The generalized coordinates ``q`` (T, n_q) are every tree joint's coordinates (its kind's
chain of elementary screws), body by body in tree order. The drivers prescribe some of them
(``Plan.driven``); the others (``Plan.dependent``) follow from the closure of the cut joints,
``g(q) = 0``, whose Jacobian ``J = dg/dq`` (T, rows, n_q) has the rows ``phi^T (s_B - s_A)``.
Redundant closure rows (a planar loop in space) are fine: every solve is least squares.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import topology as topology_mod
from ..errors import AssemblyError, ModelError
from . import algebra as sa
from . import joints as sj

RANK = 1e-9          # a singular value below this fraction of the largest counts as zero
CLOSED = 1e-10       # closure: a residual row below this (times the size for a length) is closed
SINGULAR = "the mechanism passes a singular position (the dependent joints' Jacobian loses rank)"
SINGULAR_FIX = ("Limit the driver's range, or change the geometry so the loops do not reach a "
                "dead-centre or locked position")
ANGLE_STEP = 0.3     # rad, continuation step of an angular driver
LENGTH_STEP = 0.1    # of the mechanism's size, continuation step of a sliding driver


@dataclass(frozen=True)
class Plan:
    """The numeric form of a spatial model that the stages read (one design).

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
            rp = o[:, par] + RA @ g.p
            RB = RA @ Rrel
            rq = rp + sa.matvec(RA, d)
            R[:, i], o[:, i] = RB, rq - RB @ g.q
        else:            # child A: R_A = R_B R_rel^T, r_Ap = r_Bq - R_A d
            RB = R[:, par]
            rq = o[:, par] + RB @ g.q
            RA = RB @ np.swapaxes(Rrel, -1, -2)
            R[:, i], o[:, i] = RA, rq - sa.matvec(RA, d) - RA @ g.p
        c[:, i] = rq
        S.append(s * kind.screws(g, RA, RB, rq, qi))
    return Tree(R, o, c, S)


def joint_pose(p: Plan, tree: Tree, j: int, model_joint) -> sj.Pose:
    """A joint's :class:`~linkdyn.spatial.joints.Pose` at the samples."""
    a, b = p.topo.bodies.index(model_joint.body_a), p.topo.bodies.index(model_joint.body_b)
    g = p.geometry[j]
    return sj.Pose(tree.R[:, a], tree.R[:, b], tree.o[:, a] + tree.R[:, a] @ g.p,
                   tree.o[:, b] + tree.R[:, b] @ g.q)


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
        q[:, ang] = np.unwrap(q[:, ang], axis=0)
        S = kind.screws(g, pose.RA, pose.RB, pose.rq, q)
        St = np.swapaxes(S, -1, -2)
        qd, _, _ = sa.lstsq(St, m.V[:, b] - m.V[:, a], 1e-12)
        rhs = m.A[:, b] - m.A[:, a] - chain_bias(S, qd, m.V[:, a])
        qdd, _, _ = sa.lstsq(St, rhs, 1e-12)
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
    return g / np.where(p.length_row, p.size, 1.0)


def newton(model, p: Plan, q: np.ndarray, iterations: int = 30) -> tuple[np.ndarray, np.ndarray]:
    """Close the loops from the guess ``q`` (T, n_q), moving the dependent coordinates by
    Gauss-Newton steps (least squares, so redundant rows are fine); a sample stops when it is
    closed exactly, or closed and its error no longer halves (rounding). Returns ``(q,
    error)``, error (T,) the largest scaled residual."""
    q = q.copy()
    dep = p.dependent
    err = np.full(len(q), np.inf)
    active = np.arange(len(q))
    for _ in range(iterations):
        g, _, J = closure(model, p, poses(p, q[active]))
        before, err[active] = err[active], np.max(np.abs(scaled(p, g)), axis=1, initial=0.0)
        at_rounding = (err[active] == 0) | ((err[active] < CLOSED)
                                           & (err[active] > 0.5 * before))
        active, g, J = active[~at_rounding], g[~at_rounding], J[~at_rounding]
        if not len(active):
            break
        step, _, _ = sa.lstsq(J[:, :, dep], g, 1e-12)
        q[np.ix_(active, dep)] -= step
    else:
        g, _, _ = closure(model, p, poses(p, q[active]))
        err[active] = np.max(np.abs(scaled(p, g)), axis=1, initial=0.0)
    return q, err


def rank_of(p: Plan, J: np.ndarray, cols=None) -> np.ndarray:
    """The numerical rank (T,) of each closure Jacobian (T, rows, k) (its columns ``cols`` of
    the tree coordinates, default all): of ``J`` made dimensionless (length rows over the
    mechanism's size, length columns times it), counting singular values above ``RANK``
    times the largest or 1, whichever is larger (a Jacobian of round-off alone, a wholly
    redundant loop, has rank 0)."""
    if J.shape[1] == 0 or J.shape[2] == 0:
        return np.zeros(len(J), dtype=int)
    lengths = p.length_coordinate if cols is None else p.length_coordinate[cols]
    Jn = (J / np.where(p.length_row, p.size, 1.0)[:, None]) * np.where(lengths, p.size, 1.0)
    s = np.linalg.svd(Jn, compute_uv=False)
    return np.sum(s > RANK * np.maximum(s[:, :1], 1.0), axis=1)


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


def _steps(p: Plan, a: np.ndarray, b: np.ndarray) -> int:
    """Continuation steps from driver values ``a`` to ``b`` (n_drivers,)."""
    if not len(a):
        return 1
    scale = np.array([ANGLE_STEP if p.kinds[p.topo.tree_joint[i]].angular
                      else LENGTH_STEP * p.size for i in p.topo.driven])
    return max(1, int(np.ceil(np.max(np.abs(b - a) / scale))))


def assemble(model, p: Plan, t: np.ndarray, qi: np.ndarray) -> np.ndarray:
    """Coordinates (T, n_q) closing the loops at every sample, on the branch the design pose
    picks: continuation from the design pose to the first sample, then from node to node
    along the samples (a node where the drivers have moved by a step), each sample then
    solved from its node's solution, all samples together.

    Raises
    ------
    AssemblyError
        Naming the time and driver values where the loop stops closing or passes a singular
        position (the dependent coordinates' Jacobian loses rank).
    ModelError
        A mobility from the closure Jacobian's rank that differs from the number of drivers.
    """
    T = len(t)
    q = np.tile(p.q0, (T, 1))
    q[:, p.driven] = qi
    here = p.q0.copy()
    # design pose -> first sample, then node to node
    nodes = [0]
    for k in range(1, T):
        if _steps(p, qi[nodes[-1]], qi[k]) > 1 or k == T - 1:
            nodes.append(k)
    start, previous, last = p.q0[p.driven], None, None
    for k in nodes:
        n = _steps(p, start, qi[k])
        for u in np.linspace(0, 1, n + 1)[1:]:
            guess = here.copy()
            guess[p.driven] = start + u * (qi[k] - start)
            if last is not None:     # secant predictor from the last two solutions
                ratio = _ratio(guess[p.driven] - here[p.driven], here[p.driven] - last[p.driven])
                guess[p.dependent] += ratio * (here[p.dependent] - last[p.dependent])
            sol, err = newton(model, p, guess[None])
            if err[0] > CLOSED:
                if previous is None:
                    raise _fail(model, t[0], guess[p.driven], "the mechanism cannot be "
                                "assembled from its design pose", "Check the geometry, or give "
                                "a design pose nearer the first sample's")
                _first_open(model, p, t, qi, previous, k, here)
            last, here = here, sol[0]
        if previous is None:
            _check_mobility(model, p, here)
        q[k] = here
        start, previous = qi[k], k
    # every sample from its nodes' solutions: between the node at or before it and the next,
    # in proportion to the drivers' travel
    nodes = np.asarray(nodes)
    a = nodes[np.searchsorted(nodes, np.arange(T), side="right") - 1]
    b = nodes[np.minimum(np.searchsorted(nodes, np.arange(T), side="left"), len(nodes) - 1)]
    span = qi[b] - qi[a]
    u = np.sum((qi - qi[a]) * span, 1) / np.where(np.sum(span * span, 1) > 0,
                                                  np.sum(span * span, 1), 1.0)
    guess = q[a] + u[:, None] * (q[b] - q[a])
    guess[:, p.driven] = qi
    q, err = newton(model, p, guess)
    bad = np.flatnonzero(err > CLOSED)
    if len(bad):
        k = int(bad[0])
        raise _fail(model, t[k], qi[k], "the loops stop closing",
                    "Check the driver's range: the mechanism cannot reach this driver value")
    return q


def _first_open(model, p: Plan, t, qi, previous: int, k: int, here: np.ndarray):
    """Raise the AssemblyError of the first sample after node ``previous`` (solved: ``here``)
    up to node ``k`` where the loops stop closing, following them sample by sample."""
    for m in range(previous + 1, k + 1):
        guess = here.copy()
        guess[p.driven] = qi[m]
        sol, err = newton(model, p, guess[None])
        if err[0] > CLOSED:
            jd = closure(model, p, poses(p, here[None]))[2][:, :, p.dependent]
            if rank_of(p, jd, p.dependent)[0] < len(p.dependent):     # stuck at a singular position
                raise _fail(model, t[m - 1], qi[m - 1], SINGULAR, SINGULAR_FIX)
            raise _fail(model, t[m], qi[m], "the loops stop closing",
                        "Check the geometry and the driver's range: the mechanism cannot "
                        "reach this driver value (a limit position lies before it)")
        here = sol[0]
    raise _fail(model, t[k], qi[k], "the loops stop closing",
                "Check the geometry and the driver's range: the mechanism cannot reach this "
                "driver value")


def _ratio(new: np.ndarray, old: np.ndarray) -> float:
    """How far ``new`` goes along ``old`` (driver steps): ``new . old / old . old``, 0 for none."""
    den = float(old @ old)
    return float(new @ old) / den if den > 0 else 0.0


def _check_mobility(model, p: Plan, q: np.ndarray) -> None:
    """At the assembly: the mobility from the closure Jacobian's rank, ``n_q - rank J``, must
    equal the number of drivers (exit 2 otherwise)."""
    _, _, J = closure(model, p, poses(p, q[None]))
    mob = p.n_q - int(rank_of(p, J)[0])
    if mob != len(model.drivers):
        raise ModelError(
            f"the mechanism has mobility {mob} (from the closure Jacobian's rank at the "
            f"assembly; Grübler–Kutzbach gives {p.topo.mobility}) but "
            f"{len(model.drivers)} driver(s)", file=model.source, field="drivers",
            fix="Give one driver per degree of freedom" if mob > len(model.drivers) else
            "Remove drivers, or check the joints and axes")


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
    :func:`motion_at`; exit 3 where ``J_dep`` loses rank."""
    qi, qdi, qddi = driver_motion(model, t)
    q = assemble(model, p, t, qi)
    m = motion_at(model, p, t, q, qdi, qddi)
    dep = p.dependent
    singular = rank_of(p, m.J[:, :, dep], dep) < len(dep)
    if np.any(singular):
        k = int(np.argmax(singular))
        raise _fail(model, t[k], qi[k], SINGULAR, SINGULAR_FIX)
    return m


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
    qd[:, dep], _, _ = sa.lstsq(J[:, :, dep], -np.einsum("trk,tk->tr", J, qd), 1e-12)
    V = twists(p, tree, qd)
    qdd = np.zeros_like(q)
    qdd[:, p.driven] = qddi
    A0 = twist_rates(p, tree, V, qd, qdd)
    # phi . (A_B - A_A) + gamma with qdd_dep = 0, then J_dep qdd_dep = -that
    rho = _relative(model, p, phi, A0) + closure_bias(model, p, tree, V)
    qdd[:, dep], _, _ = sa.lstsq(J[:, :, dep], -rho, 1e-12)
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
