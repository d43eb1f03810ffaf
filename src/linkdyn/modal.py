"""Static equilibrium of the free coordinates and the small vibrations about it.

A mechanism with ``f`` free degrees of freedom (mobility minus drivers, as for ``simulate``)
obeys ``H(q_f) qdd_f + h(q_f, qd_f) = 0`` in its free coordinates (docs/theory.md, F4-F6:
``h`` is the effort an actuator in each free joint would need to hold ``qdd_f = 0``, ``H`` the
generalized inertia), with the drivers held at their position at t = 0 and the loads at t = 0.

- **Equilibrium** (E1): ``h(q_f, 0) = 0``, by Newton's method on ``q_f`` from ``[initial] q``
  (else the assembly), ``q_f <- q_f - K^-1 h`` with the stiffness ``K = dh/dq_f``.
- **Linearization** (E2): about the equilibrium, ``H dq'' + C dq' + K dq = 0`` with
  ``K = dh/dq_f`` and ``C = dh/dqd_f`` at ``qd_f = 0`` (dampers and rate-dependent loads; the
  velocity-quadratic terms vanish there), each column by the fourth-order central difference
  ``(8 (h(+d) - h(-d)) - (h(+2d) - h(-2d))) / (12 d)`` (truncation ``O(d^4)``), all of them in
  one batch of the same inverse dynamics ``simulate`` integrates.
- **Modes** (E3): the eigenvalues ``s`` of ``[[0, I], [-H^-1 K, -H^-1 C]]``: natural frequency
  ``|s| / 2 pi``, damping ratio ``-Re s / |s|``; undamped (``C = 0``), the symmetric problem
  ``K v = w^2 H v``. Stable: every ``Re s < 0`` (undamped: every ``w^2 > 0``).

Both spaces run the same Newton's method and eigen-solver: a spatial model (``space =
"spatial"``) takes the stages of :mod:`linkdyn.spatial.forward` (its partition, start and
``System.reduced``) through :func:`linkdyn.forward.stages`, as ``simulate`` does; its free
coordinates and mode shapes are the named joint coordinates (``J1``, ``J3.1``, ``J2.s``; a
spherical joint's have no names and no rows in the shapes).

Everything is SI (rad, m, N m, N, kg m^2, Hz); the command line prints in the file's units.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import joints as jk
from .errors import AssemblyError, ModelError
from .forward import stages
from .kinematics.positions import driver_values
from .model import Driver, Model, point_spread
from .motion import ExpressionMotion

MAX_ITER = 50        # Newton steps of the equilibrium (E1)
STEP_TOL = 1e-13     # converged when a step moves q_f less than this (rad, or m per size)
DELTA = 1e-3         # finite-difference step of E2 (rad, or m per size; rad/s, m/s per size)
MAX_STEP = 0.5       # largest Newton step (rad, or m per size): the next state must close


class _Held:
    """A driver held at rest at ``value`` (rad or m)."""

    def __init__(self, value: float):
        self.value = float(value)

    def evaluate(self, t):
        z = np.zeros(np.shape(t))
        return z + self.value, z, z


@dataclass(frozen=True)
class Equilibrium:
    """A static equilibrium of the free coordinates and the linearized equations about it.

    Attributes
    ----------
    model : Model
    free : tuple[str, ...]
        The free joints (spatial: joint coordinates, ``J1``, ``J3.1``), in the order of every
        array below.
    q : ndarray (f,)
        Their coordinates at equilibrium, rad or m.
    joint_q : dict[str, float]
        Every tree joint's coordinate there (drivers at their t = 0 value), rad or m; of a
        spatial model every named tree coordinate (``J1``, ``J3.1``; rotations from the
        design pose).
    residual : ndarray (f,)
        ``h`` at the solution, N m or N (what an actuator in each free joint would still need).
    iterations : int
        Newton steps taken (0: the start taken as the equilibrium, ``search=False``).
    mass, stiffness, damping : ndarray (f, f)
        ``H``, ``K = dh/dq_f``, ``C = dh/dqd_f`` there (kg m^2 / N m per rad / N m s per rad
        for angles; kg, N/m, N s/m for lengths; mixed where the coordinates mix).
    efforts : dict[str, float]
        The efforts that hold each driver there, N m or N.
    shape_map : ndarray (n_tree, f)
        Each tree joint's coordinate change per unit change of each free coordinate (the
        closure's ``dq_dep/dq_f``), for the mode shapes of every joint.
    tree_joints : tuple[str, ...]
        The joints of the rows of ``shape_map`` (spatial: the named tree coordinates).
    """

    model: Model
    free: tuple[str, ...]
    q: np.ndarray
    joint_q: dict
    residual: np.ndarray
    iterations: int
    mass: np.ndarray
    stiffness: np.ndarray
    damping: np.ndarray
    efforts: dict
    shape_map: np.ndarray
    tree_joints: tuple

    def __repr__(self) -> str:
        q = ", ".join(f"{j} = {v:.6g}" for j, v in zip(self.free, self.q))
        return (f"<Equilibrium of {self.model.name!r}: {q} (SI), "
                f"{'stable' if self.stable else 'unstable'}, {self.iterations} Newton steps>")

    @property
    def stable(self) -> bool:
        """Whether small motions about it stay small: every mode decays or oscillates."""
        return bool(modes(self).stable)


@dataclass(frozen=True)
class Modes:
    """The small vibrations about an equilibrium (E3).

    Attributes
    ----------
    equilibrium : Equilibrium
    eigenvalues : ndarray (2 f,) complex
        ``s`` of ``dq = v exp(s t)``, 1/s, sorted by ``|s|``.
    frequencies : ndarray (m,)
        Natural frequencies ``|s| / 2 pi``, Hz, one per mode (a conjugate pair, or a real
        root of an overdamped or unstable coordinate), ascending.
    damping_ratios : ndarray (m,)
        ``-Re s / |s|`` (0 undamped, 1 critical; negative: the motion grows).
    shapes : ndarray (f, m)
        Each mode's free-coordinate shape, its largest component 1 (real part for a pair).
    joint_shapes : ndarray (n_tree, m)
        The same for every tree joint (``equilibrium.tree_joints``).
    stable : bool
        Every mode decays or oscillates (undamped: every ``w^2 > 0``).
    """

    equilibrium: Equilibrium
    eigenvalues: np.ndarray
    frequencies: np.ndarray
    damping_ratios: np.ndarray
    shapes: np.ndarray
    joint_shapes: np.ndarray
    stable: bool

    def __repr__(self) -> str:
        f = ", ".join(f"{x:.6g}" for x in self.frequencies)
        return f"<Modes of {self.equilibrium.model.name!r}: {f} Hz>"

    @property
    def oscillating(self) -> np.ndarray:
        """The modes that swing (not an overdamped or unstable real root): ``0 <= zeta < 1``
        and a frequency above 0; indices, ascending."""
        z = self.damping_ratios
        return np.nonzero((z >= 0) & (z < 1) & (self.frequencies > 0))[0]


def _spatial(part) -> bool:
    return getattr(part.model, "space", "planar") == "spatial"


def _scales(part) -> np.ndarray:
    """Size of a unit step of each free coordinate (nf,): 1 rad, or the mechanism's size in m."""
    size = part.plan.size if _spatial(part) else part.layout.size
    return np.where(stages(part.model).angular(part), 1.0, float(size))


def _coordinates(part) -> tuple[tuple[str, ...], list[int]]:
    """The named coordinates of the tree and their rows in the tree coordinates: each moving
    body's joint (planar), each named joint coordinate ``J1``, ``J3.1`` (spatial)."""
    if _spatial(part):
        from .spatial.forward import coordinate_rows
        from .spatial.reader import coordinate_names
        rows = coordinate_rows(part.model, part.plan, coordinate_names(part.model.joints))
        named = sorted(rows.items(), key=lambda kv: kv[1])
        return tuple(n for n, _ in named), [r for _, r in named]
    topo = part.layout.topo
    return (tuple(part.model.joints[j].name for j in topo.tree_joint[1:]),
            list(range(1, topo.n)))


def _angular(model: Model, name: str) -> bool:
    """Whether the coordinate ``name`` (a joint, or a spatial joint coordinate) is an angle."""
    if getattr(model, "space", "planar") == "spatial":
        from .spatial.reader import coordinate_names
        return bool(coordinate_names(model.joints)[name][2])
    return bool(jk.get(model.joint(name).kind).angular)


def _forces(system, t, q, dqd):
    """``h`` (nf, T), ``H`` (nf, nf, T), the drivers' efforts at ``qdd_f = 0`` (nd, T) and
    whether each state closes clear of a singular position (T,), at the free coordinates
    ``q`` and rates ``dqd`` (nf, T each), drivers held, by the space's ``System.reduced``."""
    part, nd = system.part, system.nd
    drivers = driver_values(part.model, t)
    guess = system.guess(t, np.concatenate((drivers[0], q)))
    if _spatial(part):
        from .spatial import kinematics as sk
        H, h, tau, m, _, err = system.reduced(t, q, dqd, guess)
        dep, T = system.dep, len(t)
        ok = (err <= sk.CLOSED) & (sk.rank_of(system.p, m.J[:T][:, :, dep], dep) == len(dep))
        return h, H, tau[0, :, :nd].T, ok
    H, h, tau, kin, _, dyn = system.reduced(t, q, dqd, guess, drivers)
    ok = kin.valid[0] & (kin.pivot[0] > 1e-9) & (dyn.pivot[0] > 1e-9)
    return h, H, tau[:nd, 0], ok


def _held(model: Model) -> Model:
    """``model`` with every driver held at rest at its position at t = 0."""
    if not model.drivers:
        return model
    q0 = driver_values(model, np.zeros(1))[0][:, 0]
    return replace(model, drivers=tuple(replace(d, motion=_Held(v))
                                        for d, v in zip(model.drivers, q0)))


def _linear(system, q_f: np.ndarray, scale: np.ndarray):
    """``h``, ``H``, ``K``, ``C`` at ``(q_f, qd_f = 0)`` (E2), with the kinematics of the state:
    the state and its 8 f finite-difference neighbours in one batch."""
    nf = len(q_f)
    steps = np.array([1.0, -1.0, 2.0, -2.0])
    # samples: 0 the state; then q_f + s d e_j, then qd_f + s d e_j (s in steps)
    dq = np.zeros((nf, 1 + 8 * nf))
    dqd = np.zeros((nf, 1 + 8 * nf))
    for j in range(nf):
        for k, s in enumerate(steps):
            dq[j, 1 + 4 * j + k] = s * DELTA * scale[j]
            dqd[j, 1 + 4 * nf + 4 * j + k] = s * DELTA * scale[j]
    t = np.zeros(dq.shape[1])
    h, H, tau, ok = _forces(system, t, q_f[:, None] + dq, dqd)
    if not np.all(ok):
        return None

    def derivative(offset):
        # (8 (h(+d) - h(-d)) - (h(+2d) - h(-2d))) / (12 d), column j       (E2)
        out = np.empty((nf, nf))
        for j in range(nf):
            a, b, c, d = (h[:, offset + 4 * j + k] for k in range(4))
            out[:, j] = (8.0 * (a - b) - (c - d)) / (12.0 * DELTA * scale[j])
        return out
    return h[:, 0], H[:, :, 0], derivative(1), derivative(1 + 4 * nf), tau[:, 0]


def equilibrium(model: Model, *, free: tuple[str, ...] | None = None,
                search: bool = True) -> Equilibrium:
    """The static equilibrium of the free coordinates of ``model`` near ``[initial] q`` (else
    its assembly), with the drivers held at their position at t = 0 and the loads at t = 0.

    Parameters
    ----------
    model : Model
        A mechanism with at least one free degree of freedom (as for ``simulate``).
    free : tuple of str, optional
        The free joints (default: ``[initial]``'s, else chosen as ``simulate`` chooses).
    search : bool
        False: no Newton step; ``H``, ``K`` and ``C`` (E2) at the start itself, as where a
        benchmark publishes its equilibrium and asks for the linearization there. The
        ``residual`` then says how far the start is from an equilibrium (``iterations`` 0).

    Returns
    -------
    Equilibrium

    Raises
    ------
    ModelError
        No free degree of freedom, or an invalid ``[initial]``.
    AssemblyError
        The start cannot be assembled, Newton's method leaves the positions the mechanism can
        reach or does not converge in ``MAX_ITER`` steps (no equilibrium near the start), or
        the stiffness is singular there (a neutral equilibrium: a mechanism with nothing to
        hold it, or a dead point).
    """
    return Linearization(model, free=free).equilibrium(search=search)


class Linearization:
    """The set-up of :func:`equilibrium` and :func:`modes` for one mechanism, made once: its
    free coordinates (the partition), its start assembled, the forward dynamics' ``System``
    and the check of its mass matrix. Each :meth:`equilibrium` then runs only Newton's method
    (E1) and the linearization (E2); given another ``model`` of the same mechanism (the same
    bodies, joints and drivers: other loads, springs, masses, gravity or dimensions, as a
    designer sweeping a spring's stiffness has), it re-reads that model's numbers with the
    same free coordinates and starts from the last equilibrium found, a continuation along the
    sweep, instead of from the file's start.

    Parameters
    ----------
    model : Model
        A mechanism with at least one free degree of freedom (as for ``simulate``).
    free : tuple of str, optional
        The free joints (spatial: joint coordinates) (default: ``[initial]``'s, else chosen as
        ``simulate`` chooses).

    Raises
    ------
    ModelError, AssemblyError
        As :func:`equilibrium`, for what the set-up finds.

    Examples
    --------
    >>> lin = Linearization(model)                                   # doctest: +SKIP
    >>> [modes(lin.equilibrium(with_spring(model, k))).frequencies for k in ks]  # doctest: +SKIP
    """

    def __init__(self, model: Model, *, free: tuple[str, ...] | None = None):
        if not isinstance(model, Model):
            from .errors import wrong_type
            raise wrong_type("model", model, "a linkdyn Model (linkdyn.load(path))")
        self._setup(model, free, None)

    def __repr__(self) -> str:
        return f"<Linearization of {self.model.name!r}: free {', '.join(self.free)}>"

    @property
    def free(self) -> tuple[str, ...]:
        """The free joints (spatial: joint coordinates), in the order of every array."""
        return self.part.free

    def _setup(self, model: Model, free, q_tree) -> None:
        """The partition of ``model`` (free coordinates ``free``), its System and its start:
        the tree coordinates ``q_tree`` (n,), else its own assembled start."""
        st = stages(model)
        part = st.partition(_held(model), free)
        if q_tree is None:
            q_tree = st.start_state(part)
        system = st.System(part, q_tree, np.zeros(len(q_tree)))
        st.check_inertia(part, system, q_tree)
        self.model, self.part, self.system = model, part, system
        self.free_rows = list(st.free_rows(part))
        self.scale = _scales(part)
        self.q_tree = np.array(q_tree, float)

    def _same(self, model: Model) -> None:
        """Refuse a model that is not this mechanism (field ``model``)."""
        def shape(m):
            return (getattr(m, "space", "planar"), tuple(b.name for b in m.bodies),
                    tuple((j.name, j.kind, j.body_a, j.body_b) for j in m.joints),
                    tuple(d.joint for d in m.drivers))
        if not isinstance(model, Model):
            from .errors import wrong_type
            raise wrong_type("model", model, "a linkdyn Model (linkdyn.load(path))")
        if shape(model) != shape(self.model):
            raise ModelError(
                f"this Linearization is set up for {self.model.name!r}: {model.name!r} has "
                "other bodies, joints or drivers", file=model.source, field="model",
                fix="Set up a new Linearization(model) for another mechanism")

    def equilibrium(self, model: Model | None = None, *, search: bool = True) -> Equilibrium:
        """The static equilibrium and the linearization about it (:func:`equilibrium`).

        Parameters
        ----------
        model : Model, optional
            The same mechanism with other numbers (loads, springs, masses, gravity,
            dimensions); solved from the last equilibrium found. Default: the set-up's own
            model, from its start (the last equilibrium found, after the first).
        search : bool
            False: no Newton step, the linearization at the start (:func:`equilibrium`).

        Returns
        -------
        Equilibrium
        """
        if model is not None and model is not self.model:
            self._same(model)
            self._setup(model, self.part.free, self.q_tree)
        model, part, system, scale = self.model, self.part, self.system, self.scale
        src = model.source
        nd, nf, free_rows = part.n_drivers, len(part.free), self.free_rows
        q_tree = self.q_tree
        q_f = q_tree[free_rows].copy()
        system.set_reference(0.0, q_tree, np.zeros_like(q_tree))
        state = np.concatenate((q_f, np.zeros(nf), [0.0]))
        if system.accept(0.0, state) is None:
            raise AssemblyError("the mechanism does not close at its start", file=src,
                                time=0.0, fix="Start the free joints ([initial] q) elsewhere")
        lin = _linear(system, q_f, scale)
        if search:
            q_f, lin, it = _newton(system, part, q_f, lin, scale)
        elif lin is None:
            raise AssemblyError(
                "the start cannot be linearized: a dead point, or a loop that does not close "
                "beside it", file=src, time=0.0,
                fix="Start the free joints ([initial] q) elsewhere")
        else:
            it = 0
        h, H, K, C, tau = lin
        # every tree coordinate's value and its share of the free ones' changes      (F2)
        names, rows = _coordinates(part)
        q_now, S, dep = system.ref[1], system.ref[4], system.dep
        shape_map = np.zeros((len(q_now), nf))
        shape_map[free_rows] = np.eye(nf)
        if S is not None and len(dep):
            shape_map[dep] = S[:, nd:]
        if search:
            self.q_tree = np.array(q_now, float)       # the next solve's start
        return Equilibrium(
            model=model, free=part.free, q=q_f, iterations=it,
            joint_q={n_: float(q_now[r]) for n_, r in zip(names, rows)},
            residual=h, mass=H, stiffness=K, damping=C,
            efforts={model.drivers[k].joint: float(tau[k]) for k in range(nd)},
            shape_map=shape_map[rows], tree_joints=names)

    def modes(self, model: Model | None = None, *, search: bool = True) -> "Modes":
        """:func:`modes` about :meth:`equilibrium` (``model``, ``search`` as there)."""
        return modes(self.equilibrium(model, search=search))


def _newton(system, part, q_f: np.ndarray, lin, scale: np.ndarray):
    """Newton's method on ``h(q_f, 0) = 0`` (E1) from ``q_f``, whose :func:`_linear` is
    ``lin``: the equilibrium, its ``_linear`` and the steps taken."""
    src, nf = part.model.source, len(q_f)
    last = np.inf
    for it in range(1, MAX_ITER + 1):
        if lin is None:
            raise AssemblyError(
                "no equilibrium found: Newton's method reached positions the mechanism cannot "
                "take (a dead point or a loop that does not close)", file=src,
                fix="Start the free joints ([initial] q) nearer the equilibrium")
        h, H, K, C, tau = lin
        with np.errstate(all="ignore"):
            try:
                step = np.linalg.solve(K, -h)
            except np.linalg.LinAlgError:
                step = np.full(nf, np.nan)
        if not np.all(np.isfinite(step)):
            raise AssemblyError(
                "no equilibrium found: the stiffness of the free coordinates is singular "
                f"at {_text(part.free, q_f)} (nothing holds the mechanism there, or a dead "
                "point)", file=src, fix="Add a spring or gravity, or start elsewhere")
        size = float(np.max(np.abs(step) / scale))
        if size <= STEP_TOL or (size >= last and last < 1e3 * STEP_TOL):
            break      # converged, or rounding decides the last digits
        # a trust region (the next state must still close from this one's guess), and a
        # step halved until it lowers |h| (scaled by the stiffness): no cycling between two
        # states
        step *= min(1.0, MAX_STEP / size)
        before, norm = system.ref, _norm(h, K, scale)
        for _ in range(30):
            trial = q_f + step
            ok = system.accept(0.0, np.concatenate((trial, np.zeros(nf), [0.0]))) is not None
            new = _linear(system, trial, scale) if ok else None
            if new is not None and _norm(new[0], K, scale) < norm:
                break
            system.ref = before
            step = 0.5 * step
        else:
            raise AssemblyError(
                "no equilibrium found: no Newton step from "
                f"{_text(part.free, q_f)} lowers the generalized forces (h = "
                f"{_text(part.free, h)} N m or N)", file=src,
                fix="Start the free joints ([initial] q) nearer the equilibrium")
        q_f, lin, last = trial, new, size
    else:
        raise AssemblyError(f"no equilibrium found in {MAX_ITER} Newton steps from the start",
                            file=src, fix="Start the free joints ([initial] q) nearer it")
    return q_f, lin, it


def modes(model: Model | Equilibrium, *, free: tuple[str, ...] | None = None) -> Modes:
    """Natural frequencies, damping ratios and mode shapes of the small vibrations about the
    equilibrium of ``model`` (:func:`equilibrium`, E3), or about a given :class:`Equilibrium`."""
    eq = model if isinstance(model, Equilibrium) else equilibrium(model, free=free)
    H, K, C = eq.mass, eq.stiffness, eq.damping
    nf = len(eq.q)
    scale = max(float(np.max(np.abs(K))), 1e-300)
    symmetric = np.max(np.abs(K - K.T)) <= 1e-7 * scale
    undamped = not np.any(C)
    if undamped and symmetric:
        import scipy.linalg as sl
        # K v = w^2 H v, the symmetric problem (E3)
        w2, V = sl.eigh(0.5 * (K + K.T), 0.5 * (H + H.T))
        w = np.sqrt(np.abs(w2))
        s = np.where(w2 >= 0, 1j * w, w)   # an unstable coordinate: a real root
        eig = np.concatenate((s, np.conj(s)))
        freq, zeta = w / (2 * np.pi), np.where(w2 >= 0, 0.0, -1.0)
        stable = bool(np.all(w2 > 0))
    else:
        # the first-order form [[0, I], [-H^-1 K, -H^-1 C]]                     (E3)
        Hi = np.linalg.inv(H)
        A = np.block([[np.zeros((nf, nf)), np.eye(nf)], [-Hi @ K, -Hi @ C]])
        eig, W = np.linalg.eig(A)
        keep = np.imag(eig) >= 0        # one of each conjugate pair, every real root
        eig_k, V = eig[keep], W[:nf, keep]
        order = np.argsort(np.abs(eig_k))
        eig_k, V = eig_k[order], V[:, order]
        mag = np.abs(eig_k)
        freq = mag / (2 * np.pi)
        with np.errstate(all="ignore"):
            zeta = np.where(mag > 0, -np.real(eig_k) / mag, 0.0)
        V = np.real(V * np.exp(-1j * np.angle(V[np.argmax(np.abs(V), axis=0),
                                                 np.arange(V.shape[1])])))
        stable = bool(np.all(np.real(eig) < 0))
    V = np.asarray(V, float)
    V = V / V[np.argmax(np.abs(V), axis=0), np.arange(V.shape[1])]
    order = np.argsort(np.abs(eig))
    return Modes(equilibrium=eq, eigenvalues=eig[order], frequencies=np.asarray(freq),
                 damping_ratios=np.asarray(zeta), shapes=V, joint_shapes=eq.shape_map @ V,
                 stable=stable)


#: The largest free coordinate's swing in an animated mode: rad, or this part of the size.
MODE_SWING = 0.1


def mode_motion(md: Modes, k: int, *, swing: float = MODE_SWING) -> Model:
    """The model moving in mode ``k`` (E3), for its report page: every free joint driven by
    ``q_j(t) = q_eq_j + a v_j sin(w t)`` over one period, the drivers held at t = 0. A spatial
    model's free coordinate of a joint of several freedoms (``J3.1`` of a universal joint) is
    driven by its name: :func:`linkdyn.spatial.analyze` prescribes that coordinate alone.

    Parameters
    ----------
    md : Modes
    k : int
        The mode (0 the lowest), one that swings (:attr:`Modes.oscillating`).
    swing : float
        The swing ``a`` of the free coordinate whose shape component is 1: rad, or this part of
        the mechanism's size (m).

    Returns
    -------
    Model
        Named after the mode and its frequency, its ``duration`` the period ``1 / f`` (s), its
        assembly guesses the equilibrium's joint coordinates. ``analyze`` of it gives the
        efforts that move the mechanism so: small (second order in ``a``) when ``v`` and ``w``
        are a mode of the linearized equations.
    """
    eq = md.equilibrium
    model, f, v = eq.model, float(md.frequencies[k]), md.shapes[:, k]
    if k not in md.oscillating:
        raise ModelError(f"mode {k + 1} does not swing ({f:g} Hz, damping ratio "
                         f"{md.damping_ratios[k]:g})", field="modes",
                         fix="Animate a mode with a damping ratio from 0 to below 1")
    top = int(np.argmax(np.abs(v)))
    size = float(point_spread(np.array([p for b in model.bodies for p in b.points.values()])))
    angular = _angular(model, eq.free[top])
    a = swing * (1.0 if angular else size)
    w = float(2 * np.pi * f)
    # q_j(t) = q_eq_j + a v_j sin(w t)                                              (E3)
    moving = tuple(Driver(j, ExpressionMotion(f"{float(q)!r} + {float(a * x)!r}*sin({w!r}*t)"))
                   for j, q, x in zip(eq.free, eq.q, v))
    held = _held(model)
    return replace(held, name=f"{model.name}: mode {k + 1} at {f:.6g} Hz",
                   description=f"Mode {k + 1} of {model.name!r}: {f:.6g} Hz, damping ratio "
                               f"{md.damping_ratios[k]:.4g}, swung by {a:.4g} "
                               f"{'rad' if angular else 'm'} about the static equilibrium",
                   drivers=held.drivers + moving, duration=1.0 / f, cycles=None,
                   assembly_q=dict(eq.joint_q), initial_q={}, initial_qd={})


def _norm(h, K, scale) -> float:
    """Size of the generalized forces ``h`` as the coordinate change they would need at the
    stiffness ``K``: |h| per the largest stiffness of a unit step (rad, or m per size)."""
    k = max(float(np.max(np.abs(K * scale[None, :]))), 1e-300)
    return float(np.max(np.abs(h))) / k


def _text(names, q) -> str:
    return ", ".join(f"q_{j} = {v:.6g}" for j, v in zip(names, q))


# --- what a person reads: the file's units, each number with its unit ----------------------

def _unit(model: Model, joint: str) -> tuple[str, float, bool]:
    """The file's unit of the coordinate ``joint`` (a joint, or a spatial joint coordinate),
    its size in SI, and whether an angle (:class:`linkdyn.units.Units`, the one formatter of
    what a person reads)."""
    from .units import Units
    angular = _angular(model, joint)
    return (*Units.of(model).unit("angle" if angular else "length"), angular)


def as_dict(eq: Equilibrium, md: Modes | None = None) -> dict:
    """The equilibrium (and modes) as plain numbers, SI (rad, m, N m, N, Hz), for JSON."""
    out = {"free_joints": list(eq.free), "q": dict(zip(eq.free, map(float, eq.q))),
           "joint_q": eq.joint_q, "residual": list(map(float, eq.residual)),
           "iterations": eq.iterations, "mass": eq.mass.tolist(),
           "stiffness": eq.stiffness.tolist(), "damping": eq.damping.tolist(),
           "driver_efforts": eq.efforts}
    if md is not None:
        out["stable"] = md.stable
        out["modes"] = [
            {"frequency_hz": float(f), "damping_ratio": float(z),
             "shape": dict(zip(eq.tree_joints, map(float, md.joint_shapes[:, k])))}
            for k, (f, z) in enumerate(zip(md.frequencies, md.damping_ratios))]
    return out


def text(eq: Equilibrium, md: Modes | None = None) -> str:
    """The equilibrium (and modes) as the command line prints them, in the file's units."""
    m = eq.model
    what = "static equilibrium" if eq.iterations else "taken as the equilibrium: the start"
    lines = [f"{m.name}: {what} of {', '.join(eq.free)}"
             + (" (drivers held at their t = 0 position)" if m.drivers else "")]
    for j in eq.tree_joints:
        unit, si, _ = _unit(m, j)
        tag = "  (free)" if j in eq.free else ""
        lines.append(f"  {j} = {eq.joint_q[j] / si:.6g} {unit}{tag}")
    for j, v in eq.efforts.items():
        unit = "N m" if _angular(m, j) else "N"
        lines.append(f"  holding effort of the driver at {j}: {v:.6g} {unit}")
    res = ", ".join(f"{v:.2e} {'N m' if _unit(m, j)[2] else 'N'}"
                    for j, v in zip(eq.free, eq.residual))
    md_ = md if md is not None else modes(eq)
    lines.append(f"  residual {res} after {eq.iterations} Newton step(s); "
                 + ("stable" if md_.stable else "UNSTABLE: small motions grow from here"))
    if md is not None:
        for k, (f, z) in enumerate(zip(md.frequencies, md.damping_ratios)):
            shape = ", ".join(f"{j} {md.joint_shapes[i, k]:.4g}"
                              for i, j in enumerate(eq.tree_joints))
            what = ("undamped" if z == 0 else f"damping ratio {z:.4g}"
                    + (" (overdamped root)" if abs(z) == 1 else ""))
            lines.append(f"  mode {k + 1}: {f:.6g} Hz, {what}; shape (SI ratios) {shape}")
    return "\n".join(lines)
