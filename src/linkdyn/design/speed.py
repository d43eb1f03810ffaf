"""The speed of the independent coordinates at steady state, and the run-up to it.

For each driven or free joint coordinate ``q`` (rate ``qd``) of a run:

Window
    The last full turn of the coordinate itself: from the time ``t_a`` at which ``q`` was one
    turn (2 pi) short of its last value (linear between the two samples around it) to the end
    of the run, ``over = "last turn"``. A coordinate that does not turn a full turn over the
    run takes the window of the first independent coordinate that does (drivers first, then
    the free joints), ``over = "last turn of <joint>"``: the machine's last cycle; if none
    does, the second half of the run, ``over = "second half of the run"``.
Statistics over the window
    ``mean = (q(t_end) - q(t_a)) / (t_end - t_a)`` (the time average of ``qd``; ``q(t_a)``
    linear between samples), ``min`` and ``max`` of ``qd`` at the samples with
    ``t >= t_a``, and the coefficient of fluctuation ``C_s = (max - min) / |mean|`` (None
    when ``qd`` changes sign in the window: a coordinate that swings to and fro has no steady
    speed to fluctuate about). A turning revolute coordinate
    also gives them in rpm (``60 / 2 pi`` rpm per rad/s).
Run-up
    The steady band is the window's ``[min, max]`` widened by ``BAND_MARGIN`` of its width on
    each side (and by 1e-9 of the largest ``|qd|``, so a constant speed has a band), which the
    same fluctuation sampled at other phases stays in. ``run_up_time_s`` is the first sample
    time after which ``qd`` stays in the band to the end of the run (the first sample's time
    when it never leaves it).
Steady
    The window before the last one (the turn before the last turn, of the coordinate or of the
    machine's cycle; the first half of the run before the second) gives its own mean speed;
    ``mean_change`` is the last window's mean minus that one, and ``steady`` says whether it
    is at most ``DRIFT`` of the last window's speed range ``max - min`` (plus 1e-9 of the
    largest ``|qd|``): the speed fluctuates about a mean that no longer moves. None when the
    run holds no whole window before the last (less than two turns). A run that is not steady
    is too short to show its steady state: its statistics are those of a speed still changing.
"""

from __future__ import annotations

import numpy as np

from .. import joints as jk

TWO_PI = 2.0 * np.pi
RPM = 60.0 / TWO_PI        # rpm per rad/s
BAND_MARGIN = 0.05         # the steady band: the window's [min, max] widened by this of its width
DRIFT = 0.25               # steady: the mean moved from the window before by at most this of max - min


def _turns_back(t: np.ndarray, q: np.ndarray, n: int = 1) -> float | None:
    """The time (s) at which ``q`` (T,) was ``n`` turns short of its last value, linear
    between the two samples around it; None if it never was."""
    back = np.abs(q[-1] - q) >= n * TWO_PI
    if not np.any(back):
        return None
    k = int(np.flatnonzero(back)[-1])             # the last sample n turns or more back
    # q(t_a) = q_end -+ 2 pi n, between samples k and k + 1
    target = q[-1] - np.sign(q[-1] - q[k]) * n * TWO_PI
    return float(t[k] + (t[k + 1] - t[k]) * (target - q[k]) / (q[k + 1] - q[k]))


def _mean(t, q, t0, t1) -> float:
    """Mean rate ``(q(t1) - q(t0)) / (t1 - t0)``, ``q`` linear between samples."""
    return float((np.interp(t1, t, q) - np.interp(t0, t, q)) / (t1 - t0))


def speed_statistics(sol, joints=None) -> dict:
    """Steady-state speed of each independent coordinate of ``sol`` and its run-up (the
    module's definitions).

    Parameters
    ----------
    sol : Solution
        One run (no design axis): an ``analyze`` or ``simulate`` result.
    joints : sequence of str, optional
        The joints to describe; default the drivers' joints, then the free joints of a
        simulation (``sol.free``).

    Returns
    -------
    dict
        ``{joint: entry}``, ``entry`` with ``unit`` (``"rad/s"`` or ``"m/s"``), ``turns`` (the
        coordinate turns a full turn in the run), ``window`` (``over``, ``start_s``,
        ``end_s``), ``mean``, ``min``, ``max`` (in ``unit``), ``mean_rpm``, ``min_rpm``,
        ``max_rpm`` (a turning revolute coordinate only, else None),
        ``coefficient_of_fluctuation`` (or None), ``band`` (``[low, high]`` in ``unit``),
        ``run_up_time_s``, ``mean_change`` (in ``unit``, or None) and ``steady`` (or None). Empty with fewer than three finite samples.
    """
    m = sol.model
    names = [j.name for j in m.joints]
    if joints is None:
        joints = [d.joint for d in m.drivers] + [j for j in getattr(sol, "free", ())
                                                  if j not in {d.joint for d in m.drivers}]
    t_all = np.asarray(sol.t, float)
    ok = np.all([np.isfinite(sol.kin.q[..., names.index(j)]) & np.isfinite(
        sol.kin.qd[..., names.index(j)]) for j in joints], axis=0) if joints else None
    if not joints or np.sum(ok) < 3:
        return {}
    t = t_all[ok]
    q = {j: np.asarray(sol.kin.q[..., names.index(j)], float)[ok] for j in joints}
    qd = {j: np.asarray(sol.kin.qd[..., names.index(j)], float)[ok] for j in joints}
    angular = {j: jk.get(m.joint(j).kind).angular for j in joints}
    starts = {j: (_turns_back(t, q[j]), _turns_back(t, q[j], 2)) if angular[j] else (None, None)
              for j in joints}
    cycle = next((j for j in joints if starts[j][0] is not None), None)
    t_end = float(t[-1])
    out = {}
    for j in joints:
        if starts[j][0] is not None:
            (t_a, t_b), over = starts[j], "last turn"
        elif cycle is not None:
            (t_a, t_b), over = starts[cycle], f"last turn of {cycle}"
        else:
            t_a, t_b, over = 0.5 * (t[0] + t_end), float(t[0]), "second half of the run"
        # mean = (q(t_end) - q(t_a)) / (t_end - t_a); min, max of qd at the window's samples
        mean = _mean(t, q[j], t_a, t_end)
        inside = qd[j][t >= t_a]
        lo, hi = float(np.min(inside)), float(np.max(inside))
        peak = float(np.max(np.abs(inside)))
        # C_s = (max - min) / |mean|, for a coordinate that moves one way through the window
        cf = (hi - lo) / abs(mean) if lo * hi > 0 else None
        # the steady band and the last sample outside it
        margin = BAND_MARGIN * (hi - lo) + 1e-9 * peak
        band = (lo - margin, hi + margin)
        outside = np.flatnonzero((qd[j] < band[0]) | (qd[j] > band[1]))
        run_up = float(t[outside[-1] + 1]) if len(outside) else float(t[0])
        # steady: the mean moved from the window before by at most DRIFT of max - min
        change = None if t_b is None else mean - _mean(t, q[j], t_b, t_a)
        turns = starts[j][0] is not None
        out[j] = {"unit": "rad/s" if angular[j] else "m/s", "turns": turns,
                  "window": {"over": over, "start_s": float(t_a), "end_s": t_end},
                  "mean": mean, "min": lo, "max": hi,
                  "mean_rpm": mean * RPM if turns else None,
                  "min_rpm": lo * RPM if turns else None,
                  "max_rpm": hi * RPM if turns else None,
                  "coefficient_of_fluctuation": cf, "band": [band[0], band[1]],
                  "run_up_time_s": run_up, "mean_change": change,
                  "steady": None if change is None else
                  bool(abs(change) <= DRIFT * (hi - lo) + 1e-9 * peak)}
    return out
