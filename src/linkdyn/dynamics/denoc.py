"""Recursive inverse dynamics with the DeNOC matrices (seed paper, eqs. 8-27).

For each body, the uncoupled Newton–Euler wrench about O_i (eq. 10)

    w_star_i = M_i td_i + W_i M_i E_i t_i - w_ext_i,

is reduced by the DeNOC matrices without forming them: the backward recursion

    w_tilde_i = w_star_i + sum_{children c} A(r_c - r_i)^T w_tilde_c

gives ``N_l^T w_star`` body by body, and ``N_d^T`` picks ``Q_i = p_i . w_tilde_i``, the
generalized force needed at tree joint i. With the cut-joint multipliers ``lam`` (eqs. 16-24)
and the driver efforts ``tau`` (eqs. 25-26), eq. (27) reads ``Q = J^T lam + D tau``; its rows
at the dependent joints give ``J_dep^T lam = Q_dep`` and the driven rows then give
``tau = Q_drv - J_drv^T lam`` (:func:`less_cut`, cut by cut).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable

import numpy as np

from ..brief import brief_repr

from ..kinematics import KinematicSolution
from ..kinematics.recursion import _axis, relative
from ..loads import Loads
from .. import joints as jk
from ..planar import about, at, cross, dot, last, solve_small, stack_last, turned
from ..steps import step


@dataclass(frozen=True)
class DynamicSolution:
    """Driver efforts, cut-joint multipliers and the reduced quantities behind them.

    Attributes
    ----------
    lam : ndarray (T, n_rows)
        Cut-joint multipliers, each cut's kind's rows in turn (``topo.rows``): revolute
        ``[Fx, Fy]`` by the first body on the second (N); prismatic ``[M, F_n]`` (N m about the
        second body's point; N along the axis normal); slot ``[F_n]`` (N along the slot normal).
    tau : ndarray (T, n_drivers)
        Driver efforts in the order of ``model.drivers``, N m or N.
    kinetic_energy : ndarray (T,)
        J.
    pivot : ndarray (T,)
        Smallest relative pivot of ``J_dep^T`` (~0 at a singular position).
    internals : tuple or callable
        ``(wstar, wtilde, Q)``, or a function returning them when one is first read (the
        compiled backend keeps no per-sample copy of them unless asked: its kernel then runs
        again, keeping them).
    wstar : list of ndarray (3, T)
        Uncoupled Newton–Euler wrench of each body about O_i minus applied loads, tree order.
    wtilde : list of ndarray (3, T)
        Composite wrench of each body's subtree about O_i (``N_l^T w_star``).
    Q : ndarray (T, n)
        Generalized force at each tree joint (``N^T w_star``), N m or N, tree order (column 0,
        the ground, is zero).
    """

    __repr__ = brief_repr   # shapes, not every number (linkdyn.brief)

    lam: np.ndarray
    tau: np.ndarray
    kinetic_energy: np.ndarray
    pivot: np.ndarray
    internals: tuple | Callable = field(repr=False, compare=False)

    @cached_property
    def _internals(self) -> tuple:
        return self.internals() if callable(self.internals) else self.internals

    @property
    def wstar(self) -> list:
        return self._internals[0]

    @property
    def wtilde(self) -> list:
        return self._internals[1]

    @property
    def Q(self) -> np.ndarray:
        return self._internals[2]

    @property
    def w_star(self) -> np.ndarray:
        """``w_star`` stacked components last, (T, n, 3)."""
        return stack_last(self.wstar)

    @property
    def w_tilde(self) -> np.ndarray:
        """``w_tilde`` stacked components last, (T, n, 3)."""
        return stack_last(self.wtilde)


# --- the steps: each equation once, for both backends (linkdyn.steps) ------------------------

@step
def newton_euler_wrench(mass, inertia, com, c, s, t, td, w_ext):
    """Uncoupled Newton–Euler wrench ``w_star_i`` of one body about O_i, and its kinetic energy.

    Parameters
    ----------
    mass, inertia : float or array
        ``m`` (kg) and the moment of inertia about the mass centre ``I_C`` (kg m^2).
    com : (x, y)
        Mass centre from O_i in the body's frame, m.
    c, s : float or array
        Cosine and sine of the body's angle.
    t, td : (w, vx, vy)
        Twist and twist rate of the body at O_i (rad/s, m/s; rad/s^2, m/s^2).
    w_ext : (n, fx, fy)
        Applied wrench about O_i, N m / N.

    Returns
    -------
    w_star : (n, fx, fy)
        ``M_i td_i + W_i M_i E_i t_i - w_ext_i`` about O_i, N m / N.
    ke : float or array
        ``1/2 m |v_C|^2 + 1/2 I_C w^2``, J.
    """
    # d = R com;  n = I_O al + m d x a_O,  f = m (a_O + al perp(d) - w^2 d),  minus w_ext
    d = turned(c, s, com)
    w2 = t[0] * t[0]
    i_o = inertia + mass * dot(d, d)
    n = (i_o * td[0] + mass * cross(d, (td[1], td[2]))) - w_ext[0]
    fx = mass * (td[1] - td[0] * d[1] - w2 * d[0]) - w_ext[1]
    fy = mass * (td[2] + td[0] * d[0] - w2 * d[1]) - w_ext[2]
    # kinetic energy with the mass centre's velocity v_C = v_O + w perp(d)
    v_c = at(t, d)
    return (n, fx, fy), 0.5 * mass * (v_c[1] * v_c[1] + v_c[2] * v_c[2]) + 0.5 * inertia * w2


@step
def plus_child(w_parent, w_child, r_child, r_parent):
    """``w_p + A(r_i - r_p)^T w_i``: a child's wrench about O_i added to its parent's about O_p
    (one term of the backward recursion of ``N_l^T``)."""
    m = about(w_child, relative(r_parent, r_child))
    return (w_parent[0] + m[0], w_parent[1] + m[1], w_parent[2] + m[2])


@step
def generalized_force(code, s, e, w_tilde):
    """``Q_i = p_i . w_tilde_i``: the force the tree joint i of kind ``code`` (sign ``s``, global
    axis ``e``) must carry, N m or N (``N_d^T``; every component multiplied, so a NaN spreads)."""
    return dot(jk.motion(code, s, e), w_tilde)


@step
def less_cut(tau, j, lam):
    """``tau - j . lam``: one cut joint's share taken off a driver's effort, the cut's rows of
    ``tau = Q_drv - J_drv^T lam`` (eq. 27); ``j`` the driven joint's Jacobian entries in the
    cut's rows and ``lam`` its multipliers, each padded with zeros to three."""
    return tau - (j[0] * lam[0] + j[1] * lam[1] + j[2] * lam[2])


def padded(x, rows: slice) -> tuple:
    """The rows ``rows`` of ``x`` (n_rows, ...) padded with zeros to three: one cut joint's
    entries as the steps take them."""
    own = tuple(x[rows])
    return own + (0.0,) * (3 - len(own))


# --- the numpy path: the steps on whole arrays, a loop over bodies ----------------------------

def _array(parts, *like) -> np.ndarray:
    """A component-first array (k, ...) from a step's tuple, broadcast with the arrays ``like``
    (a constant component takes the batch shape)."""
    shape = np.broadcast_shapes(*(np.shape(x) for x in tuple(parts) + like))
    out = np.empty((len(parts),) + shape)
    for k, x in enumerate(parts):
        out[k] = x
    return out


def newton_euler(kin: KinematicSolution, w_ext: list):
    """Uncoupled Newton–Euler wrenches ``w_star_i`` (3, T) and the kinetic energy (T,), by
    :func:`newton_euler_wrench` body by body."""
    lay, pose = kin.layout, kin.pose
    w_star = [np.zeros((3,) + kin.shape)]   # the ground's (w_ext[0] may be a broadcast zero)
    ke = np.zeros(kin.shape)
    for i in range(1, lay.topo.n):
        w, ke_i = newton_euler_wrench(lay.mass[i], lay.inertia[i], lay.com[i], pose.c[i],
                                      pose.s[i], kin.twists[i], kin.rates[i], w_ext[i])
        w_star.append(_array(w, pose.c[i]))
        ke = ke + ke_i
    return w_star, ke


def composite(kin: KinematicSolution, w: list) -> list:
    """Backward recursion ``w_tilde_i = w_i + sum_c A(r_c - r_i)^T w_tilde_c``, (3, T) each, by
    :func:`plus_child` from the leaves; ``w``: per body a (3, T) array or a tuple of its
    components."""
    topo, r = kin.layout.topo, kin.pose.r
    out = list(w)
    for i in range(topo.n - 1, 0, -1):
        k = topo.parent[i]
        out[k] = plus_child(out[k], out[i], r[i], r[k])
    like = np.zeros(kin.shape)
    return [x if isinstance(x, np.ndarray) else _array(x, like) for x in out]


def reduce(kin: KinematicSolution, w_star: list) -> tuple[list, np.ndarray]:
    """``w_tilde`` (3, T) per body and the generalized forces ``Q`` (n, T) of ``w_star``."""
    # N_l^T w_star by the backward recursion, then N_d^T: Q_i = p_i . w_tilde_i
    lay, pose = kin.layout, kin.pose
    w_tilde = composite(kin, w_star)
    Q = np.zeros((lay.topo.n,) + kin.shape)
    for i in range(1, lay.topo.n):
        Q[i] = generalized_force(jk.CODES[lay.kind[i]], lay.topo.sign[i], _axis(pose.e[i]),
                                 w_tilde[i])
    return w_tilde, Q


def solve(kin: KinematicSolution, loads: Loads) -> DynamicSolution:
    """Driver efforts and cut-joint multipliers of the motion ``kin`` under ``loads``."""
    topo = kin.layout.topo
    dep, drv = np.array(topo.dependent, int), np.array(topo.driven, int)
    w_star, ke = newton_euler(kin, loads.wrenches)
    w_tilde, Q = reduce(kin, w_star)
    # eq. (27): J_dep^T lam = Q_dep, then tau = Q_drv - J_drv^T lam
    J = kin.jacobian
    if len(dep):
        lam, pivot = solve_small(np.swapaxes(J[:, dep - 1], 0, 1), Q[dep])
    else:
        lam, pivot = np.zeros((0,) + kin.shape), np.ones(kin.shape)
    # tau_j = Q_j less each cut's share J_cj^T lam_c
    tau = np.zeros((len(drv),) + kin.shape)
    for k, i in enumerate(drv):
        tau_k = Q[i]
        for c in range(topo.n_loops):
            rows = topo.row_slice(c)
            tau_k = less_cut(tau_k, padded(J[:, i - 1], rows), padded(lam, rows))
        tau[k] = tau_k
    return DynamicSolution(last(lam), last(tau), ke, pivot, (w_star, w_tilde, last(Q)))
