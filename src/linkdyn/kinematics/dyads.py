"""Closed-form position analysis of loops that are dyads.

A loop whose only unknown joints, once the loops solved before it are known, are two revolute
joints, closed at a revolute or prismatic cut, is a dyad: a triangle with two known vertices
and two known side lengths (RRR), or a circle and a line (RRP), or a line turning about a
pivot (RPR). Its missing vertex lies on the side given by the assembly mode (+1/-1, the side
of the line through the known vertices where the current guess has it); the two unknown joint
angles then follow as the turns that carry the guess onto the solution.

Four shapes occur along the spanning tree:

- *split* (RRR): one unknown joint on each side of the cut. Known vertices: the two joints;
  the third vertex: the cut point (:func:`circles`).
- *chain* (RRR): both unknown joints on the same side. Known vertices: the upper joint and the
  cut point on the other side; the third vertex: the lower joint (:func:`circles`).
- *slide* (RRP): a slider cut with both unknown joints on one side; the lower joint lies where
  a circle meets the slide line (:func:`on_line`).
- *swing* (RPR): a slider cut between the two unknown joints' sides; the line body's turn
  solves ``a cos + b sin = k``.

Each shape is one step (:mod:`linkdyn.steps`): :func:`split`, :func:`chain`, :func:`slide`,
:func:`swing` return the two turns (angle, cos, sin, centre) from the poses of the cut's
bodies, and :func:`split_mode` ... :func:`swing_mode` the assembly mode of a pose. The numpy
path (:func:`solve`, :func:`sides`) calls them once per dyad on whole arrays; the compiled
kernel (:mod:`.compiled`) calls the same steps inside its sample loops.

:func:`plan` orders the loops so each dyad only needs joints already solved; a mechanism that
does not decompose this way (prismatic joints inside the loop, Stephenson-type coupled loops)
has no plan and uses Newton's method instead.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import joints as jk
from ..planar import _stack, cross, dot, normal, turned
from ..steps import atan2, select, step


@dataclass(frozen=True)
class Dyad:
    """One dyad: cut index, the two unknown joints (body indices, ``upper`` nearer the ground)
    and the shape: RRR ``'split'`` or ``'chain'``, RRP ``'slide'``; ``side`` ('a' or 'b') is the
    side of the cut carrying both unknown joints of a chain or slide."""

    cut: int
    upper: int
    lower: int
    shape: str
    side: str = ""


def plan(lay) -> tuple[Dyad, ...] | None:
    """An order of dyads solving every loop in closed form, or None."""
    topo = lay.topo
    known = set(topo.driven)
    todo = list(range(len(lay.cuts)))
    out = []
    while todo:
        for k in todo:
            c = lay.cuts[k]
            on_a = {j for j in range(1, topo.n) if topo.ancestors[c.a, j] and not topo.ancestors[c.b, j]}
            on_b = {j for j in range(1, topo.n) if topo.ancestors[c.b, j] and not topo.ancestors[c.a, j]}
            unknown = sorted((on_a | on_b) - known)
            cut = jk.get(c.kind).dyad
            if (len(unknown) != 2 or cut not in ("R", "P")
                    or any(jk.get(lay.kind[j]).dyad != "R" for j in unknown)):
                continue
            j1, j2 = unknown
            if cut == "P" and (j1 in on_a) != (j2 in on_a):
                # a slider cut between the two unknown joints' sides: RPR
                upper, lower = (j1, j2) if j1 in on_a else (j2, j1)
                out.append(Dyad(k, upper, lower, "swing"))
            elif cut == "P":  # a slider cut with both unknown joints on one side: RRP
                upper, lower = (j1, j2) if topo.ancestors[j2, j1] else (j2, j1)
                out.append(Dyad(k, upper, lower, "slide", "a" if j1 in on_a else "b"))
            elif (j1 in on_a) != (j2 in on_a):
                upper, lower = (j1, j2) if j1 in on_a else (j2, j1)
                out.append(Dyad(k, upper, lower, "split"))
            else:
                upper, lower = (j1, j2) if topo.ancestors[j2, j1] else (j2, j1)
                out.append(Dyad(k, upper, lower, "chain", "a" if j1 in on_a else "b"))
            known.update(unknown)
            todo.remove(k)
            break
        else:
            return None
    return tuple(out)


# --- the dyads' equations as steps (linkdyn.steps), for both backends ----------------------------
# A body's pose is the tuple (cos, sin, x, y) of its angle and origin O; a point of it given in
# its frame is p (x, y). A turn is (angle, cos, sin, centre x, centre y): the rotation of a
# joint's subtree about the joint. ``side`` is an assembly mode, +1 or -1.

@step
def minus(a, b):
    """``a - b`` of two vectors ``(x, y)``."""
    return (a[0] - b[0], a[1] - b[1])


@step
def point(body, p):
    """Global position of the point ``p`` of ``body`` (cos, sin, x, y): ``O + R p``."""
    g = turned(body[0], body[1], p)
    return (body[2] + g[0], body[3] + g[1])


@step
def length(a):
    """``|a|`` of a vector ``(x, y)``."""
    return np.sqrt(dot(a, a))


@step
def flat(h2, r2):
    """``sqrt(h2)``, a squared height against a squared length ``r2``; NaN where ``h2 < 0``
    (no solution), but 0 where ``h2`` lies within rounding below 0 (a toggle, where the
    triangle is flat: rounding must not turn it into "cannot close")."""
    h2 = select((h2 < 0) & (h2 > -1e-12 * r2), 0.0, h2)
    return np.sqrt(select(h2 >= 0, h2, np.nan))


@step
def mode(cond):
    """An assembly mode from a condition: +1 where it holds, else -1."""
    return select(cond, 1.0, -1.0)


@step
def turn(u, v):
    """The rotation that carries direction ``u`` onto direction ``v``: its angle in
    (-pi, pi], its cosine and its sine (``u . v`` and ``u x v`` normalized)."""
    x, y = dot(u, v), cross(u, v)
    norm = np.sqrt(x * x + y * y)
    return (atan2(y, x), x / norm, y / norm)


@step
def around(rot, centre):
    """The turn ``rot`` (angle, cos, sin) about ``centre`` (x, y), as a turn 5-tuple."""
    return (rot[0], rot[1], rot[2], centre[0], centre[1])


@step
def circles(c1, r1, c2, r2, side):
    """Intersection of the circles (c1, r1) and (c2, r2) on the ``side`` (+1 left, -1 right)
    of the line c1 -> c2; NaN where they do not meet.

    With ``d = |c2 - c1|`` and ``e`` its direction, the point is
    ``c1 + a e + side h perp(e)``, ``a = (r1^2 - r2^2 + d^2) / 2d``, ``h = sqrt(r1^2 - a^2)``.
    """
    d_vec = minus(c2, c1)
    d = length(d_vec)
    ex = (d_vec[0] / d, d_vec[1] / d)
    a = (r1 * r1 - r2 * r2 + d * d) / (2 * d)
    h = flat(r1 * r1 - a * a, r1 * r1)
    n = normal(ex)
    return (c1[0] + a * ex[0] + side * h * n[0], c1[1] + a * ex[1] + side * h * n[1])


@step
def on_line(c, r, p0, e, side):
    """Intersection of the circle (c, r) with the line ``p0 + s e`` (``e`` unit) on the
    ``side`` (+1: ahead along e of the foot of c, -1: behind); NaN where they do not meet.

    The foot ``f = p0 + ((c - p0) . e) e``; the point ``f + side sqrt(r^2 - |c - f|^2) e``.
    """
    along = dot(minus(c, p0), e)
    foot = (p0[0] + along * e[0], p0[1] + along * e[1])
    h = flat(r * r - dot(minus(c, foot), minus(c, foot)), r * r)
    return (foot[0] + side * h * e[0], foot[1] + side * h * e[1])


@step
def turned_pose(rot, phi, c, s, r):
    """A body's pose (phi, cos, sin, origin ``r`` (x, y)) turned by the turn ``rot`` (angle,
    cos, sin, centre x, y): ``phi + angle``, ``R c``, ``centre + R (r - centre)``."""
    centre = (rot[3], rot[4])
    g = turned(rot[1], rot[2], minus(r, centre))
    return (phi + rot[0], rot[1] * c - rot[2] * s, rot[2] * c + rot[1] * s,
            (centre[0] + g[0], centre[1] + g[1]))


@step
def split_mode(A, B, pa, pb, x1, x2):
    """Assembly mode of an RRR split: the side of the line x1 -> x2 (the two unknown joints)
    where the cut point (on body A at ``pa``) lies."""
    return mode(cross(minus(x2, x1), minus(point(A, pa), x1)) >= 0)


@step(inline=True)
def split(A, B, pa, pb, x1, x2, side):
    """RRR split: the cut point m is at the distances of the cut points of A and B from the
    two unknown joints x1 (turning A's side) and x2 (B's): m = circles(x1, |p_a - x1|, x2,
    |p_b - x2|). Returns the upper and lower turns, about x1 and x2, carrying p_a and p_b
    onto m."""
    u1, u2 = minus(point(A, pa), x1), minus(point(B, pb), x2)
    m = circles(x1, length(u1), x2, length(u2), side)
    return around(turn(u1, minus(m, x1)), x1), around(turn(u2, minus(m, x2)), x2)


@step
def chain_mode(M, F, pm, pf, x1, x2):
    """Assembly mode of an RRR chain: the side of the line from the upper joint x1 to the
    fixed cut point (body F at ``pf``) where the lower joint x2 lies."""
    return mode(cross(minus(point(F, pf), x1), minus(x2, x1)) >= 0)


@step(inline=True)
def chain(M, F, pm, pf, x1, x2, side):
    """RRR chain: both unknown joints x1 (upper) and x2 (lower) on the side of the moving
    body M (cut point at ``pm``); the other, F, holds the fixed cut point (at ``pf``). The
    lower joint goes to m = circles(x1, |x2 - x1|, p_f, |p_m - x2|): returns the upper turn,
    about x1, carrying x2 onto m, and m, the centre of the lower turn (:func:`chain_lower`,
    taken once the upper turn has moved M)."""
    p_m, p_f = point(M, pm), point(F, pf)
    m = circles(x1, length(minus(x2, x1)), p_f, length(minus(p_m, x2)), side)
    return around(turn(minus(x2, x1), minus(m, x1)), x1), m


@step
def chain_lower(M, F, pm, pf, m):
    """RRR chain, after the upper turn (:func:`chain`): the lower turn, about the lower joint
    m, carrying the moving cut point (body M at ``pm``) onto the fixed one (body F at
    ``pf``)."""
    return around(turn(minus(point(M, pm), m), minus(point(F, pf), m)), m)


@step
def slide_line(A, M, F, pm, pf, axis, angle, sgn, x2):
    """Geometry of an RRP dyad: a slider cut (line fixed in body A = the cut's body a, along
    ``axis``; fixed angle ``angle`` of b to a) with both unknown joints on the side of the
    moving body M (b if ``sgn`` = +1, a if -1; F is the other).

    M must end at the known angle ``phi_F + sgn angle``, so the subtree below the lower
    joint x2 turns by a known total (cd, sd) (``phi_target - phi_M``); the lower joint then
    lies on the slide line shifted back by the turned offset from x2 to M's cut point.
    Returns the shifted line's point, its unit direction and (cd, sd).
    """
    ca, sa = np.cos(angle), np.sin(angle)
    # target angle of the moving body phi_F + sgn angle, then its difference to phi_M
    ct, st = F[0] * ca - sgn * F[1] * sa, F[1] * ca + sgn * F[0] * sa
    cd, sd = ct * M[0] + st * M[1], st * M[0] - ct * M[1]
    # the slide direction, turning with A when A is the moving body (sgn = -1)
    e_a = turned(A[0], A[1], axis)
    e_t = turned(cd, sd, e_a)
    e = (select(sgn > 0, e_a[0], e_t[0]), select(sgn > 0, e_a[1], e_t[1]))
    off = turned(cd, sd, minus(point(M, pm), x2))
    return minus(point(F, pf), off), e, (cd, sd)


@step
def slide_mode(A, M, F, pm, pf, axis, angle, sgn, x1, x2):
    """Assembly mode of an RRP dyad: the side of the foot of the upper joint x1 on the
    shifted slide line, along it, where the lower joint x2 lies."""
    p0, e, _ = slide_line(A, M, F, pm, pf, axis, angle, sgn, x2)
    along = dot(minus(x1, p0), e)
    return mode(dot(minus(x2, (p0[0] + along * e[0], p0[1] + along * e[1])), e) >= 0)


@step(inline=True)
def slide(A, M, F, pm, pf, axis, angle, sgn, x1, x2, side):
    """RRP: the lower joint m is where the circle about the upper joint x1 through x2 meets
    the shifted slide line (:func:`slide_line`); the upper turn (about x1) carries x2 onto
    m, the lower turn (about m) supplies the rest of the known total turn."""
    p0, e, total = slide_line(A, M, F, pm, pf, axis, angle, sgn, x2)
    m = on_line(x1, length(minus(x2, x1)), p0, e, side)
    up = turn(minus(x2, x1), minus(m, x1))
    c2 = total[0] * up[1] + total[1] * up[2]
    s2 = total[1] * up[1] - total[0] * up[2]
    return around(up, x1), (atan2(s2, c2), c2, s2, m[0], m[1])


@step
def swing_terms(A, B, pa, pb, axis, angle, x1, x2):
    """Geometry of an RPR dyad: a slider cut whose line body A turns about the unknown joint
    x1 and whose slider body B about x2. B must turn by delta (cd, sd) more than A to keep
    their angle; the slider point then stays on the line when
    ``a cos(theta) + b sin(theta) = k`` for A's turn theta, with n the line's normal,
    ``a = (x2 - x1) . n``, ``b = (x2 - x1) . perp(n)``,
    ``k = (p_a - x1 - R_delta (p_b - x2)) . n``. Returns (a, b, k, cd, sd)."""
    # delta = angle - (phi_b - phi_a), from the cosines and sines
    cr, sr = B[0] * A[0] + B[1] * A[1], B[1] * A[0] - B[0] * A[1]
    ca, sa = np.cos(angle), np.sin(angle)
    cd, sd = ca * cr + sa * sr, sa * cr - ca * sr
    n = normal(turned(A[0], A[1], axis))
    d = minus(x2, x1)
    k = dot(minus(minus(point(A, pa), x1), turned(cd, sd, minus(point(B, pb), x2))), n)
    return (dot(d, n), dot(d, normal(n)), k, cd, sd)


@step
def swing_mode(A, B, pa, pb, axis, angle, x1, x2):
    """Assembly mode of an RPR dyad: which root of ``a cos + b sin = k`` the pose sits on
    (theta = 0)."""
    return mode(swing_terms(A, B, pa, pb, axis, angle, x1, x2)[1] <= 0)


@step(inline=True)
def swing(A, B, pa, pb, axis, angle, x1, x2, side):
    """RPR: A's side turns about x1 by ``theta = atan2(b, a) + side acos(k / |(a, b)|)``,
    B's about x2 by theta + delta (:func:`swing_terms`)."""
    a, b, k, cd, sd = swing_terms(A, B, pa, pb, axis, angle, x1, x2)
    ratio = k / np.sqrt(a * a + b * b)
    # within rounding beyond +-1 at a toggle: on it
    ratio = select((np.abs(ratio) > 1) & (np.abs(ratio) < 1 + 1e-12),
                   select(ratio > 0, 1.0, -1.0), ratio)
    theta = atan2(b, a) + side * np.arccos(select(np.abs(ratio) <= 1, ratio, np.nan))
    c1, s1 = np.cos(theta), np.sin(theta)
    up = atan2(s1, c1)
    return ((up, c1, s1, x1[0], x1[1]),
            (up + atan2(sd, cd), c1 * cd - s1 * sd, s1 * cd + c1 * sd, x2[0], x2[1]))


# --- the numpy path: each dyad's step on whole arrays -------------------------------------------

def _body(pose, i):
    """Body i's pose tuple (cos, sin, x, y) from a :class:`~.recursion.Pose`."""
    return (pose.c[i], pose.s[i], pose.r[i][0], pose.r[i][1])


def _args(lay, dy, pose):
    """The arguments of dyad ``dy``'s shape step (and of its mode step, without ``side``)."""
    c = lay.cuts[dy.cut]
    A, B = _body(pose, c.a), _body(pose, c.b)
    x1, x2 = pose.r[dy.upper], pose.r[dy.lower]
    if dy.shape in ("split", "swing"):
        rest = (A, B, c.pa, c.pb) + ((c.axis, c.angle) if dy.shape == "swing" else ())
        return rest + (x1, x2)
    M, F, pm, pf = (B, A, c.pb, c.pa) if dy.side == "b" else (A, B, c.pa, c.pb)
    if dy.shape == "chain":
        return (M, F, pm, pf, x1, x2)
    return (A, M, F, pm, pf, c.axis, c.angle, 1.0 if dy.side == "b" else -1.0, x1, x2)


#: each shape's steps: (mode, turns)
SHAPES = {"split": (split_mode, split), "chain": (chain_mode, chain),
          "slide": (slide_mode, slide), "swing": (swing_mode, swing)}


def _turn_subtree(lay, pose, root, rot):
    """Turn body ``root`` and every body beyond it by ``rot`` (a turn 5-tuple), in place."""
    for j in range(1, lay.topo.n):
        if lay.topo.ancestors[j, root]:
            pose.phi[j], pose.c[j], pose.s[j], r = turned_pose(rot, pose.phi[j], pose.c[j],
                                                               pose.s[j], pose.r[j])
            pose.r[j] = _stack(r)
            if pose.e[j] is not None:
                pose.e[j] = _stack(turned(rot[1], rot[2], pose.e[j]))


def _mode(lay, dy, pose):
    """Assembly mode of one dyad in ``pose``: +1 or -1, shape (...)."""
    return SHAPES[dy.shape][0](*_args(lay, dy, pose))


def sides(lay, dyads, q, forward) -> list:
    """Assembly mode of each dyad at the configuration ``q`` (+1/-1, shape (...)): the side of
    the line through its known vertices where its apex lies (for a slider, the side of the
    foot of the upper joint where the lower joint lies along the slide)."""
    pose = forward(lay, q)
    return [_mode(lay, dy, pose) for dy in dyads]


def solve(lay, dyads: tuple[Dyad, ...], q: np.ndarray, forward, sides=None):
    """Close every loop of ``q`` (n, ...) exactly, dyad by dyad.

    Each dyad's apex is put on the side given by ``sides`` (the assembly modes from
    :func:`sides`), or, if None, on the side where the guess ``q`` has it. The joint angles move
    by less than pi from ``q``, which therefore sets their winding. ``forward(lay, q)`` gives
    the guess's pose; each dyad then turns the subtrees beyond its two joints rigidly, so later
    dyads stand on the joints earlier ones moved. Returns the closed ``q`` and its pose.
    """
    q = np.array(q, dtype=float)
    topo = lay.topo
    pose = forward(lay, q)
    pose = type(pose)(*(list(x) for x in (pose.phi, pose.c, pose.s, pose.r, pose.e)))
    for k, dy in enumerate(dyads):
        side = _mode(lay, dy, pose) if sides is None else sides[k]
        up, low = SHAPES[dy.shape][1](*_args(lay, dy, pose), side)
        # the subtrees beyond the two joints turn rigidly: the upper's (holding the lower's
        # in a chain or slide), then the lower's about its moved joint
        _turn_subtree(lay, pose, dy.upper, up)
        if dy.shape == "chain":   # the lower turn follows from the moved cut point
            low = chain_lower(*_args(lay, dy, pose)[:4], low)
        _turn_subtree(lay, pose, dy.lower, low)
        # q_i = s (phi_i - phi_parent): the turns are the changes of the two joint angles
        q[dy.upper] += topo.sign[dy.upper] * up[0]
        q[dy.lower] += topo.sign[dy.lower] * low[0]
    return q, pose



MAX_MODES = 256   # mode combinations tried by :func:`closable` (2 ** number of dyads)


def closable(lay, dyads: tuple[Dyad, ...], q: np.ndarray, forward) -> np.ndarray:
    """Whether the loops can close at the driver values of ``q`` (n, ...), shape (...).

    A dyad's two side lengths are fixed by its bodies, so whether it closes depends only on
    its known vertices (two circles meet when ``|r1 - r2| <= d <= r1 + r2``, a line meets a
    circle when its distance from the centre is at most the radius, ``a cos + b sin = k`` has
    a root when ``|k| <= |(a, b)|``), which the dyads solved before it place according to
    their assembly modes. :func:`solve` in every combination of modes: False where none closes
    every dyad (NaN), so that no starting guess of Newton's method can assemble the loops
    there (with the same rounding allowance at a toggle as :func:`solve`, which closes the
    branch followed from the assembly). With more than ``log2(MAX_MODES)`` dyads: True.
    """
    ok = np.zeros(q.shape[1:], bool)
    if 2 ** len(dyads) > MAX_MODES:
        return ~ok
    dep = list(lay.topo.dependent)
    for k in range(2 ** len(dyads)):
        modes = [1.0 if k >> j & 1 else -1.0 for j in range(len(dyads))]
        with np.errstate(all="ignore"):
            closed, _ = solve(lay, dyads, q, forward, sides=modes)
        ok |= np.all(np.isfinite(closed[dep]), axis=0)
    return ok
