"""Joint kinds: one module per kind behind one protocol (:class:`JointKind`), and the registry.

Nothing else in linkdyn branches on a joint's kind: the solvers ask the kind (``get(name)``)
for its freedoms, placement, motion vector, cut rows, cut wrench and coordinate. To add a kind,
write a module defining a :class:`JointKind` subclass and its instance ``KIND``, and list it in
:data:`REGISTRY` below (``docs/architecture.md``).
"""

from __future__ import annotations

from . import prismatic, revolute, slot
from .base import JointKind, line_motion

#: Every joint kind by its model-file ``type``, in the order the docs list them.
REGISTRY: dict[str, JointKind] = {k.name: k for k in (revolute.KIND, prismatic.KIND,
                                                       slot.KIND)}


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


__all__ = ["JointKind", "REGISTRY", "UnknownJointKind", "get", "line_motion", "names"]
