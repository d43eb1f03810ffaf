"""The bodies and joints of a spatial model (``Model.space == "spatial"``), SI units.

A spatial :class:`~linkdyn.model.Model` holds these in ``bodies`` and ``joints``; its
``gravity`` is (3,), its loads' values are 3-vectors (forces and torques, global).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class Body:
    """A rigid body in space.

    Attributes
    ----------
    name : str
    points : dict[str, ndarray (3,)]
        Named points in the body's frame, m.
    mass : float
        kg (0 for the ground).
    com : ndarray (3,)
        Mass centre in the body's frame, m.
    inertia : ndarray (3, 3)
        Inertia tensor about the mass centre in the body's frame, kg m^2.
    origin : ndarray (3,)
        The body frame's origin at the design pose, global, m.
    rotation : ndarray (3, 3)
        The body frame's orientation at the design pose (body to global).
    """

    name: str
    points: dict
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3))
    rotation: np.ndarray = field(default_factory=lambda: np.eye(3))


@dataclass(frozen=True)
class Joint:
    """A spatial joint between ``body_a`` (first, point ``point_a``) and ``body_b`` (second,
    point ``point_b``) of kind ``kind`` (:mod:`linkdyn.spatial.joints`).

    ``axis`` (3,): unit axis in ``body_a``'s frame (revolute, prismatic, cylindrical,
    universal); ``axis2`` (3,): the universal joint's second axis in ``body_b``'s frame.
    Unused ones are zeros."""

    name: str
    kind: str
    body_a: str
    point_a: str
    body_b: str
    point_b: str
    axis: np.ndarray = field(default_factory=lambda: np.zeros(3))
    axis2: np.ndarray = field(default_factory=lambda: np.zeros(3))
