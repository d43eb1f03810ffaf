"""Display units: an SI value of a known quantity in the model file's own units, with the unit
named, and a number a person types (a CLI option, a metric constraint) read back to SI.

Everything a person reads (the printed summary, ``check``, the exit-3 messages, the sweep and
optimize printouts, ``summary.json``'s display fields, ``results.csv --units model``) goes
through :meth:`Units.show` (or :meth:`Units.value` for a bare number); the computation stays SI
inside. The file declares a length and an angle unit (``[units]``); every other unit follows from
them (``deg/s``, ``mm/s^2``, ``kg mm^2``); force is N, torque N m, mass kg, time s, energy J,
power W whatever the file.

>>> Units("mm", "deg").show(0.0381, "length")
'38.1 mm'
>>> Units("mm", "deg").parse("0.1", "length")    # a bare number is in the file's unit
0.0001
>>> Units("mm", "deg").parse("30deg", "angle") == math.radians(30)
True
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from .errors import ModelError
from .io.units import ANGLE_UNITS, LENGTH_UNITS

__all__ = ["Units", "QUANTITIES", "REPORT", "coordinate", "joint_units", "model_columns", "of"]

# the quantities a value may be: how its unit is made from the file's length L and angle A
QUANTITIES = ("length", "angle", "angular_rate", "angular_acceleration", "velocity",
              "acceleration", "force", "torque", "mass", "inertia", "energy", "power", "time",
              "stiffness", "angular_stiffness", "damping", "angular_damping", "pressure", "number")

_NUMBER = re.compile(r"\s*([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(.*?)\s*\Z")


def _aliases(name: str) -> str:
    """A unit as typed, normalized: spaces, ``*`` and ``²`` folded (``'kg*mm^2'``, ``'kg mm²'``,
    ``'kgmm2'`` are one unit)."""
    return name.replace("²", "2").replace("^", "").replace("*", "").replace(" ", "")


@dataclass(frozen=True)
class Units:
    """The display units of a model file: ``length`` (m, mm, cm, in) and ``angle`` (rad, deg).

    Attributes
    ----------
    length, angle : str
        Names as in ``[units]``.
    """

    length: str = "m"
    angle: str = "rad"

    @classmethod
    def of(cls, model) -> "Units":
        """The units of the file ``model`` came from (``Model.length_unit``, ``angle_unit``)."""
        return cls(getattr(model, "length_unit", "m"), getattr(model, "angle_unit", "rad"))

    def unit(self, quantity: str) -> tuple[str, float]:
        """``(name, SI size of one unit)`` of ``quantity`` in these units, e.g.
        ``('deg/s', pi/180)`` for ``'angular_rate'`` in a deg file."""
        L, A = self.length, self.angle
        l, a = LENGTH_UNITS[L], ANGLE_UNITS[A]
        table = {
            "length": (L, l), "angle": (A, a),
            "angular_rate": (f"{A}/s", a), "angular_acceleration": (f"{A}/s^2", a),
            "velocity": (f"{L}/s", l), "acceleration": (f"{L}/s^2", l),
            "force": ("N", 1.0), "torque": ("N m", 1.0), "mass": ("kg", 1.0),
            "inertia": (f"kg {L}^2", l * l), "energy": ("J", 1.0), "power": ("W", 1.0),
            "time": ("s", 1.0), "stiffness": (f"N/{L}", 1.0 / l),
            "angular_stiffness": (f"N m/{A}", 1.0 / a), "damping": (f"N s/{L}", 1.0 / l),
            "angular_damping": (f"N m s/{A}", 1.0 / a),
            "pressure": (f"N/{L}^2", 1.0 / (l * l)), "number": ("", 1.0)}
        if quantity not in table:
            raise KeyError(f"unknown quantity {quantity!r}; one of {', '.join(QUANTITIES)}")
        return table[quantity]

    def value(self, x, quantity: str):
        """An SI value (a number or an array) in these units (no unit attached)."""
        return np.asarray(x, float) / self.unit(quantity)[1] if np.ndim(x) else \
            float(x) / self.unit(quantity)[1]

    def show(self, x, quantity: str, digits: int = 6) -> str:
        """An SI value in these units with the unit named: ``'38.1 mm'``, ``'139.2 deg'``;
        ``'n/a'`` for None or a value that is not finite (a figure the run could not give)."""
        if x is None or not np.isfinite(x):
            return "n/a"
        name = self.unit(quantity)[0]
        return f"{self.value(x, quantity):.{digits}g} {name}".rstrip()

    def span(self, lo, hi, quantity: str, digits: int = 6) -> str:
        """A range of SI values in these units: ``'110 .. 250 deg'``."""
        a = self.show(lo, quantity, digits).removesuffix(" " + self.unit(quantity)[0])
        return f"{a} .. {self.show(hi, quantity, digits)}"

    @staticmethod
    def accepted(quantity: str) -> dict[str, float]:
        """Units a typed value of ``quantity`` may carry (name -> SI size): every unit of that
        quantity, not only the file's (``30deg`` in a rad file, ``0.1mm`` in an m file)."""
        out = {}
        for L in LENGTH_UNITS:
            for A in ANGLE_UNITS:
                name, size = Units(L, A).unit(quantity)
                out[name] = size
        if quantity == "angular_rate":
            out["rpm"] = 2 * math.pi / 60
        return out

    @staticmethod
    def size(unit: str, quantity: str) -> float | None:
        """The SI size of ``unit`` typed for ``quantity`` (spaces, ``^`` and ``*`` ignored:
        ``'kg mm^2'``, ``'kgmm2'``, ``'N m'``, ``'Nm'``), None if it is none of its units."""
        known = {_aliases(n): s for n, s in Units.accepted(quantity).items()}
        return known.get(_aliases(unit))

    def quantity_of(self, name: str) -> str | None:
        """The quantity whose unit in these units is ``name`` (``'mm'`` -> ``'length'``,
        ``'kg mm^2'`` -> ``'inertia'``, ``'rev/min'`` -> ``'angular_rate'``); None if none is."""
        if name == "rev/min":
            return "angular_rate"
        return next((q for q in QUANTITIES if q != "number" and self.unit(q)[0] == name), None)

    def parse(self, text, quantity: str, field: str = "", example: str = "") -> float:
        """A typed value to SI: a bare number is in these units (the file's), a number with a
        unit of the quantity in that unit (``'30deg'``, ``'0.1 mm'``, ``'45rpm'``).

        Raises
        ------
        ModelError
            Naming ``field`` when the text is no number or its unit is not one of the quantity.
        """
        name = self.unit(quantity)[0]
        m = _NUMBER.match(str(text))
        if m is None:
            raise ModelError(f"cannot read {str(text)!r} as a number", field=field,
                             fix=f"Give a number in the file's unit ({name or 'no unit'})"
                                 f"{', or with a unit, e.g. ' + example if example else ''}")
        number, unit = float(m.group(1)), m.group(2)
        if not np.isfinite(number):
            raise ModelError(f"{str(text)!r} is not finite", field=field,
                             fix="Give a finite number")
        if not unit:
            return number * self.unit(quantity)[1]
        size = self.size(unit, quantity)
        if size is None:
            raise ModelError(f"{str(text)!r}: '{unit}' is not a unit of "
                             f"{quantity.replace('_', ' ')}", field=field,
                             fix=f"Give the number alone (the file's unit, {name}) or with one "
                                 f"of {', '.join(self.accepted(quantity))}")
        return number * size


# the quantity of each SI unit a result column is in (``Solution.units``)
_SI_QUANTITY = {"s": "time", "rad": "angle", "m": "length", "rad/s": "angular_rate",
                "m/s": "velocity", "rad/s^2": "angular_acceleration", "m/s^2": "acceleration",
                "N": "force", "N m": "torque", "J": "energy", "W": "power", "kg": "mass",
                "kg m^2": "inertia"}


def model_columns(columns: dict, si_units: dict, units: Units) -> dict:
    """Result columns (name -> SI array, :attr:`linkdyn.Solution.columns`) in the model file's
    ``units``, each name followed by its unit: ``{'q_J1 [deg]': ..., 'x_coupler.P [mm]': ...}``
    (``results.csv --units model``). A column of a unit without a quantity here stays SI, named
    with its SI unit."""
    out = {}
    for name, values in columns.items():
        si = si_units.get(name, "")
        quantity = _SI_QUANTITY.get(si)
        unit, size = units.unit(quantity) if quantity else (si, 1.0)
        out[f"{name} [{unit}]" if unit else name] = np.asarray(values, float) / size
    return out


#: The report page's own display units: angles in deg, lengths of its geometry, paths and
#: key results in mm (its plots are otherwise SI): every deg and mm the page shows comes
#: through it.
REPORT = Units("mm", "deg")


def of(model) -> Units:
    """:meth:`Units.of`: the display units of ``model``."""
    return Units.of(model)


def coordinate(model, joint: str) -> str:
    """The quantity of a joint's coordinate ``q_<joint>``: ``'angle'`` (revolute) or
    ``'length'`` (prismatic, slot)."""
    from . import joints as jk
    return "angle" if jk.get(model.joint(joint).kind).angular else "length"


def joint_units(model) -> dict[str, tuple[str, float]]:
    """Every joint's coordinate unit in the file: ``{joint: (name, SI size)}``, as
    :class:`linkdyn.errors.AssemblyError` names its driver values."""
    u = Units.of(model)
    return {j.name: u.unit(coordinate(model, j.name)) for j in model.joints}
