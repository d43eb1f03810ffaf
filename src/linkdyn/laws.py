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

from .steps import by_kind, select, step

PI = np.pi

# Each law is a step (linkdyn.steps): u (an array, or one float in a compiled loop) -> the
# tuple (s, s', s'', s'''), so that the cam joint's steps evaluate the same laws on both backends.


@step
def _harmonic(u):
    a = PI * u
    return ((1 - np.cos(a)) / 2, PI / 2 * np.sin(a), PI ** 2 / 2 * np.cos(a),
            -PI ** 3 / 2 * np.sin(a))


@step
def _cycloidal(u):
    a = 2 * PI * u
    return (u - np.sin(a) / (2 * PI), 1 - np.cos(a), 2 * PI * np.sin(a),
            4 * PI ** 2 * np.cos(a))


@step
def _poly345(u):
    # 10 u^3 - 15 u^4 + 6 u^5 and its derivatives
    return (u ** 3 * (10.0 + u * (-15.0 + 6.0 * u)), u * u * (30.0 + u * (-60.0 + 30.0 * u)),
            u * (60.0 + u * (-180.0 + 120.0 * u)), 60.0 + u * (-360.0 + 360.0 * u))


@step
def _poly4567(u):
    # 35 u^4 - 84 u^5 + 70 u^6 - 20 u^7 and its derivatives
    return (u ** 4 * (35.0 + u * (-84.0 + u * (70.0 - 20.0 * u))),
            u ** 3 * (140.0 + u * (-420.0 + u * (420.0 - 140.0 * u))),
            u * u * (420.0 + u * (-1680.0 + u * (2100.0 - 840.0 * u))),
            u * (840.0 + u * (-5040.0 + u * (8400.0 - 4200.0 * u))))


def _half(first):
    """A law symmetric about u = 1/2 (``s(u) = 1 - s(1 - u)``) from its first half
    ``first(u)``, u in [0, 1/2]: the rate and the jerk mirror, the acceleration changes sign."""
    def law(u):
        back = u > 0.5
        s, s1, s2, s3 = first(select(back, 1.0 - u, u))
        return (select(back, 1.0 - s, s), s1, select(back, -s2, s2), s3)
    law.__name__ = law.__qualname__ = first.__name__[:-5]
    return step(law)


@step
def _modified_sine_half(u):
    # a = A sin(4 pi u) to u = 1/8, then A cos(w (u - 1/8)), w = 4 pi / 3; A = 4 pi^2 / (pi + 4)
    A, k, w = 4 * PI ** 2 / (PI + 4), 4 * PI, 4 * PI / 3
    v1, s1 = A / k, A / k * (0.125 - 1 / k)
    x = u - 0.125
    first = u <= 0.125
    return (select(first, A / k * (u - np.sin(k * u) / k),
                   s1 + v1 * x + A / w ** 2 * (1 - np.cos(w * x))),
            select(first, A / k * (1 - np.cos(k * u)), v1 + A / w * np.sin(w * x)),
            select(first, A * np.sin(k * u), A * np.cos(w * x)),
            select(first, A * k * np.cos(k * u), -A * w * np.sin(w * x)))


@step
def _modified_trapezoid_half(u):
    # a = A sin(4 pi u) to u = 1/8, A to 3/8, then A cos(4 pi (u - 3/8)); A = 8 pi / (2 + pi)
    A, k = 8 * PI / (2 + PI), 4 * PI
    v1, s1 = A / k, A / k * (0.125 - 1 / k)
    v2, s2 = v1 + A / 4, s1 + v1 / 4 + A / 32
    x, y = u - 0.125, u - 0.375
    rise, flat = u <= 0.125, u <= 0.375
    s = select(rise, A / k * (u - np.sin(k * u) / k),
               select(flat, s1 + v1 * x + A / 2 * x * x,
                      s2 + v2 * y + A / k ** 2 * (1 - np.cos(k * y))))
    v = select(rise, A / k * (1 - np.cos(k * u)),
               select(flat, v1 + A * x, v2 + A / k * np.sin(k * y)))
    a = select(rise, A * np.sin(k * u), select(flat, A + 0.0 * u, A * np.cos(k * y)))
    j = select(rise, A * k * np.cos(k * u), select(flat, 0.0 * u, -A * k * np.sin(k * y)))
    return s, v, a, j


@step
def _dwell(u):
    z = 0.0 * u
    return z, z, z, z


#: Every law by its model-file name.
LAWS = {
    "dwell": _dwell,
    "harmonic": _harmonic,
    "cycloidal": _cycloidal,
    "poly345": _poly345,
    "poly4567": _poly4567,
    "modified_sine": _half(_modified_sine_half),
    "modified_trapezoid": _half(_modified_trapezoid_half),
}

#: Each law's integer code (its place in :data:`LAWS`), as a joint's numbers carry it.
CODES = {name: k for k, name in enumerate(LAWS)}

#: The step ``law(code, u) -> (s, s', s'', s''')`` of the law with that code.
law = by_kind([(CODES[name], fn) for name, fn in LAWS.items()])


def rise(law: str, u) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(s, s', s'', s''')`` of ``law`` at ``u`` (any shape, clipped to [0, 1]); shape of ``u``."""
    u = np.clip(np.asarray(u, np.float64), 0.0, 1.0)
    return tuple(np.broadcast_to(x, u.shape) * 1.0 for x in LAWS[law](u))
