"""The compiled loads stage: applied wrenches of gravity and the loads over a block of samples.

The numpy path is :func:`linkdyn.loads.wrenches` (a loop over the loads, each on whole
arrays); here one kernel helper per part, each a loop over the bodies (or the loads) and,
inside it, over the samples of a block, calling the same steps of :mod:`linkdyn.loads`
(``body_point``, ``force_at``, ``weight``, ``spring_force``, ``damper_force``):
:func:`weights` (gravity, which the fused sweep applies alone), :func:`applied` (gravity and
every load: the one dispatch over load kinds on the compiled backend) and :func:`run_program`,
which evaluates the load formulas as one flat program of op codes (:func:`linkdyn.expr.flatten`,
numpy's rules of :meth:`linkdyn.expr.Expr.evaluate`). :func:`table` builds a layout's loads
as the arrays these read, once per layout. The per-sample arrays are those of a block of the
kinematics kernel's scratch: ``c``, ``s`` (n, 1, block), ``r`` (n, 2, 1, block), ``tw``, ``w``
(n, 3, 1, block).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from .. import expr
from ..loads import body_point, damper_force, force_at, spring_force, weight
from ..planar import turned
from . import inline, inner, njit, screw_views, vector_views

#: the load kinds' codes in :data:`Table` (``kind``)
LOAD_KINDS = {"force": 0, "torque": 1, "joint_torque": 2, "joint_force": 3, "spring": 4,
              "damper": 5}
FORCE, TORQUE, JOINT_TORQUE, JOINT_FORCE, SPRING, DAMPER = range(6)

#: A layout's loads as the kernels read them (:func:`table`), per load (L,): ``kind``
#: (:data:`LOAD_KINDS`), ``body``, ``body2`` (tree indices; 0 where it has none), ``rate``
#: the row of its joint's rate among the program's variables (a load inside a joint);
#: ``number`` (L, 9): its point on ``body`` and on ``body2`` (each relative to O, body frame),
#: its axis (first body's frame), stiffness, free length, damping; ``roots`` (L, 2) the
#: program rows of its value (a force's two components); the formulas' program ``code``
#: (N, 4), ``value`` (N,) (:func:`linkdyn.expr.flatten`), whose variables are ``[t, q of each
#: model joint, qd of each, the values without a formula]``.
Table = namedtuple("Table", ("kind", "body", "body2", "rate", "number", "roots", "code",
                             "value"), module=__name__)


# --- the formulas: a register machine over op codes, a block of samples at a time ------------

@inline
def _apply(op, u, v, w):
    """The operator or function of op code ``op`` (:data:`linkdyn.expr.OPCODES`, from 2) of
    one sample's operands: numpy's rules (NaN outside a function's domain, a comparison 1 or
    0, NaN propagating through ``min``, ``max``, ``clip``)."""
    if op == 2:
        return u + v
    if op == 3:
        return u - v
    if op == 4:
        return u * v
    if op == 5:
        return u / v
    if op == 6:
        return u ** v
    if op == 7:
        return -u
    if op == 8:
        return math.sin(u)
    if op == 9:
        return math.cos(u)
    if op == 10:
        return math.tan(u)
    if op == 11:
        return math.exp(u)
    if op == 12:
        return math.log(u) if u >= 0 else math.nan
    if op == 13:
        return math.sqrt(u) if u >= 0 else math.nan
    if op == 14:
        return math.sinh(u)
    if op == 15:
        return math.cosh(u)
    if op == 16:
        return math.tanh(u)
    if op == 17:
        return math.asin(u) if abs(u) <= 1 else math.nan
    if op == 18:
        return math.acos(u) if abs(u) <= 1 else math.nan
    if op == 19:
        return math.atan(u)
    if op == 20:
        return abs(u)
    if op == 21:   # sign: NaN stays NaN
        return 1.0 if u > 0 else (-1.0 if u < 0 else (0.0 if u == 0 else u))
    if op == 22:   # min, max, clip: NaN propagates (np.minimum)
        return math.nan if v != v else (u if u != u or u <= v else v)
    if op == 23:
        return math.nan if v != v else (u if u != u or u >= v else v)
    if op == 24:
        m = math.nan if u != u or v != v else (u if u >= v else v)
        return math.nan if m != m or w != w else (m if m <= w else w)
    if op == 25:   # where(condition, a, b)
        return v if u != 0 else w
    if op == 26:
        return 1.0 if u < v else 0.0
    if op == 27:
        return 1.0 if u <= v else 0.0
    if op == 28:
        return 1.0 if u > v else 0.0
    return 1.0 if u >= v else 0.0


@njit
def run_program(code, value, x, reg, nb):
    """Evaluate a flattened program (:func:`linkdyn.expr.flatten`) at the variables ``x``
    (n_vars, block) of the samples ``0 .. nb``: ``reg[k]`` (block,) the value of row k
    (children first), as :meth:`linkdyn.expr.Expr.evaluate` gives it."""
    for k in range(code.shape[0]):
        op, out = code[k, 0], reg[k]
        if op == 0:                              # num
            for j in range(nb):
                out[j] = value[k]
        elif op == 1:                            # var: x[slot] / scale
            x_a = x[code[k, 1]]
            for j in range(nb):
                out[j] = x_a[j] / value[k]
        else:   # the operands' rows (an unused one: row 0, never read)
            u, v, w = reg[max(code[k, 1], 0)], reg[max(code[k, 2], 0)], reg[max(code[k, 3], 0)]
            for j in range(nb):
                out[j] = _apply(op, u[j], v[j], w[j])


# --- the wrenches ------------------------------------------------------------------------------

@inline
def _plus(w, k, x):
    """``w[k] += x`` for the views ``w`` of a wrench (:func:`~linkdyn.compiled.screw_views`)
    and a wrench tuple ``x``."""
    w[0][k] += x[0]
    w[1][k] += x[1]
    w[2][k] += x[2]


@inline
def _body(c, s, r, tw, i, nb):
    """Body i's cosine, sine, origin and twist over a block, as views."""
    ks = slice(0, nb)
    return c[i, 0, ks], s[i, 0, ks], vector_views(r, i, 0, ks), screw_views(tw, i, 0, ks)


@inline
def _point(B, k, p):
    """Sample k's position and velocity of the point ``p`` (body frame, from O) of a body whose
    views are ``B`` (:func:`_body`) (:func:`~linkdyn.loads.body_point`)."""
    c, s, r, t = B
    return body_point(c[k], s[k], (r[0][k], r[1][k]), (t[0][k], t[1][k], t[2][k]), p)


@inner
def weights(L, g, dp, nb, c, s, r, w, pe):
    """Every body's weight ``m_i g`` at its mass centre as a wrench about O_i
    (:func:`~linkdyn.loads.weight`, :func:`~linkdyn.loads.force_at`, as
    :func:`linkdyn.loads.wrenches` applies gravity) over one block, from the block's poses
    ``c``, ``s`` (n, 1, block), ``r`` (n, 2, 1, block), into ``w`` (n, 3, 1, block) (the
    bodies' rows set, the ground's left), its potential energy ``-m_i g . r_C`` added to ``pe``
    (block,); design ``dp`` of the mass centres and masses, the gravity ``g`` (2,)."""
    ks = slice(0, nb)
    for i in range(1, L.mass.shape[0]):
        mi, com_i = L.mass[i, dp], (L.com[i, 0, dp], L.com[i, 1, dp])
        c_i, s_i, (rx_i, ry_i) = c[i, 0, ks], s[i, 0, ks], vector_views(r, i, 0, ks)
        w_i = screw_views(w, i, 0, ks)
        for k in range(nb):
            a = turned(c_i[k], s_i[k], com_i)   # r_C = r_i + R com_i
            r_c = (rx_i[k] + a[0], ry_i[k] + a[1])
            f, pe_k = weight(mi, g, r_c)
            w_i[0][k], w_i[1][k], w_i[2][k] = force_at(f, (rx_i[k], ry_i[k]), r_c)
            pe[k] += pe_k


@inner
def applied(L, T, dp, nb, c, s, r, tw, x, reg, w, pe, power):
    """The applied wrenches ``w`` (n, 3, 1, block) about each O_i of gravity and the loads of
    the table ``T`` (:data:`Table`) over one block, as :func:`linkdyn.loads.wrenches`: their
    potential energy (gravity, springs) into ``pe`` and the power of the non-conservative loads
    into ``power`` (block,). The formulas' values by :func:`run_program` at the variables ``x``
    (n_vars, block), in ``reg`` (n_rows, block); design ``dp`` of the layout's view ``L``. The
    ground's row holds the loads on it (it enters no balance)."""
    ks = slice(0, nb)
    w[:, :, :, ks] = 0.0
    pe[ks], power[ks] = 0.0, 0.0
    g = (L.gravity[0, dp], L.gravity[1, dp])
    if g[0] != 0.0 or g[1] != 0.0:
        weights(L, g, dp, nb, c, s, r, w, pe)
    run_program(T.code, T.value, x, reg, nb)
    for m in range(T.kind.shape[0]):
        kind, i, j = T.kind[m], T.body[m], T.body2[m]
        p1, p2 = (T.number[m, 0], T.number[m, 1]), (T.number[m, 2], T.number[m, 3])
        a, b = _body(c, s, r, tw, i, nb), _body(c, s, r, tw, j, nb)
        w_i, w_j = screw_views(w, i, 0, ks), screw_views(w, j, 0, ks)
        X, Y, rate = reg[T.roots[m, 0]], reg[T.roots[m, 1]], x[T.rate[m]]
        if kind == FORCE:   # f at the point, its power f . v
            for k in range(nb):
                r_p, v_p = _point(a, k, p1)
                f = (X[k], Y[k])
                _plus(w_i, k, force_at(f, (a[2][0][k], a[2][1][k]), r_p))
                power[k] += f[0] * v_p[0] + f[1] * v_p[1]
        elif kind == TORQUE:   # its power n omega
            for k in range(nb):
                w_i[0][k] += X[k]
                power[k] += X[k] * a[3][0][k]
        elif kind == JOINT_TORQUE:   # x on the joint's second body, -x on its first
            for k in range(nb):
                w_i[0][k] += X[k]
                w_j[0][k] -= X[k]
                power[k] += X[k] * rate[k]
        elif kind == JOINT_FORCE:   # x e at the second body's point, -x e on the first
            axis = (T.number[m, 4], T.number[m, 5])
            for k in range(nb):
                r_p, _ = _point(a, k, p1)
                ex, ey = turned(b[0][k], b[1][k], axis)   # e = R_a axis
                _plus(w_i, k, force_at((X[k] * ex, X[k] * ey), (a[2][0][k], a[2][1][k]), r_p))
                _plus(w_j, k, force_at((-(X[k] * ex), -(X[k] * ey)), (b[2][0][k], b[2][1][k]),
                                       r_p))
                power[k] += X[k] * rate[k]
        else:   # a spring or damper between two points, along the line joining them
            for k in range(nb):
                r1, v1 = _point(a, k, p1)
                r2, v2 = _point(b, k, p2)
                if kind == SPRING:
                    f, pe_k, _ = spring_force(T.number[m, 6], T.number[m, 7], r1, r2)
                    pe[k] += pe_k
                else:
                    f, pw, _ = damper_force(T.number[m, 8], r1, v1, r2, v2)
                    power[k] += pw
                _plus(w_i, k, force_at(f, (a[2][0][k], a[2][1][k]), r1))
                _plus(w_j, k, force_at((-f[0], -f[1]), (b[2][0][k], b[2][1][k]), r2))


# --- the layout's loads as the kernels' arrays -------------------------------------------------

def table(lay, n_joints: int) -> tuple[Table, list]:
    """The loads of layout ``lay`` (one design) as a :data:`Table`, and the loads' values that
    are functions of time without a formula, ``[(load, component), ...]``: the caller evaluates
    them and passes them as the program's last variables."""
    slots = {"t": (0, 1.0)}
    rows, nums, formulas, external = [], [], [], []
    for m, row in enumerate(lay.loads):
        f = row.values[0]
        comps = getattr(f, "components", None)
        slots.update({name: (1 + k * n_joints + joint, unit)
                      for name, joint, k, unit in getattr(f, "state", ())})
        count = 2 if row.kind == "force" else 1
        if row.kind in ("spring", "damper"):   # no value: their constants
            parts = [0.0]
        elif comps is not None and all(isinstance(x, (expr.Expr, float, int)) for x in comps):
            parts = list(comps)
        else:   # an opaque function of time: its values come as variables
            parts = []
            for k in range(count):
                name = f"__ext{len(external)}"
                slots[name] = (1 + 2 * n_joints + len(external), 1.0)
                external.append((m, k))
                parts.append(expr.Expr("var", (name,)))
        roots = list(range(len(formulas), len(formulas) + len(parts)))
        formulas.extend(parts)
        p1 = lay.points[row.body][row.point] if row.point else np.zeros(2)
        p2 = lay.points[row.body2][row.point2] if row.point2 else np.zeros(2)
        axis = np.zeros(2) if row.axis is None else row.axis
        rows.append([LOAD_KINDS[row.kind], row.body, max(row.body2, 0),
                     1 + n_joints + max(row.joint, 0), roots[0], roots[-1]])
        nums.append([*p1, *p2, *axis, float(row.stiffness), float(row.free_length),
                     float(row.damping)])
    code, value, at = expr.flatten(formulas, slots) if formulas else (
        np.zeros((0, 4), np.int64), np.zeros(0), np.zeros(0, np.int64))
    ints = np.array(rows, np.int64).reshape(-1, 6)
    roots = at[ints[:, 4:6]] if len(rows) else np.zeros((0, 2), np.int64)
    out = Table(*(np.ascontiguousarray(ints[:, k]) for k in range(4)),
                np.array(nums, float).reshape(-1, 9), np.ascontiguousarray(roots, np.int64),
                np.ascontiguousarray(code, np.int64), np.ascontiguousarray(value, float))
    return out, external
