"""Where the mechanism goes: the travel of its joints and the straightness of a point's path.

Joint travel (:func:`joint_travel`)
    Extreme values of each joint coordinate over the run (a slider's stroke, a rocker's swing),
    refined between samples by one Newton step on ``qd = 0``.

Path straightness (:func:`path_straightness`)
    For a named point over a range of the first driver's coordinate: the total-least-squares
    line through its samples (principal axis of their scatter), the maximum and RMS
    perpendicular distance from it, the width of the band between the two parallel lines that
    hold the path (for a circular arc of angle 2 alpha: the sagitta R (1 - cos alpha)) and the
    length it covers along the line. Samples weigh equally (uniform in time for the usual
    uniform sampling).
"""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from .. import joints as jk
from ..model import GROUND, Model
from .fourbar import _other
from ..planar import cross, first

TWO_PI = 2.0 * np.pi


def _extreme(t, q, qd, qdd, k, sign) -> float:
    """q[k] refined by one Newton step on qd = 0 when the extreme lies between samples."""
    if 0 < k < len(q) - 1 and np.isfinite(qdd[k]) and sign * qdd[k] < 0:
        dt = abs(qd[k] / qdd[k])
        if dt <= max(t[k + 1] - t[k], t[k] - t[k - 1]):
            return float(q[k] - 0.5 * qd[k] ** 2 / qdd[k])
    return float(q[k])


def joint_travel(sol, joint: str) -> tuple[float, float]:
    """Smallest and largest value of a joint coordinate over the run (rad or m)."""
    k = [j.name for j in sol.model.joints].index(joint)
    t = sol.t
    q, qd, qdd = sol.kin.q[..., k], sol.kin.qd[..., k], sol.kin.qdd[..., k]
    lo = _extreme(t, q, qd, qdd, int(np.nanargmin(q)), -1)
    hi = _extreme(t, q, qd, qdd, int(np.nanargmax(q)), +1)
    return lo, hi


def _parse_point(model: Model, point: str) -> tuple[str, str]:
    body, _, name = point.partition(".")
    names = [b.name for b in model.bodies]
    if body not in names or not name:
        raise ModelError(f"no body '{body}' for the path point '{point}'", field="--path-point",
                         fix="Give BODY.POINT with a body of the model: " + ", ".join(names))
    points = model.body(body).points
    if name not in points:
        raise ModelError(f"body '{body}' has no point '{name}'", field="--path-point",
                         fix=f"Points of '{body}': " + ", ".join(points))
    return body, name


def default_path_point(model: Model) -> str | None:
    """The only named point, not used by a joint, of a link not jointed to the ground (a coupler
    point such as Hoeken's ``coupler.P``); None if there is not exactly one."""
    on_ground = {_other(j, GROUND) for j in model.joints if GROUND in (j.body_a, j.body_b)}
    used = {(j.body_a, j.point_a) for j in model.joints} | {(j.body_b, j.point_b)
                                                            for j in model.joints}
    free = [f"{b.name}.{p}" for b in model.moving_bodies if b.name not in on_ground
            for p in b.points if (b.name, p) not in used]
    return free[0] if len(free) == 1 else None


def _in_range(model: Model, q: np.ndarray, q_range) -> np.ndarray:
    """Samples whose first driver coordinate lies in ``q_range = (a, b)``; for a revolute
    driver the angles from a counter-clockwise to b, taken modulo 2 pi."""
    a, b = (float(x) for x in q_range)
    if not jk.get(model.joint(model.drivers[0].joint).kind).angular:
        return (q >= min(a, b) - 1e-12) & (q <= max(a, b) + 1e-12)
    if b - a >= TWO_PI:
        return np.isfinite(q)
    width = np.mod(b - a, TWO_PI)
    tol = 1e-9
    return np.mod(q - a + tol, TWO_PI) <= width + 2 * tol


def path_straightness(sol, point: str, q_range=None) -> dict:
    """Straightness of a point's path (see the module docstring).

    Parameters
    ----------
    point : str
        ``'BODY.POINT'``.
    q_range : (float, float) or None
        Range of the first driver's coordinate (rad or m); None for the whole run.

    Returns
    -------
    dict with ``point``, ``range``, ``samples``, ``centroid_m`` (2), ``direction`` (unit, 2),
    ``max_deviation_m``, ``rms_deviation_m``, ``band_m``, ``length_m``.
    """
    m = sol.model
    body, name = _parse_point(m, point)
    xy = sol.point(body, name)
    sel = np.all(np.isfinite(xy), axis=-1)
    if q_range is not None:
        if not m.drivers:
            raise ModelError("--path-range needs a driver", field="--path-range",
                             fix="Drop --path-range")
        k = [j.name for j in m.joints].index(m.drivers[0].joint)
        sel &= _in_range(m, sol.kin.q[..., k], q_range)
    if np.sum(sel) < 3:
        raise ModelError(f"the driver range {q_range} holds {int(np.sum(sel))} samples of the run",
                         field="--path-range",
                         fix="Give a range A:B of the first driver's coordinate (rad or m) that "
                             "the run covers, with at least 3 samples")
    pts = xy[sel]
    c = pts.mean(axis=0)
    # principal axis of the scatter: the total-least-squares line
    _, _, vt = np.linalg.svd(pts - c, full_matrices=False)
    u = vt[0] * (1.0 if vt[0][np.argmax(np.abs(vt[0]))] > 0 else -1.0)
    along = (pts - c) @ u
    dev = cross(first(u), first(pts - c))  # signed distance from the line
    return {"point": point,
            "range": None if q_range is None else [float(x) for x in q_range],
            "samples": int(np.sum(sel)),
            "centroid_m": c.tolist(), "direction": u.tolist(),
            "max_deviation_m": float(np.max(np.abs(dev))),
            "rms_deviation_m": float(np.sqrt(np.mean(dev ** 2))),
            "band_m": float(np.max(dev) - np.min(dev)),
            "length_m": float(np.max(along) - np.min(along))}
