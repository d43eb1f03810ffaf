"""Design quantities a mechanism designer judges a linkage by.

Four-bar loops (Grashof type, transmission angle), peak and RMS driver efforts, peak joint
reactions, and the run's numerical health (closure residual, power balance, conditioning).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import GROUND, REVOLUTE, Model


@dataclass(frozen=True)
class FourBar:
    """A four-bar loop of revolute joints: ground, input (driven) link, coupler, output link.

    ``pins``: joint names ground-input, input-coupler, coupler-output, output-ground.
    ``lengths``: ground, input, coupler, output, m.
    """

    input: str
    coupler: str
    output: str
    pins: tuple[str, str, str, str]
    lengths: tuple[float, float, float, float]

    @property
    def grashof(self) -> str:
        """Grashof classification: which links can rotate fully."""
        g, a, b, c = self.lengths
        s, l = min(self.lengths), max(self.lengths)
        pq = sum(self.lengths) - s - l
        if np.isclose(s + l, pq, rtol=1e-9):
            return "change-point (s + l = p + q: passes a folded position)"
        if s + l > pq:
            return "non-Grashof triple-rocker (no link rotates fully)"
        shortest = int(np.argmin(self.lengths))
        return ["Grashof double-crank (drag link)", "Grashof crank-rocker",
                "Grashof double-rocker (the coupler rotates fully)",
                "Grashof rocker-crank (the output rotates fully)"][shortest]


def _joint_point(model: Model, joint: str, body: str) -> np.ndarray:
    jt = model.joint(joint)
    point = jt.point_a if jt.body_a == body else jt.point_b
    return np.asarray(model.body(body).points[point], float)


def four_bars(model: Model) -> list[FourBar]:
    """Four-bar loops of revolute joints whose input link is driven from the ground."""
    rev = [j for j in model.joints if j.kind == REVOLUTE]

    def other(j, body):
        return j.body_b if j.body_a == body else j.body_a

    found = []
    for d in model.drivers:
        j1 = model.joint(d.joint)
        if j1.kind != REVOLUTE or GROUND not in (j1.body_a, j1.body_b):
            continue
        inp = other(j1, GROUND)
        for j2 in rev:
            if j2 is j1 or inp not in (j2.body_a, j2.body_b) or GROUND in (j2.body_a, j2.body_b):
                continue
            cpl = other(j2, inp)
            for j3 in rev:
                if j3 in (j1, j2) or cpl not in (j3.body_a, j3.body_b):
                    continue
                out = other(j3, cpl)
                if out in (GROUND, inp):
                    continue
                for j4 in rev:
                    if j4 in (j1, j2, j3) or {out, GROUND} != {j4.body_a, j4.body_b}:
                        continue
                    lengths = (
                        np.linalg.norm(_joint_point(model, j1.name, GROUND)
                                       - _joint_point(model, j4.name, GROUND)),
                        np.linalg.norm(_joint_point(model, j1.name, inp)
                                       - _joint_point(model, j2.name, inp)),
                        np.linalg.norm(_joint_point(model, j2.name, cpl)
                                       - _joint_point(model, j3.name, cpl)),
                        np.linalg.norm(_joint_point(model, j3.name, out)
                                       - _joint_point(model, j4.name, out)))
                    found.append(FourBar(inp, cpl, out, (j1.name, j2.name, j3.name, j4.name),
                                         tuple(float(x) for x in lengths)))
    return found


def transmission_angle(sol, fb: FourBar) -> np.ndarray:
    """Transmission angle (T,) rad in [0, pi]: between the coupler (input pin to output pin) and
    the output link (ground pivot to output pin)."""
    m = sol.model
    A = _pin(sol, fb.pins[1], fb.coupler)
    B = _pin(sol, fb.pins[2], fb.coupler)
    O = _pin(sol, fb.pins[3], fb.output)
    u, v = B - A, B - O
    c = np.sum(u * v, -1) / (np.linalg.norm(u, axis=-1) * np.linalg.norm(v, axis=-1))
    del m
    return np.arccos(np.clip(c, -1.0, 1.0))


def _pin(sol, joint: str, body: str) -> np.ndarray:
    jt = sol.model.joint(joint)
    point = jt.point_a if jt.body_a == body else jt.point_b
    return sol.point(body, point)


def _peak(t, x):
    k = int(np.nanargmax(np.abs(x)))
    return float(np.abs(x[k])), float(t[k])


def summary(sol) -> dict:
    """Summary of a solution as plain JSON-ready data (SI units)."""
    m, kin, topo = sol.model, sol.kin, sol.topology
    t, valid = sol.t, sol.valid
    out: dict = {
        "model": m.name,
        "file": m.source,
        "samples": int(len(t)),
        "duration_s": float(t[-1] - t[0]),
        "mobility": topo.mobility,
        "loops": topo.n_loops,
        "cut_joints": [m.joints[j].name for j in topo.cut],
        "spanning_tree": {b: m.joints[topo.tree_joint[i]].name
                          for i, b in enumerate(topo.bodies) if i},
        "drivers": {},
        "reactions": {},
        "four_bars": [],
        "invalid_samples": int(np.sum(~valid)),
    }
    for k, d in enumerate(m.drivers):
        tau = sol.dyn.tau[..., k]
        peak, at = _peak(t, tau)
        unit = "N" if m.joint(d.joint).kind != REVOLUTE else "N m"
        out["drivers"][d.joint] = {
            "effort": "force" if unit == "N" else "torque", "unit": unit,
            "peak": peak, "peak_time_s": at,
            "rms": float(np.sqrt(np.nanmean(tau ** 2))),
            "motion": d.description}
    for k, j in enumerate(m.joints):
        f = np.linalg.norm(sol.reactions.force[..., k, :], axis=-1)
        peak, at = _peak(t, f)
        entry = {"peak_force_N": peak, "peak_time_s": at}
        if j.kind != REVOLUTE:
            entry["peak_moment_Nm"] = _peak(t, sol.reactions.moment[..., k])[0]
        out["reactions"][j.name] = entry
    for fb in four_bars(m):
        mu = np.degrees(transmission_angle(sol, fb))
        kmin = int(np.nanargmin(np.minimum(mu, 180 - mu)))
        out["four_bars"].append({
            "links": {"input": fb.input, "coupler": fb.coupler, "output": fb.output},
            "lengths_m": dict(zip(("ground", "input", "coupler", "output"), fb.lengths)),
            "grashof": fb.grashof,
            "transmission_angle_deg": {"min": float(np.nanmin(mu)), "max": float(np.nanmax(mu)),
                                       "worst": float(mu[kmin]), "worst_time_s": float(t[kmin])}})
    out["health"] = health(sol)
    return out


def health(sol) -> dict:
    """Numerical health of the run: closure residual, power balance, conditioning.

    The power balance compares the drivers' power with ``sum_i t_i . w_star_i`` (the rate of
    kinetic energy minus the power of all applied loads): the cut-joint multipliers must do no
    work. The condition number is that of ``J_dep``, the matrix of both the rate and the
    ``[lam; tau]`` solves.
    """
    kin, dyn, topo = sol.kin, sol.dyn, sol.topology
    ok = sol.valid
    p_drv = sol.driver_power
    p_ne = np.einsum("...ik,...ik->...", kin.tw, dyn.w_star)
    scale = max(np.nanmax(np.abs(p_drv[ok])) if np.any(ok) else 0.0, 1e-300)
    resid = np.abs(p_drv - p_ne)[ok]
    dep = np.array(topo.dependent, int)
    cond = np.nan
    if len(dep) and np.any(ok):
        Jd = kin.J[ok][..., dep - 1]
        cond = float(np.max(np.linalg.cond(Jd)))
    return {
        "closure_residual_rel": float(np.nanmax(kin.residual[ok])) if np.any(ok) else None,
        "power_balance_residual_rel": float(np.max(resid) / scale) if resid.size else None,
        "worst_condition_number": cond,
    }
