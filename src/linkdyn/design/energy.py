"""What the drivers put in: power, work, energy fluctuation and the flywheel it calls for.

Driver power and energy (:func:`driver_power`, :func:`driver_energy`)
    Power ``P = tau qd`` per driver; work over the run by the trapezoid rule, split into its
    positive and negative parts. Energy fluctuation over one cycle (the first driver period of
    a constant-speed driver, else the whole run): ``E(t) = int (P - P_mean) dt``,
    ``Delta E = max E - min E``. The flywheel that keeps the speed of a constant-speed revolute
    driver within a coefficient of fluctuation ``C_s = (w_max - w_min) / w_mean`` needs
    ``I = Delta E / (C_s w_mean^2)`` (kg m^2, about the driver's axis, on top of the
    mechanism's own inertia).
"""

from __future__ import annotations

import numpy as np

from .. import joints as jk


def driver_power(sol) -> np.ndarray:
    """Power of each driver (T, n_drivers), W: ``tau qd`` at its joint
    (:attr:`linkdyn.analysis.Solution.driver_powers`)."""
    return sol.driver_powers


def _cumtrapz(t, y):
    """Running trapezoid integral of y (..., T) over t (T,), starting at 0."""
    steps = np.cumsum(0.5 * (y[..., 1:] + y[..., :-1]) * np.diff(t), axis=-1)
    return np.concatenate((np.zeros(steps.shape[:-1] + (1,)), steps), axis=-1)


def energy_fluctuation(t, power):
    """``max E - min E`` of ``E(t) = int (P - P_mean) dt`` over the samples given, J.

    ``t`` (T,) s; ``power`` (..., T) W (any leading design axes): a float for one design, an
    array (...,) for many."""
    t, power = np.asarray(t, float), np.asarray(power, float)
    work = _cumtrapz(t, power)
    e = work - work[..., -1:] * (t - t[0]) / (t[-1] - t[0])
    out = np.max(e, axis=-1) - np.min(e, axis=-1)
    return float(out) if out.ndim == 0 else out


def first_cycle(t, period) -> tuple[np.ndarray, str]:
    """Samples (T,) bool of one cycle: the first driver period if the run covers it, else the
    whole run; and a label saying which."""
    span = t[-1] - t[0]
    if period and span >= period * (1 - 1e-9):
        return t <= t[0] + period * (1 + 1e-9), "first cycle"
    return np.ones(len(t), bool), "run (shorter than one cycle)" if period else "run"


def flywheel_inertia(delta_e, omega_mean, fluctuation: float = 0.02):
    """Flywheel inertia ``Delta E / (C_s omega_mean^2)``, kg m^2 (float, or array for arrays;
    inf where ``C_s omega_mean^2`` underflows to zero, as for ``omega_mean = 1e-300``)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.asarray(delta_e, float) / (fluctuation * np.asarray(omega_mean, float) ** 2)
    return float(out) if out.ndim == 0 else out


def _constant_speed(d) -> float | None:
    from ..motion import ConstantSpeed

    return float(d.motion.speed) if isinstance(d.motion, ConstantSpeed) else None


def _work(t, p) -> dict:
    """Work (trapezoid rule), its positive and negative parts, mean, largest and smallest
    power of the power ``p`` (T,) W over the times ``t`` (T,) s, its NaN samples left out:
    ``(entry, t, p)`` with the finite samples; the entry's figures None with fewer than two."""
    ok = np.isfinite(p)
    tk, pk = t[ok], p[ok]
    entry: dict = {"work_J": None, "positive_work_J": None, "negative_work_J": None,
                   "mean_power_W": None, "max_power_W": None, "min_power_W": None}
    if len(tk) < 2:
        return entry, tk, pk
    span = tk[-1] - tk[0]
    # W = int P dt, W+ = int max(P, 0) dt, W- = int min(P, 0) dt, P_mean = W / span
    work = float(_cumtrapz(tk, pk)[-1])
    entry.update({
        "work_J": work,
        "positive_work_J": float(_cumtrapz(tk, np.clip(pk, 0, None))[-1]),
        "negative_work_J": float(_cumtrapz(tk, np.clip(pk, None, 0))[-1]),
        "mean_power_W": work / span if span > 0 else None,
        "max_power_W": float(np.max(pk)), "min_power_W": float(np.min(pk))})
    return entry, tk, pk


def driver_energy(sol, fluctuation: float = 0.02) -> dict:
    """Work, power and energy fluctuation of each driver, with the flywheel a constant-speed
    revolute driver needs for a coefficient of speed fluctuation ``fluctuation``; then the
    same of each actuator inside a joint (a ``joint_torque`` or ``joint_force`` load, e.g. a
    motor with its torque-speed line), keyed by its label (:func:`linkdyn.loads.labels`),
    with its ``joint`` and ``kind``, and neither energy fluctuation nor flywheel (its speed is
    not prescribed: :func:`linkdyn.design.speed_statistics` gives the fluctuation it
    leaves).

    Samples that are not valid (NaN rows) are left out of the integrals.
    """
    from ..loads import labels

    m, t = sol.model, sol.t
    power = driver_power(sol)
    out = {}
    for k, d in enumerate(m.drivers):
        entry, tk, pk = _work(t, power[..., k])
        entry.update({"energy_fluctuation_J": None, "fluctuation_over": None, "flywheel": None})
        out[d.joint] = entry
        if entry["work_J"] is None:
            continue
        # one cycle: the first driver period if the run covers it, else the whole run
        cyc, over = first_cycle(tk, d.period)
        if np.sum(cyc) < 2:
            continue
        de = energy_fluctuation(tk[cyc], pk[cyc])
        entry["energy_fluctuation_J"], entry["fluctuation_over"] = de, over
        speed = _constant_speed(d)
        inertia = flywheel_inertia(de, speed, fluctuation) if speed else None
        # a speed so small that no finite flywheel holds it: no flywheel is given
        if jk.get(m.joint(d.joint).kind).angular and speed and np.isfinite(inertia):
            entry["flywheel"] = {"speed_fluctuation": float(fluctuation),
                                 "mean_speed_rad_s": abs(speed),
                                 "inertia_kg_m2": inertia}
    for ld, label, p in zip(m.loads, labels(m), sol.loads.powers):
        if ld.kind not in ("joint_torque", "joint_force"):
            continue
        out[label] = {"joint": ld.joint, "kind": ld.kind, **_work(t, np.asarray(p, float))[0],
                      "energy_fluctuation_J": None, "fluctuation_over": None, "flywheel": None}
    return out


def load_energy(sol) -> dict:
    """Each load's value and work over the run, keyed by its label
    (:func:`linkdyn.loads.labels`): ``kind``, ``unit`` and ``peak`` (largest magnitude of its
    value: a force's length, a torque, an effort inside a joint, a spring's or damper's
    tension), ``peak_time_s``, then the work of its power (:func:`_work`), and for a damper
    ``dissipated_J`` (minus its work, never negative). A spring's work is minus the change of
    its potential energy. NaN samples are left out."""
    from ..loads import VALUE_UNITS, labels

    m, t = sol.model, np.asarray(sol.t, float)
    out = {}
    for ld, label, value, p in zip(m.loads, labels(m), sol.loads.values, sol.loads.powers):
        if ld.kind == "friction":
            continue   # the summary's "friction" entry (linkdyn.friction.summary)
        v = np.asarray(value, float)
        size = np.hypot(v[0], v[1]) if ld.kind == "force" else np.abs(v)
        size = np.broadcast_to(size, t.shape)
        k = int(np.nanargmax(size)) if np.any(np.isfinite(size)) else None
        entry = {"kind": ld.kind, "unit": VALUE_UNITS[ld.kind],
                 "peak": None if k is None else float(size[k]),
                 "peak_time_s": None if k is None else float(t[k]),
                 **_work(t, np.asarray(p, float))[0]}
        if ld.kind == "damper":
            entry["dissipated_J"] = None if entry["work_J"] is None else -entry["work_J"]
        out[label] = entry
    return out


def energy_account(sol) -> dict:
    """Where the energy of the run went, J, each work by the trapezoid rule over the samples:
    ``kinetic_change`` and ``potential_change`` (last sample minus first), ``driver_work``
    (the drivers', :func:`driver_power`), ``load_work`` (of the loads but springs, whose work
    is in the potential energy, dampers and friction), ``damper_dissipation`` (minus the
    dampers' work), ``friction_dissipation`` (minus the friction loads' work) and ``residual``
    = kinetic + potential change - (driver work + load work - damper dissipation - friction
    dissipation): zero but for the trapezoid rule's error and the solution's. Samples that
    are not finite are left out; None without two finite samples."""
    t = np.asarray(sol.t, float)
    kin_e = np.asarray(sol.kinetic_energy, float)
    pot = np.broadcast_to(np.asarray(sol.potential_energy, float), t.shape)
    drv = np.sum(driver_power(sol), axis=-1) if sol.model.drivers else np.zeros(t.shape)
    loads = [np.broadcast_to(np.asarray(p, float), t.shape)
             for ld, p in zip(sol.model.loads, sol.loads.powers)
             if ld.kind not in ("spring", "damper", "friction")]
    damp = [np.broadcast_to(np.asarray(p, float), t.shape)
            for ld, p in zip(sol.model.loads, sol.loads.powers) if ld.kind == "damper"]
    rub = [np.broadcast_to(np.asarray(p, float), t.shape)
           for ld, p in zip(sol.model.loads, sol.loads.powers) if ld.kind == "friction"]
    p_loads, p_damp = sum(loads, np.zeros(t.shape)), sum(damp, np.zeros(t.shape))
    p_rub = sum(rub, np.zeros(t.shape))
    ok = np.isfinite(kin_e) & np.isfinite(pot) & np.isfinite(drv) & np.isfinite(p_loads) \
        & np.isfinite(p_damp) & np.isfinite(p_rub)
    keys = ("kinetic_change", "potential_change", "driver_work", "load_work",
            "damper_dissipation", "friction_dissipation", "residual")
    if np.sum(ok) < 2:
        return dict.fromkeys(keys)
    tk = t[ok]
    out = {"kinetic_change": float(kin_e[ok][-1] - kin_e[ok][0]),
           "potential_change": float(pot[ok][-1] - pot[ok][0]),
           "driver_work": float(_cumtrapz(tk, drv[ok])[-1]),
           "load_work": float(_cumtrapz(tk, p_loads[ok])[-1]),
           "damper_dissipation": 0.0 - float(_cumtrapz(tk, p_damp[ok])[-1]),
           "friction_dissipation": 0.0 - float(_cumtrapz(tk, p_rub[ok])[-1])}
    # dKE + dPE = W_drivers + W_loads - D_dampers - D_friction
    out["residual"] = (out["kinetic_change"] + out["potential_change"]
                       - (out["driver_work"] + out["load_work"] - out["damper_dissipation"]
                          - out["friction_dissipation"]))
    return out
