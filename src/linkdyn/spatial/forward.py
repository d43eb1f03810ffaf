"""Forward dynamics of spatial models: the stages :func:`linkdyn.simulate`'s driver
(:mod:`linkdyn.forward`) calls for ``space = "spatial"`` (docs/theory.md, "Spatial forward
dynamics").

The same method as the planar one (F1-F9, F11, F12): the free joint coordinates (``[initial]``,
by their results.csv names ``J1``, ``J3.s``, ``J2.1``) join the drivers' as the independent
coordinates of the tree; the dependent ones close the loops by Newton's method
(:func:`.kinematics.newton`) from the extrapolated guess at every evaluation; the DeNOC
efforts of the independent coordinates (``[E_d, J^T] [tau; lam] = Q``, least squares, so
redundant closure rows are fine) at ``qdd_f = 0`` and at each unit free acceleration give
``H qdd_f = -h``. The free coordinates are kept over the run (no switch at their dead points,
F10: the run stops with exit 3 there).
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from ..balance import energy_drift
from ..brief import brief_repr
from ..errors import AssemblyError, ModelError
from ..model import GROUND, Driver
from ..motion import Free
from ..planar import solve_small
from . import dynamics as sd
from . import kinematics as sk
from .reader import coordinate_names
from .solution import SpatialSolution


@dataclass(frozen=True)
class Partition:
    """The independent coordinates of a spatial simulation.

    Attributes
    ----------
    model : Model
        The user's model.
    inner : Model
        The same with one placeholder driver per free coordinate after the real drivers (so
        the topology keeps the free joints in the tree).
    plan : Plan
        ``inner``'s plan whose ``driven`` are the drivers' coordinates then the free ones.
    free : tuple[str, ...]
        The free coordinates' names (``J1``, ``J3.s``, ...).
    """

    __repr__ = brief_repr

    model: object
    inner: object
    plan: sk.Plan
    free: tuple

    @property
    def n_drivers(self) -> int:
        return len(self.model.drivers)

    @property
    def n(self) -> int:
        """Tree coordinates."""
        return self.plan.n_q

    @property
    def free_rows(self) -> list:
        """The free coordinates' indices in the tree coordinates."""
        return [int(k) for k in self.plan.driven[self.n_drivers:]]

    @property
    def angular(self) -> np.ndarray:
        """Which free coordinates are angles (bool, nf)."""
        return ~self.plan.length_coordinate[self.free_rows]


def coordinate_rows(model, p: sk.Plan, names) -> dict:
    """The column in the tree coordinates of each coordinate of ``names`` (``J1``, ``J3.s``)
    whose joint is a tree joint of ``p``, by name."""
    coords = coordinate_names(model.joints)
    body = {p.topo.tree_joint[i]: i for i in range(1, p.topo.n)}
    index = [j.name for j in model.joints].index
    return {c: p.cols[body[index(coords[c][0])]].start + coords[c][1] for c in names
            if index(coords[c][0]) in body}


def _partition(model, free: tuple) -> Partition:
    names = coordinate_names(model.joints)
    joints = [names[c][0] for c in free]
    # a free joint stays in the tree: a [topology] cut naming one gives way to the automatic
    cut = None if model.cut and set(model.cut) & set(joints) else model.cut
    inner = replace(model, cut=cut, drivers=model.drivers + tuple(
        Driver(j, Free(), "free (integrated)") for j in joints))
    p = sk.plan(inner)
    rows = list(coordinate_rows(model, p, free).values())
    driven = np.array(list(p.driven[:len(model.drivers)]) + rows, dtype=int)
    dependent = np.array([k for k in range(p.n_q) if k not in set(driven.tolist())], dtype=int)
    return Partition(model, inner, replace(p, driven=driven, dependent=dependent), tuple(free))


def partition(model, free: tuple | None = None) -> Partition:
    """The free coordinates: ``free``, else those named in ``[initial]``, else the first
    coordinates (file order) whose dependent coordinates are determined at the design pose
    closed with the drivers at t = 0.

    Raises
    ------
    ModelError
        No free freedom (mobility from the closure Jacobian's rank), or ``[initial]`` naming
        the wrong count.
    """
    src = model.source
    p = sk.plan(model)
    q = _closed_design(model, p)
    _, _, J = sk.closure(model, p, sk.poses(p, q[None]))
    mob = p.n_q - int(sk.rank_of(p, J)[0])
    nf = mob - len(model.drivers)
    if nf <= 0:
        raise ModelError(
            f"the mechanism has no free degree of freedom (mobility {mob} from the closure "
            f"Jacobian's rank, {len(model.drivers)} driver(s)): its motion is prescribed",
            file=src, field="drivers" if nf == 0 else "joints",
            fix="Use `linkdyn analyze` for a fully driven mechanism, or remove a driver to let "
                "that joint move under the loads")
    section = "initial.q" if model.initial_q else "initial.qd"
    given = tuple(free or model.initial_q or model.initial_qd)
    if model.initial_q and set(model.initial_qd) - set(model.initial_q):
        c = sorted(set(model.initial_qd) - set(model.initial_q))[0]
        raise ModelError(f"coordinate '{c}' has a rate but no value in [initial]", file=src,
                         field=f"initial.qd.{c}",
                         fix=f"Give rates of the coordinates in initial.q "
                             f"({', '.join(model.initial_q)})")
    if given:
        if len(given) != nf:
            raise ModelError(
                f"[initial] names {len(given)} coordinate(s) but the mechanism has {nf} free "
                f"degree(s) of freedom (mobility {mob} minus {len(model.drivers)} driver(s))",
                file=src, field=section,
                fix=f"Give exactly {nf} joint coordinate(s), one per free degree of freedom")
        part = _partition(model, given)
        if not _determined(part):
            raise ModelError(
                f"the free coordinates ({', '.join(given)}) do not describe the mechanism at "
                "its design pose: other coordinates stay undetermined", file=src,
                field=section, fix="Name other joint coordinates in [initial]")
        return part
    driven = {d.joint for d in model.drivers}
    candidates = [c for c, (j, _, _) in coordinate_names(model.joints).items()
                  if j not in driven]
    best = _best_conditioned(model, p, q, J[0], candidates, nf)
    for combo in itertools.chain([best], itertools.islice(
            itertools.combinations(candidates, nf), 200)):
        try:
            part = _partition(model, combo)
        except ModelError:
            continue
        if _determined(part):
            return part
    raise ModelError("no choice of free joint coordinates describes the mechanism at its "
                     "design pose", file=src, field="initial",
                     fix='Name the free coordinates in [initial] q = { J1 = value }')


def _best_conditioned(model, p: sk.Plan, q: np.ndarray, J: np.ndarray, candidates: list,
                      nf: int) -> tuple:
    """The ``nf`` candidate coordinates (names) that best describe the motion at the closed
    pose ``q`` (n_q,) of closure Jacobian ``J`` (rows, n_q) (F10's choice): QR with column
    pivoting of the candidates' rows of the closure's null space (lengths times the size)."""
    import scipy.linalg as sl
    rows = coordinate_rows(model, p, candidates)
    free = np.setdiff1d(np.arange(p.n_q), p.driven)
    A = J[:, free] * np.where(p.length_coordinate[free], p.size, 1.0)
    V = np.linalg.svd(A)[2][len(free) - nf:].T if len(A) else np.eye(len(free))[:, :nf]
    names = [c for c in candidates if c in rows]
    if len(names) < nf:
        return tuple(candidates[:nf])
    Vc = V[np.searchsorted(free, [rows[c] for c in names])]
    piv = sl.qr(Vc.T, pivoting=True, mode="r")[1][:nf]
    return tuple(names[k] for k in sorted(piv))


def _closed_design(model, p: sk.Plan) -> np.ndarray:
    """The design pose closed (n_q,): the drivers at t = 0, every other coordinate free
    (least-squares Newton steps, the nearest closed pose)."""
    q = p.q0.copy()
    q[p.driven] = sk.driver_motion(model, np.zeros(1))[0][0][:len(p.driven)]
    free = replace(p, dependent=np.setdiff1d(np.arange(p.n_q), p.driven))
    q, err = sk.newton(model, free, q[None])
    if err[0] > sk.CLOSED:
        raise AssemblyError("the mechanism cannot be assembled from its design pose",
                            file=model.source, time=0.0, fix="Check the geometry",
                            drivers={}, units=sk.driver_units(model))
    return q[0]


def _determined(part: Partition) -> bool:
    """Whether the dependent coordinates of ``part`` are determined (``J_dep`` of full column
    rank) at the closed design pose."""
    p = part.plan
    q = _closed_design(part.inner, replace(p, driven=p.driven[:part.n_drivers]))
    _, _, J = sk.closure(part.inner, p, sk.poses(p, q[None]))
    return int(sk.rank_of(p, J[:, :, p.dependent], p.dependent)[0]) == len(p.dependent)


def start_state(part: Partition) -> np.ndarray:
    """Closed tree coordinates (n_q,) at t = 0: drivers at their motion's start, the free
    coordinates at ``[initial] q`` (else the design pose's), continued from the design pose."""
    p, model = part.plan, part.model
    nd = part.n_drivers
    start = p.q0[p.driven].copy()
    start[:nd] = sk.driver_motion(model, np.zeros(1))[0][0]
    start[nd:] = [model.initial_q.get(c, p.q0[k]) for c, k in zip(part.free, part.free_rows)]
    try:
        return sk.assemble(part.inner, p, np.zeros(1), start[None])[0]
    except ModelError as err:        # the mobility at the start is not the design's
        raise AssemblyError(err.message, file=model.source, time=0.0,
                            drivers=values(part, p.q0), units=sk.driver_units(model),
                            fix="Start the free coordinates ([initial] q) elsewhere") from None


class System:
    """The ODE ``y' = F(t, y)`` with ``y = [q_f, qd_f, W]`` of a spatial partition, with the
    interface of :class:`linkdyn.forward.System` (the driver's)."""

    kernel = None          # no compiled right-hand side for spatial models

    def __init__(self, part: Partition, q0: np.ndarray, qd0: np.ndarray, fast: bool = False):
        self.part, self.p, self.model = part, part.plan, part.inner
        self.nd, self.nf = part.n_drivers, len(part.free)
        self.ind, self.dep = self.p.driven, self.p.dependent
        self.set_reference(0.0, q0, qd0)
        self.last = self.bad = None
        self.nfev = 0

    def set_reference(self, t0, q, qd, qdd=None, J=None):
        """The state (time, q, qd, qdd (n_q,)) the guesses are extrapolated from, and the
        closure Jacobian there (rows, n_q) for the dependent coordinates' share of a change of
        the independent ones."""
        S = None
        if J is not None and len(self.dep):
            # dq_dep / dq_ind = -J_dep^+ J_ind at the reference                    (F2)
            S = -np.linalg.pinv(J[:, self.dep]) @ J[:, self.ind]
            S = S if np.all(np.isfinite(S)) else None
        self.ref = (t0, q, qd, np.zeros_like(q) if qdd is None else qdd, S)

    def guess(self, t, q_ind=None) -> np.ndarray:
        """Coordinates (n_q, T) near the solution at ``t`` (T,): the reference extrapolated,
        its dependent rows moved by their share of the independent ones' difference."""
        t0, q, qd, qdd, S = self.ref
        dt = np.asarray(t) - t0
        g = q[:, None] + qd[:, None] * dt + 0.5 * qdd[:, None] * dt**2
        if S is not None and q_ind is not None:
            g[self.dep] += S @ (q_ind - g[self.ind])
        return g

    def reduced(self, t, q_f, qd_f, guess):
        """``H`` (nf, nf, T), ``h`` (nf, T) of ``H qdd_f + h = 0`` at the states ``(t, q_f,
        qd_f)`` (nf, T each but t (T,)) from the coordinate ``guess`` (n_q, T), the efforts
        ``tau`` (1 + nf, T, k) of the independent coordinates in the batch (case 0:
        ``qdd_f = 0``; 1 + j: ``qdd_f = e_j``), its motion and loads, and the closure
        error (T,)."""
        nf, T = self.nf, len(t)
        qd_d, qdd_d = sk.driver_motion(self.part.model, t)[1:]
        q = guess.T.copy()
        q[:, self.ind[self.nd:]] = q_f.T
        q[:, self.ind[:self.nd]] = sk.driver_motion(self.part.model, t)[0]
        q, err = sk.newton(self.model, self.p, q)
        # the 1 + nf cases stacked along the samples (case-major)                  (F5)
        K = 1 + nf
        unit = np.repeat(np.eye(nf + 1)[:, 1:], T, axis=0)            # (K T, nf)
        m = sk.motion_at(self.model, self.p, np.tile(t, K), np.tile(q, (K, 1)),
                         np.tile(np.concatenate((qd_d, qd_f.T), 1), (K, 1)),
                         np.concatenate((np.tile(qdd_d, (K, 1)), unit), 1))
        coords = (sk.joint_coordinates(self.model, self.p, m)
                  if any(getattr(ld.value, "state_variables", ()) for ld in self.model.loads)
                  else {})
        applied = sd.loads(self.model, self.p, m, coords)
        _, _, Q, ke = sd.generalized(self.model, self.p, m, applied)
        _, x, _ = sd.efforts(self.p, m, Q)
        tau = x[:, :len(self.ind)].reshape(K, T, -1)
        # tau_f = H qdd_f + h: h at qdd_f = 0, H's columns the unit responses   (F4-F5)
        h = tau[0, :, self.nd:].T
        H = np.moveaxis(tau[1:, :, self.nd:] - tau[:1, :, self.nd:], 0, 1).T   # (row, col, T)
        self.energy = (float(ke[0]), float(applied.potential_energy[0]))
        return H, h, tau, m, applied, err

    def evaluate(self, t, q_f, qd_f, guess):
        """Free accelerations ``qdd_f`` (nf, T) at the states, the motion of the batch, the
        power of drivers and non-conservative loads (T,) and the closed coordinates (T, n_q)."""
        nd, nf, T = self.nd, self.nf, len(t)
        H, h, tau, m, applied, err = self.reduced(t, q_f, qd_f, guess)
        # no actuator in a free joint: H qdd_f = -h                             (F6)
        qdd_f = solve_small(H, -h)[0] if nf > 1 else -h / H[0]
        # drivers' efforts at the solution (affine in qdd_f) and the power balance   (F8)
        tau_d = tau[0, :, :nd] + np.einsum("ktj,kt->tj", tau[1:, :, :nd] - tau[:1, :, :nd],
                                           qdd_f)
        qd_d = sk.driver_motion(self.part.model, t)[1]
        power = applied.work_power[:T] + np.sum(tau_d * qd_d, axis=1)
        dep = self.dep
        ok = (err <= sk.CLOSED) & (sk.rank_of(self.p, m.J[:T][:, :, dep], dep) == len(dep))
        return np.where(ok, qdd_f, np.nan), m, power, ok

    def __call__(self, t, y):
        nf = self.nf
        self.nfev += 1
        if not np.all(np.isfinite(y)):      # a stage built on a right-hand side not finite
            self.last = (t, y.copy(), None, np.full((nf, 1), np.nan))
            return np.full_like(y, np.nan)
        tt = np.array([t])
        q_ind = np.concatenate((sk.driver_motion(self.part.model, tt)[0][0], y[:nf]))[:, None]
        qdd, m, power, ok = self.evaluate(tt, y[:nf, None], y[nf:2 * nf, None],
                                          self.guess(tt, q_ind))
        self.last = (t, y.copy(), m if ok[0] else None, qdd)
        out = np.concatenate((y[nf:2 * nf], qdd[:, 0], power))
        if not np.all(np.isfinite(out)) and np.all(np.isfinite(y)):
            self.bad = (t, y.copy())
        return out

    def shift(self, rows, by) -> None:
        """Move the reference's coordinates ``rows`` by ``by`` (whole turns of free angles)."""
        t0, q, qd, qdd, S = self.ref
        q = q.copy()
        q[rows] += by
        self.ref = (t0, q, qd, qdd, S)

    def energies(self, t, y) -> tuple[float, float]:
        """Kinetic and potential energy (J) at the state ``(t, y)``."""
        if self.last is None or self.last[0] != t or not np.array_equal(self.last[1], y):
            self(t, y)
        return self.energy

    def accept(self, t, y):
        """Move the reference to an accepted step's end ``(t, y)``; the closure Jacobian there
        (rows, n_q), or None where the state does not close or is singular."""
        if self.last is None or self.last[0] != t or not np.array_equal(self.last[1], y):
            self(t, y)
        _, _, m, qdd_f = self.last
        if m is None or not np.all(np.isfinite(qdd_f)):
            return None
        self.set_reference(t, m.q[0], m.qd[0], accelerations(m, qdd_f)[0], m.J[0])
        return m.J[0]


def accelerations(m: sk.Motion, qdd_f: np.ndarray) -> np.ndarray:
    """The tree coordinates' accelerations (T, n_q) at the solution ``qdd_f`` (nf, T) of a
    batch ``m`` of :meth:`System.reduced`: case 0 (``qdd_f = 0``) plus the unit responses
    times ``qdd_f`` (F5)."""
    T = qdd_f.shape[1]
    return m.qdd[:T] + np.einsum("kt,ktn->tn", qdd_f,
                                 m.qdd[T:].reshape(len(qdd_f), T, -1) - m.qdd[None, :T])


def better(part: Partition, J: np.ndarray, switch: float) -> tuple | None:
    """The tree coordinates (rows of q) of better free coordinates where those of ``part``
    describe the motion badly at the state of closure Jacobian ``J`` (rows, n_q): their
    growth ``max |V V_f^-1|`` (V the closure's null space over the coordinates not driven,
    lengths times the size) past ``switch`` (``forward.SWITCH``) and twice the best's; else None (F10)."""
    import scipy.linalg as sl
    p, nd = part.plan, part.n_drivers
    moving = np.setdiff1d(np.arange(p.n_q), p.driven[:nd])
    A = J[:, moving] * np.where(p.length_coordinate[moving], p.size, 1.0)
    nf = len(part.free)
    if not np.all(np.isfinite(A)):
        return None
    V = np.linalg.svd(A)[2][len(moving) - nf:].T if len(A) else np.eye(len(moving))[:, :nf]

    def growth(rows):
        with np.errstate(all="ignore"):
            try:
                G = np.linalg.solve(V[np.searchsorted(moving, rows)].T, V.T)
            except np.linalg.LinAlgError:
                return np.inf
        return float(np.max(np.abs(G))) if np.all(np.isfinite(G)) else np.inf
    now = growth(part.free_rows)
    if now <= switch:
        return None
    named = np.array(sorted(coordinate_rows(part.model, p, coordinate_names(
        part.model.joints)).values()), dtype=int)
    named = named[np.isin(named, moving)]
    piv = sl.qr(V[np.searchsorted(moving, named)].T, pivoting=True, mode="r")[1][:nf]
    best = tuple(int(r) for r in np.sort(named[piv]))
    return best if growth(list(best)) < now / 2 else None


def variant(part: Partition, rows: tuple) -> Partition:
    """``part`` with the tree coordinates ``rows`` as the free ones: the same tree and cut
    joints (every state keeps its coordinates), other independent and dependent sets (F10)."""
    p, nd = part.plan, part.n_drivers
    name = {r: c for c, r in coordinate_rows(part.model, p, coordinate_names(
        part.model.joints)).items()}
    driven = np.concatenate((p.driven[:nd], np.asarray(rows, int)))
    dependent = np.setdiff1d(np.arange(p.n_q), driven)
    return Partition(part.model, part.inner, replace(p, driven=driven, dependent=dependent),
                     tuple(name[r] for r in rows))


def check_inertia(part: Partition, system: System, q: np.ndarray) -> None:
    """Refuse free coordinates that move no mass (``H`` singular at ``q``, t = 0).

    Raises
    ------
    ModelError
        Naming the bodies without mass (field ``bodies``).
    """
    nf = len(part.free)
    q_f = q[part.free_rows][:, None]
    H = system.reduced(np.zeros(1), q_f, np.zeros((nf, 1)), q[:, None])[0][:, :, 0]
    w = np.linalg.eigvalsh(0.5 * (H + H.T)) if np.all(np.isfinite(H)) else np.array([np.nan])
    if np.min(w) > 1e-12 * max(float(np.max(np.abs(w))), 1e-300):
        return
    massless = [b.name for b in part.model.bodies if b.name != GROUND and b.mass == 0]
    raise ModelError(
        f"the free coordinates ({', '.join(part.free)}) move no mass: their mass matrix is "
        f"singular (massless bodies: {', '.join(massless) or 'none'})", file=part.model.source,
        field="bodies", fix="Give the bodies the free coordinates move a mass and an inertia, "
                            "or drive those joints")


def values(part: Partition, q: np.ndarray) -> dict:
    """The independent coordinates of ``q`` (n_q,) by name, rad or m (for a message)."""
    names = [d.joint for d in part.model.drivers] + list(part.free)
    return {n: float(q[k]) for n, k in zip(names, part.plan.driven)}


def units(model) -> dict:
    """The coordinates' units in the file, for the messages: name -> (unit, SI size)."""
    from ..io.units import ANGLE_UNITS, LENGTH_UNITS
    out = sk.driver_units(model)
    for c, (_, _, angular) in coordinate_names(model.joints).items():
        out[c] = ((model.angle_unit, ANGLE_UNITS.get(model.angle_unit, 1.0)) if angular else
                  (model.length_unit, LENGTH_UNITS.get(model.length_unit, 1.0)))
    return out


class SpatialSimulation(SpatialSolution):
    """A :class:`~linkdyn.spatial.SpatialSolution` computed by :func:`linkdyn.simulate`, with
    ``work`` (T,) J (drivers and non-conservative loads since t = 0), ``free`` (the free
    coordinates' names), ``stats`` (as :class:`linkdyn.forward.Simulation`'s)."""

    def __init__(self, *args, work, free, stats):
        super().__init__(*args)
        self.work, self.free, self.stats = work, free, stats

    @property
    def energy(self) -> np.ndarray:
        """Mechanical energy (T,): kinetic plus potential, J."""
        return self.kinetic_energy() + self.potential_energy()

    @cached_property
    def energy_drift(self) -> float:
        """Energy balance (F9): largest ``|E - E(0) - W|`` at the samples and the steps' ends,
        relative to the largest energy (:func:`linkdyn.balance.energy_drift`)."""
        return energy_drift(self.kinetic_energy(), self.potential_energy(), self.work,
                            self.stats.get("energy_steps"))

    @cached_property
    def _columns(self) -> dict:
        return {**SpatialSolution._columns.func(self), "work": self.work}


def outputs(parts, segment, t, Y, guesses, stats, kernel, backend) -> SpatialSimulation:
    """Every ``analyze`` quantity at the output states ``Y`` (2 nf + 1, T), ``guesses``
    (n_q, T) their coordinates, each sample in the partition it was integrated in
    (``parts[segment[k]]``, all on one tree): the closed positions, rates and free
    accelerations (F6) of each, then the kinematics, loads, inverse dynamics and reactions of
    ``analyze``'s stages in the first partition."""
    part = parts[0]
    nd, nf = part.n_drivers, len(part.free)
    T, p, model = len(t), part.plan, part.inner
    q, qd, qdd = (np.zeros((T, p.n_q)) for _ in range(3))
    for k, other in enumerate(parts):
        g = np.flatnonzero(segment == k)
        if len(g):
            system = System(other, guesses[:, g[0]], np.zeros(part.n))
            qdd_f, m, _, _ = system.evaluate(t[g], Y[:nf, g], Y[nf:2 * nf, g], guesses[:, g])
            q[g], qd[g], qdd[g] = m.q[:len(g)], m.qd[:len(g)], accelerations(m, qdd_f)
    motion = sk.motion_at(model, p, t, q, qd[:, p.driven], qdd[:, p.driven])
    coords = sk.joint_coordinates(model, p, motion)
    applied = sd.loads(model, p, motion, coords)
    dyn = sd.solve(model, p, motion, applied)
    # the free efforts vanish at the solution of F6: what is left is rounding
    _, _, Q, _ = sd.generalized(model, p, motion, replace(applied, w_ext=0 * applied.w_ext))
    scale = max(float(np.max(np.abs(Q), initial=0.0)),
                float(np.max(np.abs(dyn.Q), initial=0.0)), 1e-300)
    stats["free_effort_residual"] = float(np.max(np.abs(dyn.tau[:, nd:])) / scale)
    stats["closure_residual"] = float(np.max(motion.residual))
    dyn = replace(dyn, tau=dyn.tau[:, :nd])
    return SpatialSimulation(part.model, p, motion, coords, applied, dyn,
                             sk.redundant_rows(model, p, motion.J[0]), work=Y[-1],
                             free=part.free, stats=stats)
