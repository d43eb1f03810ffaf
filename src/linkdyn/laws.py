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

``dwell`` is ``s = 0`` throughout (the segment holds its start).
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
}


def rise(law: str, u) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(s, s', s'', s''')`` of ``law`` at ``u`` (any shape, clipped to [0, 1]); shape of ``u``."""
    u = np.clip(np.asarray(u, np.float64), 0.0, 1.0)
    return LAWS[law](u)
