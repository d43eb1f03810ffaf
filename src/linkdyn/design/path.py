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

import warnings

import numpy as np

from ..errors import ModelError
from .. import joints as jk
from ..model import GROUND, Model
from .fourbar import _other
from ..planar import cross

TWO_PI = 2.0 * np.pi


def _extreme(t, q, qd, qdd, k, sign):
    """q at sample ``k`` (one per leading index: ``k`` (...,) for q (..., T)) refined by one
    Newton step on qd = 0 when the extreme lies between samples:
    ``q_k - qd_k^2 / (2 qdd_k)``, where qdd has the extreme's sign and ``|qd_k / qdd_k|`` is
    within a sample step."""
    take = lambda x: np.take_along_axis(x, k[..., None], axis=-1)[..., 0]   # noqa: E731
    qk, qdk, qddk = take(q), take(qd), take(qdd)
    inner = (k > 0) & (k < q.shape[-1] - 1)
    h = np.maximum(t[np.minimum(k + 1, len(t) - 1)] - t[k], t[k] - t[np.maximum(k - 1, 0)])
    with np.errstate(divide="ignore", invalid="ignore"):
        ok = inner & np.isfinite(qddk) & (sign * qddk < 0) & (np.abs(qdk / qddk) <= h)
        return np.where(ok, qk - 0.5 * qdk ** 2 / qddk, qk)


def travel(t, q, qd, qdd):
    """Smallest and largest value of a coordinate over the last (time) axis, each refined
    between samples (:func:`_extreme`); finite samples only, NaN where none is.

    Parameters
    ----------
    t : ndarray (T,)
        Sample times, s.
    q, qd, qdd : ndarray (..., T)
        The coordinate and its rates (rad or m, per s, per s^2).

    Returns
    -------
    lo, hi : ndarray (...,)
    """
    q, qd, qdd = (np.asarray(x, float) for x in (q, qd, qdd))
    ok = np.isfinite(q)
    kmin = np.argmin(np.where(ok, q, np.inf), axis=-1)
    kmax = np.argmax(np.where(ok, q, -np.inf), axis=-1)
    some = np.any(ok, axis=-1)
    return (np.where(some, _extreme(t, q, qd, qdd, kmin, -1), np.nan),
            np.where(some, _extreme(t, q, qd, qdd, kmax, +1), np.nan))


def joint_travel(sol, joint: str) -> tuple[float, float]:
    """Smallest and largest value of a joint coordinate over the run (rad or m)."""
    k = [j.name for j in sol.model.joints].index(joint)
    lo, hi = travel(sol.t, sol.kin.q[..., k], sol.kin.qd[..., k], sol.kin.qdd[..., k])
    return float(lo), float(hi)


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
    c, u, dev = line_fit(xy, sel)
    along = np.where(sel, np.sum((xy - c) * u, axis=-1), np.nan)
    return {"point": point,
            "range": None if q_range is None else [float(x) for x in q_range],
            "range_unit": None if q_range is None else (
                "rad" if jk.get(m.joint(m.drivers[0].joint).kind).angular else "m"),
            "samples": int(np.sum(sel)),
            "centroid_m": c.tolist(), "direction": u.tolist(),
            "max_deviation_m": float(max_deviation(dev)),
            "rms_deviation_m": float(np.sqrt(np.nanmean(dev ** 2))),
            "band_m": float(np.nanmax(dev) - np.nanmin(dev)),
            "length_m": float(np.nanmax(along) - np.nanmin(along))}


def line_fit(xy, sel):
    """Total-least-squares line through the selected samples of a path, batched.

    Parameters
    ----------
    xy : ndarray (..., T, 2)
        Path, m, global frame.
    sel : ndarray (..., T) bool
        Samples to fit (broadcast against ``xy[..., 0]``); non-finite points are left out.

    Returns
    -------
    c : ndarray (..., 2)
        Centroid of the selected samples, m.
    u : ndarray (..., 2)
        Unit direction of the line, its largest component positive.
    dev : ndarray (..., T)
        Signed perpendicular distance of each sample from the line, m (NaN where not selected).
    """
    # on the two components, each (..., T) (a batch's contiguous arrays, not strided by 2)
    x, y = xy[..., 0], xy[..., 1]
    sel = np.broadcast_to(sel, x.shape) & np.isfinite(x) & np.isfinite(y)
    n = np.sum(sel, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        c = (np.sum(np.where(sel, x, 0.0), axis=-1) / n, np.sum(np.where(sel, y, 0.0), axis=-1) / n)
    d = (np.where(sel, x - c[0][..., None], 0.0), np.where(sel, y - c[1][..., None], 0.0))
    # principal axis of the scatter S = sum d d^T: angle theta with tan 2 theta = 2 Sxy / (Sxx - Syy)
    sxx, syy = np.sum(d[0] * d[0], -1), np.sum(d[1] * d[1], -1)
    sxy = np.sum(d[0] * d[1], -1)
    theta = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    u = (np.cos(theta), np.sin(theta))
    # the direction's largest component positive
    flip = np.where(np.abs(u[1]) > np.abs(u[0]), u[1], u[0]) < 0
    u = (np.where(flip, -u[0], u[0]), np.where(flip, -u[1], u[1]))
    dev = np.where(sel, cross((u[0][..., None], u[1][..., None]), d), np.nan)
    return np.stack(c, axis=-1), np.stack(u, axis=-1), dev


def max_deviation(dev):
    """Largest perpendicular distance (...,) m from the fitted line, over the selected samples
    (``dev`` from :func:`line_fit`; NaN where none is selected)."""
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a design without samples is NaN
        return np.nanmax(np.abs(dev), axis=-1)
