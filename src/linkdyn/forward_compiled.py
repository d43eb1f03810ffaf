"""The compiled right-hand side of :func:`linkdyn.simulate` (docs/theory.md, F2-F8): the
compiled backend's stages run on a block of one state.

:func:`rhs_kernel` evaluates ``y' = F(t, y)`` at one state with the block helpers the batch
kernels run (each a loop over the bodies or cuts and, inside it, over a block's samples; here
a block of one): Newton's method closing the loops from the extrapolated guess
(:func:`linkdyn.kinematics.compiled.newton`, F2), the closure Jacobian, the rates and the
twists (:mod:`linkdyn.kinematics.compiled`), the joints' motion, the applied loads with their
formulas (:func:`linkdyn.compiled.loads.applied`), then, for ``qdd_f = 0`` and for each unit
free acceleration, the accelerations (twist rates, bias, ``J_dep qdd_dep = -b``) and the DeNOC
inverse dynamics (:mod:`linkdyn.dynamics.compiled`: Newton–Euler, the backward recursion,
``Q``, ``J_dep^T lam = Q_dep``, the efforts; F3-F5). What is its own: the guess, the
acceleration cases, ``H qdd_f = -h`` (F6) and the power balance (F7-F8). It reads the layout
through the kernels' one view (:attr:`linkdyn.kinematics.layout.Layout.view`), its loads
through :func:`linkdyn.compiled.loads.table`, and writes into work arrays allocated once per
run (:func:`work`).

Where Newton's method from the guess does not close the loops, the kernel says so and the
caller evaluates that state by the numpy path (whose damped restart takes over).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numpy as np

from .analysis import SINGULAR
from .compiled import factor, njit, substitute
from .compiled.loads import applied, table
from .dynamics import compiled as dc
from .kinematics import compiled as kc
from .kinematics.positions import ACCEPT, driver_values

try:  # optional: the numpy path is complete without it
    from numba.core import types as nbtypes
    from numba.experimental import structref
except ImportError:  # pragma: no cover - depends on the environment
    structref = None

if structref is not None:
    @structref.register
    class HeldType(nbtypes.StructRef):
        """numba's type of :class:`Held`: one field, ``item``."""

        def preprocess_fields(self, fields):
            return tuple((name, nbtypes.unliteral(t)) for name, t in fields)

    class Held(structref.StructRefProxy):
        """The arguments :func:`rhs_kernel` takes at every call, in one object (``item``, read
        by compiled code only): a call unboxes it, not each of its seventy arrays. A numba
        ``StructRef``: its code compiles in a few seconds, a typed ``List`` of the same item
        in about forty."""

    structref.define_constructor(Held, HeldType, ["item"])
    structref.define_boxing(HeldType, Held)

#: The work arrays of :func:`rhs_kernel`, shaped as the batch kernels' for a block of one
#: sample (design axis 1, block 1; :func:`work`): the kinematics' ``q``, ``phi``, ``c``, ``s``,
#: ``qd``, ``qdd`` (n, 1, 1), ``r``, ``e`` (n, 2, 1, 1), ``tw``, ``td`` (n, 3, 1, 1), ``J``
#: (n_rows, n - 1, 1, 1), ``cut`` (n_cut, 3, 1, 1), ``err`` (1, 1), its scratch ``tmp``
#: (:func:`linkdyn.kinematics.compiled.scratch`), the independent rates ``qd_ind`` (k, 1, 1);
#: the loads' variables ``x`` (n_vars, 1), their program's rows ``reg`` (N, 1), ``pe``,
#: ``power`` (1,), the applied wrenches ``w``; the dynamics' ``wstar``, ``wtilde`` (n, 3, 1,
#: 1), ``Q`` (n, 1, 1), ``A`` (m, m + 1, 1), ``lam`` (m, 1), ``ke``, ``piv`` (1,), ``lam_b``
#: (n_rows, 1, 1), ``tau_b`` (k, 1, 1), ``pivot`` (1, 1); each case's ``qdd_c`` (1 + nf, n)
#: and efforts ``tau`` (k, 1 + nf) (then, in the unit cases' rows, the responses per unit
#: free acceleration).
Work = namedtuple("Work", (
    "q", "phi", "c", "s", "r", "e", "J", "qd", "qdd", "tw", "td", "cut", "err", "tmp", "qd_ind",
    "x", "reg", "pe", "power", "w", "wstar", "wtilde", "Q", "A", "lam", "ke", "piv", "lam_b",
    "tau_b", "pivot", "qdd_c", "tau"), module=__name__)


@njit
def rhs_kernel(held, t0, t, y, drv, ext, ref, S, unit, o_y, o_state, o_J, o_e):
    """``y' = F(t, y)`` (F7) at one state, ``y = [q_f, qd_f, W]``.

    Parameters
    ----------
    held : Held
        Its ``item``, ``(L, T, W)``: the partition's layout as the kernels read it
        (:attr:`.kinematics.layout.Layout.view`, one design; ``L.driven`` the independent tree
        bodies, drivers' then free, ``L.dependent`` the dependent ones), its loads
        (:data:`linkdyn.compiled.loads.Table`) and the work arrays (:data:`Work`), held in
        one object so that a call passes it, not their seventy arrays (:class:`Kernel`).
    t, y : float, (2 nf + 1,)
        The state.
    drv : float (3, nd)
        The drivers' coordinates, rates and accelerations at ``t``.
    ext : float (E,)
        Values of the loads that are functions of time only, at ``t``, where they have no
        formula.
    t0 : float
        The reference state's time.
    ref : float (3, n)
        The reference state's tree coordinates, rates and accelerations at ``t0``; ``S``
        (m, k) the dependent coordinates' share of the independent ones there (0 x 0: none).
    unit : float (nf,)
        The size of each unit free acceleration of F5, ``s_k`` (:func:`linkdyn.forward.unit_scale`:
        1, or a power of two near a large ``|qdd_f|``), rad/s^2 or m/s^2.
    o_y : float (2 nf + 1,)
        ``y'``; ``o_state`` (3, n) the tree coordinates, rates and accelerations; ``o_J``
        (n_rows, n - 1) the closure Jacobian; ``o_e`` (2,) the kinetic and potential energy.

    Returns
    -------
    int
        0: done (``y'`` NaN where the state is singular); 1: Newton's method from the guess
        did not close the loops (the state's outputs not written: the caller takes the numpy
        path).
    """
    L, T, W = held.item
    ind, dep, drivers = L.driven, L.dependent, L.tree_joint
    n, m, k_ind, nc = L.parent.shape[0], dep.shape[0], ind.shape[0], L.cut_a.shape[0]
    nd = drv.shape[1]
    nf = k_ind - nd
    nj = n - 1 + nc   # the model's joints: every one is a tree joint or a cut joint
    # the block of one: design 0, sample 0 (int64, so that the helpers' compilations for the
    # batch kernels serve here too)
    z, one = np.int64(0), np.int64(1)
    ks = slice(0, 1)
    cq, sq, _, _, rhs, P, A, sol, col, perm, _ = W.tmp
    q, qd, qdd = W.q[:, 0, 0], W.qd[:, 0, 0], W.qdd[:, 0, 0]
    # the guess: the reference extrapolated, its dependent rows moved by their share of the
    # independent coordinates' deviation from the extrapolation                     (F2)
    dt = t - t0
    for i in range(n):
        q[i] = ref[0, i] + ref[1, i] * dt + 0.5 * ref[2, i] * dt ** 2
    q_ind = W.qd_ind[:, 0, 0]   # the independent coordinates, for now
    for j in range(k_ind):
        q_ind[j] = drv[0, j] if j < nd else y[j - nd]
    if S.shape[0] > 0:
        for a in range(m):
            acc = 0.0
            for j in range(k_ind):
                acc += S[a, j] * (q_ind[j] - q[ind[j]])
            q[dep[a]] += acc
    for j in range(k_ind):
        q[ind[j]] = q_ind[j]
    for i in range(1, n):
        kc._coordinates(L, i, W.q[i, 0], W.q[i, 0], cq[i], sq[i], one)
    # positions: Newton's method on the dependent coordinates                      (F1-F2)
    kc.newton(L, z, z, one, W.q, cq, sq, W.phi, W.c, W.s, W.r, W.e, W.J, P, rhs, W.err, A,
              perm, col, sol)
    if not W.err[0, 0] <= ACCEPT:
        return 1
    kc._jacobian(L, z, z, z, one, W.r, W.e, P, W.J)
    # rates: J_dep qd_dep = -J_ind qd_ind                                          (eqs. 4-5)
    for j in range(k_ind):
        W.qd_ind[j, 0, 0] = drv[1, j] if j < nd else y[nf + j - nd]
        qd[ind[j]] = W.qd_ind[j, 0, 0]
    piv_kin = 1.0
    if m > 0:   # J_dep, factored once for the rates and the accelerations
        kc._driven_rhs(ind, m, W.J, z, ks, W.qd_ind, z, ks, one, rhs)
        kc._factor_dep(dep, W.J, z, z, one, A, perm, col)
        piv_kin = col[0]
        kc._solve_dep(dep, A, perm, col, z, z, one, rhs, W.qd, sol)
    kc._twists(L, z, z, one, W.r, W.e, W.qd, W.tw)
    # the loads: formulas of t and the joints' motion (the twist rates not yet known)
    W.td[:, :, :, :] = 0.0
    kc._cut_motion(L, z, z, z, one, W.phi, W.r, W.tw, W.td, P, W.cut)
    x = W.x[:, 0]
    x[0] = t
    for i in range(1, n):
        x[1 + drivers[i]], x[1 + nj + drivers[i]] = q[i], qd[i]
    for k in range(nc):
        x[1 + L.cut_joint[k]], x[1 + nj + L.cut_joint[k]] = W.cut[k, 0, 0, 0], W.cut[k, 1, 0, 0]
    for k in range(ext.shape[0]):
        x[1 + 2 * nj + k] = ext[k]
    applied(L, T, z, one, W.c, W.s, W.r, W.tw, W.x, W.reg, W.w, W.pe, W.power)
    # 1 + nf acceleration cases: qdd_f = 0, then qdd_f = s_k e_k                     (F5)
    ok = math.isfinite(piv_kin)
    for i in range(n):
        ok = ok and math.isfinite(qd[i])
    piv_dyn = 1.0
    for cs in range(1 + nf):
        for j in range(k_ind):
            qdd[ind[j]] = drv[2, j] if j < nd else (unit[j - nd] if j - nd == cs - 1 else 0.0)
        # J_dep qdd_dep = -bias(qdd_dep = 0)                                       (eqs. 6-7)
        for a in range(m):
            qdd[dep[a]] = 0.0
        kc._twist_rates(L, z, z, one, W.r, W.e, W.tw, W.qd, W.qdd, W.td)
        if m > 0:
            kc._bias(L, z, z, z, one, W.r, W.tw, W.td, P, rhs)
            for a in range(m):
                rhs[a, 0] = -rhs[a, 0]
            kc._solve_dep(dep, A, perm, col, z, z, one, rhs, W.qdd, sol)
            kc._twist_rates(L, z, z, one, W.r, W.e, W.tw, W.qd, W.qdd, W.td)
        for i in range(n):
            ok = ok and math.isfinite(qdd[i])
            W.qdd_c[cs, i] = qdd[i]
        # the DeNOC inverse dynamics: Q, then J_dep^T lam = Q_dep, tau = Q_ind - J_ind^T lam
        W.wtilde[0, :, 0, 0] = 0.0   # the ground's only accumulates
        dc._newton_euler(L, z, z, z, one, z, z, W.c, W.s, W.tw, W.td, W.w, W.w, W.ke,
                         W.wstar, W.wtilde)
        dc._composite(L, W.r, z, z, one, z, z, W.wtilde)
        dc._generalized(L, z, z, one, z, z, W.e, W.wtilde, W.Q)
        dc._multipliers(L, z, z, one, W.J, W.Q[:, 0, 0:1], W.A, W.lam, W.piv, W.lam_b,
                        W.tau_b, W.pivot)
        if cs == 0:
            o_e[0], o_e[1], piv_dyn = W.ke[0], W.pe[0], W.pivot[0, 0]
        for j in range(k_ind):
            W.tau[j, cs] = W.tau_b[j, 0, 0]
    tau = W.tau
    # each unit case's response per unit acceleration, (tau(s_k e_k) - tau(0)) / s_k  (F5)
    for k in range(nf):
        for j in range(k_ind):
            tau[j, 1 + k] = (tau[j, 1 + k] - tau[j, 0]) / unit[k]
        for i in range(n):
            W.qdd_c[1 + k, i] = (W.qdd_c[1 + k, i] - W.qdd_c[0, i]) / unit[k]
    # tau_f = H qdd_f + h; no actuator in a free joint: H qdd_f = -h              (F4-F6)
    qdd_f = np.zeros(nf)
    if nf == 1:
        qdd_f[0] = -tau[nd, 0] / tau[nd, 1]
    elif nf > 1:
        H = np.empty((nf, nf, 1))
        hb, hx = np.empty((nf, 1)), np.empty((nf, 1))
        hperm, hrel = np.empty((nf, 1), np.int64), np.empty(1)
        for a in range(nf):
            hb[a, 0] = -tau[nd + a, 0]
            for k in range(nf):
                H[a, k, 0] = tau[nd + a, 1 + k]
        factor(H, nf, one, hperm, hrel)
        substitute(H, hperm, hrel, nf, one, hb, hx, kc.PIVOT_TOL)
        for a in range(nf):
            qdd_f[a] = hx[a, 0]
    # the drivers' efforts at the solution and the power balance                  (F8)
    power = W.power[0]
    for j in range(nd):
        eff = tau[j, 0]
        for k in range(nf):
            eff += tau[j, 1 + k] * qdd_f[k]
        power += eff * drv[1, j]
    ok = ok and piv_kin > SINGULAR and piv_dyn > SINGULAR
    for k in range(nf):
        o_y[k] = y[nf + k]
        o_y[nf + k] = qdd_f[k] if ok else math.nan
    o_y[2 * nf] = power
    # the tree state at the solution (accelerations affine in qdd_f), the Jacobian
    for i in range(n):
        o_state[0, i], o_state[1, i] = q[i], qd[i]
        acc = W.qdd_c[0, i]
        for k in range(nf):
            acc += qdd_f[k] * W.qdd_c[1 + k, i]
        o_state[2, i] = acc
    for a in range(o_J.shape[0]):
        for j in range(o_J.shape[1]):
            o_J[a, j] = W.J[a, j, 0, 0]
    return 0


def work(lay, n_drivers: int, n_vars: int, n_code: int) -> Work:
    """The work arrays of :func:`rhs_kernel` (:data:`Work`) for the layout ``lay`` of a
    partition with ``n_drivers``, the loads' program of ``n_vars`` variables and ``n_code``
    rows; zeroed: the rows the helpers never write (the ground's, a revolute joint's slider
    axis, the Jacobian's columns of joints that move no cut) stay so."""
    topo = lay.topo
    n, nc, rows = topo.n, topo.n_loops, topo.n_rows
    m, k = len(topo.dependent), len(topo.driven)
    cases = 1 + k - n_drivers

    def z(*shape):
        return np.zeros(shape)
    return Work(
        q=z(n, 1, 1), phi=z(n, 1, 1), c=z(n, 1, 1), s=z(n, 1, 1), r=z(n, 2, 1, 1),
        e=z(n, 2, 1, 1), J=z(rows, n - 1, 1, 1), qd=z(n, 1, 1), qdd=z(n, 1, 1),
        tw=z(n, 3, 1, 1), td=z(n, 3, 1, 1), cut=z(nc, 3, 1, 1), err=z(1, 1),
        tmp=kc.scratch(n, nc, m, rows, 1), qd_ind=z(k, 1, 1), x=z(n_vars, 1),
        reg=z(max(n_code, 1), 1), pe=z(1), power=z(1), w=z(n, 3, 1, 1), wstar=z(n, 3, 1, 1),
        wtilde=z(n, 3, 1, 1), Q=z(n, 1, 1), A=z(m, m + 1, 1), lam=z(max(m, 1), 1), ke=z(1),
        piv=z(1), lam_b=z(rows, 1, 1), tau_b=z(k, 1, 1), pivot=z(1, 1), qdd_c=z(cases, n),
        tau=z(k, cases))


@njit
def _hold(item):
    """``item`` in a :class:`Held`, made by compiled code (its constructor is compiled with
    this function, and cached on disk with it)."""
    return Held(item)


class _Plain:
    """:class:`Held` without numba."""

    def __init__(self, item):
        self.item = item


def _held(item):
    """``item`` held for :func:`rhs_kernel` (:func:`_hold`; the kernel then unboxes one object
    per call, not each of its arrays); a plain object without numba."""
    return _hold(item) if structref is not None else _Plain(item)


class Kernel:
    """The compiled right-hand side of one partition (:class:`linkdyn.forward.Partition`):
    its layout's view, loads and work arrays, and :meth:`__call__`."""

    def __init__(self, part):
        self.part = part
        lay = part.layout
        n_joints = len(part.inner.joints)
        loads, self.external = table(lay, n_joints)
        n_vars = 1 + 2 * n_joints + len(self.external)
        self.held = _held((lay.view, loads, work(lay, part.n_drivers, n_vars, len(loads.code))))
        self.nd = part.n_drivers
        n, rows = lay.topo.n, len(lay.topo.dependent)
        self.noS = np.zeros((0, 0))
        self.drv_none = np.zeros((3, 0))
        self.ext_none = np.zeros(0)
        self.state = np.zeros((3, n))
        self.J = np.zeros((rows, n - 1))
        self.energy = np.zeros(2)
        # the reference as the kernel reads it, stacked once per reference (System.ref is
        # replaced, never changed in place): (ref, (3, n) array, S)
        self._ref = (None, None, None)

    def __call__(self, t: float, y: np.ndarray, ref, unit: np.ndarray) -> np.ndarray | None:
        """``y'`` (2 nf + 1,) at ``(t, y)`` from the reference ``ref`` = ``(t0, q, qd, qdd,
        S)`` (``System.ref``) with unit free accelerations of sizes ``unit`` (nf,)
        (:meth:`linkdyn.forward.System.sizes`), else None where Newton's method from the guess
        does not close the loops; :attr:`state` (3, n) and :attr:`J` hold the tree state and
        the closure Jacobian of the last call, :attr:`energy` its kinetic and potential
        energy."""
        if self._ref[0] is not ref:   # a new reference (an accepted step)
            S = ref[4]
            self._ref = (ref, np.stack(ref[1:4]),
                         self.noS if S is None else np.ascontiguousarray(S))
        _, tree, S = self._ref
        drv = self.drv_none
        if self.nd:
            drv = np.ascontiguousarray(np.stack(driver_values(self.part.model, np.array([t])))
                                       [:, :, 0])
        ext = self.ext_none
        if self.external:
            lay, tt = self.part.layout, np.array([float(t)])
            ext = np.array([np.reshape(lay.load_values(lay.loads[m], tt), -1)[k]
                            for m, k in self.external])
        out = np.empty(len(y))
        status = rhs_kernel(self.held, float(ref[0]), float(t),
                            np.ascontiguousarray(y, dtype=float), drv, ext, tree, S,
                            np.ascontiguousarray(unit, dtype=float), out,
                            self.state, self.J, self.energy)
        return out if status == 0 else None
