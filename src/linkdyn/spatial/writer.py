"""The bodies and joints of a spatial model as the model file writes them (the inverse of
:mod:`.reader`), in the file's units: each body's design pose (``origin``, ``rotation`` as a
rotation vector), its points, mass centre and inertia tensor in its frame; each joint's
``axis`` and ``axis2`` in its bodies' frames. :func:`linkdyn.io.writer.model_to_dict` writes
the rest (drivers, loads, topology, analysis) as for planar models."""

from __future__ import annotations

import numpy as np

from ..model import GROUND
from . import algebra as sa
from . import joints as sj


def rotation_vector_of(r: np.ndarray) -> np.ndarray:
    """The rotation vector (3,), rad, of the rotation ``r`` (3, 3): ``theta e`` with the unit
    quaternion ``[cos(theta/2), sin(theta/2) e]`` (accurate near 0 and near pi), the inverse
    of :func:`.algebra.rotation_vector`."""
    q = sa.quaternion(np.asarray(r, float)[None])[0]
    s = float(np.linalg.norm(q[1:]))
    if s == 0.0:
        return np.zeros(3)
    return 2.0 * np.arctan2(s, q[0]) * q[1:] / s


def bodies(model, L: float, A: float, num, vec) -> list[dict]:
    """``[[bodies]]`` of the spatial ``model`` in the file's length ``L`` and angle ``A``
    units (m and rad per unit); ``num`` and ``vec`` write a number and a vector."""
    out = []
    for b in model.bodies:
        entry: dict = {"name": b.name, "points": {k: vec(v, L) for k, v in b.points.items()}}
        if b.name != GROUND:
            i = np.asarray(b.inertia)   # principal moments where the tensor is diagonal
            diagonal = np.count_nonzero(i - np.diag(np.diag(i))) == 0
            entry.update(mass=num(b.mass), com=vec(b.com, L),
                         inertia=vec(np.diag(i), L ** 2) if diagonal else
                         [vec(row, L ** 2) for row in i])
            if np.any(b.origin != 0):
                entry["origin"] = vec(b.origin, L)
            if not np.array_equal(b.rotation, np.eye(3)):
                entry["rotation"] = vec(rotation_vector_of(b.rotation), A)
        out.append(entry)
    return out


def joints(model, num, vec) -> list[dict]:
    """``[[joints]]`` of the spatial ``model``: the axes (unit, dimensionless) its kinds take."""
    out = []
    for j in model.joints:
        entry = {"name": j.name, "type": j.kind,
                 "connect": [f"{j.body_a}.{j.point_a}", f"{j.body_b}.{j.point_b}"]}
        for key in sj.get(j.kind).keys:
            entry[key] = vec(getattr(j, key))
        out.append(entry)
    return out


def angular(model, name: str) -> bool | None:
    """Whether the joint coordinate ``name`` (``J1``, ``J3.1``, ``J2.s``, as ``[initial]``
    names it) is an angle; None when no joint of ``model`` has it."""
    for j in model.joints:
        for suffix, ang in sj.get(j.kind).coordinates_named:
            if f"{j.name}{suffix}" == name:
                return bool(ang)
    return None
