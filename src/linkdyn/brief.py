"""Short ``repr`` of result objects: a console or notebook that echoes a result shows its kind
and the shapes it holds, never thousands of numbers (``repr(Simulation)`` was 32,853
characters)."""

from __future__ import annotations

import dataclasses

import numpy as np

__all__ = ["brief", "brief_repr", "LIMIT"]

LIMIT = 400   # characters of a brief repr at most


def brief(value, depth: int = 0) -> str:
    """One short description of a field's value: an array by its shape (``array(4, 361)``), a
    sequence of arrays by its length and the first shape, a nested result by its kind, a short
    scalar or string as itself."""
    if isinstance(value, np.ndarray):
        return f"array{value.shape}" if value.ndim != 1 else f"array({value.shape[0]},)"
    if isinstance(value, (tuple, list)) and value and depth < 1:
        inner = brief(value[0], depth + 1)
        return f"{len(value)} x {inner}" if len(value) > 1 else f"[{inner}]"
    if isinstance(value, dict):
        return f"dict({len(value)})"
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return type(value).__name__
    text = repr(value)
    return text if len(text) <= 40 else type(value).__name__


def brief_repr(self) -> str:
    """``<KinematicSolution pose=Pose, q=array(4, 361), ...>``: every dataclass field (shown
    in :func:`repr` by the class) briefly, at most :data:`LIMIT` characters."""
    parts = [f"{f.name}={brief(getattr(self, f.name, None))}"
             for f in dataclasses.fields(self) if f.repr]
    text = f"<{type(self).__name__} {', '.join(parts)}>"
    return text if len(text) <= LIMIT else text[:LIMIT - 4] + "...>"
