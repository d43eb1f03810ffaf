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
    """Power of each driver (T, n_drivers), W: ``tau qd`` at its joint."""
    idx = [[j.name for j in sol.model.joints].index(d.joint) for d in sol.model.drivers]
    return sol.dyn.tau * sol.kin.qd[..., idx]


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
    return out
