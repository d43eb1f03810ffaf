"""The mechanism model: bodies, joints, drivers, loads, in SI units.

A :class:`Model` is frozen and holds no results. It is built by :func:`linkdyn.io.load_model`
from a model file (which converts units), or directly in Python. Vectors are NumPy arrays of
shape ``(2,)`` in the body's local frame unless stated otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

GROUND = "ground"
REVOLUTE = "revolute"
PRISMATIC = "prismatic"


class Motion(Protocol):
    """A driver's prescribed joint coordinate as a function of time."""

    def evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Return ``(q, qd, qdd)``, each of the shape of ``t`` (rad or m, per s, per s^2)."""
        ...


def default_transition_speed(angular: bool) -> float:
    """The transition speed of a friction load's tanh smoothing when a model gives none:
    0.01 rad/s for a revolute joint, 0.001 m/s for a sliding one."""
    return 0.01 if angular else 0.001


@dataclass(frozen=True)
class Body:
    """A rigid body.

    Attributes
    ----------
    name : str
    points : dict[str, ndarray (2,)]
        Named points in the body's frame, m.
    mass : float
        kg (0 for the ground).
    com : ndarray (2,)
        Mass centre in the body's frame, m.
    inertia : float
        Moment of inertia about the mass centre, kg m^2.
    bars : tuple[Bar, ...]
        The uniform bars the mass properties were composed of (:func:`bar_mass`), when the
        model file gave them that way (``save`` writes them back); empty otherwise.
    """

    name: str
    points: dict[str, np.ndarray]
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(2))
    inertia: float = 0.0
    bars: tuple = ()


@dataclass(frozen=True)
class Bar:
    """A uniform slender bar between two named points of a body: its ``mass`` (kg), or its
    ``mass_per_length`` (kg/m) times its length (exactly one of the two, the other None)."""

    start: str
    end: str
    mass: float | None = None
    mass_per_length: float | None = None


def bar_mass(points: dict, bars) -> tuple[float, np.ndarray, float]:
    """Mass (kg), mass centre (2,) and centroidal inertia (kg m^2) of the uniform bars
    ``bars`` between the named ``points`` (m, the body's frame), composed: ``m = sum m_k``,
    ``c = sum m_k c_k / m`` with ``c_k`` each bar's midpoint, ``I_C = sum (m_k L_k^2 / 12 +
    m_k |c_k - c|^2)``."""
    ms, cs, ls = [], [], []
    for b in bars:
        p, q = np.asarray(points[b.start], float), np.asarray(points[b.end], float)
        length = float(np.hypot(*(q - p)))
        ms.append(b.mass if b.mass is not None else b.mass_per_length * length)
        cs.append((p + q) / 2)
        ls.append(length)
    m = float(sum(ms))
    c = sum(mk * ck for mk, ck in zip(ms, cs)) / m if m > 0 else np.mean(cs, axis=0)
    inertia = sum(mk * (lk ** 2 / 12 + float(np.sum((ck - c) ** 2)))
                  for mk, ck, lk in zip(ms, cs, ls))
    return m, np.asarray(c, float), float(inertia)


@dataclass(frozen=True, init=False)
class Joint:
    """A pair between body ``body_a`` (first) and body ``body_b`` (second).

    ``Joint(name, kind, body_a, point_a, body_b, point_b, *values, numbers=None, **named)``:
    the kind's numbers (:attr:`linkdyn.joints.JointKind.numbers`, SI) by position in the
    kind's order, by name, or as the dict ``numbers``; those not given take their defaults.

    Attributes
    ----------
    name : str
    kind : str
        A kind registered in :mod:`linkdyn.joints` (``'revolute'``, ``'prismatic'``, ...).
    body_a, point_a, body_b, point_b : str
        ``connect = ["body_a.point_a", "body_b.point_b"]``.
    numbers : dict
        The kind's numbers by name, SI: a float, or an array of the number's shape (e.g. a
        slider's ``axis`` (2,), unit sliding direction in ``body_a``'s frame, and ``angle``,
        rad, the fixed angle of ``body_b``'s frame to ``body_a``'s). Each is also an attribute
        (``joint.axis``); a number of another kind reads as that number's default.
    coupled : tuple[str, ...]
        The joints a coupling couples (``joints = [...]`` in the file; its bodies and points
        are theirs, :func:`linkdyn.joints.coupling.couple`); empty for the other kinds.
    """

    name: str
    kind: str
    body_a: str
    point_a: str
    body_b: str
    point_b: str
    numbers: dict
    coupled: tuple = ()

    def __init__(self, name, kind, body_a, point_a, body_b, point_b, *values, numbers=None,
                 coupled=(), **named):
        from . import joints as jk
        if kind not in jk.REGISTRY:   # no declarations to hold them to (topology names it)
            if values:
                raise TypeError(f"unknown joint kind {kind!r}: give its numbers by name")
            held = dict(numbers or {}, **named)
        else:
            declared = jk.REGISTRY[kind].numbers
            names = [x.name for x in declared]
            if len(values) > len(names):
                raise TypeError(f"a {kind} joint takes {len(names)} numbers "
                                f"({', '.join(names)}), not {len(values)}")
            other = [k for k in named if k not in names]
            if other:
                raise TypeError(f"a {kind} joint has no number {other[0]!r}")
            # ``numbers`` (as dataclasses.replace passes them): the kind's own of them
            given = {**dict(numbers or {}), **dict(zip(names, values)), **named}
            held = {x.name: x.value(given.get(x.name)) for x in declared}
        for k, v in (("name", name), ("kind", kind), ("body_a", body_a), ("point_a", point_a),
                     ("body_b", body_b), ("point_b", point_b), ("numbers", held),
                     ("coupled", tuple(coupled))):
            object.__setattr__(self, k, v)

    def __getattr__(self, name: str):
        from . import joints as jk
        numbers = self.__dict__.get("numbers")
        if numbers is None or name not in jk.NUMBERS:
            raise AttributeError(name)
        return numbers[name] if name in numbers else jk.NUMBERS[name].value()


@dataclass(frozen=True)
class Driver:
    """Prescribed motion of one joint coordinate ``q_<joint>``."""

    joint: str
    motion: Motion
    description: str = ""
    period: float | None = None  # s, for a fully rotating constant-speed driver


@dataclass(frozen=True)
class Load:
    """An applied load.

    ``kind`` is one of ``force`` (``value`` N, global frame, at ``body.point``), ``torque`` (``value``
    N m on ``body``), ``spring`` and ``damper`` (between ``body.point`` and ``body2.point2``;
    ``stiffness`` N/m, ``free_length`` m, ``damping`` N s/m), ``joint_torque`` / ``joint_force``
    (``value`` N m or N inside the revolute or prismatic joint ``joint``: on its second body,
    ``body``, and minus that on its first, ``body2``), ``friction`` (in the joint ``joint``, its
    bodies as for a joint load: ``coefficient``, ``radius`` m for a revolute joint and
    ``transition_speed`` rad/s or m/s; see :mod:`linkdyn.friction`). A ``value`` is a callable of time
    returning the shape of ``t`` plus the load's components, so constant and time-varying loads
    share one path; one whose ``state_variables`` is not empty also takes the joints' motion
    (see :func:`linkdyn.loads.evaluate`).
    """

    kind: str
    body: str
    point: str | None = None
    value: Any = None
    body2: str | None = None
    point2: str | None = None
    stiffness: float = 0.0
    free_length: float = 0.0
    damping: float = 0.0
    name: str = ""
    joint: str = ""
    coefficient: float = 0.0       # friction: coefficient of friction mu, 1
    radius: float = 0.0            # friction in a revolute joint: the pin radius, m
    transition_speed: float = 0.0  # friction: rate of the tanh smoothing, rad/s or m/s
    static_coefficient: float | None = None  # friction: mu at rest (None: ``coefficient``)
    stiction_speed: float | None = None      # friction: rate of the static-to-dynamic blend
    viscous: float = 0.0           # friction: viscous coefficient, N m s/rad or N s/m
    preload: float = 0.0           # friction: load added to |F|, N


@dataclass(frozen=True)
class Model:
    """A planar mechanism, in SI units.

    Attributes
    ----------
    name : str
    bodies : tuple[Body, ...]
        Includes the ground, named ``'ground'``.
    joints : tuple[Joint, ...]
    drivers : tuple[Driver, ...]
    loads : tuple[Load, ...]
    gravity : ndarray (2,)
        m/s^2, global frame.
    assembly_phi : dict[str, float]
        Guesses of absolute body angles at t = 0, rad.
    assembly_q : dict[str, float]
        Guesses of joint coordinates at t = 0, rad or m.
    cut : tuple[str, ...] or None
        Joints to cut; ``None`` chooses automatically.
    duration, cycles, samples : optional analysis defaults.
    space : str
        ``"planar"`` (this module's bodies and joints) or ``"spatial"`` (bodies and joints of
        :mod:`linkdyn.spatial.model`, 3-vectors; solved by :mod:`linkdyn.spatial`).
    initial_q, initial_qd : dict[str, float]
        ``[initial]``: coordinates (rad or m) and rates (per s) of the free degrees of freedom at
        t = 0, by joint name (``simulate``; an empty ``initial_q`` takes them from the assembly).
    path_point : str or None
        ``BODY.POINT`` whose path straightness the summary reports.
    path_range : (float, float) or None
        Range of the first driver's coordinate for ``path_point``, rad or m.
    output : tuple[str, ...]
        ``[analysis] output``: the names of the loads the mechanism works against (its output),
        whose power the instantaneous efficiency divides by the drivers' power
        (:func:`linkdyn.friction.output_power`).
    source : str
        File the model came from ('' if built in Python).
    length_unit, angle_unit : str
        The units of the file it came from (``[units]``; 'm' and 'rad' otherwise), kept so a
        written model (:func:`linkdyn.save`) and design parameters use the file's units.
    """

    name: str
    bodies: tuple[Body, ...]
    joints: tuple[Joint, ...]
    drivers: tuple[Driver, ...] = ()
    loads: tuple[Load, ...] = ()
    gravity: np.ndarray = field(default_factory=lambda: np.zeros(2))
    assembly_phi: dict[str, float] = field(default_factory=dict)
    assembly_q: dict[str, float] = field(default_factory=dict)
    cut: tuple[str, ...] | None = None
    duration: float | None = None
    cycles: float | None = None
    samples: int | None = None
    source: str = ""
    description: str = ""
    path_point: str | None = None
    path_range: tuple[float, float] | None = None
    output: tuple[str, ...] = ()
    length_unit: str = "m"
    angle_unit: str = "rad"
    initial_q: dict[str, float] = field(default_factory=dict)
    initial_qd: dict[str, float] = field(default_factory=dict)
    space: str = "planar"

    def body(self, name: str) -> Body:
        return next(b for b in self.bodies if b.name == name)

    def joint(self, name: str) -> Joint:
        return next(j for j in self.joints if j.name == name)

    @property
    def moving_bodies(self) -> tuple[Body, ...]:
        return tuple(b for b in self.bodies if b.name != GROUND)


def point_spread(points) -> np.ndarray | float:
    """Characteristic size of a mechanism, m: the larger spread (max - min) of the x and the y
    coordinates of all its named points, each in its own body's frame; 1 where there is one
    point or no spread.

    ``points`` (N, 2) for one design, or (N, 2, D) for D designs (then (D,) sizes). The
    closure's tolerances and the continuation steps scale with it.
    """
    points = np.asarray(points, float)
    if len(points) < 2:
        return 1.0 if points.ndim < 3 else np.ones(points.shape[2:])
    size = np.max(np.ptp(points, axis=0), axis=0)
    size = np.where(size > 0, size, 1.0)
    return float(size) if size.ndim == 0 else size

