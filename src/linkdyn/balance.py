"""The energy balance of a simulation (F9, docs/theory.md): ``T + V - E(0) - W``, which is zero
for the exact motion, gathered at the output samples and at the end of every integrator step,
and its largest value relative to the run's largest energy. Read by both spaces' simulations
(:class:`linkdyn.forward.Simulation`, :class:`linkdyn.spatial.forward.SpatialSimulation`)."""

from __future__ import annotations

import numpy as np


class Balance:
    """The energy balance ``T + V - E0 - W`` (F9) gathered at the end of each accepted step:
    a snap between two output samples (a stiff spring letting go) shows here where the
    samples would miss it."""

    def __init__(self):
        self.residual, self.kinetic, self.work = 0.0, 0.0, 0.0
        self.potential = (np.inf, -np.inf)

    def add(self, ke: float, pe: float, e0: float, w: float) -> None:
        """One step's end: kinetic and potential energy, the energy at t = 0 and the work
        done since (J)."""
        self.residual = max(self.residual, abs(ke + pe - e0 - w))
        self.kinetic, self.work = max(self.kinetic, abs(ke)), max(self.work, abs(w))
        self.potential = (min(self.potential[0], pe), max(self.potential[1], pe))

    def summary(self) -> dict:
        """``residual``, ``kinetic``, ``work``: the largest of each, J; ``potential``: the
        range of the potential energy, J (0 without a step)."""
        span = self.potential[1] - self.potential[0] if np.isfinite(self.potential[0]) else 0.0
        return dict(residual=self.residual, kinetic=self.kinetic, work=self.work,
                    potential=float(span))


def energy_drift(kinetic, potential, work, steps: dict | None = None) -> float:
    """Energy balance (F9) of a simulation: the largest ``|E - E(0) - W|`` relative to the
    largest energy of the run (kinetic, potential variation, or work).

    Parameters
    ----------
    kinetic, potential, work : ndarray (T,)
        At the output samples, J.
    steps : dict, optional
        The same at every step's end (:meth:`Balance.summary`), which the samples may miss.
    """
    e = kinetic + potential - (kinetic[0] + potential[0]) - work
    residual = float(np.max(np.abs(e)))
    scale = max(float(np.max(np.abs(kinetic))), float(np.ptp(potential)),
                float(np.max(np.abs(work))))
    if steps:
        residual = max(residual, steps["residual"])
        scale = max(scale, steps["kinetic"], steps["potential"], steps["work"])
    return residual / scale if scale > 0 else 0.0
