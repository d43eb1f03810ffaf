"""Four-bar loops: their Grashof type, transmission angle and mechanical advantage.

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
    inverse, ``omega_out / omega_in``. A sampled run's largest value is only a number of its
    sampling (1251 at 361 samples of Hoeken's crank turn, 5112 at 3601), so :func:`stops`
    locates where a link stops between samples: there the advantage is infinite (or zero).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from ..model import GROUND, REVOLUTE, Model


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
        """Grashof classification: which links can rotate fully relative to the frame (what
        the loop's lengths allow; :func:`link_travel` gives what a run does)."""
        return {
            "change-point": "change-point (s + l = p + q: passes a folded position)",
            "triple-rocker": "non-Grashof triple-rocker (no link rotates fully)",
            "double-crank": "Grashof double-crank (drag link)",
            "crank-rocker": "Grashof crank-rocker",
            "double-rocker": "Grashof double-rocker (the coupler can rotate fully)",
            "rocker-crank": "Grashof rocker-crank (the output can rotate fully)",
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


def transmission_worst(mu):
    """Distance of the transmission angle from the folded positions, ``min(mu, pi - mu)`` (same
    shape as ``mu``, rad): 90 deg is ideal, 0 a toggle. Its minimum over a run is the sweep
    metric ``min_transmission_angle`` and the summary's ``worst``."""
    return np.minimum(mu, np.pi - mu)


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


def stops(sol, fb: FourBar, role: str) -> list[dict]:
    """Where the loop's ``role`` link (``'input'`` or ``'output'``) stops relative to its frame
    in the run while the other one moves: there the mechanical advantage is zero (the input
    stops: the toggle) or infinite (the output stops: a rocker's limit positions).

    A stop is a sign change of the link's relative angular speed ``w = omega_role -
    omega_frame`` between two valid samples, or a sample where ``w`` is zero (below 1e-12 of its
    largest magnitude; a rest of several samples counts once). Between samples k and k+1 the
    stop is where the linear interpolation of ``w`` vanishes, ``f = w_k / (w_k - w_k+1)``, and
    so are its time and the first driver's coordinate. A stop the other link shares (in the
    same sample interval, as a loop whose input and output both swing with one rocker) leaves
    the ratio finite (0/0) and is not listed.

    Returns
    -------
    list of dict
        In time order, each ``{'k': nearest sample, 't': time s, 'q': the first driver's
        coordinate at the stop (SI: rad or m), or None without a driver}``; empty when the
        link never stops, or never moves.
    """
    other = {"input": "output", "output": "input"}[role]
    a, b, f = _rate_stops(sol.omega(getattr(fb, role)) - sol.omega(fb.frame))
    keep = ~np.isin(a, _rate_stops(sol.omega(getattr(fb, other)) - sol.omega(fb.frame))[0])
    a, b, f = a[keep], b[keep], f[keep]
    t = np.asarray(sol.t, float).reshape(-1)
    q = None
    if sol.model.drivers:
        q = np.asarray(sol.columns[f"q_{sol.model.drivers[0].joint}"], float).reshape(-1)
    return [{"k": int(a[n] if f[n] < 0.5 else b[n]),
             "t": float(t[a[n]] + f[n] * (t[b[n]] - t[a[n]])),
             "q": None if q is None else float(q[a[n]] + f[n] * (q[b[n]] - q[a[n]]))}
            for n in range(a.size)]


def _rate_stops(w) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The stops of a rate ``w`` (T,) for :func:`stops`: the samples ``a`` and ``b`` (the next
    valid one) around each and the fraction ``f`` of the way from ``a`` to ``b``."""
    w = np.asarray(w, float).reshape(-1)
    ok = np.flatnonzero(np.isfinite(w))
    if ok.size == 0 or not np.any(w[ok]):
        return np.zeros(0, int), np.zeros(0, int), np.zeros(0)
    w_ok = w[ok]
    sign = np.sign(w_ok) * (np.abs(w_ok) > 1e-12 * np.max(np.abs(w_ok)))
    # a zero sample that does not follow another, and a sign change between nonzero ones
    zero = (sign == 0) & np.r_[True, sign[:-1] != 0]
    change = np.r_[sign[:-1] * sign[1:] < 0, False]
    at = np.flatnonzero(zero | change)
    a, b = ok[at], ok[np.minimum(at + 1, ok.size - 1)]
    f = np.where(zero[at], 0.0, w[a] / np.where(w[a] != w[b], w[a] - w[b], 1.0))
    return a, b, f


def link_travel(sol, fb: FourBar) -> dict:
    """What the run does with the loop's links: for the input, coupler and output, the travel
    of its angle relative to the frame over the valid samples, deg (max - min of the
    continuous angle ``phi_link - phi_frame``), and whether it turns fully (360 deg or more).

    The Grashof class says which links *can* rotate fully; this says which do in the run (a
    rocker-crank driven through its rocker's partial swing only rocks its output).
    """
    phi_f = sol.phi(fb.frame)
    out = {}
    for role in ("input", "coupler", "output"):
        rel = np.degrees(sol.phi(getattr(fb, role)) - phi_f)
        rel = rel[np.isfinite(rel)]
        travel = float(np.max(rel) - np.min(rel)) if rel.size else None
        out[role] = {"travel_deg": travel,
                     "full_turn": None if travel is None else bool(travel >= 360.0 * (1 - 1e-9))}
    return out


def travel_words(travel: dict, units=None) -> str:
    """``link_travel`` in words: 'in this run the input turns fully, the output swings 77.6
    deg', the swing in ``units``' angle unit (:class:`linkdyn.units.Units`; None: deg)."""
    from ..units import Units

    units = units or Units(angle="deg")
    parts = []
    for role in ("input", "output"):
        t = travel[role]
        if t["travel_deg"] is None:
            continue
        turns = t["travel_deg"] / 360.0
        parts.append(f"the {role} " + (
            f"swings {units.show(np.radians(t['travel_deg']), 'angle', 4)}" if not t["full_turn"] else
            "turns fully" if turns < 1.0 + 1e-6 else f"turns fully ({turns:.3g} turns)"))
    return ("in this run " + ", ".join(parts)) if parts else ""
