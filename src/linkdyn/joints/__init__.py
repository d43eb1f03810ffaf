"""Joint kinds: one module per kind behind one protocol (:class:`JointKind`), and the registry.

Nothing else in linkdyn branches on a joint's kind: the solvers ask the kind (``get(name)``)
for its freedoms, placement, motion vector, cut rows, cut wrench and coordinate, and the model
file, the model, the layout and the design studies carry the numbers it declares per joint
(:attr:`JointKind.numbers`, gathered in :data:`NUMBERS`). To add a kind, write a module
defining a :class:`JointKind` subclass and its instance ``KIND``, and list it in
:data:`REGISTRY` below (``docs/architecture.md``).
"""

from __future__ import annotations

from . import (cam, coupling, distance, flat_cam, gear, prismatic, rack, revolute,
               rocker_cam, rocker_flat_cam, slot)
from ..steps import by_kind
from .base import WIDTH, JointKind, Number, frame, line_motion, no_contact

#: A free body's freedoms in the plane (Grübler–Kutzbach's ``3 (n - 1)``).
BODY_FREEDOMS = 3

#: Every joint kind by its model-file ``type``, in the order the docs list them.
REGISTRY: dict[str, JointKind] = {k.name: k for k in (revolute.KIND, prismatic.KIND,
                                                       slot.KIND,
                                                       gear.KIND, rack.KIND, distance.KIND,
                                                       cam.KIND, rocker_cam.KIND,
                                                       flat_cam.KIND, rocker_flat_cam.KIND,
                                                       coupling.KIND)}


def _numbers() -> dict[str, Number]:
    """Every number some kind declares, by name, in the order of first declaration; a name two
    kinds declare must mean the same (shape and unit)."""
    out: dict[str, Number] = {}
    for kind in REGISTRY.values():
        for x in kind.numbers:
            same = out.setdefault(x.name, x)
            if (same.shape, same.unit) != (x.shape, x.unit):
                raise TypeError(f"joint kind {kind.name!r} declares {x.name!r} with another "
                                f"shape or unit than an earlier kind")
    return out


#: Every per-joint number of the registered kinds, by name: each joint row of the numeric
#: layout has every one of them (a kind's own value, else the number's default).
NUMBERS: dict[str, Number] = _numbers()


#: Each kind's integer code, as the numeric layout and the compiled kernels carry it (0: none).
CODES: dict[str, int] = {name: k + 1 for k, name in enumerate(REGISTRY)}


def _dispatch(method: str):
    """The step ``f(code, *args)`` running ``method`` of the kind with that code (the kinds that
    define it: a kind that is never a tree joint has no ``place``)."""
    return by_kind([(CODES[name], getattr(kind, method)) for name, kind in REGISTRY.items()
                    if getattr(kind, method) is not None])


# the kinds' steps by code (linkdyn.steps), as the solvers of both backends call them
place = _dispatch("place")
motion = _dispatch("motion")
plus_motion = _dispatch("plus_motion")
plus_motion_rate = _dispatch("plus_motion_rate")
residual = _dispatch("residual")
selected = _dispatch("selected")
selected_rate = _dispatch("selected_rate")
wrench = _dispatch("wrench")
coordinate = _dispatch("coordinate")
#: a higher pair's contact parameter (the kinds that define ``locate``; 0 for every other code)
locate = by_kind([(CODES[name], kind.locate) for name, kind in REGISTRY.items()
                  if kind.locate is not None] + [(0, no_contact)])


class UnknownJointKind(ValueError):
    """A joint ``type`` that no registered kind has."""


def names() -> tuple[str, ...]:
    """The registered kinds' names (the model reader's list of joint types)."""
    return tuple(REGISTRY)


def get(name: str) -> JointKind:
    """The kind registered as ``name``; :class:`UnknownJointKind` names the known ones."""
    try:
        return REGISTRY[name]
    except (KeyError, TypeError):
        raise UnknownJointKind(f"unknown joint kind {name!r}; known kinds: "
                               + ", ".join(REGISTRY)) from None


__all__ = ["CODES", "WIDTH", "frame", "JointKind", "NUMBERS", "Number", "REGISTRY", "UnknownJointKind", "get", "line_motion", "names"]
