"""``[[loads]]``: point forces and torques (numbers or formulas of t and of the joints' motion),
loads inside joints, springs and dampers."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .. import expr as _expr
from .. import joints as jk
from ..model import GROUND, Body, Joint, Load, default_transition_speed
from .reader import _Reader, _count, _entry_field, _type_name

LOAD_KEYS = {"force": ("kind", "name", "body", "point", "value"),
             "torque": ("kind", "name", "body", "value"),
             "spring": ("kind", "name", "body", "point", "body2", "point2", "stiffness",
                        "free_length"),
             "damper": ("kind", "name", "body", "point", "body2", "point2", "damping"),
             "joint_torque": ("kind", "name", "joint", "value"),
             "joint_force": ("kind", "name", "joint", "value"),
             "friction": ("kind", "name", "joint", "coefficient", "radius", "transition_speed",
                          "static_coefficient", "stiction_speed", "viscous", "preload")}
#: keys a kind may leave out (the rest but ``name`` are required)
OPTIONAL_KEYS = {"friction": ("radius", "transition_speed", "static_coefficient",
                              "stiction_speed", "viscous", "preload")}


@dataclass(frozen=True)
class _TimeFunction:
    """A load value: each component a constant or a formula of t and of the joints' motion;
    shape ``t.shape + shape`` (the batch shape of the motion when it is given).

    ``state`` lists the joint variables the formulas use as ``(name, joint, k, unit)``: ``joint``
    the joint's index in the model, ``k`` 0 for the coordinate ``q_<joint>``, 1 for the rate
    ``qd_<joint>``; ``unit`` the SI size of the file's unit (formulas read the file's angle or
    length unit, per second for rates). ``motion`` is ``(q, qd)``, per-joint lists of SI arrays.
    """

    components: tuple  # floats or linkdyn.expr.Expr
    vector: bool
    state: tuple = ()

    @property
    def state_variables(self) -> tuple[str, ...]:
        return tuple(v[0] for v in self.state)

    def __call__(self, t, motion=None) -> np.ndarray:
        values = {"t": np.asarray(t, dtype=float)}
        for name, joint, k, unit in self.state:
            values[name] = np.asarray(motion[k][joint]) / unit
        shape = np.broadcast_shapes(*(v.shape for v in values.values()))
        out = np.stack([np.broadcast_to(c.evaluate(**values) if isinstance(c, _expr.Expr) else c,
                                        shape).astype(float) for c in self.components], axis=-1)
        return out if self.vector else out[..., 0]


def _variables(r: _Reader, joints: dict[str, Joint]) -> dict[str, tuple]:
    """Joint variables a load formula may use: ``q_<joint>``, ``qd_<joint>`` -> (joint, k, unit)."""
    out = {}
    for index, (name, j) in enumerate(joints.items()):
        kind = r.kind(j.kind)
        if kind.freedoms != 1:          # a joint of several coordinates: none by one name
            continue
        unit = r.angle if kind.angular else r.length
        out[f"q_{name}"], out[f"qd_{name}"] = (index, 0, unit), (index, 1, unit)
    return {k: v for k, v in out.items() if k.isidentifier()}


def _load_value(r: _Reader, value: Any, f: str, vector: bool, unit: str = "N m",
                joints: dict[str, Joint] | None = None) -> _TimeFunction:
    state = _variables(r, joints or {})
    used: dict[str, tuple] = {}

    def component(c: Any, field: str, unit: str):
        if not isinstance(c, str):
            return r.number(c, field, unit)
        try:
            e = _expr.parse(c, variables=("t", *state))
        except _expr.ExpressionError as err:
            r.fail(field, str(err).rstrip("."),
                   f"Write a formula giving {unit} of time t (s) and of joint coordinates "
                   f"q_<joint> and rates qd_<joint> (file units); see docs/model-format.md")
        used.update({v: state[v] for v in e.variables if v in state})
        return e

    if vector:
        if not isinstance(value, list) or len(value) != r.dim:
            got = _count(len(value)) if isinstance(value, list) else _type_name(value)
            names = ", ".join(("f" if unit == "N" else "t") + c for c in "xyz"[:r.dim])
            numbers = ", ".join(["-20.0", "35.0", "0.0"][:r.dim])
            formulas = ", ".join(['"10*sin(t)"'] + ['"0"'] * (r.dim - 1))
            r.fail(f, f"expected [{names}] ({r.dim} numbers or formulas of t), got {got}",
                   f"Write value = [{numbers}] ({unit}, global frame) or value = [{formulas}]")
        comps = tuple(component(c, f"{f}[{k}]", unit) for k, c in enumerate(value))
        return _TimeFunction(comps, True, tuple((k, *v) for k, v in sorted(used.items())))
    comp = component(value, f, unit)
    return _TimeFunction((comp,), False, tuple((k, *v) for k, v in sorted(used.items())))


def _loads(r: _Reader, entries: Any, bodies: dict[str, Body],
           joints: dict[str, Joint] | None = None) -> list[Load]:
    loads: list[Load] = []
    L, Lu = r.length, r.length_name
    for i, entry in enumerate(r.entries(entries, "loads")):
        f = _entry_field("loads", i, entry)
        if "kind" not in entry:
            r.fail(f"{f}.kind", "missing required key 'kind'",
                   f"Add kind = one of {', '.join(LOAD_KEYS)}")
        kind = r.choice(entry["kind"], f"{f}.kind", LOAD_KEYS, "load kind")
        need = tuple(k for k in LOAD_KEYS[kind]
                     if k != "name" and k not in OPTIONAL_KEYS.get(kind, ()))
        r.table(entry, f, LOAD_KEYS[kind], required=need, what=f'keys for kind = "{kind}"')
        name = r.name(entry["name"], f"{f}.name") if "name" in entry else ""
        if kind == "friction":
            loads.append(_friction(r, entry, f, name, joints or {}))
            continue
        if kind in ("joint_torque", "joint_force"):
            # an effort inside a joint: on its second body, minus that on the first
            joint = r.choice(entry["joint"], f"{f}.joint", joints or {}, "joint")
            jt = joints[joint]
            if r.kind(jt.kind).freedoms != 1:
                r.fail(f"{f}.joint", f"joint '{joint}' is a {jt.kind} joint with "
                       f"{r.kind(jt.kind).freedoms} freedoms: a {kind} acts along the one "
                       "freedom of a revolute (joint_torque) or prismatic (joint_force) joint",
                       "Name a revolute or prismatic joint, or apply a force or torque to the "
                       "bodies (kind = \"force\" or \"torque\")")
            want = "joint_torque" if r.kind(jt.kind).angular else "joint_force"
            if kind != want:
                r.fail(f"{f}.kind", f"joint '{joint}' is {jt.kind}: its load is a {want}",
                       f'Write kind = "{want}" (a torque in a revolute joint, a force along a '
                       "prismatic joint's axis)")
            value = _load_value(r, entry["value"], f"{f}.value", False,
                                "N m" if kind == "joint_torque" else "N", joints)
            loads.append(Load(kind, jt.body_b, jt.point_b, value, jt.body_a, jt.point_a,
                              name=name, joint=joint))
            continue
        body = r.choice(entry["body"], f"{f}.body", bodies, "body", "bodies")
        point = (r.point(body, bodies[body].points, entry["point"], f"{f}.point")
                 if "point" in entry else None)
        if kind in ("force", "torque"):
            if body == GROUND:
                r.fail(f"{f}.body", f"a {kind} on the ground has no effect",
                       "Apply it to a moving body")
            # a force's components; a torque's too in space (a number in the plane)
            value = _load_value(r, entry["value"], f"{f}.value", kind == "force" or r.dim == 3,
                                "N" if kind == "force" else "N m", joints)
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


def _friction(r: _Reader, entry: dict, f: str, name: str, joints: dict[str, Joint]) -> Load:
    """A ``kind = "friction"`` entry: Coulomb friction in a joint (docs/model-format.md)."""

    joint = r.choice(entry["joint"], f"{f}.joint", joints, "joint")
    jt = joints[joint]
    kind = jk.get(jt.kind)
    mu = r.number(entry["coefficient"], f"{f}.coefficient", nonnegative=True)
    if kind.angular:
        if "radius" not in entry:
            r.fail(f"{f}.radius", f"friction in the revolute joint '{joint}' needs the pin "
                   "radius", f"Add radius = the pin's radius ({r.length_name}): the friction "
                   "couple is coefficient x radius x |joint force|")
        radius = r.number(entry["radius"], f"{f}.radius", r.length_name,
                          nonnegative=True) * r.length
    else:
        if "radius" in entry:
            r.fail(f"{f}.radius", f"joint '{joint}' is a {jt.kind} joint: its friction is a "
                   "force coefficient x |normal force| along the guide, with no radius",
                   "Remove radius")
        radius = 0.0
    unit = r.angle if kind.angular else r.length
    unit_name = f"{r.angle_name if kind.angular else r.length_name}/s"
    if "transition_speed" in entry:
        speed = r.number(entry["transition_speed"], f"{f}.transition_speed", unit_name,
                         positive=True) * unit
    else:
        speed = default_transition_speed(kind.angular)
    static = (r.number(entry["static_coefficient"], f"{f}.static_coefficient",
                       nonnegative=True) if "static_coefficient" in entry else None)
    stiction = (r.number(entry["stiction_speed"], f"{f}.stiction_speed", unit_name,
                         positive=True) * unit if "stiction_speed" in entry else None)
    # viscous: N m per (angle unit / s) or N per (length unit / s), to SI
    effort = "N m" if kind.angular else "N"
    per_rate = r.angle_name if kind.angular else r.length_name
    viscous = (r.number(entry["viscous"], f"{f}.viscous", f"{effort} s/{per_rate}",
                        nonnegative=True) / unit if "viscous" in entry else 0.0)
    preload = (r.number(entry["preload"], f"{f}.preload", "N", nonnegative=True)
               if "preload" in entry else 0.0)
    return Load("friction", jt.body_b, jt.point_b, None, jt.body_a, jt.point_a, name=name,
                joint=joint, coefficient=mu, radius=radius, transition_speed=speed,
                static_coefficient=static, stiction_speed=stiction, viscous=viscous,
                preload=preload)
