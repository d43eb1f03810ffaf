"""Recursive inverse dynamics with the DeNOC matrices (seed paper, eqs. 8-27).

For each body, the uncoupled Newton–Euler wrench about O_i (eq. 10)

    w_star_i = M_i td_i + W_i M_i E_i t_i - w_ext_i,

is reduced by the DeNOC matrices without forming them: the backward recursion

    w_tilde_i = w_star_i + sum_{children c} A(r_c - r_i)^T w_tilde_c

gives ``N_l^T w_star`` body by body, and ``N_d^T`` picks ``Q_i = p_i . w_tilde_i``, the
generalized force needed at tree joint i. With the cut-joint multipliers ``lam`` (eqs. 16-24)
and the driver efforts ``tau`` (eqs. 25-26), eq. (27) reads ``Q = J^T lam + D tau``; its rows
at the dependent joints give ``J_dep^T lam = Q_dep`` and the driven rows then give
``tau = Q_drv - J_drv^T lam``.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property
from typing import Callable

import numpy as np

from ..kinematics import KinematicSolution
from ..loads import Loads
from ..planar import cross, dot, last, perp, shift_wrench, solve_small, stack_last, twist


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
        compiled backend keeps no per-sample copy of them unless asked: they are then
        computed by the numpy recursion of this module).
    wstar : list of ndarray (3, T)
        Uncoupled Newton–Euler wrench of each body about O_i minus applied loads, tree order.
    wtilde : list of ndarray (3, T)
        Composite wrench of each body's subtree about O_i (``N_l^T w_star``).
    Q : ndarray (T, n)
        Generalized force at each tree joint (``N^T w_star``), N m or N, tree order (column 0,
        the ground, is zero).
    """

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


def newton_euler(kin: KinematicSolution, w_ext: list):
    """Uncoupled Newton–Euler wrenches ``w_star_i`` (3, T) and the kinetic energy (T,).

    About O_i with ``d`` the vector from O_i to the mass centre (eq. 10, planar):
    ``n = I_O al + m d x a_O``, ``f = m (a_O + al perp(d) - w^2 d)``.
    """
    lay = kin.layout
    w_star = [np.zeros((3,) + kin.shape)]   # the ground's (w_ext[0] may be a broadcast zero)
    ke = np.zeros(kin.shape)
    for i in range(1, lay.topo.n):
        m = lay.mass[i]
        d = kin.pose.rotate(i, lay.com[i])
        (w, v), (al, a) = (kin.twists[i][0], kin.twists[i][1:]), (kin.rates[i][0], kin.rates[i][1:])
        i_o = lay.inertia[i] + m * dot(d, d)
        # M_i td_i + W_i M_i E_i t_i - w_ext_i
        w_star.append(twist(i_o * al + m * cross(d, a), m * (a + al * perp(d) - w ** 2 * d))
                      - w_ext[i])
        # kinetic energy: 1/2 m |v_C|^2 + 1/2 I_C w^2
        v_c = v + w * perp(d)
        ke += 0.5 * m * dot(v_c, v_c) + 0.5 * lay.inertia[i] * w ** 2
    return w_star, ke


def composite(kin: KinematicSolution, w: list) -> list:
    """Backward recursion ``w_tilde_i = w_i + sum_c A(r_c - r_i)^T w_tilde_c``, (3, T) each."""
    topo, r = kin.layout.topo, kin.pose.r
    out = list(w)
    for i in range(topo.n - 1, 0, -1):
        k = topo.parent[i]
        out[k] = out[k] + shift_wrench(out[i], r[i] - r[k])
    return out


def reduce(kin: KinematicSolution, w_star: list) -> tuple[list, np.ndarray]:
    """``w_tilde`` (3, T) per body and the generalized forces ``Q`` (n, T) of ``w_star``."""
    # N_l^T w_star by the backward recursion, then N_d^T: Q_i = p_i . w_tilde_i
    w_tilde = composite(kin, w_star)
    Q = np.stack([np.zeros(kin.shape)] + [dot(kin.motion[i], w_tilde[i])
                                            for i in range(1, kin.layout.topo.n)])
    return w_tilde, Q


def internals(kin: KinematicSolution, loads: Loads) -> tuple:
    """``(w_star, w_tilde, Q)`` of the motion ``kin`` under ``loads``, as
    :attr:`DynamicSolution.internals`."""
    w_star, _ = newton_euler(kin, loads.wrenches)
    w_tilde, Q = reduce(kin, w_star)
    return w_star, w_tilde, last(Q)


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
    tau = Q[drv] - np.einsum("ij...,i...->j...", J[:, drv - 1], lam)
    return DynamicSolution(last(lam), last(tau), ke, pivot, (w_star, w_tilde, last(Q)))
