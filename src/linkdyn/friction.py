"""Joint friction that grows with the joint load, solved together with the reactions.

SPEC "Loads that depend on the state": a load ``kind = "friction"`` in a joint is Coulomb
friction on the joint's second body, minus that on its first, opposing the joint's rate ``qd``:

    f = -c |F| tanh(qd / v),      c = mu r (revolute: a couple, N m)  or  mu (sliding: N),

along the joint's freedom (a couple for a revolute joint; a force along the guide, at the
second body's joint point, for a prismatic or slot joint), where ``F`` is the joint's reaction
force (by the first body on the second; for a sliding joint it is the normal force, the guide's
moment does not enter) and ``v`` the transition speed.

The method (docs/theory.md, "Friction"). At a fixed kinematic state the inverse dynamics is
linear in the applied wrenches, so every reaction force is affine in the k friction efforts
``f`` (one per friction load):

    F_j(f) = F0_j + sum_l A_jl f_l,

``F0`` the frictionless reactions and ``A_jl`` the response of joint j's force to a unit effort
in friction joint l. The friction equations ``f = g(F(f))`` are then a k x k system per sample,
solved by Newton's method from the frictionless solution ``f = 0`` (:func:`residuals` and
:func:`newton_step`, written once for both backends). On numpy (:func:`solve`) ``F0`` and
``A`` come from runs of the dynamics and reactions stages on the same kinematics, Newton's
method steps every
sample at once, and a last run of the stages with the converged efforts gives the efforts,
multipliers and reactions; on the compiled backend :func:`linkdyn.friction_compiled.solve`
does the same in one kernel, a block of samples at a time. The reactions exclude the friction,
as they exclude a driver's effort: the friction is an applied load.

A load that depends on the reactions answers one question (the interface the load registry
should carry, :data:`linkdyn.loads.REACTION_KINDS`): given the joint's reaction force and the
state, its effort and the effort's derivative with respect to that force (:func:`coulomb`); its
wrench is an effort inside the joint (:func:`linkdyn.loads.joint_effort_units`).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from . import joints as jk
from .loads import Loads, joint_effort_units
from .model import Load, Model, default_transition_speed
from .steps import select, step

#: Newton's method stops when every equation's residual is at most TOL of their scale (the
#: largest friction effort c |F| of the run, per design).
TOL = 1e-12
MAX_ITERATIONS = 50


def joint_friction(model: Model, joint: str, coefficient: float, radius: float = 0.0,
                   transition_speed: float | None = None, name: str = "", *,
                   static_coefficient: float | None = None,
                   stiction_speed: float | None = None, viscous: float = 0.0,
                   preload: float = 0.0) -> Load:
    """The :class:`~linkdyn.model.Load` of friction in ``model``'s joint ``joint``, SI.

    Parameters
    ----------
    coefficient : float
        Coefficient of friction mu, 1.
    radius : float
        Pin radius, m (revolute joints: the couple is mu r |F|); 0 for a sliding joint.
    transition_speed : float, optional
        Rate of the tanh smoothing, rad/s (revolute) or m/s (sliding); default
        :func:`default_transition_speed`.
    static_coefficient : float, optional
        mu at rest (default ``coefficient``, the dynamic one); the coefficient blends from it
        to ``coefficient`` as ``exp(-(qd / stiction_speed)^2)`` fades.
    stiction_speed : float, optional
        Rate of that blend, rad/s or m/s; default 10 x the transition speed.
    viscous : float
        Viscous coefficient b, N m s/rad or N s/m: an effort ``-b qd`` more.
    preload : float
        A load added to the joint's force magnitude, N (a bearing's or a guide's preload).
    """
    jt = model.joint(joint)
    angular = jk.get(jt.kind).angular
    speed = default_transition_speed(angular) if transition_speed is None else transition_speed
    return Load("friction", jt.body_b, jt.point_b, None, jt.body_a, jt.point_a, name=name,
                joint=joint, coefficient=float(coefficient),
                radius=float(radius) if angular else 0.0, transition_speed=float(speed),
                static_coefficient=None if static_coefficient is None
                else float(static_coefficient),
                stiction_speed=None if stiction_speed is None else float(stiction_speed),
                viscous=float(viscous), preload=float(preload))


def stiction_speed(load: Load) -> float:
    """The rate of a friction load's static-to-dynamic blend, rad/s or m/s: its own, else 10
    times its transition speed."""
    return 10.0 * load.transition_speed if load.stiction_speed is None else load.stiction_speed


def present(model: Model) -> bool:
    """Whether ``model`` has a friction load."""
    return any(ld.kind == "friction" for ld in model.loads)


@dataclass(frozen=True)
class Row:
    """One friction load in tree indices: its joint (model order) and bodies (the second
    ``body``, the first ``body2``), the second body's joint point, the axis of a sliding joint
    in the first body's frame (None: a revolute joint, the effort is a couple), and per design
    ``arm`` and ``arm_static`` (mu r, m, or mu; dynamic and at rest), ``speed`` and
    ``stiction`` (the rates of the tanh and of the static blend, rad/s or m/s), ``viscous``
    (N m s/rad or N s/m) and ``preload`` (N): floats, or (D, 1)."""

    label: str
    joint: int
    body: int
    body2: int
    point: str
    axis: np.ndarray | None
    arm: object
    speed: object
    arm_static: object = 0.0
    stiction: object = 1.0
    viscous: object = 0.0
    preload: object = 0.0
    load: int = -1          # its place in model.loads


def rows(models, topo) -> tuple[Row, ...]:
    """The friction loads of ``models`` (one Model, or the D designs of a batch)."""
    models = [models] if isinstance(models, Model) else list(models)
    m0 = models[0]
    pos = {name: k for k, name in enumerate(topo.bodies)}
    names = [j.name for j in m0.joints]
    out = []
    for n, ld in enumerate(m0.loads):
        if ld.kind != "friction":
            continue
        jt = m0.joint(ld.joint)
        angular = jk.get(jt.kind).angular

        def per(f):  # a float, or (D, 1) over the designs
            v = np.array([f(m.loads[n]) for m in models], float)
            return float(v[0]) if len(models) == 1 else v[:, None]

        r = (lambda x: x.radius) if angular else (lambda x: 1.0)
        out.append(Row(ld.name or ld.joint, names.index(ld.joint), pos[jt.body_b],
                       pos[jt.body_a], jt.point_b,
                       None if angular else np.asarray(jt.axis, float),
                       per(lambda x: x.coefficient * r(x)), per(lambda x: x.transition_speed),
                       per(lambda x: (x.coefficient if x.static_coefficient is None
                                      else x.static_coefficient) * r(x)),
                       per(stiction_speed), per(lambda x: x.viscous),
                       per(lambda x: x.preload), n))
    return tuple(out)


# --- the reaction-dependent load: its effort and derivative, one equation ---------------------

@step
def coulomb(arm, arm_static, stiction, speed, viscous, preload, fx, fy, qd):
    """Friction effort in a joint whose reaction force is ``F = (fx, fy)`` and rate ``qd``,
    and its derivative ``(df/dfx, df/dfy)``: :func:`dry` with the SPEC's smooth sense
    ``tanh(qd / speed)`` (``speed`` the transition speed, rad/s or m/s)."""
    return dry(arm, arm_static, stiction, viscous, preload, fx, fy, qd, np.tanh(qd / speed))


@step
def dry(arm, arm_static, stiction, viscous, preload, fx, fy, qd, sense):
    """Friction effort in a joint whose reaction force is ``F = (fx, fy)``, rate ``qd`` and
    sense of sliding ``sense`` (in [-1, 1]), and its derivative ``(df/dfx, df/dfy)``:

        f = -a(qd) (|F| + preload) sense - viscous qd,
        a(qd) = arm + (arm_static - arm) exp(-(qd / stiction)^2),

    ``arm``, ``arm_static`` mu r (m) for a revolute joint (f a couple, N m) or mu for a sliding
    one (f a force, N), dynamic and at rest. At ``F = 0`` the derivative is taken as 0 (|F| has
    no derivative there)."""
    return dry_at(sliding_arm(arm, arm_static, stiction, qd, sense), viscous * qd, preload,
                  fx, fy)


@step
def sliding_arm(arm, arm_static, stiction, qd, sense):
    """``a(qd) sense`` of :func:`dry`: what multiplies the joint's load, m or 1."""
    x = qd / stiction
    return (arm + (arm_static - arm) * np.exp(-x * x)) * sense


@step
def dry_at(c, v, preload, fx, fy):
    """:func:`dry` at one rate: ``f = -c (|F| + preload) - v`` and ``df/dF = -c F / |F|``
    (0 at ``F = 0``), ``c`` its :func:`sliding_arm`, ``v`` its viscous effort ``viscous qd``."""
    # |F| = sqrt(fx^2 + fy^2)
    size = np.sqrt(fx * fx + fy * fy)
    safe = select(size > 0, size, 1.0)
    k = select(size > 0, -c / safe, 0.0)
    return -c * (size + preload) - v, (k * fx, k * fy)


@step
def bigger(a, b):
    """The larger of ``a`` and ``b``, NaN if ``a`` or ``b`` is (``np.maximum``, on scalars too)."""
    return select(a != a, a, select(a > b, a, b))


@step(inline=True)
def residuals(F0, A, c, v, preload, f, r, dg):
    """The residuals of the friction equations ``f = g(F0 + A f)`` (T9)-(T10) at the efforts
    ``f``: ``r = f - g`` and each load's ``dg/dF`` at its force, in place; the first half of a
    step of Newton's method (:func:`newton_step` the second), which stops here when ``r`` is
    small enough, without forming the Jacobian.

    Every entry is a float (one sample, in a compiled sample loop) or an array over the
    samples (numpy), so the same lines serve both backends.

    Parameters
    ----------
    F0 : (k, 2)
        The friction joints' reaction forces at ``f = 0``, N.
    A : (k, k, 2)
        ``A[j, l]``: the change of joint j's force under a unit effort in friction load l.
    c, v, preload : (k,)
        Each load's :func:`sliding_arm`, viscous effort (N m or N) and preload (N).
    f : (k,)
        The efforts, N m or N.
    r, dg : (k,), (k, 2)
        Receive the residuals and ``dg_j/dF_j``.

    Returns
    -------
    (big_r, big_g)
        The largest ``|r|`` and ``|g|`` at ``f``.
    """
    k = len(f)
    big_r, big_g = 0.0, 0.0
    # F_j = F0_j + sum_l A_jl f_l;  r_j = f_j - g_j(F_j)
    for j in range(k):
        fx, fy = F0[j, 0], F0[j, 1]
        for n in range(k):
            fx = fx + A[j, n, 0] * f[n]
            fy = fy + A[j, n, 1] * f[n]
        g, (gx, gy) = dry_at(c[j], v[j], preload[j], fx, fy)
        r[j] = f[j] - g
        dg[j, 0] = gx
        dg[j, 1] = gy
        big_r = bigger(np.abs(f[j] - g), big_r)
        big_g = bigger(np.abs(g), big_g)
    return big_r, big_g


@step(inline=True)
def newton_step(A, dg, f, r, K, x):
    """The step of Newton's method on the friction equations from :func:`residuals`' ``r``
    and ``dg`` at ``f``, in place: ``f <- f - J^-1 r``, ``J = I - (dg/dF) A``
    (``J_jl = delta_jl - dg_j/dF_j . A_jl``); ``K`` (k, k + 1) and ``x`` (k,) work. Returns
    ``det J``. Entries floats or arrays over the samples, as in :func:`residuals`."""
    k = len(f)
    det = 1.0
    for j in range(k):
        K[j, k] = r[j]
        for n in range(k):
            K[j, n] = (1.0 if j == n else 0.0) - (dg[j, 0] * A[j, n, 0] + dg[j, 1] * A[j, n, 1])
    # J x = r by elimination with partial pivoting (each swap changes det's sign)
    for col in range(k):
        for i in range(col + 1, k):
            swap = np.abs(K[i, col]) > np.abs(K[col, col])
            for n in range(col, k + 1):
                upper, lower = select(swap, K[i, n], K[col, n]), select(swap, K[col, n], K[i, n])
                K[col, n] = upper
                K[i, n] = lower
            det = select(swap, -det, det)
        p = K[col, col]
        det = det * p
        safe = select(p != 0, p, 1.0)
        for i in range(col + 1, k):
            m = K[i, col] / safe
            for n in range(col, k + 1):
                K[i, n] = K[i, n] - m * K[col, n]
    for j in range(k - 1, -1, -1):
        acc = K[j, k]
        for n in range(j + 1, k):
            acc = acc - K[j, n] * x[n]
        x[j] = acc / K[j, j]
    for j in range(k):
        f[j] = f[j] - x[j]
    return det


def capacity(row: Row, F):
    """What the static friction of ``row`` can hold at rest under the joint force ``F``
    (2, ...), N m or N: ``arm_static (|F| + preload)``."""
    return row.arm_static * (np.sqrt(F[0] * F[0] + F[1] * F[1]) + row.preload)


# --- the solution ------------------------------------------------------------------------------

@dataclass(frozen=True)
class Friction:
    """The friction of a solution.

    Attributes
    ----------
    joints : tuple of str
        The joint of each friction load (load order among the friction loads).
    labels : tuple of str
        Each friction load's name (its joint's when it has none).
    angular : tuple of bool
        Whether each is a couple (revolute joint) or a force (sliding joint).
    effort : ndarray (k, ...)
        The friction effort on each joint's second body (minus it on the first) along the
        joint's freedom, N m or N, batch shape of the samples; its sign opposes ``qd``.
    power : ndarray (k, ...)
        Its power ``effort * qd``, W (never positive: minus the power it dissipates).
    iterations : int
        Newton iterations the slowest sample took.
    residual : float
        Largest residual of the friction equations at the reported reactions, relative to
        their scale (the largest c |F| of the run).
    locked : ndarray (...) bool
        Samples where the friction equations have no solution reached from the frictionless
        one (the mechanism locks: it cannot be driven).
    lock_joint : ndarray (...) int
        At a locked sample, the friction load (index into ``joints``) with the largest
        residual; -1 elsewhere.
    """

    joints: tuple
    labels: tuple
    angular: tuple
    effort: np.ndarray
    power: np.ndarray
    iterations: int
    residual: float
    locked: np.ndarray
    lock_joint: np.ndarray

    def design(self, k: int) -> Friction:
        """Design k of a batch's friction (arrays (k, D, T) -> (k, T))."""
        return replace(self, effort=self.effort[:, k], power=self.power[:, k],
                       locked=self.locked[k], lock_joint=self.lock_joint[k])


def with_efforts(applied: Loads, kin, friction_rows, efforts) -> Loads:
    """``applied`` plus the friction efforts ``efforts`` (k, ...) inside their joints: the
    wrenches on the moving bodies, the ground's share in ``on_ground``, their power in
    ``power`` and, if ``applied`` keeps each load's value and power, the friction loads' (their
    effort and its power)."""
    # each body a friction load acts on gets one new array, accumulated in place; the others
    # are not copied
    shape = (3,) + kin.shape
    w = [np.broadcast_to(x, shape) for x in applied.wrenches]
    w[0] = np.zeros(shape)
    own = {0}
    power = applied.power
    qd = kin.joint_motion[1]
    values, powers = list(applied.values), list(applied.powers)
    for row, x in zip(friction_rows, efforts):
        for body, u in zip((row.body, row.body2),
                           joint_effort_units(kin, row.body, row.body2, row.point, row.axis)):
            if body not in own:
                w[body] = np.array(w[body])
                own.add(body)
            w[body] += u * x
        p = x * qd[row.joint]
        power = power + p
        if values and powers:
            values[row.load], powers[row.load] = x, p
    # the ground's O_0 is the global origin: its share joins the anchored loads' there
    on_ground = applied.on_ground + w[0]
    w[0] = np.broadcast_to(np.zeros((3,) + (1,) * len(kin.shape)), (3,) + kin.shape)
    return replace(applied, wrenches=w, power=power, on_ground=on_ground,
                   values=tuple(values), powers=tuple(powers))


def unit(none: Loads, kin, row: Row) -> Loads:
    """``none`` (no load) with a unit effort in the friction load ``row``'s joint
    (:func:`linkdyn.loads.joint_effort_units`): a revolute joint's couple is the same at every
    sample, kept as one sample broadcast along them (the compiled kernels then read it once)."""
    w = list(none.wrenches)
    shape = (3,) + kin.shape
    on_b, on_a = joint_effort_units(kin, row.body, row.body2, row.point, row.axis)
    w[row.body2] = np.broadcast_to(on_a, shape)
    w[row.body] = np.broadcast_to(on_b, shape)
    w[0] = none.wrenches[0]   # the ground's share is no wrench on a moving body
    return replace(none, wrenches=w)


def forces(react, friction_rows) -> np.ndarray:
    """The reaction forces (k, 2, ...) of the friction joints, by the first body on the
    second, N."""
    return np.stack([np.asarray(react.on_second[r.joint])[1:3] for r in friction_rows])


def _sense(row: Row, qd, sense):
    """The sense of sliding of a friction load: ``sense`` where given (not NaN), else the
    SPEC's ``tanh(qd / v)``."""
    s = np.tanh(qd / row.speed)
    return s if sense is None else np.where(np.isnan(sense), s, sense)


def equations(friction_rows, F, qd, sense=None):
    """``g(F)`` (k, ...) and ``dg/dF`` (k, 2, ...) of every friction load at the forces F
    (k, 2, ...) and rates qd (k, ...); ``sense`` (k, ...): the sense of sliding of each, where
    not NaN (default: the SPEC's ``tanh(qd / v)``)."""
    g, dg = [], []
    for k, r in enumerate(friction_rows):
        gk, (gx, gy) = dry(r.arm, r.arm_static, r.stiction, r.viscous, r.preload,
                           F[k, 0], F[k, 1], qd[k],
                           _sense(r, qd[k], None if sense is None else sense[k]))
        g.append(gk)
        dg.append(np.stack([gx, gy]))
    if not g:
        return np.zeros((0,) + np.shape(qd)[1:]), np.zeros((0, 2) + np.shape(qd)[1:])
    return np.stack(g), np.stack(dg)


def newton(friction_rows, F0, A, qd, sense=None):
    """The friction efforts ``f`` (k, ...) that solve ``f = g(F0 + A f)`` (T9)-(T10), by
    Newton's method (:func:`residuals`, :func:`newton_step`) from the frictionless solution
    ``f = 0``, every
    sample at once.

    Parameters
    ----------
    friction_rows : sequence of Row
        The k friction loads.
    F0 : ndarray (k, 2, ...)
        Their joints' reaction forces at ``f = 0``, N; the last axis the samples.
    A : ndarray (k, k, 2, ...)
        ``A[j, l]``: the change of joint j's force under a unit effort in friction load l.
    qd : ndarray (k, ...)
        Their joints' rates, rad/s or m/s.
    sense : ndarray (k, ...), optional
        The sense of sliding where it is known (not NaN); elsewhere ``tanh(qd / v)``.

    Returns
    -------
    (f, iterations, locked, lock_joint, scale)
        ``f`` (NaN where locked), each sample's iteration count, the locked samples (no
        solution reached from ``f = 0``: Newton's method does not converge, or ends where
        ``det J <= 0``), the load with the largest residual there (-1 elsewhere), and the scale
        of the residuals (..., 1): the largest friction effort of the run, per design.
    """
    k, shape = len(friction_rows), qd.shape[1:]
    F0, A = np.asarray(F0, float), np.asarray(A, float)
    # what does not change with the forces: each load's a(qd) sense, viscous effort, preload
    c = np.zeros((k,) + shape)
    v, pre = np.zeros((k,) + shape), np.zeros((k,) + shape)
    for j, r in enumerate(friction_rows):
        c[j] = sliding_arm(r.arm, r.arm_static, r.stiction, qd[j],
                           _sense(r, qd[j], None if sense is None else sense[j]))
        v[j], pre[j] = r.viscous * qd[j], r.preload
    f, res = np.zeros((k,) + shape), np.zeros((k,) + shape)
    dg, K, x = np.zeros((k, 2) + shape), np.zeros((k, k + 1) + shape), np.zeros((k,) + shape)
    # a state whose forces are not finite is not iterated (nor locked)
    finite_state = np.all(np.isfinite(F0), axis=(0, 1)) if k else np.ones(shape, bool)
    done = ~(finite_state & (np.all(np.isfinite(A), axis=(0, 1, 2)) if k else True))
    converged, det = np.zeros(shape, bool), np.ones(shape)
    iterations, scale = np.zeros(shape, int), 0.0
    for _ in range(MAX_ITERATIONS + 1):
        big_r, big_g = residuals(F0, A, c, v, pre, f, res, dg)
        scale = np.maximum(scale, np.nanmax(big_g, axis=-1, keepdims=True, initial=0.0))
        # converged: every residual at most TOL of the sample's largest friction effort
        now = ~done & (big_r <= TOL * np.maximum(big_g, 1e-300))
        converged = converged | now
        done = done | now
        if np.all(done):
            break
        new = f.copy()
        with np.errstate(divide="ignore", invalid="ignore"):   # a singular J: not finite
            d = newton_step(A, dg, new, res, K, x)
        # a singular J (a fold of the friction equations) ends that sample's iterations
        done = done | ~np.all(np.isfinite(new), axis=0)
        # det J of the last step taken: its sign at the solution, a step before it
        f, det = np.where(done, f, new), np.where(done, det, d)
        iterations = iterations + ~done
    # a solution not reached from the frictionless one (J no longer positive) locks too
    locked = finite_state & ~(converged & (det > 0))
    lock_joint = np.where(locked, np.argmax(np.nan_to_num(np.abs(res), nan=np.inf), axis=0)
                          if k else 0, -1)
    return np.where(locked, np.nan, f), iterations, locked, lock_joint, scale


def solve(models, kin, applied: Loads, dynamics, reactions_stage, kernel=None):
    """Efforts, reactions and friction of a model with friction loads, solved together.

    Parameters
    ----------
    models : Model or sequence of Model
        The mechanism (or the D designs of a batch, each with its friction numbers).
    kin : KinematicSolution
        The kinematics, batch shape (T,) or (D, T).
    applied : Loads
        The other applied loads (:func:`linkdyn.loads.wrenches`, which leaves friction out).
    dynamics, reactions_stage : callable
        The backend's stages (:func:`linkdyn.analysis.stage_functions`).
    kernel : callable, optional
        On the compiled backend :func:`linkdyn.friction_compiled.solve`, which runs the stages
        under the applied loads and under each unit effort, and Newton's method, in one kernel
        (the same steps), given ``(model, kin,
        applied, units, rows, qd)`` as prepared here.

    Returns
    -------
    (Loads, DynamicSolution, Reactions, Friction)
        The applied loads with the friction in, the dynamics and the reactions under them, and
        the friction itself.
    """
    model = models if isinstance(models, Model) else list(models)[0]
    fr = rows(models, kin.layout.topo)
    k, shape = len(fr), kin.shape
    qd = np.stack([np.broadcast_to(kin.joint_motion[1][r.joint], shape) for r in fr])
    # each friction load's wrenches under a unit effort alone; those the same at every sample
    # (a revolute joint's couple) kept as one sample, which the compiled kernels read once
    zero = np.broadcast_to(np.zeros((3,) + (1,) * len(shape)), (3,) + shape)
    none = replace(applied, wrenches=[zero] * len(applied.wrenches), values=(), powers=(),
                   power=np.zeros(shape), on_ground=zero)
    units = [unit(none, kin, r) for r in fr]
    if kernel is not None:
        return kernel(model, kin, applied, units, fr, qd)
    # F0: the reactions under the applied loads; A[:, l]: their response to a unit effort in
    # friction load l, the stages under it alone less the stages under no load (linear in the
    # loads: the motion's share cancels); each a run of the stages on the same kinematics
    def reaction_forces(loads):
        return forces(reactions_stage(model, kin, loads, dynamics(kin, loads)), fr)
    F0 = reaction_forces(applied)
    R0 = reaction_forces(none)
    A = np.stack([reaction_forces(u) - R0 for u in units], axis=1)   # (k, l, 2, ...)
    f, iterations, locked, lock_joint, scale = newton(fr, F0, A, qd)
    # the stages once more with the converged friction
    final = with_efforts(applied, kin, fr, f)
    dyn = dynamics(kin, final)
    react = reactions_stage(model, kin, final, dyn)
    g, _ = equations(fr, forces(react, fr), qd)
    res = np.abs(f - g) / np.maximum(scale, 1e-300)
    residual = float(np.nanmax(res, initial=0.0)) if res.size else 0.0
    return final, dyn, react, friction_of(model, fr, f, qd, iterations, residual, locked,
                                          lock_joint)


def friction_of(model, fr, f, qd, iterations, residual, locked, lock_joint) -> Friction:
    """The :class:`Friction` of the efforts ``f`` (k, ...) at the rates ``qd``."""
    return Friction(tuple(model.joints[r.joint].name for r in fr),
                    tuple(r.label for r in fr), tuple(r.axis is None for r in fr),
                    f, f * qd, int(np.max(iterations, initial=0)), residual, locked, lock_joint)


# --- what a person reads -----------------------------------------------------------------------

def columns(fr: Friction, model: Model):
    """The results.csv columns of the friction ``fr``: ``(name, values, unit)`` per friction
    load, ``friction_<joint>`` (N m or N, the couple or force on the joint's second body
    along its freedom) and ``friction_power_<joint>`` (W, never positive)."""
    for k, j in enumerate(fr.joints):
        yield f"friction_{j}", fr.effort[k], "N m" if fr.angular[k] else "N"
        yield f"friction_power_{j}", fr.power[k], "W"


def output_power(sol) -> tuple[np.ndarray, np.ndarray]:
    """The power the mechanism delivers to its output loads (``model.output``, ``[analysis]
    output``), ``P_out = -sum P_load`` (a load the mechanism works against takes power: its
    own power is negative), and the instantaneous efficiency ``eta = P_out / P_in``, ``P_in``
    the drivers' power, NaN where the drivers put no power in (``P_in <= 0``), both (...), W
    and 1. With inertia ``eta`` also counts the power stored in motion (``P_in = P_out +
    dKE/dt + dPE/dt + friction's loss``); over whole cycles that share returns."""
    m = sol.model
    names = [ld.name for ld in m.loads]
    p_out = -sum((sol.loads.powers[names.index(n)] for n in m.output), np.zeros(sol.kin.shape))
    p_in = sol.driver_power
    ok = p_in > 0
    return p_out, np.where(ok, p_out / np.where(ok, p_in, 1.0), np.nan)


def output_summary(sol) -> dict:
    """The output loads' figures over the run, SI: their names, the work done on them
    (``output_work_J``, the integral of :func:`output_power`'s ``P_out`` over the valid
    samples), the drivers' net work and the efficiency over the run, their ratio (None when the
    drivers do no positive net work), and the least and the largest instantaneous efficiency
    (None where the drivers never put power in)."""
    w_out, w_in, ratio = (float(x) for x in output_efficiency(sol))
    eta = output_power(sol)[1]
    eta = eta[np.asarray(sol.valid, bool) & np.isfinite(eta)]
    return {"loads": list(sol.model.output), "output_work_J": w_out, "driver_work_J": w_in,
            "efficiency": ratio if np.isfinite(ratio) else None,
            "efficiency_least": float(np.min(eta)) if eta.size else None,
            "efficiency_largest": float(np.max(eta)) if eta.size else None}


def output_lines(s: dict) -> list[str]:
    """The printed line of :func:`output_summary`'s dict."""
    def pct(x):
        return "n/a" if x is None else f"{100 * x:.2f}%"

    return [f"  output ({', '.join(s['loads'])}): {s['output_work_J']:.6g} J of the drivers' "
            f"{s['driver_work_J']:.6g} J, efficiency {pct(s['efficiency'])} over the run; "
            f"instantaneous {pct(s['efficiency_least'])} .. {pct(s['efficiency_largest'])}"]


def energies(sol) -> tuple[np.ndarray, np.ndarray]:
    """The energy each friction load dissipates over the run (k, ...) and the drivers' net
    work over it (...), J: trapezoidal integrals over the valid samples of ``-power`` and of
    the drivers' power, over the last (time) axis (a batch: one per design)."""
    return -over_run(sol, sol.friction.power), over_run(sol, sol.driver_power)


def over_run(sol, p) -> np.ndarray:
    """The integral of the power ``p`` (..., T) over the run, J: the trapezoidal rule over
    ``sol``'s valid samples (an invalid one counts as zero power), along the last axis."""
    t, valid = np.asarray(sol.t), np.asarray(sol.valid, bool)
    p = np.where(valid, p, 0.0)
    return np.sum(0.5 * (p[..., 1:] + p[..., :-1]) * np.diff(t), axis=-1)


def output_efficiency(sol) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The work done on the output loads over the run (:func:`output_power`), the drivers' net
    work and the efficiency over the run, their ratio (NaN where the drivers do no positive
    net work), J, J and 1 (...: one per design of a batch)."""
    w_out, w_in = over_run(sol, output_power(sol)[0]), over_run(sol, sol.driver_power)
    ok = w_in > 0
    return w_out, w_in, np.where(ok, w_out / np.where(ok, w_in, 1.0), np.nan)


def efficiency(lost, work):
    """The mechanical efficiency over the run, ``1 - lost / work``: the share of the drivers'
    net work not lost in friction (delivered to the loads or stored); NaN where the drivers do
    no positive net work."""
    work = np.asarray(work, float)
    ok = work > 0
    return np.where(ok, 1.0 - np.asarray(lost) / np.where(ok, work, 1.0), np.nan)


def summary(sol) -> dict:
    """The friction figures of a solution over its run, SI: per friction joint the energy
    it dissipates (J, over the run and per cycle of the first driver when the run spans whole
    cycles), its peak effort; the drivers' net work; the mechanical efficiency
    (:func:`efficiency`; None when the drivers do no positive net work); Newton's iterations
    and residual."""
    fr = sol.friction
    per_joint, work = energies(sol)
    cycles = _cycles(sol)
    joints = {}
    for k, j in enumerate(fr.joints):
        e = float(per_joint[k])
        joints[j] = {"effort": "torque" if fr.angular[k] else "force",
                     "unit": "N m" if fr.angular[k] else "N",
                     "peak": float(np.nanmax(np.abs(fr.effort[k]), initial=0.0)),
                     "energy_lost_J": e,
                     "energy_lost_per_cycle_J": e / cycles if cycles else None}
    lost = float(np.sum(per_joint))
    eff = float(efficiency(lost, work))
    return {"joints": joints, "energy_lost_J": lost,
            "energy_lost_per_cycle_J": lost / cycles if cycles else None,
            "cycles": cycles, "driver_work_J": float(work),
            "efficiency": eff if np.isfinite(eff) else None,
            "newton_iterations": fr.iterations, "residual_rel": fr.residual}


def _cycles(sol) -> float | None:
    """The first driver's whole cycles over the run (a periodic driver), else None."""
    m = sol.model
    if not m.drivers or m.drivers[0].period is None:
        return None
    n = (float(sol.t[-1]) - float(sol.t[0])) / m.drivers[0].period
    return float(round(n)) if round(n) >= 1 and abs(n - round(n)) < 1e-6 else None


def summary_lines(s: dict) -> list[str]:
    """The printed lines of :func:`summary`'s dict."""
    def num(x, fmt):
        return "n/a" if x is None or not np.isfinite(x) else format(x, fmt)

    out = []
    per = s["energy_lost_per_cycle_J"]
    eff = s["efficiency"]
    out.append(f"  friction: {num(s['energy_lost_J'], '.6g')} J lost over the run"
               + (f" ({num(per, '.6g')} J per cycle)" if per is not None else "")
               + f", efficiency {num(None if eff is None else 100 * eff, '.2f')}%"
               + f" of the drivers' {num(s['driver_work_J'], '.6g')} J"
               + f"; Newton {s['newton_iterations']} iterations, residual "
               + f"{num(s['residual_rel'], '.1e')}")
    for j, e in s["joints"].items():
        out.append(f"    {j:8s} peak friction {e['effort']} {num(e['peak'], '.6g')} {e['unit']},"
                   f" {num(e['energy_lost_J'], '.6g')} J lost")
    return out


def locked_error(model: Model, fr: Friction, k: int, where: dict):
    """The AssemblyError of the locked sample k (of a single mechanism); ``where``: the
    error's file, time, drivers and units there."""
    from .errors import AssemblyError

    j = int(fr.lock_joint[k])
    return AssemblyError(
        f"the mechanism locks at joint {fr.joints[j]}: its friction grows with the joint "
        "load faster than the drivers can overcome it (self-locking), so no driver effort "
        "moves it at this time", **where,
        fix=f"Lower the friction coefficient (or radius) of {fr.joints[j]}'s friction load, or "
            "change the geometry so the load on that joint grows less with the effort")
