"""A run at a glance: the summary of every design quantity (``summary.json``) and the
numerical health of the solve (closure residual, energy balance, conditioning)."""

from __future__ import annotations

import numpy as np

from ..errors import ModelError, quiet
from .. import joints as jk
from ..model import GROUND
from ..planar import dot, perp
from .reduce import plus_square, root_mean
from .energy import driver_energy, load_energy
from .fourbar import (four_bars, link_travel, mechanical_advantage, stops, transmission_angle,
                      transmission_worst, travel_words)
from .path import TWO_PI, default_path_point, joint_travel, path_straightness
from .shaking import inertia_wrench, shaking_wrench
from ..units import Units

# a cam's contact force counts as lost below -ROUNDING x its peak, not at the last digit
ROUNDING = 1e-12


def peak(x):
    """Largest |x| over the last (time) axis, finite samples only: (...,) for x (..., T); NaN
    where no sample is finite. The ``peak`` of every summary entry and of the sweep metrics.
    Its reduction one sample at a time, from 0, is :func:`.reduce.larger_magnitude` (the
    sweep kernel's, :func:`linkdyn.dynamics.compiled.sweep`)."""
    x = np.abs(np.asarray(x, float))
    ok = np.any(np.isfinite(x), axis=-1)
    out = np.max(np.where(np.isfinite(x), x, -np.inf), axis=-1)
    return np.where(ok, out, np.nan)


def rms(x):
    """Root mean square over the last (time) axis, finite samples only: (...,) for x (..., T):
    :func:`.reduce.root_mean` of the sum of :func:`.reduce.plus_square` over the samples (the
    sweep kernel sums the same step one sample at a time)."""
    x = np.asarray(x, float)
    ok = np.isfinite(x)
    with np.errstate(invalid="ignore", divide="ignore"):
        return root_mean(np.sum(plus_square(0.0, np.where(ok, x, 0.0)), axis=-1),
                         np.sum(ok, axis=-1))


def _peak(t, x):
    """Largest |x| (over the finite samples) and its time; NaN where none is finite."""
    if not np.any(np.isfinite(x)):
        return np.nan, np.nan
    k = int(np.nanargmax(np.abs(x)))
    return float(peak(x)), float(t[k])


def _rms(x):
    return float(rms(x))


def _extremes(t, x) -> dict:
    """Smallest and largest x and their times; NaN (not defined: "n/a" in the text, null in
    summary.json) where no sample is finite, as a mechanical advantage 0/0 of a mechanism at
    rest."""
    if not np.any(np.isfinite(x)):
        return {"min": np.nan, "min_time_s": np.nan, "max": np.nan, "max_time_s": np.nan}
    kmin, kmax = int(np.nanargmin(x)), int(np.nanargmax(x))
    return {"min": float(x[kmin]), "min_time_s": float(t[kmin]),
            "max": float(x[kmax]), "max_time_s": float(t[kmax])}


def advantage_range(sol, fb) -> dict:
    """A four-bar loop's mechanical advantage over the run: :func:`_extremes` of the samples,
    but infinite where the output stops (``max`` None, ``infinite_at_s`` the times of its
    stops, :func:`.fourbar.stops`) and zero where the input stops (``min`` 0, ``zero_at_s``):
    the sampled extreme there is a number of the sampling, not of the linkage."""
    ma = _extremes(np.asarray(sol.t), mechanical_advantage(sol, fb))
    out, inp = stops(sol, fb, "output"), stops(sol, fb, "input")
    if out:
        ma.update(max=np.nan, max_time_s=out[0]["t"], infinite_at_s=[s["t"] for s in out])
    if inp:
        ma.update(min=0.0, min_time_s=inp[0]["t"], zero_at_s=[s["t"] for s in inp])
    return ma


@quiet
def summary(sol, *, fluctuation: float = 0.02, path_point: str | None = None,
            path_range=None, default_range=None) -> dict:
    """Summary of a solution as plain JSON-ready data (SI units).

    Parameters
    ----------
    fluctuation : float
        Coefficient of speed fluctuation C_s for the flywheel size.
    path_point : str or None
        ``'BODY.POINT'`` whose path straightness is reported; None picks
        :func:`default_path_point` (no report if there is none).
    path_range : (float, float) or None
        Range of the first driver's coordinate for the straightness; it must hold at least 3
        samples of the run. None takes ``default_range``.
    default_range : (float, float) or None
        A range used only if it fits (such as the model's ``[analysis] path_range``); the whole
        run otherwise, or when None.

    A spatial solution (``space = "spatial"``) gets ``linkdyn analyze``'s spatial summary
    (:func:`linkdyn.spatial.cli.summary`: mobility, redundancy, peak efforts and reactions);
    the options above apply to planar runs only.
    """
    if getattr(sol.model, "space", "planar") == "spatial":
        from ..spatial.cli import summary as spatial_summary
        return spatial_summary(sol)
    if not fluctuation > 0:
        raise ModelError(f"the coefficient of speed fluctuation must be positive, got "
                         f"{fluctuation}", field="--fluctuation", fix="Give e.g. 0.02")
    m, topo = sol.model, sol.topology
    t, valid = sol.t, sol.valid
    units = Units.of(m)
    out: dict = {
        "model": m.name,
        "file": m.source,
        # the file's units: what the printed summary and the display fields (``motion``,
        # ``words``, ``range_shown``) are in; every number under a ``_m``/``_rad``/... key is SI
        "units": {"length": units.length, "angle": units.angle},
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
        "assembly": assembly(sol),
        "sampling": sampling(sol),
    }
    for k, d in enumerate(m.drivers):
        tau = sol.dyn.tau[..., k]
        peak, at = _peak(t, tau)
        unit = "N m" if jk.get(m.joint(d.joint).kind).angular else "N"
        out["drivers"][d.joint] = {
            "effort": "force" if unit == "N" else "torque", "unit": unit,
            "peak": peak, "peak_time_s": at,
            "rms": _rms(tau),
            "motion": d.description}
    for k, j in enumerate(m.joints):
        f = np.linalg.norm(sol.reactions.force[..., k, :], axis=-1)
        peak, at = _peak(t, f)
        entry = {"peak_force_N": peak, "peak_time_s": at}
        if "M" in jk.get(j.kind).reaction:
            entry["peak_moment_Nm"] = _peak(t, sol.reactions.moment[..., k])[0]
        out["reactions"][j.name] = entry
    for fb in four_bars(m):
        mu = np.degrees(transmission_angle(sol, fb))
        kmin = int(np.nanargmin(np.degrees(transmission_worst(np.radians(mu)))))
        ta = {"min": float(np.nanmin(mu)), "max": float(np.nanmax(mu)),
              "worst": float(mu[kmin]), "worst_time_s": float(t[kmin])}
        ta["min_time_s"] = float(t[int(np.nanargmin(mu))])
        ta["max_time_s"] = float(t[int(np.nanargmax(mu))])
        out["four_bars"].append({
            "links": {"input": fb.input, "coupler": fb.coupler, "output": fb.output},
            "frame": fb.frame,
            "pins": list(fb.pins),
            # first key "ground" as before; "frame" for a loop that does not contain the ground
            "lengths_m": dict(zip(("ground" if fb.frame == GROUND else "frame", "input",
                                   "coupler", "output"), fb.lengths)),
            "grashof": fb.grashof,
            "type": fb.type,
            # what the run does, beside what the lengths allow
            "motion": dict(link_travel(sol, fb), words=travel_words(link_travel(sol, fb), units)),
            "transmission_angle_deg": ta,
            "mechanical_advantage": advantage_range(sol, fb)})
    from .checks import slider_crank_runs
    out["slider_cranks"] = slider_crank_runs(sol)
    out["joint_travel"] = {}
    for j in m.joints:
        lo, hi = joint_travel(sol, j.name)
        angular = jk.get(j.kind).angular
        entry = {"unit": "rad" if angular else "m", "min": lo, "max": hi, "range": hi - lo}
        if angular:
            entry["full_turn"] = bool(hi - lo >= TWO_PI * (1 - 1e-9))
        out["joint_travel"][j.name] = entry
    ws = shaking_wrench(sol)
    f_mag = np.linalg.norm(ws[..., 1:], axis=-1)
    i_mag = np.linalg.norm(inertia_wrench(sol)[..., 1:], axis=-1)
    out["shaking"] = {
        "force_N": dict(zip(("peak", "peak_time_s"), _peak(t, f_mag)), rms=_rms(f_mag)),
        "moment_Nm": dict(zip(("peak", "peak_time_s"), _peak(t, ws[..., 0])),
                          rms=_rms(ws[..., 0])),
        "inertia_force_N": dict(zip(("peak", "peak_time_s"), _peak(t, i_mag)), rms=_rms(i_mag)),
        "moment_about": "global origin",
        "includes": "ground-joint reactions, driver reactions and ground-anchored springs and "
                    "dampers, as loads on the ground"}
    out["driver_energy"] = driver_energy(sol, fluctuation)
    out["load_energy"] = load_energy(sol)
    point = path_point or default_path_point(m)
    out["path_straightness"] = None
    if point:
        try:
            out["path_straightness"] = path_straightness(
                sol, point, default_range if path_range is None else path_range)
        except ModelError:
            if path_range is not None:
                raise  # a range the user asked for and the run does not reach
            # the default range does not fit this run: measure the whole run, if it has the
            # three samples a line needs (else no straightness is reported)
            if default_range is not None and np.sum(valid) >= 3:
                out["path_straightness"] = path_straightness(sol, point, None)
    ps = out["path_straightness"]
    if ps and ps["range"] is not None:   # the range as a person typed it, in the file's unit
        ps["range_shown"] = units.span(*ps["range"], "angle" if ps["range_unit"] == "rad"
                                       else "length")
    out["health"] = health(sol)
    if any(jk.get(m.joints[j].kind).one_sided for j in topo.cut):
        out["contact"] = contact(sol)
    if getattr(sol, "friction", None) is not None:   # energy lost per joint, efficiency
        from .. import friction
        out["friction"] = friction.summary(sol)
    if getattr(sol.model, "output", ()):   # the work on the output loads, the efficiency
        from .. import friction
        out["output"] = friction.output_summary(sol)
    return out


def contact(sol) -> dict:
    """The contact force of every joint that can only push (a cam's, ``one_sided``), by joint
    name: its signed magnitude ``|R|`` (N; negative where the multiplier is: the cam would
    pull), its least value and time, and the samples where it is below zero by more than
    rounding, 1e-12 of its peak (``lost_samples``, the first and last of their times): where
    the follower would leave the cam at the run's speed, and a stronger spring or preload is
    needed. (A spring the summary proposes makes the least force zero: rounding decides its
    sign there.)"""
    m, t = sol.model, sol.t
    forces = contact_forces(sol, sol.dyn, sol.reactions)
    out = {}
    for name, f in forces.items():
        # lost: below zero beyond rounding
        lost = np.isfinite(f) & (f < -ROUNDING * np.nanmax(np.abs(f), initial=0.0))
        kmin = int(np.nanargmin(f)) if np.any(np.isfinite(f)) else 0
        out[name] = {
            "min_force_N": float(f[kmin]), "min_time_s": float(t[kmin]),
            "lost_samples": int(np.sum(lost)),
            "lost_from_s": float(t[lost][0]) if np.any(lost) else None,
            "lost_to_s": float(t[lost][-1]) if np.any(lost) else None}
    for name, leave in leaves(sol, forces).items():
        out[name]["leaves"] = leave
    for name, hz in contact_stress(sol, forces).items():
        k = int(np.nanargmax(hz["p_max_Pa"])) if np.any(np.isfinite(hz["p_max_Pa"])) else 0
        out[name]["stress"] = {
            "max_pressure_Pa": float(hz["p_max_Pa"][k]), "max_time_s": float(t[k]),
            "max_cam_angle_rad": float(hz["cam_angle_rad"][k]),
            "half_width_m": float(hz["half_width_m"][k]), "force_N": float(forces[name][k]),
            "cam_radius_m": float(hz["cam_radius_m"][k]),
            "effective_radius_m": float(hz["effective_radius_m"][k])}
    if not prescribed(sol):
        return out
    if any(c["lost_samples"] for c in out.values()):
        for name, fix in spring_fixes(sol, forces).items():
            out[name]["springs"] = fix
    for name, jump in jump_speeds(sol, forces).items():
        out[name].update(jump)
    return out


def contact_stress(sol, forces: dict | None = None) -> dict:
    """The Hertz line contact of every cam joint with a roller whose numbers ask for it
    (``roller_width`` > 0, :meth:`linkdyn.joints.cam.Cam.stressed`), by joint name, each (T,)
    over the run: ``p_max_Pa`` the contact's peak pressure, ``half_width_m`` its half-width
    ``b`` (:func:`linkdyn.cams.hertz_line`, 0 where the follower would leave the cam),
    ``cam_angle_rad`` the contact's cam angle, ``cam_radius_m`` the profile's radius of
    curvature there (negative concave) and ``effective_radius_m`` ``R``. ``forces``: the
    signed contact forces (:func:`contact_forces`; computed if None). One design only."""
    from ..cams import hertz_line

    def stressed(joint):
        kind = jk.get(joint.kind)
        return kind.one_sided and getattr(kind, "stressed", None) and kind.stressed(
            joint.numbers)

    frames = one_sided_frames(sol, stressed)
    if not frames:
        return {}
    forces = contact_forces(sol, sol.dyn, sol.reactions) if forces is None else forces
    out = {}
    for joint, f in frames:
        x = joint.numbers
        theta, r_cam, r_roller = jk.get(joint.kind).contact_radii(x, f)
        b, p, R = hertz_line(forces[joint.name], r_cam, r_roller, x["roller_width"],
                             x["cam_modulus"], x["cam_poisson"], x["roller_modulus"],
                             x["roller_poisson"])
        out[joint.name] = {"p_max_Pa": p, "half_width_m": b, "cam_angle_rad": theta + 0 * p,
                           "cam_radius_m": r_cam + 0 * p, "effective_radius_m": R}
    return out


def one_sided_frames(sol, which=None) -> list:
    """``(joint, frame)`` of every one-sided cut joint of a one-design run (``which(joint)``
    true, if given): the cut's frame ``(e_a, d, e_b, t)`` over the run (each component (T,),
    :func:`linkdyn.joints.frame`), as its kind's steps take it."""
    from ..kinematics.recursion import cut_frame

    if sol.batched:
        return []
    m, topo = sol.model, sol.topology
    lay, pose = sol.kin.layout, sol.kin.pose
    out = []
    for k, j in enumerate(topo.cut):
        joint = m.joints[j]
        if not jk.get(joint.kind).one_sided or (which is not None and not which(joint)):
            continue
        c = lay.cuts[k]
        r_pa, r_pb, e_a = cut_frame(jk.CODES[c.kind], c.own, pose.c[c.a], pose.s[c.a],
                                    pose.r[c.a], pose.c[c.b], pose.s[c.b], pose.r[c.b], c.pa,
                                    c.pb, c.axis, np.nan)
        out.append((joint, jk.frame(r_pa, r_pb, e_a)))
    return out


def leaves(sol, forces: dict) -> dict:
    """Where each one-sided joint's contact force first crosses zero from above (or is below
    zero at the first sample), by joint name: ``time_s`` (between the two samples by linear
    interpolation of the force), ``cam_angle_rad`` (the contact's cam angle there, within one
    turn) and ``cam_speed_rad_s`` (the cam body's angular velocity relative to the follower's
    there). The joint holds the follower on (a bilateral constraint): from there on the run
    is that of a follower kept on the cam, which a real one would leave; its flight is not
    modelled. Joints whose force never turns negative are left out."""
    t = np.asarray(sol.t, float)
    out = {}
    for joint, f in one_sided_frames(sol):
        x = forces[joint.name]
        scale = np.nanmax(np.abs(x), initial=0.0)
        below = np.isfinite(x) & (x < -ROUNDING * scale)
        if not np.any(below):
            continue
        k = int(np.argmax(below))
        kind = jk.get(joint.kind)
        theta = np.unwrap(kind.cam_angle(joint.numbers, f) + 0.0 * x)
        w = (np.asarray(sol.omega(joint.body_a), float)
             - np.asarray(sol.omega(joint.body_b), float)) + 0.0 * x
        if k == 0 or not np.isfinite(x[k - 1]):
            u, k0 = 0.0, k
        else:   # the zero of the line through (t[k-1], x[k-1]) and (t[k], x[k])
            u, k0 = x[k - 1] / (x[k - 1] - x[k]), k - 1
        k1 = min(k0 + 1, len(t) - 1)

        def at(y):
            return float(y[k0] + u * (y[k1] - y[k0]))

        out[joint.name] = {"time_s": at(t), "cam_angle_rad": float(np.mod(at(theta), TWO_PI)),
                           "cam_speed_rad_s": at(w)}
    return out


def prescribed(sol) -> bool:
    """Whether the run's motion is prescribed (an ``analyze``, not a ``simulate``) and its
    loads free of friction: then every contact force is affine in each load and, at one
    driver angle, a quadratic in the driver's speed."""
    from ..motion import Free
    return (not getattr(sol, "friction", None) and not getattr(sol, "free", ())
            and not any(isinstance(d.motion, Free) for d in sol.model.drivers))


def contact_forces(sol, dyn, react) -> dict:
    """The signed contact force (T,) N of every one-sided cut joint, by name, out of the
    multipliers ``dyn.lam`` and reactions ``react``: ``sign(lam) |R|`` (negative: the cam
    would pull)."""
    m, topo = sol.model, sol.topology
    out = {}
    for k, j in enumerate(topo.cut):
        if jk.get(m.joints[j].kind).one_sided:
            lam = dyn.lam[..., topo.row_slice(k)][..., 0]
            out[m.joints[j].name] = np.sign(lam) * np.linalg.norm(react.force[..., j, :],
                                                                 axis=-1)
    return out


def contact_forces_of(sol, model, kin) -> dict:
    """:func:`contact_forces` of ``model`` (``sol.model`` with other loads) moving as ``kin``
    (``sol``'s motion, or the same positions at another speed): its inverse dynamics and
    reactions on the numpy backend."""
    from .. import loads as loads_mod, reactions as reactions_mod
    from ..dynamics import denoc
    dyn = denoc.solve(kin, loads_mod.wrenches(model, kin))
    return contact_forces(sol, dyn, reactions_mod.solve(model, kin, dyn))


def least_shift(f0, b):
    """The ``x`` nearest 0 with ``f0 + x b >= 0`` at every finite sample (f0, b (T,)), or
    None if none does: the interval ``[max -f0/b (b > 0), min -f0/b (b < 0)]``."""
    ok = np.isfinite(f0) & np.isfinite(b)
    f0, b = f0[ok], b[ok]
    scale = np.max(np.abs(b), initial=0.0)
    if np.any((np.abs(b) <= 1e-12 * scale) & (f0 < 0)):
        return None   # a lost sample this load does not reach
    up, down = b > 1e-12 * scale, b < -1e-12 * scale
    lo = np.max(-f0[up] / b[up], initial=-np.inf)
    hi = np.min(-f0[down] / b[down], initial=np.inf)
    if lo > hi:
        return None
    return float(min(max(0.0, lo), hi))


def smallest_root(A, B, C):
    """The least ``r >= 0`` (per sample, shapes of A) where ``A + B r + C r^2`` turns negative
    (0 where A < 0; inf where it never does)."""
    scale = np.maximum(np.abs(A), 1e-300)
    C = np.where(np.abs(C) <= 1e-9 * scale, 0.0, C)
    B = np.where(np.abs(B) <= 1e-9 * scale, 0.0, B)
    disc = B * B - 4 * A * C
    root = np.sqrt(np.maximum(disc, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        # the roots of C r^2 + B r + A (or of B r + A): the larger one where C < 0 (the
        # parabola falls through it), the smaller where C > 0 and B < 0 (a dip below zero)
        r = np.where(C < 0, (-B - root) / (2 * C),
                     np.where(C > 0, np.where((B < 0) & (disc > 0), (-B - root) / (2 * C),
                                              np.inf),
                              np.where(B < 0, -A / B, np.inf)))
    return np.where(A < 0, 0.0, np.where(np.isfinite(r) & (r >= 0), r, np.inf))


def jump_speeds(sol, forces) -> dict:
    """The speed at which each one-sided joint would first lose contact, for a run driven at
    one constant speed ``w``: by joint name, ``jump_speed_rad_s`` (|w| r, None if never) and
    ``jump_time_s`` (the run's sample, i.e. the driver's angle, where it goes first). At one
    driver angle every velocity grows as w and every acceleration as w^2, so the contact force
    is ``A + B r + C r^2`` at the speed ``r w`` (B of dampers, C of inertia): fitted through
    runs at r = 1, 2, 3 and checked at r = 1/2 (a load that depends on time fails the check:
    then the speed is not given)."""
    from dataclasses import replace

    from ..motion import ConstantSpeed

    m, t, kin = sol.model, sol.t, sol.kin
    motion = m.drivers[0].motion if len(m.drivers) == 1 else None
    if not isinstance(motion, ConstantSpeed) or motion.speed == 0 or sol.batched:
        return {}

    def at(r):   # the contact forces at the speed r w, at the run's driver angles
        q, qd, qdd = kin.joint_motion
        # the same positions; velocities times r, accelerations times r^2 (no driver's own)
        fast = replace(kin, t=t / r, joint_motion=(q, [r * x for x in qd],
                                                   [r * r * x for x in qdd]),
                       twists=[r * x for x in kin.twists],
                       rates=[r * r * x for x in kin.rates], arrays=None)
        return contact_forces_of(sol, m, fast)

    f2, f3, half = at(2.0), at(3.0), at(0.5)
    out = {}
    for name, f1 in forces.items():
        # through r = 1, 2, 3: C = (f1 - 2 f2 + f3) / 2, B = f2 - f1 - 3 C, A = f1 - B - C
        C = (f1 - 2 * f2[name] + f3[name]) / 2
        B = f2[name] - f1 - 3 * C
        A = f1 - B - C
        scale = np.nanmax(np.abs(np.stack((f1, f2[name], f3[name]))))
        if not np.nanmax(np.abs(A + B / 2 + C / 4 - half[name])) <= 1e-8 * scale:
            continue
        r = smallest_root(A, B, C)
        k = int(np.argmin(np.where(np.isfinite(r), r, np.inf)))
        out[name] = {"jump_speed_rad_s": float(r[k] * abs(motion.speed))
                     if np.isfinite(r[k]) else None,
                     "jump_time_s": float(t[k]) if np.isfinite(r[k]) else None}
    return out


def spring_fixes(sol, forces) -> dict:
    """For every one-sided joint that loses contact, each spring's change that keeps every
    contact force at or above zero (the least one, exact at the worst sample), by joint name
    then spring label: ``free_length_m`` (the stiffness kept: the spring's force changed by
    ``tension_change_N``, positive pulling) and ``stiffness_N_m`` (the free length kept);
    None where that change cannot. The motion is prescribed, so each contact force is affine
    in a spring's force: ``f = f0 + c dT`` with ``c`` from one more inverse dynamics at a
    changed free length, and ``dT = (r - 1) T0`` for the stiffness ``r k``."""
    from dataclasses import replace

    from .. import loads as loads_mod

    m, kin = sol.model, sol.kin

    def forces_with(k, **change):   # the contact forces with load k changed
        return contact_forces_of(sol, replace(m, loads=tuple(
            replace(x, **change) if i == k else x for i, x in enumerate(m.loads))), kin)

    scale = max(float(np.nanmax(np.abs(f), initial=1.0)) for f in forces.values())
    fixes: dict = {name: {} for name, f in forces.items() if np.nanmin(f) < 0}
    for k, (load, label) in enumerate(zip(m.loads, loads_mod.labels(m))):
        if load.kind != "spring" or not load.stiffness > 0:
            continue
        # c: the contact force per newton of added tension (the free length shorter by dT/k)
        dT = scale
        per_N = forces_with(k, free_length=load.free_length - dT / load.stiffness)
        # b: the contact force's change as the stiffness doubles at the same free length
        doubled = forces_with(k, stiffness=2 * load.stiffness)
        for name in fixes:
            f0 = forces[name]
            x = least_shift(f0, (per_N[name] - f0) / dT)
            r = least_shift(f0, doubled[name] - f0)
            fixes[name][label] = {
                "tension_change_N": x,
                "free_length_m": None if x is None else load.free_length - x / load.stiffness,
                "stiffness_N_m": None if r is None or r <= -1 else (1 + r) * load.stiffness}
    return fixes


def assembly(sol) -> dict:
    """How the run was assembled: ``guess`` (whether the model's ``[assembly]`` gave one; if
    not, the closure was solved from zero angles and the assembly mode is the one found
    nearest them) and ``start_phi_rad``, every moving body's angle at the first sample."""
    m = sol.model
    first = {b.name: float(sol.phi(b.name)[..., 0]) if sol.phi(b.name).ndim == 1 else None
             for b in m.moving_bodies}
    return {"guess": bool(m.assembly_phi or m.assembly_q), "start_time_s": float(sol.t[0]),
            "start_phi_rad": first}


COARSE_STEP = np.pi / 2   # rad of a revolute driver between samples beyond which a run is coarse


def sampling(sol) -> dict:
    """How finely the run samples the motion: ``driver_step`` (the largest change of each
    driver's coordinate between consecutive samples, rad or m) and ``coarse`` (True when a
    revolute driver moves more than a quarter turn between samples: peaks, travel, work and the
    path are then those of the samples, not of the motion between them)."""
    m = sol.model
    names = [j.name for j in m.joints]
    steps, coarse = {}, False
    for d in m.drivers:
        q = np.asarray(sol.kin.q[..., names.index(d.joint)])
        dq = np.abs(np.diff(q, axis=-1))
        step = float(np.nanmax(dq)) if dq.size and np.any(np.isfinite(dq)) else 0.0
        steps[d.joint] = step
        coarse |= bool(jk.get(m.joint(d.joint).kind).angular and step > COARSE_STEP)
    return {"driver_step": steps, "coarse": coarse}


POWER_NOISE = 1e-9   # a power below this fraction of KE times the fastest rate is rounding


def health(sol) -> dict:
    """Numerical health of the run: closure residual, energy balance, conditioning.

    The energy balance checks ``P_drivers + P_loads = dKE/dt`` at every valid sample, where
    ``P_loads`` is the power of every applied load (gravity and springs included) and ``dKE/dt``
    is computed from the mass centres, ``sum m v_C . a_C + I_C w al`` — a path independent of
    the Newton–Euler wrenches about O_i the solver uses. The residual is relative to the largest
    of the three powers over the run; it is None (``energy_balance`` says "not meaningful")
    when even that power is rounding: below ``POWER_NOISE`` of the mechanism's power scale, the
    largest kinetic energy times its fastest rate (a body's ``|w|`` or ``|v_C| / size``), as a
    parallelogram turned at constant speed without loads, whose every power is zero. The condition number is that of ``J_dep`` (the matrix of
    the rate and the ``[lam; tau]`` solves) made dimensionless: rows of velocity divided by the
    mechanism's size, columns of slider rates multiplied by it.
    """
    kin, topo, lay = sol.kin, sol.topology, sol.kin.layout
    ok = sol.valid
    p_drv = sol.driver_power
    p_loads = sum(dot(t, w) for t, w in zip(kin.twists, sol.loads.wrenches))
    dke, ke, rate = np.zeros(kin.shape), np.zeros(kin.shape), np.zeros(kin.shape)
    for i in range(1, topo.n):
        d = kin.pose.rotate(i, lay.com[i])
        (w, v), (al, a) = (kin.twists[i][0], kin.twists[i][1:]), (kin.rates[i][0], kin.rates[i][1:])
        v_c = v + w * perp(d)
        a_c = a + al * perp(d) - w ** 2 * d
        dke = dke + lay.mass[i] * dot(v_c, a_c) + lay.inertia[i] * w * al
        # the power scale: KE = sum (m v_C^2 + I w^2) / 2 times the fastest rate
        ke = ke + 0.5 * (lay.mass[i] * dot(v_c, v_c) + lay.inertia[i] * w * w)
        rate = np.fmax(rate, np.fmax(np.abs(w), np.sqrt(dot(v_c, v_c)) / np.min(lay.size)))
    resid = np.abs(p_drv + p_loads - dke)[ok]
    scale = max((float(np.max(np.abs(x[ok]))) for x in (p_drv, p_loads, dke)), default=0.0)
    p0 = float(np.max(ke[ok]) * np.max(rate[ok])) if np.any(ok) else 0.0
    balance = (float(np.max(resid) / scale) if scale > POWER_NOISE * p0 and scale > 0
               else None) if resid.size else None
    dep = np.array(topo.dependent, int)
    cond = None
    if len(dep) and np.any(ok):
        rows = np.array([1.0 / float(np.min(lay.size)) if unit == "m" else 1.0
                         for c in lay.cuts for unit in jk.get(c.kind).row_units])
        cols = np.array([1.0 if jk.get(lay.kind[i]).angular else float(np.min(lay.size))
                         for i in dep])
        Jd = kin.J[ok][..., dep - 1] * rows[:, None] * cols
        cond = float(np.max(np.linalg.cond(Jd)))
    return {
        "closure_residual_rel": float(np.nanmax(kin.residual[ok])) if np.any(ok) else None,
        "energy_balance_residual_rel": balance,
        "energy_balance": ("not meaningful (every power is rounding)" if resid.size and
                           balance is None else "checked" if resid.size else "no valid sample"),
        "worst_condition_number": cond,
    }
