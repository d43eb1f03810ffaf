"""Design quantities a mechanism designer judges a linkage by.

Everything here is computed from a solved run (:func:`linkdyn.analyze`) through the public
arrays of the :class:`~linkdyn.Solution`; all values are SI (m, rad, s, N, N m, J, W, kg m^2).

Four-bar loops (:func:`four_bars`)
    Every loop of four bodies closed by four revolute joints, e.g. both loops of a Watt-II
    six-bar. Each loop is classified relative to its *frame*: the ground if the loop contains it,
    otherwise the loop's body nearest to the ground (fewest joints away). The *input* is the
    frame-adjacent link that is driven from the frame, otherwise the one nearer (through the
    moving bodies) to a driven joint; the other frame-adjacent link is the *output*, the fourth
    link the *coupler*. Grashof: with s, l the shortest and longest and p, q the other two
    lengths, s + l < p + q lets the shortest link turn fully relative to the others, and the
    frame's choice gives double-crank / crank-rocker / double-rocker / rocker-crank;
    s + l > p + q is a triple-rocker; s + l = p + q a change-point linkage.

Transmission angle (:func:`transmission_angle`)
    mu in [0, pi] between the coupler (input pin to output pin) and the output link (frame pin
    to output pin). It equals the angle at the output pin between the two links; at the input
    angles theta = 0 and pi (crank along the frame), by the cosine law
    ``cos mu = (b^2 + c^2 - a^2 - d^2 +- 2 a d) / (2 b c)`` (a input, b coupler, c output,
    d frame). The farther mu stays from 0 and 180 deg, the better the force transmission.

Mechanical advantage (:func:`mechanical_advantage`)
    ``MA = |omega_in / omega_out|``, the angular speeds taken relative to the loop's frame. For an
    ideal (frictionless, inertia-free) linkage, power conservation ``T_in omega_in + T_out
    omega_out = 0`` makes it the ratio of output to input torque magnitudes. It is infinite where
    the output stops (a rocker's limit positions, where the linkage locks against a load on the
    output) and zero at the toggle where the input stops. :func:`velocity_ratio` is the signed
    inverse, ``omega_out / omega_in``.

Shaking force and moment (:func:`shaking_wrench`, :func:`shaking_force`, :func:`shaking_moment`)
    The resultant load the moving links exert on the ground (the frame), moment about the global
    origin: at every joint between the ground and a moving body, the joint's reaction on the
    ground plus the reaction of the joint's driver (minus the driver torque, or minus the
    driver force along the slider axis, for the ground as the joint's second body the effort
    itself); plus the force of every spring and damper anchored on the ground. Loads applied
    directly to the ground are not transmitted by the mechanism and are left out. By the moving
    links' momentum balance it equals the sum over moving links of the applied loads that do not
    come from the ground (gravity, point forces, torques) minus the rate of their momentum,
    ``sum(m g + F) - sum(m a_G)``. :func:`inertia_wrench` is the inertia part alone,
    ``-sum(m a_G)`` and ``-sum(r_G x m a_G + I_G alpha)``, the target of mass balancing.

Driver power and energy (:func:`driver_power`, :func:`driver_energy`)
    Power ``P = tau qd`` per driver; work over the run by the trapezoid rule, split into its
    positive and negative parts. Energy fluctuation over one cycle (the first driver period of
    a constant-speed driver, else the whole run): ``E(t) = int (P - P_mean) dt``,
    ``Delta E = max E - min E``. The flywheel that keeps the speed of a constant-speed revolute
    driver within a coefficient of fluctuation ``C_s = (w_max - w_min) / w_mean`` needs
    ``I = Delta E / (C_s w_mean^2)`` (kg m^2, about the driver's axis, on top of the
    mechanism's own inertia).

Joint travel (:func:`joint_travel`)
    Extreme values of each joint coordinate over the run (a slider's stroke, a rocker's swing),
    refined between samples by one Newton step on ``qd = 0``.

Path straightness (:func:`path_straightness`)
    For a named point over a range of the first driver's coordinate: the total-least-squares
    line through its samples (principal axis of their scatter), the maximum and RMS
    perpendicular distance from it, the width of the band between the two parallel lines that
    hold the path (for a circular arc of angle 2 alpha: the sagitta R (1 - cos alpha)) and the
    length it covers along the line. Samples weigh equally (uniform in time for the usual
    uniform sampling).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from .errors import ModelError
from .model import GROUND, PRISMATIC, REVOLUTE, Model
from .planar import dot, perp

TWO_PI = 2.0 * np.pi


# ---------------------------------------------------------------------------- small algebra
# components last: (..., 2) vectors

def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _perp(a):
    return np.stack((-a[..., 1], a[..., 0]), axis=-1)


def _rot(phi, v):
    """Rotate the local vector ``v`` (2,) by the angles ``phi`` (...) -> (..., 2)."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack((c * v[0] - s * v[1], s * v[0] + c * v[1]), axis=-1)


def _peak(t, x):
    """Largest |x| (over the finite samples) and its time."""
    k = int(np.nanargmax(np.abs(x)))
    return float(np.abs(x[k])), float(t[k])


def _rms(x):
    return float(np.sqrt(np.nanmean(np.asarray(x) ** 2)))


# ---------------------------------------------------------------------------- four-bar loops

@dataclass(frozen=True)
class FourBar:
    """A four-bar loop of revolute joints: frame, input link, coupler, output link.

    ``pins``: joint names frame-input, input-coupler, coupler-output, output-frame.
    ``lengths``: frame, input, coupler, output (pin-to-pin), m.
    ``frame``: the link the loop is classified relative to (the ground when in the loop).
    """

    input: str
    coupler: str
    output: str
    pins: tuple[str, str, str, str]
    lengths: tuple[float, float, float, float]
    frame: str = GROUND

    @property
    def type(self) -> str:
        """Short Grashof type: 'double-crank', 'crank-rocker', 'double-rocker', 'rocker-crank',
        'triple-rocker' or 'change-point'."""
        s, l = min(self.lengths), max(self.lengths)
        pq = sum(self.lengths) - s - l
        if np.isclose(s + l, pq, rtol=1e-9):
            return "change-point"
        if s + l > pq:
            return "triple-rocker"
        return ["double-crank", "crank-rocker", "double-rocker",
                "rocker-crank"][int(np.argmin(self.lengths))]

    @property
    def grashof(self) -> str:
        """Grashof classification: which links can rotate fully relative to the frame."""
        return {
            "change-point": "change-point (s + l = p + q: passes a folded position)",
            "triple-rocker": "non-Grashof triple-rocker (no link rotates fully)",
            "double-crank": "Grashof double-crank (drag link)",
            "crank-rocker": "Grashof crank-rocker",
            "double-rocker": "Grashof double-rocker (the coupler rotates fully)",
            "rocker-crank": "Grashof rocker-crank (the output rotates fully)",
        }[self.type]


def _joint_point(model: Model, joint: str, body: str) -> np.ndarray:
    jt = model.joint(joint)
    point = jt.point_a if jt.body_a == body else jt.point_b
    return np.asarray(model.body(body).points[point], float)


def _other(j, body: str) -> str:
    return j.body_b if j.body_a == body else j.body_a


def _distances(model: Model, sources, blocked=()) -> dict[str, int]:
    """Joint count from ``sources`` to every body, never passing through ``blocked`` bodies."""
    dist = {b: 0 for b in sources}
    queue = deque(sources)
    while queue:
        here = queue.popleft()
        for j in model.joints:
            if here in (j.body_a, j.body_b):
                nxt = _other(j, here)
                if nxt not in dist and nxt not in blocked:
                    dist[nxt] = dist[here] + 1
                    queue.append(nxt)
    return dist


def four_bars(model: Model) -> list[FourBar]:
    """Every four-bar loop of revolute joints, classified relative to its frame.

    Loops containing the ground come first; within that, in the order of their joints in the
    model. See the module docstring for how the frame, input and output are chosen.
    """
    rev = [j for j in model.joints if j.kind == REVOLUTE and j.body_a != j.body_b]
    order = {j.name: k for k, j in enumerate(model.joints)}
    body_order = {b.name: k for k, b in enumerate(model.bodies)}
    from_ground = _distances(model, [GROUND])
    driven = [model.joint(d.joint) for d in model.drivers]
    sources = sorted({b for j in driven for b in (j.body_a, j.body_b) if b != GROUND},
                     key=body_order.get)

    loops: dict[frozenset, tuple[list[str], list]] = {}
    for j1 in rev:
        for b0, b1 in ((j1.body_a, j1.body_b), (j1.body_b, j1.body_a)):
            for j2 in rev:
                if j2 is j1 or b1 not in (j2.body_a, j2.body_b):
                    continue
                b2 = _other(j2, b1)
                if b2 in (b0, b1):
                    continue
                for j3 in rev:
                    if j3 in (j1, j2) or b2 not in (j3.body_a, j3.body_b):
                        continue
                    b3 = _other(j3, b2)
                    if b3 in (b0, b1, b2):
                        continue
                    for j4 in rev:
                        if j4 not in (j1, j2, j3) and {j4.body_a, j4.body_b} == {b3, b0}:
                            key = frozenset((j1.name, j2.name, j3.name, j4.name))
                            loops.setdefault(key, ([b0, b1, b2, b3], [j1, j2, j3, j4]))

    found = []
    for bodies, joints in loops.values():
        # frame: the ground, else the loop's body nearest the ground; rotate it to the front
        f = min(range(4), key=lambda k: (bodies[k] != GROUND,
                                         from_ground.get(bodies[k], 10 ** 9),
                                         body_order[bodies[k]]))
        bodies, joints = bodies[f:] + bodies[:f], joints[f:] + joints[:f]
        frame, x, cpl, y = bodies
        jfx, jxc, jcy, jyf = joints
        # input: driven from the frame, else nearer a driven joint through the moving bodies
        dist = _distances(model, sources, blocked=(GROUND, frame)) if sources else {}

        def rank(link, pin):
            return (pin not in driven, dist.get(link, 10 ** 9), body_order[link])

        if rank(y, jyf) < rank(x, jfx):
            x, y, jfx, jxc, jcy, jyf = y, x, jyf, jcy, jxc, jfx
        names = (jfx.name, jxc.name, jcy.name, jyf.name)
        lengths = tuple(
            np.linalg.norm(_joint_point(model, p.name, body) - _joint_point(model, q.name, body))
            for body, p, q in ((frame, jfx, jyf), (x, jfx, jxc), (cpl, jxc, jcy), (y, jcy, jyf)))
        found.append(FourBar(x, cpl, y, names, tuple(float(v) for v in lengths), frame))
    found.sort(key=lambda fb: (fb.frame != GROUND, sorted(order[p] for p in fb.pins)))
    return found


def _pin(sol, joint: str, body: str) -> np.ndarray:
    jt = sol.model.joint(joint)
    point = jt.point_a if jt.body_a == body else jt.point_b
    return sol.point(body, point)


def transmission_angle(sol, fb: FourBar) -> np.ndarray:
    """Transmission angle (T,) rad in [0, pi]: between the coupler (input pin to output pin) and
    the output link (frame pin to output pin)."""
    A = _pin(sol, fb.pins[1], fb.coupler)
    B = _pin(sol, fb.pins[2], fb.coupler)
    O = _pin(sol, fb.pins[3], fb.output)
    u, v = B - A, B - O
    c = np.sum(u * v, -1) / (np.linalg.norm(u, axis=-1) * np.linalg.norm(v, axis=-1))
    return np.arccos(np.clip(c, -1.0, 1.0))


def velocity_ratio(sol, fb: FourBar) -> np.ndarray:
    """``omega_out / omega_in`` (T,), both relative to the loop's frame (signed)."""
    w_f = sol.omega(fb.frame)
    with np.errstate(divide="ignore", invalid="ignore"):
        return (sol.omega(fb.output) - w_f) / (sol.omega(fb.input) - w_f)


def mechanical_advantage(sol, fb: FourBar) -> np.ndarray:
    """Ideal mechanical advantage ``|omega_in / omega_out|`` (T,), relative to the frame: the ratio
    of output to input torque magnitudes of the frictionless, inertia-free linkage (inf where
    the output stops)."""
    w_f = sol.omega(fb.frame)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.abs((sol.omega(fb.input) - w_f) / (sol.omega(fb.output) - w_f))


# ---------------------------------------------------------------------------- shaking

def _spring_forces_on_ground(sol):
    """Force (T, 2) on the ground and its moment about the origin (T,) of every spring or damper
    with one end on the ground."""
    m = sol.model
    f_tot = np.zeros(sol.t.shape + (2,))
    n_tot = np.zeros(sol.t.shape)
    for load in m.loads:
        if load.kind not in ("spring", "damper") or (load.body == GROUND) == (load.body2 == GROUND):
            continue
        r1, r2 = sol.point(load.body, load.point), sol.point(load.body2, load.point2)
        v1 = sol.kin.point_velocity(load.body, load.point)
        v2 = sol.kin.point_velocity(load.body2, load.point2)
        d = r2 - r1
        length = np.linalg.norm(d, axis=-1)
        u = d / length[..., None]
        if load.kind == "spring":  # tension k (l - l0) pulls the two ends together
            tension = load.stiffness * (length - load.free_length)
        else:  # damper: tension c dl/dt
            tension = load.damping * np.sum(u * (v2 - v1), axis=-1)
        # end 1 is pulled towards end 2 (+u), end 2 towards end 1 (-u)
        f, r = ((tension[..., None] * u, r1) if load.body == GROUND
                else (-tension[..., None] * u, r2))
        f_tot += f
        n_tot += _cross(r, f)
    return f_tot, n_tot


def shaking_wrench(sol) -> np.ndarray:
    """Resultant load of the moving links on the ground, (T, 3) ``[n_z, fx, fy]``.

    ``n_z`` is the moment about the global origin (N m), ``f`` the force (N), global components.
    Included: every ground joint's reaction on the ground, the reaction of its driver (torque
    or force) and every ground-anchored spring or damper. See the module docstring.
    """
    m = sol.model
    drivers = {d.joint: k for k, d in enumerate(m.drivers)}
    out = np.zeros(sol.t.shape + (3,))
    for k, j in enumerate(m.joints):
        if (j.body_a == GROUND) == (j.body_b == GROUND):
            continue
        # wrench by the first body on the second, about the second body's joint point
        f = np.array(sol.reactions.force[..., k, :])
        n = np.array(sol.reactions.moment[..., k])
        if j.name in drivers:
            tau = sol.dyn.tau[..., drivers[j.name]]
            if j.kind == REVOLUTE:
                n = n + tau
            else:  # along the axis, fixed in the first body; its line passes the joint points
                f = f + tau[..., None] * _rot(sol.phi(j.body_a), np.asarray(j.axis, float))
        r = sol.point(j.body_b, j.point_b)
        sign = 1.0 if j.body_b == GROUND else -1.0
        out[..., 0] += sign * (n + _cross(r, f))
        out[..., 1:] += sign * f
    f_s, n_s = _spring_forces_on_ground(sol)
    out[..., 0] += n_s
    out[..., 1:] += f_s
    return out


def shaking_force(sol) -> np.ndarray:
    """Shaking force (T, 2) on the ground, N, global (see :func:`shaking_wrench`)."""
    return shaking_wrench(sol)[..., 1:]


def shaking_moment(sol) -> np.ndarray:
    """Shaking moment (T,) on the ground about the global origin, N m, driver reaction included
    (see :func:`shaking_wrench`)."""
    return shaking_wrench(sol)[..., 0]


def inertia_wrench(sol) -> np.ndarray:
    """Inertia load of the moving links, (T, 3): ``[-sum(r_G x m a_G + I_G alpha), -sum m a_G]``,
    moment about the global origin. Equals the shaking wrench when no loads act."""
    m = sol.model
    out = np.zeros(sol.t.shape + (3,))
    for b in m.moving_bodies:
        phi, w, al = sol.phi(b.name), sol.omega(b.name), sol.alpha(b.name)
        # mass centre from any named point P of the body: a_G = a_P + alpha perp(d) - w^2 d
        p_name, p_loc = next(iter(b.points.items()))
        d = _rot(phi, np.asarray(b.com, float) - np.asarray(p_loc, float))
        r_g = sol.point(b.name, p_name) + d
        a_g = (sol.kin.point_acceleration(b.name, p_name) + al[..., None] * _perp(d)
               - (w ** 2)[..., None] * d)
        out[..., 1:] -= b.mass * a_g
        out[..., 0] -= b.mass * _cross(r_g, a_g) + b.inertia * al
    return out


# ---------------------------------------------------------------------------- driver energy

def driver_power(sol) -> np.ndarray:
    """Power of each driver (T, n_drivers), W: ``tau qd`` at its joint."""
    idx = [[j.name for j in sol.model.joints].index(d.joint) for d in sol.model.drivers]
    return sol.dyn.tau * sol.kin.qd[..., idx]


def _cumtrapz(t, y):
    return np.concatenate(([0.0], np.cumsum(0.5 * (y[1:] + y[:-1]) * np.diff(t))))


def energy_fluctuation(t, power) -> float:
    """``max E - min E`` of ``E(t) = int (P - P_mean) dt`` over the samples given, J."""
    t, power = np.asarray(t, float), np.asarray(power, float)
    work = _cumtrapz(t, power)
    e = work - work[-1] * (t - t[0]) / (t[-1] - t[0])
    return float(np.max(e) - np.min(e))


def flywheel_inertia(delta_e: float, omega_mean: float, fluctuation: float = 0.02) -> float:
    """Flywheel inertia ``Delta E / (C_s omega_mean^2)``, kg m^2."""
    return float(delta_e / (fluctuation * omega_mean ** 2))


def _constant_speed(d) -> float | None:
    from .motion import ConstantSpeed

    return float(d.motion.speed) if isinstance(d.motion, ConstantSpeed) else None


def driver_energy(sol, fluctuation: float = 0.02) -> dict:
    """Work, power and energy fluctuation of each driver, with the flywheel a constant-speed
    revolute driver needs for a coefficient of speed fluctuation ``fluctuation``.

    Samples that are not valid (NaN rows) are left out of the integrals.
    """
    m, t = sol.model, sol.t
    power = driver_power(sol)
    out = {}
    for k, d in enumerate(m.drivers):
        p = power[..., k]
        ok = np.isfinite(p)
        tk, pk = t[ok], p[ok]
        entry: dict = {"work_J": None, "positive_work_J": None, "negative_work_J": None,
                       "mean_power_W": None, "max_power_W": None, "min_power_W": None,
                       "energy_fluctuation_J": None, "fluctuation_over": None, "flywheel": None}
        out[d.joint] = entry
        if len(tk) < 2:
            continue
        span = tk[-1] - tk[0]
        entry.update({
            "work_J": float(_cumtrapz(tk, pk)[-1]),
            "positive_work_J": float(_cumtrapz(tk, np.clip(pk, 0, None))[-1]),
            "negative_work_J": float(_cumtrapz(tk, np.clip(pk, None, 0))[-1]),
            "mean_power_W": float(_cumtrapz(tk, pk)[-1] / span) if span > 0 else None,
            "max_power_W": float(np.max(pk)), "min_power_W": float(np.min(pk))})
        # one cycle: the first driver period if the run covers it, else the whole run
        period = d.period
        if period and span >= period * (1 - 1e-9):
            cyc = tk <= tk[0] + period * (1 + 1e-9)
            over = "first cycle"
        else:
            cyc = np.ones(len(tk), bool)
            over = "run (shorter than one cycle)" if period else "run"
        if np.sum(cyc) < 2:
            continue
        de = energy_fluctuation(tk[cyc], pk[cyc])
        entry["energy_fluctuation_J"], entry["fluctuation_over"] = de, over
        speed = _constant_speed(d)
        if m.joint(d.joint).kind == REVOLUTE and speed:
            entry["flywheel"] = {"speed_fluctuation": float(fluctuation),
                                 "mean_speed_rad_s": abs(speed),
                                 "inertia_kg_m2": flywheel_inertia(de, speed, fluctuation)}
    return out


# ---------------------------------------------------------------------------- travel

def _extreme(t, q, qd, qdd, k, sign) -> float:
    """q[k] refined by one Newton step on qd = 0 when the extreme lies between samples."""
    if 0 < k < len(q) - 1 and np.isfinite(qdd[k]) and sign * qdd[k] < 0:
        dt = abs(qd[k] / qdd[k])
        if dt <= max(t[k + 1] - t[k], t[k] - t[k - 1]):
            return float(q[k] - 0.5 * qd[k] ** 2 / qdd[k])
    return float(q[k])


def joint_travel(sol, joint: str) -> tuple[float, float]:
    """Smallest and largest value of a joint coordinate over the run (rad or m)."""
    k = [j.name for j in sol.model.joints].index(joint)
    t = sol.t
    q, qd, qdd = sol.kin.q[..., k], sol.kin.qd[..., k], sol.kin.qdd[..., k]
    lo = _extreme(t, q, qd, qdd, int(np.nanargmin(q)), -1)
    hi = _extreme(t, q, qd, qdd, int(np.nanargmax(q)), +1)
    return lo, hi


# ---------------------------------------------------------------------------- straight line

def _parse_point(model: Model, point: str) -> tuple[str, str]:
    body, _, name = point.partition(".")
    names = [b.name for b in model.bodies]
    if body not in names or not name:
        raise ModelError(f"no body '{body}' for the path point '{point}'", field="--path-point",
                         fix="Give BODY.POINT with a body of the model: " + ", ".join(names))
    points = model.body(body).points
    if name not in points:
        raise ModelError(f"body '{body}' has no point '{name}'", field="--path-point",
                         fix=f"Points of '{body}': " + ", ".join(points))
    return body, name


def default_path_point(model: Model) -> str | None:
    """The only named point, not used by a joint, of a link not jointed to the ground (a coupler
    point such as Hoeken's ``coupler.P``); None if there is not exactly one."""
    on_ground = {_other(j, GROUND) for j in model.joints if GROUND in (j.body_a, j.body_b)}
    used = {(j.body_a, j.point_a) for j in model.joints} | {(j.body_b, j.point_b)
                                                            for j in model.joints}
    free = [f"{b.name}.{p}" for b in model.moving_bodies if b.name not in on_ground
            for p in b.points if (b.name, p) not in used]
    return free[0] if len(free) == 1 else None


def _in_range(model: Model, q: np.ndarray, q_range) -> np.ndarray:
    """Samples whose first driver coordinate lies in ``q_range = (a, b)``; for a revolute
    driver the angles from a counter-clockwise to b, taken modulo 2 pi."""
    a, b = (float(x) for x in q_range)
    if model.joint(model.drivers[0].joint).kind == PRISMATIC:
        return (q >= min(a, b) - 1e-12) & (q <= max(a, b) + 1e-12)
    if b - a >= TWO_PI:
        return np.isfinite(q)
    width = np.mod(b - a, TWO_PI)
    tol = 1e-9
    return np.mod(q - a + tol, TWO_PI) <= width + 2 * tol


def path_straightness(sol, point: str, q_range=None) -> dict:
    """Straightness of a point's path (see the module docstring).

    Parameters
    ----------
    point : str
        ``'BODY.POINT'``.
    q_range : (float, float) or None
        Range of the first driver's coordinate (rad or m); None for the whole run.

    Returns
    -------
    dict with ``point``, ``range``, ``samples``, ``centroid_m`` (2), ``direction`` (unit, 2),
    ``max_deviation_m``, ``rms_deviation_m``, ``band_m``, ``length_m``.
    """
    m = sol.model
    body, name = _parse_point(m, point)
    xy = sol.point(body, name)
    sel = np.all(np.isfinite(xy), axis=-1)
    if q_range is not None:
        if not m.drivers:
            raise ModelError("--path-range needs a driver", field="--path-range",
                             fix="Drop --path-range")
        k = [j.name for j in m.joints].index(m.drivers[0].joint)
        sel &= _in_range(m, sol.kin.q[..., k], q_range)
    if np.sum(sel) < 3:
        raise ModelError(f"the driver range {q_range} holds {int(np.sum(sel))} samples of the run",
                         field="--path-range",
                         fix="Give a range A:B of the first driver's coordinate (rad or m) that "
                             "the run covers, with at least 3 samples")
    pts = xy[sel]
    c = pts.mean(axis=0)
    # principal axis of the scatter: the total-least-squares line
    _, _, vt = np.linalg.svd(pts - c, full_matrices=False)
    u = vt[0] * (1.0 if vt[0][np.argmax(np.abs(vt[0]))] > 0 else -1.0)
    along = (pts - c) @ u
    dev = _cross(u, pts - c)  # signed distance from the line
    return {"point": point,
            "range": None if q_range is None else [float(x) for x in q_range],
            "samples": int(np.sum(sel)),
            "centroid_m": c.tolist(), "direction": u.tolist(),
            "max_deviation_m": float(np.max(np.abs(dev))),
            "rms_deviation_m": float(np.sqrt(np.mean(dev ** 2))),
            "band_m": float(np.max(dev) - np.min(dev)),
            "length_m": float(np.max(along) - np.min(along))}


# ---------------------------------------------------------------------------- summary

def _extremes(t, x) -> dict:
    kmin, kmax = int(np.nanargmin(x)), int(np.nanargmax(x))
    return {"min": float(x[kmin]), "min_time_s": float(t[kmin]),
            "max": float(x[kmax]), "max_time_s": float(t[kmax])}


def summary(sol, *, fluctuation: float = 0.02, path_point: str | None = None,
            path_range=None) -> dict:
    """Summary of a solution as plain JSON-ready data (SI units).

    Parameters
    ----------
    fluctuation : float
        Coefficient of speed fluctuation C_s for the flywheel size.
    path_point : str or None
        ``'BODY.POINT'`` whose path straightness is reported; None picks
        :func:`default_path_point` (no report if there is none).
    path_range : (float, float) or None
        Range of the first driver's coordinate for the straightness; None for the whole run.
    """
    if not fluctuation > 0:
        raise ModelError(f"the coefficient of speed fluctuation must be positive, got "
                         f"{fluctuation}", field="--fluctuation", fix="Give e.g. 0.02")
    m, topo = sol.model, sol.topology
    t, valid = sol.t, sol.valid
    out: dict = {
        "model": m.name,
        "file": m.source,
        "samples": int(len(t)),
        "duration_s": float(t[-1] - t[0]),
        "mobility": topo.mobility,
        "loops": topo.n_loops,
        "cut_joints": [m.joints[j].name for j in topo.cut],
        "spanning_tree": {b: m.joints[topo.tree_joint[i]].name
                          for i, b in enumerate(topo.bodies) if i},
        "drivers": {},
        "reactions": {},
        "four_bars": [],
        "invalid_samples": int(np.sum(~valid)),
    }
    for k, d in enumerate(m.drivers):
        tau = sol.dyn.tau[..., k]
        peak, at = _peak(t, tau)
        unit = "N" if m.joint(d.joint).kind != REVOLUTE else "N m"
        out["drivers"][d.joint] = {
            "effort": "force" if unit == "N" else "torque", "unit": unit,
            "peak": peak, "peak_time_s": at,
            "rms": _rms(tau),
            "motion": d.description}
    for k, j in enumerate(m.joints):
        f = np.linalg.norm(sol.reactions.force[..., k, :], axis=-1)
        peak, at = _peak(t, f)
        entry = {"peak_force_N": peak, "peak_time_s": at}
        if j.kind != REVOLUTE:
            entry["peak_moment_Nm"] = _peak(t, sol.reactions.moment[..., k])[0]
        out["reactions"][j.name] = entry
    for fb in four_bars(m):
        mu = np.degrees(transmission_angle(sol, fb))
        kmin = int(np.nanargmin(np.minimum(mu, 180 - mu)))
        ta = {"min": float(np.nanmin(mu)), "max": float(np.nanmax(mu)),
              "worst": float(mu[kmin]), "worst_time_s": float(t[kmin])}
        ta["min_time_s"] = float(t[int(np.nanargmin(mu))])
        ta["max_time_s"] = float(t[int(np.nanargmax(mu))])
        out["four_bars"].append({
            "links": {"input": fb.input, "coupler": fb.coupler, "output": fb.output},
            "frame": fb.frame,
            "pins": list(fb.pins),
            # first key "ground" as before; "frame" for a loop that does not contain the ground
            "lengths_m": dict(zip(("ground" if fb.frame == GROUND else "frame", "input",
                                   "coupler", "output"), fb.lengths)),
            "grashof": fb.grashof,
            "type": fb.type,
            "transmission_angle_deg": ta,
            "mechanical_advantage": _extremes(t, mechanical_advantage(sol, fb))})
    out["joint_travel"] = {}
    for j in m.joints:
        lo, hi = joint_travel(sol, j.name)
        entry = {"unit": "rad" if j.kind == REVOLUTE else "m", "min": lo, "max": hi,
                 "range": hi - lo}
        if j.kind == REVOLUTE:
            entry["full_turn"] = bool(hi - lo >= TWO_PI * (1 - 1e-9))
        out["joint_travel"][j.name] = entry
    ws = shaking_wrench(sol)
    f_mag = np.linalg.norm(ws[..., 1:], axis=-1)
    i_mag = np.linalg.norm(inertia_wrench(sol)[..., 1:], axis=-1)
    out["shaking"] = {
        "force_N": dict(zip(("peak", "peak_time_s"), _peak(t, f_mag)), rms=_rms(f_mag)),
        "moment_Nm": dict(zip(("peak", "peak_time_s"), _peak(t, ws[..., 0])),
                          rms=_rms(ws[..., 0])),
        "inertia_force_N": dict(zip(("peak", "peak_time_s"), _peak(t, i_mag)), rms=_rms(i_mag)),
        "moment_about": "global origin",
        "includes": "ground-joint reactions, driver reactions and ground-anchored springs and "
                    "dampers, as loads on the ground"}
    out["driver_energy"] = driver_energy(sol, fluctuation)
    point = path_point or default_path_point(m)
    out["path_straightness"] = (path_straightness(sol, point, path_range)
                                if point else None)
    out["health"] = health(sol)
    return out


def health(sol) -> dict:
    """Numerical health of the run: closure residual, energy balance, conditioning.

    The energy balance checks ``P_drivers + P_loads = dKE/dt`` at every valid sample, where
    ``P_loads`` is the power of every applied load (gravity and springs included) and ``dKE/dt``
    is computed from the mass centres, ``sum m v_C . a_C + I_C w al`` — a path independent of
    the Newton–Euler wrenches about O_i the solver uses. The residual is relative to the largest
    of the three powers over the run. The condition number is that of ``J_dep`` (the matrix of
    the rate and the ``[lam; tau]`` solves) made dimensionless: rows of velocity divided by the
    mechanism's size, columns of slider rates multiplied by it.
    """
    kin, topo, lay = sol.kin, sol.topology, sol.kin.layout
    ok = sol.valid
    p_drv = sol.driver_power
    p_loads = sum(dot(t, w) for t, w in zip(kin.twists, sol.loads.wrenches))
    dke = np.zeros(kin.shape)
    for i in range(1, topo.n):
        d = kin.pose.rotate(i, lay.com[i])
        (w, v), (al, a) = (kin.twists[i][0], kin.twists[i][1:]), (kin.rates[i][0], kin.rates[i][1:])
        v_c = v + w * perp(d)
        a_c = a + al * perp(d) - w ** 2 * d
        dke = dke + lay.mass[i] * dot(v_c, a_c) + lay.inertia[i] * w * al
    resid = np.abs(p_drv + p_loads - dke)[ok]
    scale = max((float(np.max(np.abs(x[ok]))) for x in (p_drv, p_loads, dke)), default=0.0)
    dep = np.array(topo.dependent, int)
    cond = None
    if len(dep) and np.any(ok):
        rows = np.array([1.0 / float(np.min(lay.size)) if (c.kind == REVOLUTE or r == 1) else 1.0
                         for c in lay.cuts for r in (0, 1)])
        cols = np.array([1.0 if lay.kind[i] == REVOLUTE else float(np.min(lay.size)) for i in dep])
        Jd = kin.J[ok][..., dep - 1] * rows[:, None] * cols
        cond = float(np.max(np.linalg.cond(Jd)))
    return {
        "closure_residual_rel": float(np.nanmax(kin.residual[ok])) if np.any(ok) else None,
        "energy_balance_residual_rel": (float(np.max(resid) / scale) if scale > 0 else 0.0)
        if resid.size else None,
        "worst_condition_number": cond,
    }
