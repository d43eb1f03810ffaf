"""``[[loads]]``: point forces and torques (numbers or formulas of t), springs and dampers."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..model import GROUND, Body, Load
from .reader import _Reader, _count, _entry_field, _type_name

LOAD_KEYS = {"force": ("kind", "name", "body", "point", "value"),
             "torque": ("kind", "name", "body", "value"),
             "spring": ("kind", "name", "body", "point", "body2", "point2", "stiffness",
                        "free_length"),
             "damper": ("kind", "name", "body", "point", "body2", "point2", "damping")}


@dataclass(frozen=True)
class _TimeFunction:
    """A load value: each component a constant or an expression of t; shape ``t.shape + shape``."""

    components: tuple  # floats or linkdyn.expr.Expr
    vector: bool

    def __call__(self, t) -> np.ndarray:
        t = np.asarray(t, dtype=float)
        out = np.stack([np.broadcast_to(c(t) if callable(c) else c, t.shape).astype(float)
                        for c in self.components], axis=-1)
        return out if self.vector else out[..., 0]


def _load_value(r: _Reader, value: Any, f: str, vector: bool) -> _TimeFunction:
    def component(c: Any, field: str, unit: str):
        return r.expression(c, field, unit) if isinstance(c, str) else r.number(c, field, unit)

    if vector:
        if not isinstance(value, list) or len(value) != 2:
            got = _count(len(value)) if isinstance(value, list) else _type_name(value)
            r.fail(f, f"expected [fx, fy] (2 numbers or formulas of t), got {got}",
                   'Write value = [-20.0, 35.0] (N, global frame) or value = ["10*sin(t)", "0"]')
        return _TimeFunction(tuple(component(c, f"{f}[{k}]", "N") for k, c in enumerate(value)),
                             vector=True)
    return _TimeFunction((component(value, f, "N m"),), False)


def _loads(r: _Reader, entries: Any, bodies: dict[str, Body]) -> list[Load]:
    loads: list[Load] = []
    L, Lu = r.length, r.length_name
    for i, entry in enumerate(r.entries(entries, "loads")):
        f = _entry_field("loads", i, entry)
        if "kind" not in entry:
            r.fail(f"{f}.kind", "missing required key 'kind'",
                   f"Add kind = one of {', '.join(LOAD_KEYS)}")
        kind = r.choice(entry["kind"], f"{f}.kind", LOAD_KEYS, "load kind")
        need = tuple(k for k in LOAD_KEYS[kind] if k != "name")
        r.table(entry, f, LOAD_KEYS[kind], required=need, what=f'keys for kind = "{kind}"')
        name = r.name(entry["name"], f"{f}.name") if "name" in entry else ""
        body = r.choice(entry["body"], f"{f}.body", bodies, "body", "bodies")
        point = (r.point(body, bodies[body].points, entry["point"], f"{f}.point")
                 if "point" in entry else None)
        if kind in ("force", "torque"):
            if body == GROUND:
                r.fail(f"{f}.body", f"a {kind} on the ground has no effect",
                       "Apply it to a moving body")
            value = _load_value(r, entry["value"], f"{f}.value", vector=kind == "force")
            loads.append(Load(kind, body, point, value, name=name))
            continue
        body2 = r.choice(entry["body2"], f"{f}.body2", bodies, "body", "bodies")
        point2 = r.point(body2, bodies[body2].points, entry["point2"], f"{f}.point2")
        if body2 == body:
            r.fail(f"{f}.body2", f"both ends of the {kind} are on body '{body}'",
                   f"Attach the {kind} between two different bodies")
        if kind == "spring":
            k = r.number(entry["stiffness"], f"{f}.stiffness", f"N/{Lu}", nonnegative=True)
            l0 = r.number(entry["free_length"], f"{f}.free_length", Lu, nonnegative=True)
            loads.append(Load(kind, body, point, None, body2, point2, stiffness=k / L,
                              free_length=l0 * L, name=name))
        else:
            c = r.number(entry["damping"], f"{f}.damping", f"N s/{Lu}", nonnegative=True)
            loads.append(Load(kind, body, point, None, body2, point2, damping=c / L, name=name))
    return loads
