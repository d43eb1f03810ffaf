"""``[units]``: the length and angle units of the numbers in a model file; every value is
converted to SI as it is read (mass is always kg, time s, force N)."""

from __future__ import annotations

import math
from typing import Any

from .reader import _Reader

LENGTH_UNITS = {"m": 1.0, "mm": 1e-3, "cm": 1e-2, "in": 0.0254}  # metres per unit
ANGLE_UNITS = {"rad": 1.0, "deg": math.pi / 180.0}  # radians per unit


def _units(r: _Reader, units: Any) -> None:
    units = r.table(units, "units", ("length", "angle"),
                    note="Mass is always kg, time s, force N; inertia is kg * length^2")
    if "length" in units:
        r.length_name = r.choice(units["length"], "units.length", LENGTH_UNITS, "length unit")
    if "angle" in units:
        r.angle_name = r.choice(units["angle"], "units.angle", ANGLE_UNITS, "angle unit")
    r.length, r.angle = LENGTH_UNITS[r.length_name], ANGLE_UNITS[r.angle_name]
