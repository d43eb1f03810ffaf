"""User-facing errors. The CLI maps them to exit codes; nothing else catches them."""

from __future__ import annotations

import contextlib
import functools
import warnings


class LinkdynError(Exception):
    """Base class of errors meant for the user (no traceback is shown for these)."""

    exit_code = 1


class ModelError(LinkdynError):
    """An invalid model file or argument (exit status 2).

    Parameters
    ----------
    message : str
        What is wrong.
    file : str
        The model file ('' when the model was built in Python).
    field : str
        Dotted path of the offending field, e.g. ``joints[2].connect``.
    fix : str
        How to fix it.
    """

    exit_code = 2

    def __init__(self, message: str, *, file: str = "", field: str = "", fix: str = ""):
        self.message, self.file, self.field, self.fix = message, file, field, fix
        super().__init__(self.__str__())

    def __str__(self) -> str:
        where = ": ".join(x for x in (self.file, self.field) if x)
        text = f"{where}: {self.message}" if where else self.message
        return f"{text}. {self.fix}" if self.fix else text


class AssemblyError(LinkdynError):
    """The mechanism cannot be assembled, or passes a singular position (exit status 3).

    Parameters
    ----------
    message : str
    time : float or None
        First time (s) where it fails.
    drivers : dict[str, float]
        Driver joint coordinates at that time (rad or m).
    units : dict[str, tuple[str, float]] or None
        Each joint's coordinate unit in the model file, ``{joint: (name, SI size)}``
        (:func:`linkdyn.units.joint_units`): the message gives the driver values in it, with the
        unit; None: SI numbers without a unit (a model built in Python has no file units).
    """

    exit_code = 3

    def __init__(self, message: str, *, file: str = "", time: float | None = None,
                 drivers: dict[str, float] | None = None, fix: str = "",
                 units: dict[str, tuple[str, float]] | None = None):
        self.message, self.file, self.time, self.drivers, self.fix = (
            message, file, time, drivers or {}, fix)
        self.units = units or {}
        super().__init__(self.__str__())

    def _driver(self, joint: str, value: float) -> str:
        """``q_J1 = 139 deg``: a driver value in the file's unit (SI without units)."""
        name, size = self.units.get(joint, ("", 1.0))
        return f"q_{joint} = {value / size:.6g} {name}".rstrip()

    def __str__(self) -> str:
        parts = [self.file] if self.file else []
        if self.time is not None:
            drv = ", ".join(self._driver(k, v) for k, v in self.drivers.items())
            parts.append(f"at t = {self.time:.6g} s" + (f" ({drv})" if drv else ""))
        text = ": ".join(parts + [self.message])
        return f"{text}. {self.fix}" if self.fix else text


class InvalidValue(ModelError, ValueError):
    """An invalid value given in Python (a formula's text, a motion's number or table rows).

    A :class:`ModelError` (exit status 2, the field in its message) that is also a ``ValueError``,
    so code that catches ``ValueError`` keeps working.
    """


class ArgumentError(ModelError, TypeError):
    """An argument of the wrong type given to the Python API (``analyze``, ``simulate``,
    ``save``, ``load``): a :class:`ModelError` (exit status 2) whose field is the argument's name,
    and a ``TypeError``, so code that catches ``TypeError`` keeps working."""


def wrong_type(func: str, name: str, value, expected: str) -> ArgumentError:
    """The :class:`ArgumentError` of ``func``'s argument ``name`` holding ``value`` where
    ``expected`` (in words) is wanted."""
    return ArgumentError(f"{func}: {name} must be {expected}, not {type(value).__name__}",
                         field=name, fix=f"Pass {name} as {expected}")


@contextlib.contextmanager
def quiet_numerics():
    """Run numpy without printing floating-point ``RuntimeWarning``s: a number that is not
    finite is found and reported by the checks (an error naming the field or the time, or a NaN
    row flagged as invalid), never as a warning with a source path."""
    import numpy as np

    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        yield


def quiet(func):
    """Decorator: run ``func`` under :func:`quiet_numerics`."""
    @functools.wraps(func)
    def run(*args, **kwargs):
        with quiet_numerics():
            return func(*args, **kwargs)
    return run
