"""Closed-form position analysis of loops that are RRR dyads.

A loop closed at a revolute cut joint whose only unknown joints are two revolute joints, once
the loops solved before it are known, is an RRR dyad: a triangle with two known vertices and
two known side lengths. Its third vertex is the intersection of two circles, on the side of the
line through the known vertices where the current guess lies (the assembly branch). The two
unknown joint angles then follow as the rotations that carry the guess onto the solution.

Two shapes occur along the spanning tree:

- *split*: one unknown joint on each side of the cut. Known vertices: the two joints; the
  third vertex: the cut point.
- *chain*: both unknown joints on the same side. Known vertices: the upper joint and the cut
  point on the other side; the third vertex: the lower joint.

:func:`plan` orders the loops so each dyad only needs joints already solved; a mechanism that
does not decompose this way (prismatic loops, Stephenson-type coupled loops) has no plan and
uses Newton's method instead.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import joints as jk
from ..planar import cross, dot, perp, rotate_cs


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


def _side(c1, c2, x):
    """+1 where x lies left of the line c1 -> c2, -1 where right."""
    return np.where(cross(c2 - c1, x - c1) >= 0, 1.0, -1.0)


def _circles(c1, r1, c2, r2, side):
    """Intersection of circles (c1, r1) and (c2, r2) on the ``side`` (+1 left, -1 right) of the
    line c1 -> c2; NaN where they do not meet. Points (2, ...), radii and side (...)."""
    d_vec = c2 - c1
    d = np.sqrt(dot(d_vec, d_vec))
    ex = d_vec / d
    a = (r1 ** 2 - r2 ** 2 + d ** 2) / (2 * d)
    h2 = r1 ** 2 - a ** 2
    # at a toggle the triangle is flat (h = 0): rounding must not turn it into "cannot close"
    h2 = np.where((h2 < 0) & (h2 > -1e-12 * r1 ** 2), 0.0, h2)
    with np.errstate(invalid="ignore"):
        h = np.sqrt(np.where(h2 >= 0, h2, np.nan))
    return c1 + a * ex + side * h * perp(ex)


def _turn(u, v):
    """The rotation that carries direction u onto direction v: its angle in (-pi, pi], its
    cosine and its sine, each (...)."""
    x, y = dot(u, v), cross(u, v)
    norm = np.sqrt(x * x + y * y)
    return np.arctan2(y, x), x / norm, y / norm


def _rotate_subtree(lay, pose, root, centre, turn):
    """Rotate body ``root`` and every body beyond it about ``centre`` (2, ...) in place."""
    angle, c, s = turn
    for j in range(1, lay.topo.n):
        if lay.topo.ancestors[j, root]:
            pose.phi[j] = pose.phi[j] + angle
            pose.c[j], pose.s[j] = c * pose.c[j] - s * pose.s[j], s * pose.c[j] + c * pose.s[j]
            pose.r[j] = centre + rotate_cs(c, s, pose.r[j] - centre)
            if pose.e[j] is not None:
                pose.e[j] = rotate_cs(c, s, pose.e[j])


def _vertices(lay, dy, pose):
    """Known vertices c1, c2, the apex guess and the moving points of one dyad."""
    c = lay.cuts[dy.cut]
    p_a, p_b = pose.point(c.a, c.pa), pose.point(c.b, c.pb)
    x1, x2 = pose.r[dy.upper], pose.r[dy.lower]
    if dy.shape == "split":
        return x1, x2, p_a, p_a, p_b   # apex: the cut point over the two joints
    p_mov, p_fix = (p_a, p_b) if dy.side == "a" else (p_b, p_a)
    return x1, p_fix, x2, p_mov, p_fix  # apex: the lower joint over the upper joint and cut


def _slide(lay, dy, pose):
    """Geometry of an RRP dyad (a slider cut with both unknown joints on one side ``dy.side``).

    The body on the moving side that carries the cut point must end at a known angle (the
    other body's plus the joint's ``angle``), so the whole subtree below the lower joint turns
    by a known ``total`` turn; the lower joint then lies on the slide line shifted back by the
    turned offset from it to the cut point. Returns ``x1``, ``x2`` (the joints), the shifted
    line (point, unit direction) and ``total`` (angle, cosine, sine).
    """
    c = lay.cuts[dy.cut]
    x1, x2 = pose.r[dy.upper], pose.r[dy.lower]
    cos_a, sin_a = np.cos(c.angle), np.sin(c.angle)
    if dy.side == "b":   # the slider body b moves; the line is fixed in body a
        mov, fix, p_mov, sign = c.b, c.a, pose.point(c.b, c.pb), 1.0
        p0, e = pose.point(c.a, c.pa), pose.rotate(c.a, c.axis)
    else:                # body a, which carries the line, moves; the slider point is fixed
        mov, fix, p_mov, sign = c.a, c.b, pose.point(c.a, c.pa), -1.0
        p0, e = pose.point(c.b, c.pb), None
    # target angle of the moving body: phi_fix +- angle, as a cosine and a sine
    ct = pose.c[fix] * cos_a - sign * pose.s[fix] * sin_a
    st = pose.s[fix] * cos_a + sign * pose.c[fix] * sin_a
    cd, sd = ct * pose.c[mov] + st * pose.s[mov], st * pose.c[mov] - ct * pose.s[mov]
    total = (np.arctan2(sd, cd), cd, sd)
    if e is None:
        e = rotate_cs(cd, sd, pose.rotate(c.a, c.axis))
    return x1, x2, p0 - rotate_cs(cd, sd, p_mov - x2), e, total


def _swing(lay, dy, pose):
    """Geometry of an RPR dyad: a slider cut whose line body a turns about the unknown joint
    ``x_a`` and whose slider body b about ``x_b``. Body b must turn by ``delta`` more than body a
    (to keep their angle); then the slider point stays on the line when
    ``A cos(theta) + B sin(theta) = k`` for body a's turn ``theta``. Returns
    ``x_a, x_b, (A, B, k), delta (angle, cos, sin)``."""
    c = lay.cuts[dy.cut]
    x_a, x_b = pose.r[dy.upper], pose.r[dy.lower]
    # delta = angle - (phi_b - phi_a), from the cosines and sines
    cr = pose.c[c.b] * pose.c[c.a] + pose.s[c.b] * pose.s[c.a]
    sr = pose.s[c.b] * pose.c[c.a] - pose.c[c.b] * pose.s[c.a]
    cd, sd = np.cos(c.angle) * cr + np.sin(c.angle) * sr, np.sin(c.angle) * cr - np.cos(c.angle) * sr
    n = perp(pose.rotate(c.a, c.axis))
    d = x_b - x_a
    k = dot(pose.point(c.a, c.pa) - x_a - rotate_cs(cd, sd, pose.point(c.b, c.pb) - x_b), n)
    return x_a, x_b, (dot(d, n), dot(d, perp(n)), k), (np.arctan2(sd, cd), cd, sd)


def _on_line(c, r, p0, e, side):
    """Intersection of circle (c, r) with the line p0 + s e on the ``side`` (+1: ahead along e
    of the foot of c, -1: behind); NaN where they do not meet."""
    foot = p0 + dot(c - p0, e) * e
    d = c - foot
    h2 = r ** 2 - dot(d, d)
    h2 = np.where((h2 < 0) & (h2 > -1e-12 * r ** 2), 0.0, h2)
    with np.errstate(invalid="ignore"):
        return foot + side * np.sqrt(np.where(h2 >= 0, h2, np.nan)) * e


def _mode(lay, dy, pose):
    """Assembly mode of one dyad in ``pose``: +1 or -1, shape (...)."""
    if dy.shape == "slide":
        x1, x2, p0, e, _ = _slide(lay, dy, pose)
        return np.where(dot(x2 - (p0 + dot(x1 - p0, e) * e), e) >= 0, 1.0, -1.0)
    if dy.shape == "swing":  # which root of A cos + B sin = k the pose sits on (theta = 0)
        _, _, (a, b, _), _ = _swing(lay, dy, pose)
        return np.where(b <= 0, 1.0, -1.0)
    c1, c2, apex, _, _ = _vertices(lay, dy, pose)
    return _side(c1, c2, apex)


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
        if dy.shape == "slide":
            # the lower joint m on the shifted slide line, at the link length from the upper
            x1, x2, p0, e, total = _slide(lay, dy, pose)
            m = _on_line(x1, np.sqrt(dot(x2 - x1, x2 - x1)), p0, e, side)
            up = _turn(x2 - x1, m - x1)
            _rotate_subtree(lay, pose, dy.upper, x1, up)
            # the lower joint supplies the rest of the known total turn
            c2, s2 = total[1] * up[1] + total[2] * up[2], total[2] * up[1] - total[1] * up[2]
            low = (np.arctan2(s2, c2), c2, s2)
            _rotate_subtree(lay, pose, dy.lower, m, low)
            q[dy.upper] += topo.sign[dy.upper] * up[0]
            q[dy.lower] += topo.sign[dy.lower] * low[0]
            continue
        if dy.shape == "swing":
            # body a turns by theta = psi + mode acos(k / |(A, B)|), body b by theta + delta
            x_a, x_b, (a, b, k_), delta = _swing(lay, dy, pose)
            norm = np.sqrt(a * a + b * b)
            ratio = k_ / norm
            ratio = np.where((np.abs(ratio) > 1) & (np.abs(ratio) < 1 + 1e-12), np.sign(ratio), ratio)
            with np.errstate(invalid="ignore"):
                theta = np.arctan2(b, a) + side * np.arccos(np.where(np.abs(ratio) <= 1, ratio, np.nan))
            theta = np.arctan2(np.sin(theta), np.cos(theta))
            up = (theta, np.cos(theta), np.sin(theta))
            low = (theta + delta[0], up[1] * delta[1] - up[2] * delta[2],
                   up[2] * delta[1] + up[1] * delta[2])
            _rotate_subtree(lay, pose, dy.upper, x_a, up)
            _rotate_subtree(lay, pose, dy.lower, x_b, low)
            q[dy.upper] += topo.sign[dy.upper] * up[0]
            q[dy.lower] += topo.sign[dy.lower] * low[0]
            continue
        x1, c2, apex, p_a_or_mov, p_b_or_fix = _vertices(lay, dy, pose)
        if dy.shape == "split":
            # the cut point m over the two unknown joints x1 and x2 = c2
            p_up, p_low = p_a_or_mov, p_b_or_fix
            m = _circles(x1, np.sqrt(dot(p_up - x1, p_up - x1)), c2,
                         np.sqrt(dot(p_low - c2, p_low - c2)), side)
            up, low = _turn(p_up - x1, m - x1), _turn(p_low - c2, m - c2)
            _rotate_subtree(lay, pose, dy.upper, x1, up)
            _rotate_subtree(lay, pose, dy.lower, c2, low)
        else:
            # the lower joint m over the upper joint x1 and the fixed cut point p_fix = c2
            x2, p_mov, p_fix = apex, p_a_or_mov, p_b_or_fix
            m = _circles(x1, np.sqrt(dot(x2 - x1, x2 - x1)), p_fix,
                         np.sqrt(dot(p_mov - x2, p_mov - x2)), side)
            up = _turn(x2 - x1, m - x1)
            _rotate_subtree(lay, pose, dy.upper, x1, up)
            p_mov = pose.point(*((lay.cuts[dy.cut].a, lay.cuts[dy.cut].pa) if dy.side == "a"
                                 else (lay.cuts[dy.cut].b, lay.cuts[dy.cut].pb)))
            low = _turn(p_mov - m, p_fix - m)
            _rotate_subtree(lay, pose, dy.lower, m, low)
        # q_i = s (phi_i - phi_parent): the turns are the changes of the two joint angles
        q[dy.upper] += topo.sign[dy.upper] * up[0]
        q[dy.lower] += topo.sign[dy.lower] * low[0]
    return q, pose
