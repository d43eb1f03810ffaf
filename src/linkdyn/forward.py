"""``simulate(model, t)``: forward dynamics of the free degrees of freedom (docs/theory.md, F1-F10).

A mechanism whose mobility exceeds its number of drivers has ``f`` free degrees of freedom. One
joint coordinate per free freedom (``[initial]``) joins the drivers' as an *independent*
coordinate of the spanning tree; the other tree coordinates are dependent, fixed by the
cut-joint constraints (coordinate partitioning, F1).

- Positions: the dependent coordinates close the loops by Newton's method at every evaluation
  (from the previous step's state extrapolated), so the motion never drifts off the
  constraint manifold; rates follow from ``J qd = 0`` and are consistent by construction (F2).
- Dynamics: the DeNOC inverse dynamics gives the effort ``tau_f`` that an actuator in each
  free joint would need for given accelerations. It is affine in the free accelerations,
  ``tau_f = H qdd_f + h`` (F4); ``h`` is the effort at ``qdd_f = 0`` and column k of the
  generalized inertia ``H`` the change for a unit ``qdd_f[k]`` (F5), all 1 + f evaluations in
  one batch of the recursion. No actuator acts there (loads inside joints are applied loads),
  so ``qdd_f = -H^{-1} h`` (F6).
- Dead points of the free coordinates (F10): at every accepted step the rates compatible with
  the loops (the closure Jacobian's null space) say how well the free coordinates describe the
  motion; where their growth passes ``SWITCH`` the integration restarts from the same state in
  the best-conditioned tree coordinates (QR with column pivoting), on the same tree.
- Integration: ``y = [q_f, qd_f, W]`` (W the work of drivers and non-conservative loads, F8)
  by a scipy ODE solver (explicit RK45/DOP853/RK23, implicit Radau/BDF, or LSODA) with the
  user's tolerances; outputs at the requested times from each step's dense output, then every
  ``analyze`` quantity recomputed at those states by the same stages as ``analyze``. With a
  one-step method (RK45, DOP853, RK23, Radau) each accepted step's end is put back on the
  energy balance by scaling the free rates (F11); with those and BDF free angles are
  integrated less their whole turns (F12); the solver's history moves with its state
  (:func:`restate`).
- Friction (F13): the free accelerations and the friction efforts solved together at each
  evaluation (reactions affine in both; :func:`linkdyn.friction.newton` on the friction law),
  and a stick-slip state per free coordinate with friction in its own joint: a stuck one has
  rate and acceleration exactly zero while its static capacity holds it; the changes are
  located on each step's dense output (:func:`_transition`) and the integration restarts there.
- The right-hand side runs numpy's stages, or one compiled function per evaluation
  (:mod:`linkdyn.forward_compiled`, ``backend=``, chosen by :mod:`linkdyn.backend`); the
  outputs of a compiled run are computed by the compiled kernels of ``analyze``'s stages.
"""

from __future__ import annotations

import itertools
import numbers
import os
import time
from dataclasses import dataclass, field, fields, replace
from functools import cached_property

import numpy as np

from .brief import brief_repr

from . import backend as backend_mod, friction as friction_mod, joints as jk, loads as loads_mod
from . import reactions as reactions_mod
from .analysis import SINGULAR, Solution, blame_loads, stage_functions, times_argument
from .balance import Balance, energy_drift
from .dynamics import denoc
from .errors import ArgumentError, AssemblyError, ModelError, quiet, wrong_type
from .kinematics.layout import Layout, compile_layout
from .kinematics.positions import assembly_guess, assemble, driver_values
from .kinematics.solution import at_closed
from .kinematics.state import at_state, close
from .model import Driver, Model
from .motion import Free
from .planar import solve_small
from .topology import build, mobility
from .units import joint_units

METHODS = ("RK45", "DOP853", "RK23", "Radau", "BDF", "LSODA")
MAX_STEPS = 50_000
MIN_STEP = 1e-10     # least advance of STUCK steps, relative to the time reached (1 s at least)
STUCK = 50           # steps that together advance less than MIN_STEP: a stuck run
RTOL_MIN = 100 * np.finfo(float).eps   # scipy's floor of rtol (it raises a smaller one to this)
RTOL_MAX = 0.01      # largest rtol (a relative error of 1 %; at 10 % the energy is lost)
ATOL_MIN = 1e-18     # smallest atol: rad, m, J well below the rounding of the state's numbers
PACE = 100           # steps between the checks that the run can end within max_steps
HOPELESS = 1000      # ... it cannot when, at a steady step size, it needs this many times more
EARLY = 5            # the first checks, after EARLY and 2 EARLY steps: a run that needs more
FAR = 1e15           # than FAR steps at its pace (a duration far beyond reach) stops at once
WALL = 3             # steps cut short by a right-hand side not finite beyond them, none
                     # passing the earliest such time: they approach a time the loads cannot pass
SWITCH = 8.0         # growth of the dependent rates past which the free coordinates change (F10)
# the methods whose steps the energy projection joins (F11): the one-step methods, whose next
# step is a function of the state alone (not BDF's history, nor LSODA's)
PROJECTED = ("RK45", "DOP853", "RK23", "Radau")
# the methods whose free angles are integrated less their whole turns (F12): those whose history
# moves with a constant shift of the state (:func:`restate`; not LSODA, ODEPACK's)
UNWOUND = PROJECTED + ("BDF",)
PROJECT_MAX = 1e-3   # largest relative change of the free rates the energy projection makes (F11)
UNIT_MAX = 2.0 ** 14  # free accelerations (rad/s^2, m/s^2) up to which the unit ones of F5 are 1
# the implicit methods whose Newton's iterations are judged against the tolerances (F14): the free
# rates' atol at least RESOLVE times their resolution under the right-hand side
IMPLICIT = ("Radau", "BDF")
RESOLVE = 1e4
MAX_EVENTS = 10_000  # changes of the stick-slip state in a run (F13)


def unit_scale(qdd_f) -> np.ndarray:
    """Size of the unit free accelerations of F5 (nf, T) for states whose free accelerations
    are about ``qdd_f`` (nf, T): 1 up to :data:`UNIT_MAX`, else the power of two nearest
    ``|qdd_f|``.

    Column j of ``H`` is ``(tau(s e_j) - tau(0)) / s``, and ``|tau(0)| = |h| ~ |H qdd_f|``: with
    ``s = 1`` the difference loses the digits of ``|qdd_f|`` (about 7 under a stiff spring's
    1e7 rad/s^2). A power of two keeps the division exact and every ordinary motion's numbers
    as they were; what is not finite, or too large to scale, keeps 1.
    """
    a = np.abs(np.asarray(qdd_f, dtype=float))
    big = np.isfinite(a) & (a > UNIT_MAX) & (a < 2.0 ** 512)
    return np.where(big, np.exp2(np.round(np.log2(np.where(big, a, 1.0)))), 1.0)


@dataclass(frozen=True)
class Partition:
    """The independent coordinates of a simulation.

    Attributes
    ----------
    model : Model
        The user's model.
    inner : Model
        The same with one placeholder driver per free coordinate after the real drivers, so
        the topology keeps the free joints in the tree and lists them in ``driven``.
    layout : Layout
        ``inner``'s layout; ``layout.topo.driven[:n_drivers]`` are the driven bodies, the rest
        the free ones.
    free : tuple[str, ...]
        Joints whose coordinates are integrated.
    """

    __repr__ = brief_repr   # shapes, not every number (linkdyn.brief)

    model: Model
    inner: Model
    layout: Layout
    free: tuple[str, ...]

    @property
    def n_drivers(self) -> int:
        return len(self.model.drivers)


def partition(model: Model, free: tuple[str, ...] | None = None) -> Partition:
    """Choose the free coordinates: ``free``, else those named in ``[initial]``, else the first
    joints (file order) that leave the dependent coordinates solvable at the assembly.

    Raises
    ------
    ModelError
        No free freedom, or ``[initial]`` naming an unknown or driven joint or the wrong count.
    """
    src = model.source
    mob = mobility(model)                  # Grübler–Kutzbach, each joint kind's rows
    nf = mob - len(model.drivers)
    if nf <= 0:
        raise ModelError(
            f"the mechanism has no free degree of freedom (mobility {mob}, "
            f"{len(model.drivers)} driver(s)): its motion is prescribed", file=src,
            field="drivers" if nf == 0 else "joints",
            fix="Use `linkdyn analyze` for a fully driven mechanism, or remove a driver to let "
                "that joint move under the loads")
    driven = {d.joint for d in model.drivers}
    names = [j.name for j in model.joints]
    section = "initial.q" if model.initial_q else "initial.qd"
    given = tuple(free or model.initial_q or model.initial_qd)
    for j in given:
        if j not in names:
            import difflib
            close_ = difflib.get_close_matches(j, names, n=1)
            raise ModelError(f"unknown joint '{j}'", file=src, field=f"{section}.{j}",
                             fix=(f"Did you mean '{close_[0]}'? " if close_ else "")
                             + f"Valid joints: {', '.join(names)}")
        if j in driven:
            raise ModelError(f"joint '{j}' is driven: its motion is prescribed, not free",
                             file=src, field=f"{section}.{j}",
                             fix="Name the joints of the free degrees of freedom only")
    if model.initial_q and model.initial_qd and set(model.initial_qd) - set(model.initial_q):
        j = sorted(set(model.initial_qd) - set(model.initial_q))[0]
        raise ModelError(f"joint '{j}' has a rate but no coordinate in [initial]", file=src,
                         field=f"initial.qd.{j}",
                         fix=f"Give rates of the joints in initial.q ({', '.join(model.initial_q)})")
    if given:
        if len(given) != nf:
            raise ModelError(
                f"[initial] names {len(given)} joint(s) but the mechanism has {nf} free degree(s)"
                f" of freedom (mobility {mob} minus {len(model.drivers)} driver(s))",
                file=src, field=section,
                fix=f"Give exactly {nf} joint coordinate(s), one per free degree of freedom")
        return _partition(model, given)
    # automatic: the first combination whose dependent coordinates are solvable at the assembly
    candidates = [j.name for j in model.joints if j.name not in driven]
    last_error = None
    for combo in itertools.islice(itertools.combinations(candidates, nf), 200):
        try:
            part = _partition(model, combo)
            q0 = start_state(part)
        except (ModelError, AssemblyError) as err:
            last_error = err
            continue
        kin = at_state(part.inner, part.layout, np.zeros(1), q0[list(part.layout.topo.driven)]
                       [:, None], np.zeros((len(combo) + part.n_drivers, 1)),
                       np.zeros((len(combo) + part.n_drivers, 1)), q0[:, None])
        if kin.valid[0] and kin.pivot[0] > 1e-6:
            return part
    if isinstance(last_error, AssemblyError):
        raise last_error
    raise ModelError("no choice of free joint coordinates describes the mechanism at its "
                     "assembly", file=src, field="initial",
                     fix="Name the free joints in [initial] q = { J = value }")


def _partition(model: Model, free) -> Partition:
    # a free joint stays in the tree: a [topology] cut naming one gives way to the automatic
    cut = None if model.cut and set(model.cut) & set(free) else model.cut
    inner = replace(model, cut=cut, drivers=model.drivers + tuple(
        Driver(j, Free(), "free (integrated)") for j in free))
    return Partition(model, inner, compile_layout(inner, build(inner)), tuple(free))


def _variant(part: Partition, free_bodies: tuple[int, ...]) -> Partition:
    """``part`` with the tree coordinates of ``free_bodies`` (tree indices) as the free ones:
    the same tree and cut joints (so every state keeps its tree coordinates), other
    independent and dependent sets (F10)."""
    topo, nd = part.layout.topo, part.n_drivers
    driven = topo.driven[:nd] + tuple(free_bodies)
    free = tuple(part.model.joints[topo.tree_joint[i]].name for i in free_bodies)
    cut = tuple(part.model.joints[j].name for j in topo.cut)
    inner = replace(part.model, cut=cut, drivers=part.model.drivers + tuple(
        Driver(j, Free(), "free (integrated)") for j in free))
    tree = replace(topo, driven=driven,
                   dependent=tuple(i for i in range(1, topo.n) if i not in driven))
    # Newton's method closes the loops (the closed-form plan is the first partition's)
    return Partition(part.model, inner, replace(part.layout, topo=tree, dyads=None), free)


def conditioning(part: Partition, J: np.ndarray) -> tuple[float, tuple[int, ...], float]:
    """How well the free coordinates of ``part`` describe the motion at one state (F10).

    Parameters
    ----------
    part : Partition
    J : ndarray (n_rows, n - 1)
        Closure Jacobian at the state (columns: tree coordinates of bodies 1 .. n-1).

    Returns
    -------
    growth : float
        Largest rate of a non-driven tree coordinate per unit rate of the free ones,
        ``max |V V_f^-1|`` (rad, or m per ``layout.size``): 1 at best, infinite at a dead point
        of the free coordinates.
    best : tuple of int
        The tree bodies whose coordinates are the best-conditioned free ones (QR with column
        pivoting of ``V^T``), ascending.
    best_growth : float
        ``growth`` of that choice.
    """
    import scipy.linalg as sl
    lay, topo, nd = part.layout, part.layout.topo, part.n_drivers
    nf = len(topo.driven) - nd
    cand = np.array([i for i in range(1, topo.n) if i not in topo.driven[:nd]], int)
    free = np.searchsorted(cand, topo.driven[nd:])
    scale = np.array([1.0 if jk.get(lay.kind[i]).angular else 1.0 / float(lay.size)
                      for i in cand])
    A = J[:, cand - 1] / scale
    if not np.all(np.isfinite(A)):
        return np.inf, tuple(topo.driven[nd:]), np.inf
    # V: the rates of the candidates (scaled) in the null space of the closure, J V = 0
    _, sv, vt = np.linalg.svd(A)
    V = vt[len(cand) - nf:].T                                       # (candidates, nf)
    if nf == 0 or (len(sv) and sv[-1] <= 1e-9 * sv[0]):
        # the closure itself loses rank (a singular position of the mechanism): every choice
        # is as bad, the motion's velocity decides the branch; keep the current one
        return 1.0, tuple(topo.driven[nd:]), 1.0

    def growth(rows):
        with np.errstate(all="ignore"):
            G = np.linalg.solve(V[rows].T, V.T).T if nf else np.zeros((0, 0))   # V V_f^-1
        return float(np.max(np.abs(G))) if np.all(np.isfinite(G)) else np.inf
    try:
        current = growth(free)
    except np.linalg.LinAlgError:
        current = np.inf
    piv = sl.qr(V.T, pivoting=True, mode="r")[1][:nf]
    best = tuple(int(i) for i in np.sort(cand[piv]))
    try:
        return current, best, growth(np.sort(piv))
    except np.linalg.LinAlgError:
        return current, best, np.inf


def check_inertia(part: Partition, system: "System", q: np.ndarray) -> None:
    """Refuse free coordinates that move no mass: where massless links or point masses leave
    the generalized inertia ``H`` of the free coordinates singular at the tree coordinates
    ``q`` (n,), t = 0, ``H qdd_f = -h`` has no solution (F6).

    Raises
    ------
    ModelError
        Naming the bodies without mass or inertia (field ``bodies``).
    """
    model = part.model
    massless = [b.name for b in model.moving_bodies if b.mass == 0 or b.inertia == 0]
    if not massless:
        return
    nf = len(part.free)
    t = np.zeros(1)
    q_f = q[list(part.layout.topo.driven[part.n_drivers:])][:, None]
    H = system.reduced(t, q_f, np.zeros((nf, 1)), q[:, None])[0][:, :, 0]
    w = np.linalg.eigvalsh(0.5 * (H + H.T)) if np.all(np.isfinite(H)) else np.array([np.nan])
    if np.min(w) > 1e-12 * max(float(np.max(np.abs(w))), 1e-300):
        return
    raise ModelError(
        f"the free coordinates ({', '.join(part.free)}) move no mass: their mass matrix is "
        f"singular, with massless links or point masses ({', '.join(massless)})",
        file=model.source, field="bodies",
        fix="Give the bodies the free joints move a mass and an inertia, or drive those joints")


def start_state(part: Partition) -> np.ndarray:
    """Assembled tree coordinates (n,) at t = 0: drivers at their motion's start, free joints at
    ``[initial] q`` (else the ``[assembly]`` guess)."""
    lay, topo = part.layout, part.layout.topo
    guess = assembly_guess(part.inner, lay)
    q_drv = driver_values(part.model, np.zeros(1))[0][:, 0]
    q_free = [part.model.initial_q.get(j, guess[topo.driven[part.n_drivers + k]])
              for k, j in enumerate(part.free)]
    return assemble([part.inner], lay, np.concatenate((q_drv, q_free)), 0.0)[:, 0]


@dataclass(frozen=True, repr=False)   # Solution's short repr, not every array's numbers
class Simulation(Solution):
    """A :class:`~linkdyn.analysis.Solution` computed by :func:`simulate`.

    Extra attributes
    ----------------
    work : ndarray (T,)
        Work done since t = 0 by the drivers and the non-conservative loads (forces, torques,
        dampers, loads inside joints), J.
    free : tuple[str, ...]
        The joints whose coordinates were integrated first (``[initial]``'s).
    stats : dict
        ``method``, ``rtol``, ``atol`` (those used), ``atol_rates`` (the free rates' atol: with
        Radau or BDF at least their resolution under the right-hand side, F14; else ``atol``),
        ``steps``, ``rhs_evaluations``, ``switches`` (a list of
        ``(t, [joints])``: where the integration went on in other free coordinates, F10),
        ``free_effort_residual`` (largest effort the free joints would need at the output
        states, relative to the largest effort or load, ~0 when the accelerations solve F6),
        ``closure_residual``.
    """

    work: np.ndarray = field(default=None)
    free: tuple = ()
    stats: dict = field(default_factory=dict)

    @property
    def energy(self) -> np.ndarray:
        """Mechanical energy (T,): kinetic plus potential, J."""
        return self.kinetic_energy + self.potential_energy

    @cached_property
    def energy_drift(self) -> float:
        """Energy balance (F9): largest ``|E - E(0) - W|`` at the output samples and at every
        step's end, relative to the largest energy (kinetic, potential variation, or work) of
        the run (:func:`energy_drift`)."""
        return energy_drift(self.kinetic_energy, self.potential_energy, self.work,
                            self.stats.get("energy_steps"))

    @cached_property
    def _table(self) -> tuple[dict[str, np.ndarray], dict[str, str]]:
        """``analyze``'s columns, with ``potential_energy`` always (after ``kinetic_energy``)
        and ``work`` (J) last."""
        cols, units = Solution._table.func(self)
        out_c, out_u = {}, {}
        for k, v in cols.items():
            out_c[k], out_u[k] = v, units[k]
            if k == "kinetic_energy" and "potential_energy" not in cols:
                out_c["potential_energy"] = np.broadcast_to(self.potential_energy, self.t.shape)
                out_u["potential_energy"] = "J"
        out_c["work"], out_u["work"] = self.work, "J"
        return out_c, out_u


class System:
    """The ODE ``y' = F(t, y)`` of F7 with ``y = [q_f, qd_f, W]`` and the branch it follows."""

    def __init__(self, part: Partition, q0: np.ndarray, qd0: np.ndarray, fast: bool = False):
        self.part, self.lay = part, part.layout
        # the compiled right-hand side (linkdyn.forward_compiled), else numpy's stages
        self.kernel = None
        if fast:
            self.use_compiled()
        self.nd, self.nf = part.n_drivers, len(part.free)
        topo = self.lay.topo
        self.ind, self.dep = np.array(topo.driven, int), np.array(topo.dependent, int)
        # each tree body's joint (model order): the tree coordinates out of the joints'
        self.tree_joint = topo.tree_joint[1:]
        # the friction loads (F13): per free coordinate the one in its joint, which sticks
        self.rows = friction_mod.rows(part.model, topo)
        k = len(self.rows)
        joint_of = [j.name for j in part.model.joints]
        self.sticky = np.array([next((n for n, r in enumerate(self.rows)
                                      if joint_of[r.joint] == j), -1) for j in part.free], int)
        self.held = np.zeros(self.nf, bool)      # the free coordinates stuck
        self.sense = np.ones(self.nf)            # the sense of sliding of the others
        self.efforts = self.ratio = None
        self.scale = np.ones((self.nf, 1))   # the unit free accelerations' sizes (F5)
        self.iterations = 0
        # sample 0: qdd_f = 0; sample 1 + j: qdd_f = e_j (unit acceleration)          (F5)
        # sample 1 + nf + l: qdd_f = 0 and a unit effort in friction load l           (F13)
        self.unit = np.zeros((self.nf, 1 + self.nf + k, 1))
        for j in range(self.nf):
            self.unit[j, 1 + j] = 1.0
        self.unit_efforts = np.zeros((k, 1 + self.nf + k, 1))
        for n in range(k):
            self.unit_efforts[n, 1 + self.nf + n] = 1.0
        self.set_reference(0.0, q0, qd0)
        self.last = self.bad = None
        self.nfev = 0

    def modes(self, held, sense) -> None:
        """Set which free coordinates are stuck (``held``, nf bools) and the sense of sliding
        of the others (``sense``, +-1) (F13); the last evaluation no longer stands."""
        self.held, self.sense = np.array(held, bool), np.array(sense, float)
        self.last = None

    def use_compiled(self):
        """Evaluate the right-hand side by the compiled kernel from now on (the numpy path stays
        for states whose loops Newton's method from the guess does not close)."""
        from .forward_compiled import Kernel
        self.kernel = Kernel(self.part)

    def set_reference(self, t0, q, qd, qdd=None, J=None):
        """The state (time, tree q, qd, qdd (n,)) the guesses are extrapolated from, and the
        closure Jacobian there (n_rows, n - 1) for the dependent coordinates' share of a change
        of the independent ones."""
        S = None
        if J is not None and len(self.dep):
            # dq_dep / dq_ind = -J_dep^-1 J_ind at the reference                    (F2)
            with np.errstate(all="ignore"):
                S = np.linalg.solve(J[:, self.dep - 1], -J[:, self.ind - 1])
            S = S if np.all(np.isfinite(S)) else None
        self.ref = (t0, q, qd, np.zeros_like(q) if qdd is None else qdd, S)

    def guess(self, t, q_ind=None) -> np.ndarray:
        """Tree coordinates (n, T) near the solution at ``t`` (T,): the reference extrapolated
        with its rates and accelerations (so a motion passing a singular position keeps its
        direction), its dependent rows moved by their share of the independent coordinates'
        (k, T) difference from the extrapolation."""
        t0, q, qd, qdd, S = self.ref
        dt = np.asarray(t) - t0
        g = q[:, None] + qd[:, None] * dt + 0.5 * qdd[:, None] * dt**2
        if S is not None and q_ind is not None:
            g[self.dep] += S @ (q_ind - g[self.ind])
        return g

    def reduced(self, t, q_f, qd_f, guess, drivers=None, scale=None):
        """The free coordinates' equations of motion ``H qdd_f + h = 0`` at the states
        ``(t, q_f, qd_f)``, each (nf, T) but t (T,), from a tree-coordinate ``guess`` (n, T);
        ``drivers``: the drivers' ``(q, qd, qdd)`` (nd, T) at ``t`` when the caller has them;
        ``scale`` (nf, T): the size of the unit free accelerations (:func:`unit_scale`; 1).

        Returns ``H`` (nf, nf, T) (kg m^2, kg m or kg), ``h`` (nf, T) (N m or N: the effort
        an actuator in each free joint would need to hold ``qdd_f = 0``, without friction),
        the efforts ``tau`` of every independent joint (k, C, T) of the batch, and its
        kinematics, loads and dynamics (C, T), ``C = 1 + nf + k`` (sample 0: ``qdd_f = 0``;
        1 + j: ``qdd_f = scale[j] e_j``; 1 + nf + l: a unit effort in friction load l, F13).
        """
        nd, nf, k = self.nd, self.nf, len(self.rows)
        part, lay = self.part, self.lay
        C = 1 + nf + k
        q_d, qd_d, qdd_d = driver_values(part.model, t) if drivers is None else drivers
        scale = np.ones((nf, len(t))) if scale is None else scale
        q_ind = np.concatenate((q_d, q_f))[:, None]              # (k, 1, T)
        qd_ind = np.concatenate((qd_d, qd_f))[:, None]
        qdd_ind = np.concatenate((np.broadcast_to(qdd_d[:, None], (nd, C, len(t))),
                                  self.unit * scale[:, None]))
        kin = at_state(part.inner, lay, t, q_ind, qd_ind, qdd_ind, guess[:, None])
        # the layout holds the model's gravity and load rows (not rebuilt at every call)
        applied = loads_mod.wrenches(None, kin)
        if k:   # the unit friction efforts of the cases 1 + nf + l                    (F13)
            applied = friction_mod.with_efforts(
                applied, kin, self.rows, np.broadcast_to(self.unit_efforts, (k, C, len(t))))
        dyn = denoc.solve(kin, applied)
        # the energies of the first state (the accelerations do not enter them)
        self.energy = (float(dyn.kinetic_energy[0, 0]),
                       float(np.broadcast_to(applied.potential_energy, kin.shape)[0, 0]))
        tau = np.moveaxis(dyn.tau, -1, 0)                        # (k, 1 + nf, T)
        # tau_f = H qdd_f + h: h at qdd_f = 0, H's columns the unit responses   (F4-F5)
        h = tau[nd:, 0]
        H = (tau[nd:, 1:1 + nf] - h[:, None]) / scale            # (row, column, T)
        return H, h, tau, kin, applied, dyn

    def evaluate(self, t, q_f, qd_f, guess, near=None):
        """Free accelerations at the states ``(t, q_f, qd_f)``, each (nf, T) but t (T,);
        ``near`` (nf, T): free accelerations about as large (the reference's by default), which
        size the unit ones (:func:`unit_scale`, kept in :attr:`scale`).

        Returns ``qdd_f`` (nf, T), the kinematics of the batch (C, T) (sample 0: qdd_f = 0)
        and the power of drivers and non-conservative loads, friction's included (T,). With
        friction loads, their efforts (k, T) are kept in :attr:`efforts` and, for each stuck
        free coordinate, its friction's share of its static capacity in :attr:`ratio`
        (nf, T; 0 for the others).
        """
        nd, nf = self.nd, self.nf
        drivers = driver_values(self.part.model, t)
        self.scale = scale = np.broadcast_to(self.sizes(near), (nf, len(t)))
        H, h, tau, kin, applied, dyn = self.reduced(t, q_f, qd_f, guess, drivers, scale)
        qd_d = drivers[1]
        if self.rows:
            qdd_f, f, tau_d = self._friction(tau, kin, dyn, scale)
            # friction's power f qd_joint joins the loads'                          (F13)
            power = applied.power[0] + np.sum(tau_d * qd_d, axis=0) + np.sum(
                f * np.stack([kin.joint_motion[1][r.joint][0] for r in self.rows]), axis=0)
        else:
            # no actuator in a free joint: H qdd_f = -h                         (F6)
            if nf == 1:
                qdd_f = -h / H[0]
            else:
                qdd_f = solve_small(H, -h)[0] if nf else np.zeros((0, len(t)))
            # drivers' efforts at the solution (affine in qdd_f) and the power balance   (F8)
            tau_d = tau[:nd, 0] + np.einsum("jkt,kt->jt", (tau[:nd, 1:] - tau[:nd, :1]) / scale,
                                            qdd_f)
            power = applied.power[0] + np.sum(tau_d * qd_d, axis=0)
        ok = kin.valid[0] & (kin.pivot[0] > SINGULAR) & (dyn.pivot[0] > SINGULAR)
        qdd_f = np.where(ok, qdd_f, np.nan)
        return qdd_f, kin, power

    def sizes(self, near=None) -> np.ndarray:
        """The sizes of the unit free accelerations of F5 (nf, T) (:func:`unit_scale`) for
        states whose free accelerations are about ``near`` (nf, T), by default the reference
        state's (nf, 1): both right-hand sides, numpy's and the compiled one, take them
        from here."""
        return unit_scale(self.ref[3][self.ind[self.nd:], None] if near is None else near)

    def _friction(self, tau, kin, dyn, scale):
        """The free accelerations (nf, T), friction efforts (k, T) and drivers' efforts
        (nd, T) of the batch of :meth:`reduced` (unit accelerations of sizes ``scale``
        (nf, T)), solved together (F13).

        Efforts and reaction forces are affine in the free accelerations and the friction
        efforts (columns 1 .. nf and 1 + nf .. of the batch). A stuck coordinate has
        ``qdd_f = 0`` and its friction load's effort is unknown (what holds it); the other
        friction loads follow their law. With those ``f_L`` given, the free coordinates'
        equations ``h + H qdd_f + B f = 0`` are linear in the other unknowns ``x``
        (the sliding accelerations and the holding efforts), so the forces are affine in
        ``f_L`` alone, ``F = F0' + A' f_L``, and friction's Newton's method solves it."""
        nd, nf, k = self.nd, self.nf, len(self.rows)
        n1 = 1 + nf

        def split(x):
            # (..., C, T) -> value at case 0, unit-acceleration and unit-effort responses
            x0 = x[..., 0, :]
            return (x0, (x[..., 1:n1, :] - x0[..., None, :]) / scale,
                    x[..., n1:, :] - x0[..., None, :])
        react = reactions_mod.solve(self.part.inner, kin, dyn)
        F0, Fq, Ff = split(friction_mod.forces(react, self.rows))   # (k, 2, [nf | k], T)
        h, H, B = split(tau[nd:])                                    # (nf, [nf | k], T)
        d0, Dq, Df = split(tau[:nd])
        held = self.held
        hold = self.sticky[held]                    # the friction loads holding
        law = np.ones(k, bool)
        law[hold] = False
        slip = np.flatnonzero(~held)
        # x = [qdd_f(sliding), f(holding)] = x0 + X f_L from M x = -h - B_L f_L
        M = np.concatenate((H[:, slip], B[:, hold]), axis=1)
        x0 = _solve(M, -h[:, None])[:, 0]
        X = _solve(M, -B[:, law])
        # F = F0' + A' f_L
        G = np.concatenate((Fq[:, :, slip], Ff[:, :, hold]), axis=2)
        F0p = F0 + np.einsum("jcnt,nt->jct", G, x0)
        Ap = Ff[:, :, law] + np.einsum("jcnt,nmt->jcmt", G, X)
        rows = [r for r, use in zip(self.rows, law) if use]
        T = tau.shape[-1]
        qd = np.stack([np.broadcast_to(kin.joint_motion[1][r.joint][0], (T,)) for r in rows]
                      ) if rows else np.zeros((0, T))
        # the sense of sliding of a sliding coordinate's own friction: its state's (F13)
        sense = np.full((len(rows), T), np.nan)
        index = np.cumsum(law) - 1
        for i in slip:
            if self.sticky[i] >= 0:
                sense[index[self.sticky[i]]] = self.sense[i]
        if rows:
            f_L, its, _, _, _ = friction_mod.newton(rows, F0p[law], np.moveaxis(Ap[law], 2, 1),
                                                    qd, sense)
            self.iterations = max(self.iterations, int(np.max(its, initial=0)))
        else:
            f_L = np.zeros((0, T))
        x = x0 + np.einsum("nmt,mt->nt", X, f_L)
        qdd_f = np.zeros((nf, T))
        qdd_f[slip] = x[:len(slip)]
        f = np.zeros((k, T))
        f[law], f[hold] = f_L, x[len(slip):]
        # what holds a stuck coordinate, against its static capacity
        F = F0p + np.einsum("jcmt,mt->jct", Ap, f_L)
        self.ratio = np.zeros((nf, T))
        for i in np.flatnonzero(held):
            n = self.sticky[i]
            cap = friction_mod.capacity(self.rows[n], F[n])
            self.ratio[i] = np.abs(f[n]) / np.where(cap > 0, cap, 1e-300)
        self.efforts = f
        tau_d = d0 + np.einsum("jkt,kt->jt", Dq, qdd_f) + np.einsum("jkt,kt->jt", Df, f)
        return qdd_f, f, tau_d

    def tree(self, kin, qdd_f, scale) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Tree coordinates, rates and accelerations (n, T) at the solution of an
        :meth:`evaluate` (the accelerations affine in ``qdd_f``, F5; ``scale`` (nf, T) its
        unit accelerations' sizes)."""
        q, qd, qdd = kin.joint_motion
        tj = self.tree_joint
        qt, qdt, qddt = (np.stack([np.zeros_like(x[tj[0]][0])] + [x[j][0] for j in tj])
                         for x in (q, qd, qdd))
        if len(qdd_f):
            # column k of the unit responses: (qdd(qdd_f = s_k e_k) - qdd(0)) / s_k
            n1 = 1 + len(qdd_f)
            du = np.stack([np.zeros_like(qdd[tj[0]][1:n1])]
                          + [(qdd[j][1:n1] - qdd[j][:1]) / scale for j in tj])
            qddt = qddt + np.einsum("kt,nkt->nt", qdd_f, du)
        return qt, qdt, qddt

    def __call__(self, t, y):
        nf = self.nf
        self.nfev += 1
        if self.kernel is not None:
            out = self.kernel(t, y, self.ref, self.sizes()[:, 0])
            if out is not None:
                self.last = (t, y.copy(), None, None, None)
                self._check(t, y, out)
                return out
        tt = np.array([t])
        q_ind = np.concatenate((driver_values(self.part.model, tt)[0], y[:nf, None]))
        qdd, kin, power = self.evaluate(tt, y[:nf, None], y[nf:2 * nf, None],
                                        self.guess(tt, q_ind))
        self.last = (t, y.copy(), kin, qdd, self.scale)
        out = np.concatenate((y[nf:2 * nf], qdd[:, 0], power))
        self._check(t, y, out)
        return out

    def _check(self, t, y, out) -> None:
        """Keep ``(t, y)`` as :attr:`bad`, for the messages, when its right-hand side ``out`` is
        not finite at a finite state: the last state a step was refused at. (A state that is
        not finite itself, a Runge-Kutta stage built from such a right-hand side, would hide
        the load that was not finite.)"""
        if not np.all(np.isfinite(out)) and np.all(np.isfinite(y)):
            self.bad = (t, y.copy())

    def shift(self, rows, by) -> None:
        """Move the reference's tree coordinates ``rows`` by ``by``: whole turns of free angles,
        which leave every pose as it is."""
        t0, q, qd, qdd, S = self.ref
        q = q.copy()
        q[rows] += by
        self.ref = (t0, q, qd, qdd, S)

    def energies(self, t, y) -> tuple[float, float]:
        """Kinetic and potential energy (J) at the state ``(t, y)``."""
        if self.last is None or self.last[0] != t or not np.array_equal(self.last[1], y):
            self(t, y)
        if self.last[2] is None:   # the compiled kernel's last evaluation
            return float(self.kernel.energy[0]), float(self.kernel.energy[1])
        return self.energy

    def accept(self, t, y):
        """Move the reference to an accepted step's end ``(t, y)``; the closure Jacobian there
        (n_rows, n - 1), or None where the state does not close."""
        if self.last is None or self.last[0] != t or not np.array_equal(self.last[1], y):
            self(t, y)
        _, _, kin, qdd_f, scale = self.last
        if kin is None:   # the compiled kernel's last evaluation
            q, qd, qdd = (x.copy() for x in self.kernel.state)
            J = self.kernel.J.copy()
        else:
            q, qd, qdd = (x[:, 0] for x in self.tree(kin, qdd_f, scale))
            J = kin.jacobian[:, :, 0, 0]
        if J is not None and all(np.all(np.isfinite(x)) for x in (q, qd, qdd)):
            self.set_reference(t, q, qd, qdd, J)
            return J
        return None


def _solve(M, R):
    """``M^-1 R`` per sample: M (n, n, T), R (n, m, T) -> (n, m, T) (NaN where M is
    singular)."""
    M, R = np.moveaxis(M, -1, 0), np.moveaxis(R, -1, 0)
    with np.errstate(all="ignore"):
        try:
            return np.moveaxis(np.linalg.solve(M, R), 0, -1)
        except np.linalg.LinAlgError:
            ok = np.abs(np.linalg.det(M)) > 0
            out = np.linalg.solve(np.where(ok[:, None, None], M, np.eye(M.shape[-1])), R)
            return np.moveaxis(np.where(ok[:, None, None], out, np.nan), 0, -1)


def _settle(system: System, t: float, y: np.ndarray, candidates) -> None:
    """Hold the free coordinates ``candidates`` (sticky ones, at rest in the state ``(t, y)``)
    where their static friction can (F13): all held at first; while a held one's friction
    exceeds its static capacity, the one that exceeds it most is released, sliding the way the
    load pushes it (against its holding effort)."""
    held = system.held.copy()
    held[candidates] = True
    system.modes(held, system.sense)
    while np.any(system.held):
        system(t, y)
        ratio = system.ratio[:, 0]
        over = np.flatnonzero(system.held & ~(ratio <= 1.0))
        if not len(over):
            return
        i = over[np.argmax(np.nan_to_num(ratio[over], nan=np.inf))]
        held, sense = system.held.copy(), system.sense.copy()
        held[i] = False
        sense[i] = -1.0 if system.efforts[system.sticky[i], 0] > 0 else 1.0
        system.modes(held, sense)


def _transition(system: System, dense, t0: float, t1: float, y1: np.ndarray):
    """The first change of the stick-slip state within the step ``(t0, t1]`` (state ``y1`` at
    its end, ``dense`` its dense output), F13: a sliding sticky coordinate whose rate passes
    zero (against its sense of sliding), or a stuck one whose holding effort passes its static
    capacity. Returns ``(t, y, (coordinate, "sticks" | "slips"))`` with the system put in the
    new state at ``(t, y)``, or None."""
    from scipy.optimize import brentq

    nf = system.nf
    held = system.held.copy()
    first = None
    xtol = 4 * np.finfo(float).eps * max(abs(t1), 1.0)

    def ratio(i, tt):
        system(tt, dense(tt))
        return float(system.ratio[i, 0]) - 1.0

    for i in np.flatnonzero(system.sticky >= 0):
        if held[i]:
            # the holding effort passes the static capacity
            if not ratio(i, t1) > 0:
                continue
            tc = t0 if not ratio(i, t0) < 0 else brentq(lambda tt: ratio(i, tt), t0, t1,
                                                        xtol=xtol)
        else:
            # the rate passes zero against the sense it slides in
            def rate(tt):
                return float(dense(tt)[nf + i]) * system.sense[i]
            if not (rate(t1) < 0 < rate(t0)):
                continue
            tc = brentq(rate, t0, t1, xtol=xtol)
        if first is None or tc < first[0]:
            first = (tc, i)
    if first is None:
        return None
    tc, i = first
    y = dense(tc)
    y[nf:2 * nf][held] = 0.0
    if held[i]:
        # it slips the way the load pushes it, against the effort that held it
        system.modes(held, system.sense)
        system(tc, y)
        sense = system.sense.copy()
        sense[i] = -1.0 if system.efforts[system.sticky[i], 0] > 0 else 1.0
        held[i] = False
        system.modes(held, sense)
        return tc, y, (i, "slips")
    y[nf + i] = 0.0
    _settle(system, tc, y, [i])
    return tc, y, (i, "sticks" if system.held[i] else "reverses")


def rate_resolution(system, t: float, y: np.ndarray) -> float:
    """The resolution of the free rates under the right-hand side of ``system`` (either space's
    :class:`System`) at the state ``(t, y)``, rad/s or m/s (F14): ``lam eps max(1, |q_f|)``.

    The right-hand side reads the free coordinates rounded to ``eps max(1, |q_f|)`` (rad or m;
    more coarsely where a dependent coordinate carries a stiff load), so its free accelerations
    step by ``|A| eps |q_f|``, ``A = dqdd_f/dq_f``, and over the time ``1/lam`` of the fastest
    motion the rates by ``lam eps |q_f|``. ``lam`` is the spectral radius of the free motion
    linearized at the state, ``[[0, I], [A, B]]`` with ``B = dqdd_f/dqd_f`` (central
    differences of the right-hand side, steps ``1e-6 max(1, |y_j|)``). 0 where the
    linearization is not finite.
    """
    nf = system.nf
    if not nf:
        return 0.0
    bad = system.bad             # (a neighbour not finite is not where the run stopped)
    D = np.empty((nf, 2 * nf))
    with np.errstate(all="ignore"):
        for j in range(2 * nf):
            # column j of [A, B]: (qdd_f(y + d e_j) - qdd_f(y - d e_j)) / 2 d
            d = 1e-6 * max(1.0, abs(float(y[j])))
            up, down = y.copy(), y.copy()
            up[j] += d
            down[j] -= d
            D[:, j] = (system(t, up)[nf:2 * nf] - system(t, down)[nf:2 * nf]) / (2 * d)
        system.bad = bad
        if not np.all(np.isfinite(D)):
            return 0.0
        # lam = max |eig [[0, I], [A, B]]|
        try:
            lam = float(np.max(np.abs(np.linalg.eigvals(
                np.block([[np.zeros((nf, nf)), np.eye(nf)], [D]])))))
        except (np.linalg.LinAlgError, ValueError):
            return 0.0
        res = lam * np.finfo(float).eps * max(1.0, float(np.max(np.abs(y[:nf]))))
    return res if np.isfinite(res) else 0.0


def tolerances(rtol, atol, names=("rtol", "atol")) -> tuple[float, float]:
    """The tolerances an integration uses for the ``rtol`` and ``atol`` asked for: ``rtol``
    raised to :data:`RTOL_MIN` (scipy's own floor, which it applies with a warning), both
    checked. ``names``: how the messages name them (``--rtol``, ``--atol`` on the command line).

    Raises
    ------
    ModelError
        ``rtol`` not in (0, :data:`RTOL_MAX`] or ``atol`` not in [:data:`ATOL_MIN`, inf), naming
        it (an :class:`~linkdyn.errors.ArgumentError` for what is not a number).
    """
    for name, tol in zip(names, (rtol, atol)):
        if isinstance(tol, bool) or not isinstance(tol, numbers.Real):
            raise wrong_type("simulate", name, tol, "a positive number")
    rtol, atol = float(rtol), float(atol)
    if not (0 < rtol <= RTOL_MAX):
        raise ModelError(f"{names[0]} must be a positive number up to {RTOL_MAX:g} (a relative "
                         f"error of {RTOL_MAX:.0%}), got {rtol:g}", field=names[0],
                         fix=f"Give e.g. {names[0]} 1e-8")
    if not (ATOL_MIN <= atol < np.inf):
        raise ModelError(f"{names[1]} must be a finite number of at least {ATOL_MIN:g} (rad, m, "
                         f"per s, J; below it the tolerance asks for less than the rounding of the "
                         f"state's numbers), got {atol:g}", field=names[1],
                         fix=f"Give e.g. {names[1]} 1e-10")
    return max(rtol, RTOL_MIN), atol


def _arguments(model, t, rtol, atol, method, max_steps, backend, project):
    """``simulate``'s arguments checked: ``(model, t, rtol, atol)``, the model read when given
    as a path, the tolerances those used (:func:`tolerances`). Raises a ModelError naming the
    argument (an :class:`~linkdyn.errors.ArgumentError` for a wrong type)."""
    if isinstance(model, (str, os.PathLike)):
        from .io import load_model
        model = load_model(model)
    elif not isinstance(model, Model):
        raise wrong_type("simulate", "model", model, "a Model or the path of a model file")
    t = times_argument("simulate", t)
    if t.ndim != 1 or len(t) < 1 or not np.all(np.isfinite(t)) or t[0] < 0 or np.any(np.diff(t) < 0):
        raise ModelError("output times must be a 1-D ascending array of finite times starting at "
                         "t >= 0", file=model.source, field="t",
                         fix="Pass t = numpy.linspace(0, duration, samples)")
    if not isinstance(method, str):
        raise wrong_type("simulate", "method", method, "a str")
    if method not in METHODS:
        raise ModelError(f"unknown integration method '{method}'", field="method",
                         fix=f"Use one of {', '.join(METHODS)}")
    if isinstance(max_steps, bool) or not isinstance(max_steps, numbers.Integral) or max_steps < 1:
        raise ArgumentError(f"simulate: max_steps must be a positive int, got {max_steps!r}",
                            field="max_steps", fix="Pass e.g. max_steps=50000")
    if backend is not None and not isinstance(backend, (str, backend_mod.Backend)):
        raise wrong_type("simulate", "backend", backend, "a str")
    if not isinstance(project, (bool, np.bool_)):
        raise wrong_type("simulate", "project", project, "True or False")
    return (model, t, *tolerances(rtol, atol))


@quiet
def simulate(model: Model, t, *, rtol: float = 1e-8, atol: float = 1e-10,
             method: str = "DOP853", free: tuple[str, ...] | None = None,
             max_steps: int = MAX_STEPS, backend: str | None = None,
             project: bool = True) -> Simulation:
    """Integrate the free degrees of freedom of ``model`` from ``[initial]`` and return every
    ``analyze`` quantity at the times ``t``.

    Parameters
    ----------
    model : Model
        Drivers, where present, still prescribe their joints (their efforts are reported).
        A spatial model (``space = "spatial"``) runs on :mod:`linkdyn.spatial.forward`'s
        stages (numpy; its free coordinates named as results.csv's, ``J1``, ``J3.s``).
    t : array_like (T,)
        Output times, s, ascending, ``t[0] >= 0``; the state at t = 0 is ``[initial]``.
    rtol, atol : float
        Relative and absolute tolerances of the ODE solver (absolute in rad, m, rad/s, m/s, J).
    method : {'DOP853', 'RK45', 'RK23', 'Radau', 'BDF', 'LSODA'}
        scipy ODE solver: explicit Runge-Kutta, or implicit (Radau, BDF) for stiff springs.
    free : tuple of str, optional
        The free joints (default: those of ``[initial]``, else chosen automatically).
    backend : {'auto', 'numpy', 'compiled'}, optional
        The right-hand side's evaluation (default ``LINKDYN_BACKEND`` or ``'auto'``): numpy's
        array stages, or one compiled function per evaluation (:mod:`linkdyn.forward_compiled`,
        with numba installed); ``'auto'`` starts on numpy and switches to compiled once the
        evaluations made would have paid for the compiled code's start-up (loading it from
        numba's cache, or its first compilation: :meth:`linkdyn.backend.Backend.pays_after`),
        or once the run's CPU time so far has reached that start-up (a loaded machine, or
        numpy's evaluations dearer than the cost model says), whichever comes first.
        The outputs are computed by the same backend's stages: once the compiled right-hand
        side runs, it gives their free accelerations and closed positions, and the compiled
        kinematics, dynamics and reactions kernels the rest.
    project : bool
        With a one-step method (RK45, DOP853, RK23, Radau): after every accepted step, scale
        the free rates onto the energy balance ``T + V - W = E(0)`` (F11), which keeps the
        energy of a conservative mechanism to the tolerance over any number of steps. (BDF and
        LSODA are not projected.)

    Returns
    -------
    Simulation
        A :class:`~linkdyn.analysis.Solution` with ``work``, ``energy_drift`` and ``stats``
        (for a spatial model a :class:`~linkdyn.spatial.forward.SpatialSimulation`).

    Raises
    ------
    ModelError
        No free freedom, an invalid ``[initial]``, bad times or options.
    AssemblyError
        The mechanism cannot be assembled at t = 0, or locks (cannot move on: singular
        position, loops that stop closing) or the integration fails, naming the time.
    """
    import scipy.integrate as si

    model, t, rtol, atol = _arguments(model, t, rtol, atol, method, max_steps, backend,
                                      project)
    src = model.source
    sp = stages(model)
    sp.backend(model, backend)
    part = sp.partition(model, free)
    nd, nf = part.n_drivers, len(part.free)
    be, work = sp.backend(model, backend, nf)
    rubbing = friction_mod.present(model)
    if rubbing:
        # the compiled right-hand side knows no friction: numpy's stages throughout (F13)
        be, work = sp.backend(model, "numpy", nf)
    pays = be.pays_after(work) if not rubbing else np.inf
    # "auto": numpy's CPU seconds so far against the compiled start-up, measured from here
    start_up, clock0 = (be.start_up(work) if not rubbing else np.inf), time.process_time()
    fast = be.compiled
    compiled_after = 0 if fast else None
    q0 = sp.start_state(part)
    # initial rates: the drivers' and [initial] qd; the dependent ones close J qd = 0   (F2)
    qd_free0 = np.array([model.initial_qd.get(j, 0.0) for j in part.free])
    q_f0 = q0[sp.free_rows(part)]
    system = sp.System(part, q0, np.zeros(len(q0)), fast)
    y = np.concatenate((q_f0, qd_free0, [0.0]))
    sp.check_inertia(part, system, q0)
    events = []                    # (t, joint, "sticks" | "slips") of the stick-slip state
    if rubbing:
        # a sticky coordinate at rest starts stuck where its static friction holds it (F13)
        system.modes(system.held, np.where(qd_free0 < 0, -1.0, 1.0))
        _settle(system, 0.0, y, np.flatnonzero((system.sticky >= 0) & (qd_free0 == 0)))
        events += [(0.0, part.free[i], "sticks") for i in np.flatnonzero(system.held)]
    J = system.accept(0.0, y)
    e0 = sum(system.energies(0.0, y)) if J is not None else 0.0
    balance = Balance()
    if J is None:
        sp.blame_loads(system, system.bad)
        raise AssemblyError("the mechanism starts at a singular position", file=src, time=0.0,
                            drivers=sp.values(part, q0), units=sp.units(model),
                            fix="Start the free joints ([initial] q) away from the toggle")

    t_end = float(t[-1])
    Y = np.full((2 * nf + 1, len(t)), np.nan)
    guesses = np.full((len(q0), len(t)), np.nan)
    segment = np.zeros(len(t), int)          # the partition each output sample was computed in
    # the stick-slip state each output sample was computed in (F13)
    held_at, sense_at = np.zeros((nf, len(t)), bool), np.ones((nf, len(t)))
    at0 = t <= 0.0
    Y[:, at0] = y[:, None]
    guesses[:, at0] = q0[:, None]
    if rubbing:
        held_at[:, at0], sense_at[:, at0] = system.held[:, None], system.sense[:, None]
    parts, switches = [part], []
    steps, nfev, t_now, projections = 0, 0, 0.0, 0
    atol_rates = atol          # the free rates' atol (F14; the largest of the run's restarts)
    # a free angle is integrated less its whole turns (``turns``, rad; F12): the relative
    # tolerance on it would otherwise loosen as a crank turns on (rtol |q_f| grows with the
    # turns, and with it the error of every step). Not when a load formula reads a joint
    # coordinate: a whole turn less would change that load; nor with a cut whose rows are not
    # periodic in the angles (a gear's: a whole turn of one gear turns the other by the ratio)
    turns = np.zeros(nf)
    angular = sp.angular(part)
    unwound = method in UNWOUND and not reads_coordinates(model) and sp.periodic(part)
    pace = early = np.inf      # the step size at the last check of the pace (of each kind)
    while t_now < t_end:
        # the free coordinates describe the motion badly here (near a dead point of theirs):
        # restart in the best-conditioned ones, from the same state          (F10)
        best = sp.better(part, J)
        if best is not None:
            part = sp.variant(part, best)
            _, q, qd, qdd, _ = system.ref
            q = q.copy()
            q[sp.free_rows(parts[-1])] += turns     # the whole turns back
            turns = np.zeros(nf)
            angular = sp.angular(part)
            nfev += system.nfev
            if rubbing:
                held = dict(zip(parts[-1].free, system.held))
                sense = dict(zip(parts[-1].free, system.sense))
            system = sp.System(part, q, qd, fast)
            system.set_reference(t_now, q, qd, qdd, J)
            if rubbing:   # the stick-slip state carries over by joint (F13)
                system.modes([held.get(j, False) for j in part.free],
                             [sense.get(j, 1.0) for j in part.free])
            y = np.concatenate((q[list(best)], qd[list(best)], y[-1:]))
            parts.append(part)
            switches.append((t_now, part.free))
        tol = atol
        if method in IMPLICIT:
            # the free rates' atol at least RESOLVE times their resolution: Newton's iterations
            # of the implicit step must be able to meet it                               (F14)
            tol = np.full(len(y), atol)
            tol[nf:2 * nf] = max(atol, RESOLVE * rate_resolution(system, t_now, y))
            atol_rates = max(atol_rates, float(tol[nf]))
        solver = getattr(si, method)(system, t_now, y, t_end, rtol=rtol, atol=tol)
        recent = [solver.t]      # the times of the last steps
        walls, wall = 0, np.inf   # such steps, and the earliest time not finite
        restart = False
        while solver.status == "running":
            t_old, before, bad = solver.t, system.ref, system.bad
            modes = (system.held.copy(), system.sense.copy()) if rubbing else None
            try:
                message = solver.step()
            except ValueError as exc:
                # an implicit method's Jacobian not finite (scipy refuses its LU): the
                # right-hand side overflows between nearby states
                if "infs or NaNs" not in str(exc):
                    raise
                sp.blame_loads(system, system.last)   # a load not finite, by its field
                raise AssemblyError(
                    f"the {method} method's Jacobian of the motion is not finite (a load or the "
                    "accelerations overflow between nearby states)", file=src,
                    time=float(t_old), drivers=sp.values(part, before[1]),
                    units=sp.units(part.model),
                    fix="Check the loads for values beyond floating point, or use an explicit "
                        "method (--method DOP853)") from None
            steps += 1
            # a motion approaching a position it cannot pass (a singular position of the
            # mechanism) has accelerations growing without bound: its steps collapse
            J = None if solver.status == "failed" else system.accept(solver.t, solver.y)
            # stuck: the last STUCK steps together advance less than MIN_STEP of the time
            # reached (not of the duration: a long run is not a stuck one; and a few short
            # steps are not either, as an implicit method's first ones on a stiff spring)
            recent = (recent + [solver.t])[-STUCK - 1:]
            stuck = (solver.status == "running" and len(recent) > STUCK
                     and recent[-1] - recent[0] < MIN_STEP * max(abs(solver.t), 1.0))
            failed = J is None or not np.all(np.isfinite(solver.y)) or stuck
            if failed:
                sp.blame_loads(system, system.bad)   # a load that is not finite, by its field
                sp.blame_loads(system, system.last)
            # a load not finite just beyond the steps, which shorten towards it: name it
            if system.bad is not bad:
                walls, wall = walls + 1, min(wall, system.bad[0])
            if solver.t > wall:
                walls, wall = 0, np.inf
            if walls >= WALL:
                sp.blame_loads(system, system.bad)
                walls = 0
            # the pace: after EARLY and 2 EARLY steps against FAR (each check against the
            # one before of its kind), then every PACE steps against HOPELESS * max_steps
            if solver.status == "running" and steps in (EARLY, 2 * EARLY):
                early = _pace(early, solver, t_end, max_steps, FAR, src, part, system.ref[1],
                              sp)
            if solver.status == "running" and steps % PACE == 0:
                pace = _pace(pace, solver, t_end, max_steps, HOPELESS * max_steps, src, part,
                             system.ref[1], sp)
            if failed or steps > max_steps:
                raise AssemblyError(
                    f"the integration needs more than {max_steps} steps" if not failed else
                    "the mechanism locks or reaches a position it cannot pass (a singular "
                    "position of the mechanism, or loops that stop closing)"
                    + (f"; the solver says: {message}" if message else ""),
                    file=src, time=float(t_old), drivers=sp.values(part, before[1]),
                    units=sp.units(part.model),
                    fix="Check the loads and [initial]; a stiff spring needs "
                        f"{_implicit(method)}; or shorten --duration to the time given")
            # a change of the stick-slip state within the step ends it there        (F13)
            event, dense = None, None
            if rubbing and solver.status != "failed":
                # (DOP853's dense output evaluates the right-hand side: before any change)
                dense = solver.dense_output()
                event = _transition(system, dense, t_old, solver.t, solver.y)
            t_step = solver.t
            if event is not None:
                t_step, y_event, change = event
                J = system.accept(t_step, y_event)
                events.append((t_step, part.free[change[0]], change[1]))
                if len(events) > MAX_EVENTS:
                    raise AssemblyError(
                        f"the free joints stick and slip more than {MAX_EVENTS} times",
                        file=src, time=float(t_step), drivers=sp.values(part, system.ref[1]),
                        units=sp.units(part.model),
                        fix="Shorten --duration to the time given, or give the friction a "
                            "dynamic coefficient closer to its static one")
                if J is None:
                    raise AssemblyError(f"the mechanism cannot go on where joint "
                                        f"{part.free[change[0]]} {change[1]}", file=src, time=float(t_step),
                                        drivers=sp.values(part, system.ref[1]),
                                        units=sp.units(part.model),
                                        fix="Check the loads and [initial]")
            inside = (t > t_old) & (t <= t_step)
            if np.any(inside):
                # outputs from the step's dense output; their guesses from the step's start
                Y[:, inside] = (dense or solver.dense_output())(t[inside])
                Y[:nf, inside] += turns[:, None]
                guesses[:, inside] = _hermite(before[:3], system.ref[:3], t[inside])
                segment[inside] = len(parts) - 1
                if rubbing:
                    held_at[:, inside] = modes[0][:, None]
                    sense_at[:, inside] = modes[1][:, None]
            if event is not None:
                # the integration restarts from the event's state, in its new state
                y, t_now, restart = y_event, t_step, True
                break
            if project and method in PROJECTED and solver.status != "failed":
                # back onto the energy balance: the next step starts there         (F11)
                y_p = energy_projection(system, solver.t, solver.y, e0)
                if y_p is not None:
                    f_p = system(solver.t, y_p)
                    J_p = system.accept(solver.t, y_p)
                    if J_p is not None and np.all(np.isfinite(f_p)):
                        restate(solver, y_p, f_p)
                        J = J_p
                        projections += 1
                    else:
                        system.accept(solver.t, solver.y)
            whole = np.where(angular, 2 * np.pi * np.round(solver.y[:nf] / (2 * np.pi)), 0.0)
            if np.any(whole != 0) and solver.status == "running" and unwound:
                # whole turns of the free angles moved out of the integrated state   (F12)
                y_w = solver.y.copy()
                y_w[:nf] -= whole
                system.shift(sp.free_rows(part), -whole)
                f_w = system(solver.t, y_w)
                J_w = system.accept(solver.t, y_w)
                if J_w is not None and np.all(np.isfinite(f_w)):
                    restate(solver, y_w, f_w)
                    J = J_w
                    turns += whole
                else:   # (not expected: the same poses) keep the state as it was
                    system.shift(sp.free_rows(part), whole)
                    system.accept(solver.t, solver.y)
            y, t_now = solver.y, solver.t
            if J is not None:
                # the balance at the step's end, where the integration goes on from (after
                # the projection of F11): a snap between two output samples shows here   (F9)
                balance.add(*system.energies(t_now, y), e0, y[-1])
            spent = time.process_time() - clock0
            if nfev + system.nfev >= pays or spent >= start_up:
                # "auto": numpy's evaluations so far have paid for the compiled start-up, by
                # the cost model or by the clock
                be = be.reconsider(backend_mod.Work(1 + nf, work.bodies, nfev + system.nfev,
                                                    work.stages), spent)
                pays, start_up = be.pays_after(work), be.start_up(work)
                if be.compiled:
                    fast, compiled_after = True, nfev + system.nfev
                    system.use_compiled()
            if sp.better(part, J) is not None:
                break
        if restart:
            continue
    nfev += system.nfev
    stats = dict(method=method, rtol=rtol, atol=atol, atol_rates=atol_rates, steps=steps,
                 rhs_evaluations=nfev,
                 switches=[(float(ts), list(fr)) for ts, fr in switches],
                 energy_projections=projections, energy_steps=balance.summary(),
                 backend=be.name,
                 compiled_after=compiled_after,
                 friction_iterations=system.iterations if rubbing else 0,
                 stick_slip=[(float(ts), j, what) for ts, j, what in events])
    if fast:
        backend_mod.mark_cached("rhs")
    return sp.outputs(parts, segment, t, Y, guesses, stats, system.kernel, be,
                      (held_at, sense_at))


def _pace(last: float, solver, t_end: float, max_steps: int, limit: float, src: str, part,
          q: np.ndarray, sp) -> float:
    """The step size now; raise an AssemblyError naming the time when, at a step size that
    did not grow tenfold since the last check (``last``), the run would need more than
    ``limit`` steps to reach ``t_end``; ``q`` (n,): the tree coordinates there, for the
    message (a duration far beyond the motion's time scale, or steps collapsed for good,
    which would otherwise run for hours before stopping at ``max_steps``)."""
    h = float(solver.step_size)
    need = (t_end - solver.t) / h if h > 0 else np.inf
    if np.isfinite(last) and h < 10 * last and need > limit:
        raise AssemblyError(
            f"the integration would need about {need:.3g} more steps of {h:.3g} s to reach "
            f"t = {t_end:.6g} s (at most {max_steps} are taken)", file=src,
            time=float(solver.t), drivers=sp.values(part, q), units=sp.units(part.model),
            fix="Give a --duration within reach of the motion's time scale, e.g. "
                f"{max_steps * h:.3g} s or less; for a stiff spring, "
                + _implicit(type(solver).__name__))
    return h


def _implicit(method: str) -> str:
    """The advice for a stiff spring: the implicit methods other than ``method``."""
    others = [m for m in ("BDF", "LSODA", "Radau") if m != method]
    return f"--method {others[0]} or {others[1]}"


def _blame_loads(system: System, last) -> None:
    """Raise an AssemblyError naming the load (by its field) that is not finite at the state
    of the right-hand side's last evaluation ``last = (t, y, ...)``, where the integration
    stopped: the cause is then that load, not the mechanism. Nothing if every load is finite
    there, or the state does not close."""
    if last is None:
        return
    part, nf = system.part, system.nf
    t, y = np.array([last[0]]), last[1]
    q_d, qd_d, qdd_d = driver_values(part.model, t)
    q_ind = np.concatenate((q_d, y[:nf, None]))
    qd_ind = np.concatenate((qd_d, y[nf:2 * nf, None]))
    qdd_ind = np.concatenate((qdd_d, np.zeros((nf, 1))))
    kin = at_state(part.inner, part.layout, t, q_ind, qd_ind, qdd_ind, system.guess(t, q_ind))
    if kin.valid[0]:
        blame_loads(part.model, kin, dict(file=part.model.source, time=float(t[0]),
                                          drivers=dict(zip((d.joint for d in part.inner.drivers),
                                                           q_ind[:, 0].tolist())),
                                          units=joint_units(part.model)))


def energy_projection(system, t, y, e0) -> np.ndarray | None:
    """``y`` with the free rates of ``system`` (either space's :class:`System`: its ``nf``,
    ``nd`` and ``energies``) scaled by the factor that puts it on the energy balance
    ``T + V - W = E0`` (F11), else None (no such factor within ``PROJECT_MAX`` of 1).

    ``T`` is quadratic in the factor ``a`` (the drivers' rates fixed): ``T(a) = T_2 a^2 +
    T_1 a + T_0``, from ``T`` at ``a = 1`` (and, with drivers, at 0 and -1)."""
    nf = system.nf
    if not nf:
        return None
    ke1, pe = system.energies(t, y)
    target = e0 + y[-1] - pe
    if system.nd:
        ke0 = system.energies(t, np.concatenate((y[:nf], 0.0 * y[nf:2 * nf], y[-1:])))[0]
        kem = system.energies(t, np.concatenate((y[:nf], -y[nf:2 * nf], y[-1:])))[0]
        t2, t1, t0 = 0.5 * (ke1 + kem) - ke0, 0.5 * (ke1 - kem), ke0
    else:
        t2, t1, t0 = ke1, 0.0, 0.0
    disc = t1 * t1 - 4.0 * t2 * (t0 - target)
    if not (t2 > 0 and disc >= 0):
        return None
    roots = ((-t1 + np.sqrt(disc)) / (2 * t2), (-t1 - np.sqrt(disc)) / (2 * t2))
    a = min(roots, key=lambda x: abs(x - 1.0))
    if not abs(a - 1.0) <= PROJECT_MAX:
        return None
    return np.concatenate((y[:nf], a * y[nf:2 * nf], y[-1:]))


def restate(solver, y: np.ndarray, f: np.ndarray) -> None:
    """Move a scipy ``solver`` between two steps, at its current time, to the state ``y``
    (right-hand side ``f``): its next step starts there (F11, F12).

    An explicit Runge-Kutta method keeps only ``y`` and ``f``. Radau also keeps its last step's
    collocation polynomial, from which it predicts the next step's stages (Newton's start);
    BDF keeps its history as backward differences ``D[i] = nabla^i y_n``, from which it
    predicts and corrects. Their history moves with the state by the same constant
    ``y - solver.y`` (``D[0]`` only, the differences unchanged): for Radau's prediction a
    better start, for BDF exact only when every past state may move with it, as under whole
    turns of a free angle (the right-hand side periodic in it), so BDF is not projected (F11).
    Not for LSODA: ODEPACK keeps its history in its own work arrays, to be changed only by a
    restart.
    """
    import copy

    import scipy.integrate as si

    delta = y - solver.y
    if isinstance(solver, si.BDF):
        solver.D[0] += delta
    elif isinstance(solver, si.Radau):
        if solver.sol is not None:
            sol = copy.copy(solver.sol)       # the dense output already read stays as it was
            sol.y_old = sol.y_old + delta
            solver.sol = sol
        solver.f = f
    elif isinstance(solver, (si.RK45, si.DOP853, si.RK23)):
        solver.f = f
    else:
        raise TypeError(f"the state of {type(solver).__name__} cannot be changed between steps")
    solver.y = y


def reads_coordinates(model: Model) -> bool:
    """Whether a load formula of ``model`` reads a joint coordinate ``q_<joint>``: the right-
    hand side then changes with a whole turn of a free angle, which is then not removed (F12)."""
    return any(name.startswith("q_") for load in model.loads
               for name in getattr(load.value, "state_variables", ()))


def topo_free(part: Partition) -> tuple[int, ...]:
    """The tree bodies of the free coordinates of ``part``."""
    return part.layout.topo.driven[part.n_drivers:]


def _better(part: Partition, J: np.ndarray) -> tuple[int, ...] | None:
    """The tree bodies of better free coordinates where those of ``part`` describe the motion
    badly at the state of closure Jacobian ``J`` (growth past ``SWITCH`` and twice the best's),
    else None (F10)."""
    if closure_growth(part, J) <= SWITCH:   # the usual case, without conditioning's SVD
        return None
    growth, best, best_growth = conditioning(part, J)
    return best if growth > SWITCH and best_growth < growth / 2 else None


def closure_growth(part: Partition, J: np.ndarray) -> float:
    """``growth`` of :func:`conditioning` for the free coordinates of ``part`` alone, from the
    null space written in them: the dependent rates per unit free rate ``S = -J_dep^-1 J_f``
    (scaled as there), ``max(1, max |S|)``; infinite where ``J_dep`` is not square and
    regular."""
    topo, lay = part.layout.topo, part.layout
    dep, free = np.array(topo.dependent, int), np.array(topo_free(part), int)
    if len(dep) != J.shape[0]:
        return np.inf
    if not len(dep):
        return 1.0
    unit = np.where(lay.view.angular, 1.0, float(lay.size))   # rad, or m per size
    with np.errstate(all="ignore"):
        try:
            S = np.linalg.solve(J[:, dep - 1] * unit[dep], -J[:, free - 1] * unit[free])
        except np.linalg.LinAlgError:
            return np.inf
    return max(1.0, float(np.max(np.abs(S)))) if np.all(np.isfinite(S)) else np.inf


def _values(part: Partition, q: np.ndarray) -> dict[str, float]:
    """The independent coordinates (drivers' and free ones) of tree coordinates ``q`` (n,),
    by joint name, rad or m (for an error's message)."""
    topo = part.layout.topo
    return {part.inner.drivers[k].joint: float(q[i]) for k, i in enumerate(topo.driven)}


def _hermite(a, b, t):
    """Tree coordinates (n, T) at ``t`` by the cubic Hermite through the states ``a`` and ``b``,
    each ``(time, q (n,), qd (n,))``: the guesses of the output samples within a step."""
    (t0, q0, v0), (t1, q1, v1) = a, b
    h = t1 - t0
    u = (np.asarray(t) - t0) / h
    h00, h10, h01, h11 = 2 * u**3 - 3 * u**2 + 1, u**3 - 2 * u**2 + u, -2 * u**3 + 3 * u**2, u**3 - u**2
    return (q0[:, None] * h00 + v0[:, None] * (h * h10) + q1[:, None] * h01
            + v1[:, None] * (h * h11))


def _outputs(parts: list[Partition], segment, t, Y, guesses, stats, kernel,
             backend, modes) -> Simulation:
    """Every ``analyze`` quantity at the output states, each sample in the partition it was
    integrated in (``parts[segment[k]]``, all on one tree): the free accelerations (F6), then
    the kinematics, loads, DeNOC inverse dynamics and reactions of the same stages as
    ``analyze``; the segments' results joined along the samples. With ``kernel`` (the run's
    compiled right-hand side) the free accelerations and closed positions come from it, and
    ``backend`` (the run's) gives the stages after it. ``modes``: the stick-slip state
    ``(held, sense)`` (nf, T) each sample was integrated in (F13)."""
    groups = [np.flatnonzero(segment == k) for k in range(len(parts))]
    groups = [(parts[k], g) for k, g in enumerate(groups) if len(g)]
    done = [_stages(p, t[g], Y[:, g], guesses[:, g], kernel, backend,
                    tuple(m[:, g] for m in modes)) for p, g in groups]
    stats["free_effort_residual"] = max(d[-2] for d in done)
    stats["closure_residual"] = max(d[-1] for d in done)
    order = np.argsort(np.concatenate([g for _, g in groups]), kind="stable")
    if len(done) == 1:
        kin, applied, dyn, react, valid = done[0][:5]
    else:
        kin, applied, dyn, react, valid = _join([d[:5] for d in done], order)
    model, fr = parts[0].model, None
    if friction_mod.present(model):
        # each friction load's effort and power at the outputs (F13)
        rows = friction_mod.rows(model, parts[0].layout.topo)
        f = np.concatenate([d[5][0] for d in done], axis=1)[:, order]
        qd = np.stack([np.broadcast_to(kin.joint_motion[1][r.joint], t.shape) for r in rows])
        stats["friction_residual"] = max(d[5][1] for d in done)
        fr = friction_mod.Friction(tuple(model.joints[r.joint].name for r in rows),
                                   tuple(r.label for r in rows),
                                   tuple(r.axis is None for r in rows), f, f * qd,
                                   stats.get("friction_iterations", 0),
                                   stats["friction_residual"], np.zeros(t.shape, bool),
                                   np.full(t.shape, -1))
    return Simulation(model, kin, applied, dyn, react, valid, friction=fr, work=Y[-1],
                      free=parts[0].free, stats=stats)


def _stages(part: Partition, t, Y, guesses, kernel, backend, modes):
    """``(kin, loads, dyn, reactions, valid, free effort residual, closure residual)`` at the
    output states ``Y`` (2 nf + 1, T) of one partition, ``guesses`` (n, T) their tree
    coordinates; ``kernel``: the run's compiled right-hand side (:class:`.forward_compiled.Kernel`,
    of any partition), which then gives the free accelerations and the closed positions
    (numpy's stages where its Newton's method does not close the loops), and the stages after
    it are the compiled kernels (the kinematics kernel at the closed positions, the dynamics
    and reactions kernels) of ``backend``, the run's, as ``analyze`` maps a backend to them
    (:func:`.analysis.stage_functions`). With friction loads (numpy's right-hand side, F13),
    ``modes`` ``(held, sense)`` (nf, T) is the stick-slip state of each sample, and the result
    has one more entry before the residuals: the friction efforts (k, T) and the largest
    residual of their law relative to the largest effort, where they follow it."""
    model, lay = part.model, part.layout
    nd, nf = part.n_drivers, len(part.free)
    q_f, qd_f = Y[:nf], Y[nf:2 * nf]
    qdd_f, open_ = np.empty((nf, len(t))), np.ones(len(t), bool)
    if kernel is not None:
        # the free accelerations (F6) and closed positions by the compiled right-hand side,
        # sample by sample from its guess; its closed positions are the guesses below
        if kernel.part is not part:
            kernel = type(kernel)(part)
        zero = np.zeros(lay.topo.n)
        guesses = guesses.copy()
        for k in range(len(t)):
            ref = (t[k], guesses[:, k], zero, zero, None)
            out = kernel(t[k], Y[:, k], ref, np.ones(nf))
            if out is not None and np.any(unit_scale(out[nf:2 * nf]) != 1.0):
                # again with unit accelerations the size of these (F5)
                out = kernel(t[k], Y[:, k], ref, unit_scale(out[nf:2 * nf]))
            if out is not None:
                qdd_f[:, k], guesses[:, k], open_[k] = out[nf:2 * nf], kernel.state[0], False
    system = System(part, guesses[:, 0], np.zeros(lay.topo.n))
    efforts = np.zeros((len(system.rows), len(t)))
    # one evaluation per stick-slip state met (none without friction: one state)
    state = np.concatenate(modes) if system.rows else np.zeros((1, len(t)))
    for mode in np.unique(state, axis=1).T:
        at = open_ & np.all(state == mode[:, None], axis=0)
        if not np.any(at):
            continue
        # numpy's stages (and their damped restart) where the compiled Newton did not close
        if system.rows:
            system.modes(mode[:nf] > 0.5, mode[nf:])
        args = (t[at], q_f[:, at], qd_f[:, at], guesses[:, at])
        qdd_f[:, at] = qdd = system.evaluate(*args)[0]
        if np.any(unit_scale(qdd) != 1.0):
            # again with unit accelerations the size of these (F5)
            qdd_f[:, at] = system.evaluate(*args, near=qdd)[0]
        if system.rows:
            efforts[:, at] = system.efforts
    q_d, qd_d, qdd_d = driver_values(model, t)
    q_ind, qd_ind, qdd_ind = (np.concatenate(x) for x in ((q_d, q_f), (qd_d, qd_f),
                                                           (qdd_d, qdd_f)))
    if kernel is None:
        kin = at_state(part.inner, lay, t, q_ind, qd_ind, qdd_ind, guesses)
    else:
        # the loops closed (by the right-hand side, else as at_state closes them), the rest of
        # the kinematics by the compiled kernel
        if np.any(open_):
            guesses[:, open_] = close(lay, q_ind[:, open_], guesses[:, open_])[0]
        kin = at_closed(part.inner, lay, t, guesses, qd_ind, qdd_ind)
    applied = loads_mod.wrenches(model, kin)
    if system.rows:   # the friction efforts of the right-hand side, applied           (F13)
        applied = friction_mod.with_efforts(applied, kin, system.rows, efforts)
    dynamics, reactions_stage = stage_functions(backend)
    dyn = dynamics(kin, applied)
    react = reactions_stage(part.inner, kin, applied, dyn)
    # the free joints' efforts vanish at the solution of F6: what is left is rounding
    # scale: the generalized forces of the loads alone and of the inertia alone (Q + loads')
    _, q_loads = denoc.reduce(kin, applied.wrenches)
    scale = max(float(np.nanmax(np.abs(q_loads), initial=0.0)),
                float(np.nanmax(np.abs(dyn.Q.T + q_loads), initial=0.0)), 1e-300)
    residual = float(np.nanmax(np.abs(dyn.tau[..., nd:])) / scale) if nf else 0.0
    closure = float(np.nanmax(kin.residual)) if len(t) else 0.0
    valid = kin.valid & (kin.pivot > SINGULAR) & (dyn.pivot > SINGULAR)
    dyn = replace(dyn, tau=dyn.tau[..., :nd])
    if not system.rows:
        return kin, applied, dyn, react, valid, residual, closure
    # the law (T9) at the final reactions, where a friction load follows it (not holding)
    held = np.zeros(efforts.shape, bool)
    sense = np.full(efforts.shape, np.nan)
    for i in np.flatnonzero(system.sticky >= 0):
        held[system.sticky[i]] = modes[0][i]
        sense[system.sticky[i]] = modes[1][i]
    qd = np.stack([np.broadcast_to(kin.joint_motion[1][r.joint], t.shape) for r in system.rows])
    g, _ = friction_mod.equations(system.rows, friction_mod.forces(react, system.rows), qd,
                                  sense)
    scale = max(float(np.nanmax(np.abs(efforts), initial=0.0)), 1e-300)
    law = float(np.nanmax(np.where(held, 0.0, np.abs(efforts - g)), initial=0.0)) / scale
    return kin, applied, dyn, react, valid, (efforts, law), residual, closure


def _join(results: list[tuple], order: np.ndarray) -> tuple:
    """The ``(kin, loads, dyn, reactions, valid)`` of the segments joined along the samples,
    in time order (``order``). The layout is the first segment's: the segments share the tree,
    the cut joints and every number; they differ only in which tree coordinates were
    independent, which the joined results no longer depend on (the efforts kept are the
    drivers')."""
    kins, loads, dyns, reacts, valids = zip(*results)
    sizes = [len(v) for v in valids]

    def cat(parts: list, axis: int = -1):
        # one field: arrays joined along the samples (``axis``, where each part has its own
        # count, or 1 for a broadcast); lists, tuples and dataclasses entry by entry
        x = parts[0]
        if x is None:
            return None
        if isinstance(x, (list, tuple)):
            return type(x)(cat([p[k] for p in parts], axis) for k in range(len(x)))
        if hasattr(x, "__dataclass_fields__"):
            return replace(x, **{f.name: cat([getattr(p, f.name) for p in parts], axis)
                                 for f in fields(x)})
        arrays = []
        for p, n in zip(parts, sizes):
            p = np.asarray(p)
            shape = list(p.shape)
            shape[axis] = n
            arrays.append(np.broadcast_to(p, shape))
        return np.take(np.concatenate(arrays, axis=axis), order, axis=axis)

    def each(objs, skip=()):
        return {f.name: cat([getattr(o, f.name) for o in objs]) for f in fields(objs[0])
                if f.name not in skip}
    kin = replace(kins[0], **each(kins, ("layout", "arrays")), arrays=None)
    applied = replace(loads[0], **each(loads, ("has_potential",)))
    # components-last arrays (T, ...): multipliers, efforts, generalized forces
    internals = tuple(cat([d._internals[k] for d in dyns], 0 if k == 2 else -1) for k in range(3))
    dyn = replace(dyns[0], lam=cat([d.lam for d in dyns], 0), tau=cat([d.tau for d in dyns], 0),
                  kinetic_energy=cat([d.kinetic_energy for d in dyns]),
                  pivot=cat([d.pivot for d in dyns]), internals=internals)
    react = replace(reacts[0], on_second=cat([r.on_second for r in reacts]),
                    internals=cat([r.tree for r in reacts]))
    return kin, applied, dyn, react, cat(list(valids))


class Planar:
    """The stages :func:`simulate`'s driver calls for a planar model (a spatial model's:
    :mod:`linkdyn.spatial.forward`, through :class:`Spatial`): the partition, the start, the
    ODE system, the outputs, the messages' values."""

    partition = staticmethod(partition)
    start_state = staticmethod(start_state)
    System = System
    check_inertia = staticmethod(check_inertia)
    better = staticmethod(_better)
    variant = staticmethod(_variant)
    outputs = staticmethod(_outputs)
    blame_loads = staticmethod(_blame_loads)
    values = staticmethod(_values)
    units = staticmethod(joint_units)

    @staticmethod
    def backend(model: Model, backend, nf: int | None = None):
        """The backend asked for checked (``nf`` None), else the one chosen for the right-hand
        side and its work (the 1 + nf inverse dynamics of F5 over the moving bodies)."""
        kinds = [j.kind for j in model.joints]
        if nf is None:
            return backend_mod.choose(backend, None, kinds), None
        work = backend_mod.Work(1 + nf, len(model.bodies) - 1, 0, backend_mod.SIMULATION)
        return backend_mod.choose(backend, work, kinds), work

    @staticmethod
    def free_rows(part: Partition) -> list[int]:
        """The free coordinates' rows in the tree coordinates."""
        return list(topo_free(part))

    @staticmethod
    def angular(part: Partition) -> np.ndarray:
        return np.array([jk.get(part.layout.kind[i]).angular for i in topo_free(part)], bool)

    @staticmethod
    def periodic(part: Partition) -> bool:
        """Whether the cut rows are periodic in the angles (F12; not a gear's)."""
        return all(jk.get(k).periodic for k in part.layout.cut_kind)


class Spatial:
    """The stages of a spatial model (:mod:`linkdyn.spatial.forward`), numpy only."""

    def __getattr__(self, name):
        from .spatial import forward as sf
        return getattr(sf, name)

    @staticmethod
    def backend(model, backend, nf: int | None = None):
        """numpy's backend (``backend`` "compiled" refused, as ``analyze`` refuses it)."""
        if backend == "compiled":
            raise ModelError("the compiled backend is not yet for spatial models",
                             field="backend", fix="Use backend='numpy' (or leave it unset)")
        return backend_mod.choose("numpy", None, ()), None

    @staticmethod
    def outputs(parts, segment, t, Y, guesses, stats, kernel, backend, modes):
        """The spatial outputs (:func:`linkdyn.spatial.forward.outputs`); ``modes``, the
        stick-slip state, is all sliding: spatial models have no friction loads."""
        from .spatial import forward as sf
        return sf.outputs(parts, segment, t, Y, guesses, stats, kernel, backend)

    @staticmethod
    def better(part, J):
        """Better free coordinates past ``SWITCH`` (F10): :func:`linkdyn.spatial.forward.better`."""
        from .spatial import forward as sf
        return sf.better(part, J, SWITCH)

    free_rows = staticmethod(lambda part: part.free_rows)
    angular = staticmethod(lambda part: part.angular)
    periodic = staticmethod(lambda part: True)      # rotation coordinates enter by rotations
    blame_loads = staticmethod(lambda system, last: None)


def stages(model: Model):
    """The driver's stages for ``model``'s space: :class:`Planar` or :class:`Spatial`."""
    return Spatial() if model.space == "spatial" else Planar
