"""Motion laws: a rise from 0 to 1 over the normalized time (or cam angle) ``u`` in [0, 1].

Each law gives ``s(u)`` and its first three derivatives ``s', s'', s'''`` (per unit ``u``),
with ``s(0) = 0``, ``s(1) = 1`` and ``s'(0) = s'(1) = 0`` (the follower or joint starts and
ends at rest, so segments join a dwell or each other without a jump in velocity). A segment
of height ``h`` and duration ``T`` scales them to ``h s``, ``h s' / T``, ``h s'' / T^2``,
``h s''' / T^3`` (displacement, velocity, acceleration and jerk: SVAJ).

| law | ``s(u)`` | peak ``s'`` | peak ``|s''|`` | ends of ``s''`` |
|---|---|---|---|---|
| ``harmonic`` | ``(1 - cos pi u) / 2`` | ``pi / 2`` | ``pi^2 / 2`` | ``+-pi^2 / 2`` (a jump next to a dwell) |
| ``cycloidal`` | ``u - sin(2 pi u) / (2 pi)`` | 2 | ``2 pi`` | 0 |
| ``poly345`` | ``10 u^3 - 15 u^4 + 6 u^5`` | 15/8 | ``10 / sqrt(3)`` | 0 |
| ``poly4567`` | ``35 u^4 - 84 u^5 + 70 u^6 - 20 u^7`` | 35/16 | ``84 sqrt(5) / 25`` | 0, and jerk 0 |

| ``modified_sine`` | quarter sines of acceleration to ``u = 1/8`` and from ``7/8``, a half cosine between | ``4 pi / (pi + 4)`` | ``4 pi^2 / (pi + 4)`` | 0 |
| ``modified_trapezoid`` | quarter sines of acceleration at ``0``, ``3/8``, ``5/8``, ``7/8``, constant between | 2 | ``8 pi / (2 + pi)`` | 0 |

``dwell`` is ``s = 0`` throughout (the segment holds its start). The modified laws are written
for their first half and mirrored (``s(u) = 1 - s(1 - u)``); their peak acceleration ``A``
makes ``s(1/2) = 1/2``.
"""

from __future__ import annotations

import numpy as np

PI = np.pi


def _harmonic(u):
    a = PI * u
    return ((1 - np.cos(a)) / 2, PI / 2 * np.sin(a), PI ** 2 / 2 * np.cos(a),
            -PI ** 3 / 2 * np.sin(a))


def _cycloidal(u):
    a = 2 * PI * u
    return (u - np.sin(a) / (2 * PI), 1 - np.cos(a), 2 * PI * np.sin(a),
            4 * PI ** 2 * np.cos(a))


def _poly(coeffs):
    """The law ``sum c_k u^k`` and its derivatives, from ``{k: c_k}``."""
    def law(u):
        out = []
        for d in range(4):
            total = np.zeros_like(u)
            for k, c in coeffs.items():
                if k >= d:
                    f = float(np.prod(np.arange(k - d + 1, k + 1))) if d else 1.0
                    total = total + c * f * u ** (k - d)
            out.append(total)
        return tuple(out)
    return law


def _half(first):
    """A law symmetric about u = 1/2 (``s(u) = 1 - s(1 - u)``) from its first half
    ``first(u)``, u in [0, 1/2]: the rate and the jerk mirror, the acceleration changes sign."""
    def law(u):
        back = u > 0.5
        s, s1, s2, s3 = first(np.where(back, 1.0 - u, u))
        return (np.where(back, 1.0 - s, s), s1, np.where(back, -s2, s2), s3)
    return law


def _modified_sine_half(u):
    # a = A sin(4 pi u) to u = 1/8, then A cos(w (u - 1/8)), w = 4 pi / 3; A = 4 pi^2 / (pi + 4)
    A, k, w = 4 * PI ** 2 / (PI + 4), 4 * PI, 4 * PI / 3
    v1, s1 = A / k, A / k * (0.125 - 1 / k)
    x = u - 0.125
    first = u <= 0.125
    return (np.where(first, A / k * (u - np.sin(k * u) / k),
                     s1 + v1 * x + A / w ** 2 * (1 - np.cos(w * x))),
            np.where(first, A / k * (1 - np.cos(k * u)), v1 + A / w * np.sin(w * x)),
            np.where(first, A * np.sin(k * u), A * np.cos(w * x)),
            np.where(first, A * k * np.cos(k * u), -A * w * np.sin(w * x)))


def _modified_trapezoid_half(u):
    # a = A sin(4 pi u) to u = 1/8, A to 3/8, then A cos(4 pi (u - 3/8)); A = 8 pi / (2 + pi)
    A, k = 8 * PI / (2 + PI), 4 * PI
    v1, s1 = A / k, A / k * (0.125 - 1 / k)
    v2, s2 = v1 + A / 4, s1 + v1 / 4 + A / 32
    x, y = u - 0.125, u - 0.375
    rise, flat = u <= 0.125, u <= 0.375
    s = np.where(rise, A / k * (u - np.sin(k * u) / k),
                 np.where(flat, s1 + v1 * x + A / 2 * x * x,
                          s2 + v2 * y + A / k ** 2 * (1 - np.cos(k * y))))
    v = np.where(rise, A / k * (1 - np.cos(k * u)),
                 np.where(flat, v1 + A * x, v2 + A / k * np.sin(k * y)))
    a = np.where(rise, A * np.sin(k * u), np.where(flat, A, A * np.cos(k * y)))
    j = np.where(rise, A * k * np.cos(k * u), np.where(flat, 0.0, -A * k * np.sin(k * y)))
    return s, v, a, j


def _dwell(u):
    z = np.zeros_like(u)
    return z, z, z, z


#: Every law by its model-file name.
LAWS = {
    "dwell": _dwell,
    "harmonic": _harmonic,
    "cycloidal": _cycloidal,
    "poly345": _poly({3: 10.0, 4: -15.0, 5: 6.0}),
    "poly4567": _poly({4: 35.0, 5: -84.0, 6: 70.0, 7: -20.0}),
    "modified_sine": _half(_modified_sine_half),
    "modified_trapezoid": _half(_modified_trapezoid_half),
}


def rise(law: str, u) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(s, s', s'', s''')`` of ``law`` at ``u`` (any shape, clipped to [0, 1]); shape of ``u``."""
    u = np.clip(np.asarray(u, np.float64), 0.0, 1.0)
    return LAWS[law](u)
