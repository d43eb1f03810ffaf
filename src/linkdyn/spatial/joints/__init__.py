"""Spatial joint kinds: one module per kind behind :class:`~.base.SpatialKind`, and the
registry (the spatial counterpart of :mod:`linkdyn.joints`, which
:func:`linkdyn.topology.registry` returns for a spatial model)."""

from __future__ import annotations

from . import cylindrical, prismatic, revolute, spherical, universal
from .base import Geometry, Pose, Rates, SpatialKind

#: A free body's freedoms in space (Grübler–Kutzbach's ``6 (n - 1)``).
BODY_FREEDOMS = 6

#: Every spatial joint kind by its model-file ``type``.
REGISTRY: dict[str, SpatialKind] = {k.name: k for k in (
    revolute.KIND, prismatic.KIND, cylindrical.KIND, universal.KIND, spherical.KIND)}


class UnknownJointKind(ValueError):
    """A joint ``type`` that no spatial kind has."""


def names() -> tuple[str, ...]:
    return tuple(REGISTRY)


def get(name: str) -> SpatialKind:
    try:
        return REGISTRY[name]
    except (KeyError, TypeError):
        raise UnknownJointKind(f"unknown spatial joint kind {name!r}; known kinds: "
                               + ", ".join(REGISTRY)) from None
