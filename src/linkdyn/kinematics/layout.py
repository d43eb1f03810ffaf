"""The numeric layout: a model's numbers arranged along its spanning tree, for one design or a
batch of designs sharing one topology (a design axis on every number that may differ), read by
both backends: the numpy solvers index an entity's row, the compiled kernels take the arrays
themselves (views with the design axis last) and the topology's integer arrays, computed once
per layout."""

from __future__ import annotations

from collections import namedtuple
from dataclasses import dataclass, field, replace
from functools import cached_property, partial
from typing import Any, Callable

import numpy as np

from ..brief import brief_repr

from .. import joints as jk
from ..errors import ModelError
from ..model import Model, point_spread
from ..motion import ConstantSpeed
from ..topology import Topology, build
from . import dyads


@dataclass(frozen=True)
class Cut:
    """One cut joint as the numpy solvers read it (a view of :class:`Layout`'s cut arrays):
    bodies ``a``, ``b`` (tree indices), points relative to O_a, O_b in the bodies' frames, and
    its kind's numbers (``numbers``, also attributes: ``c.axis`` fixed in a, ``c.angle``)."""

    joint: int
    kind: str
    a: int
    b: int
    pa: np.ndarray
    pb: np.ndarray
    numbers: dict

    @property
    def own(self) -> tuple:
        """Its numbers as its kind's cut steps take them (``nums``,
        :meth:`~linkdyn.joints.JointKind.own`); a number no design may vary (a cam's law, a
        gear's ``internal``) as one float, which a step may branch on."""
        kind = jk.get(self.kind)
        fixed = {x.name for x in kind.numbers if not x.design}
        return kind.own({k: float(np.ravel(v)[0]) if k in fixed else v
                         for k, v in self.numbers.items()})

    def __getattr__(self, name: str):
        numbers = self.__dict__.get("numbers")
        if numbers is None or name not in numbers:
            raise AttributeError(name)
        return numbers[name]


@dataclass(frozen=True)
class LoadRow:
    """One applied load of the model (``model.loads[k]``) in tree indices.

    ``kind`` as in :class:`~linkdyn.model.Load`; ``body`` (tree index) and ``point`` (a name
    of ``Layout.points[body]``), for a spring or damper also ``body2``, ``point2`` (else -1,
    None). ``stiffness`` N/m, ``free_length`` m, ``damping`` N s/m: floats, or (D, 1) with
    designs. ``values``: the load's value as a function of time, one per design (one for a
    single mechanism); see :func:`evaluate_designs`.
    """

    kind: str
    name: str
    body: int
    point: str | None
    body2: int
    point2: str | None
    stiffness: Any
    free_length: Any
    damping: Any
    values: tuple
    joint: int = -1          # joint_torque / joint_force: the joint (model order), else -1
    axis: Any = None         # joint_force: the joint's axis in its first body's frame, (2,)
    #                          or (2, D, 1) with designs


# dyad shape codes of the kernels' view (linkdyn.kinematics.dyads)
DYAD_SHAPES = {"split": 0, "chain": 1, "slide": 2, "swing": 3}
#: the numbers of the bodies and cuts every layout has (the joints' own: :data:`jk.NUMBERS`)
BODY_NUMBERS = ("joint_point", "origin", "com", "mass", "inertia", "cut_pa", "cut_pb", "size",
                "gravity")

#: The kernels' view of a layout (:attr:`Layout.view`): named arrays, read by name.
#: Per tree body i (n,), int64: ``parent``, ``kind`` (code, :data:`linkdyn.joints.CODES`; 0 the
#: ground), ``sign``, ``angular`` (1: the joint's coordinate is an angle), ``tree_joint`` (its
#: model joint), ``driver_of`` (driver number, else -1); ``ancestors`` (n, n); ``dependent``,
#: ``driven`` (tree indices). Per cut joint (n_cut,), int64: ``cut_a``, ``cut_b`` (tree
#: indices), ``cut_kind``, ``cut_row`` (its first row of the stacked closure arrays),
#: ``cut_rows``, ``cut_joint`` (its model joint), ``cut_metres`` (n_cut, 3) (1 for each of its
#: rows in m, padded to three); ``side`` (n_cut, n) float, the sign of tree joint k in cut c's
#: closure. Per dyad of the closed-form plan (n_dyads,), int64: ``dyad_shape``
#: (:data:`DYAD_SHAPES`), ``dyad_cut``, ``dyad_upper``, ``dyad_lower``, ``dyad_on_b`` (1: the
#: side of both unknown joints is the cut's second body). ``cut_own`` (n_cut, WIDTH, D) float:
#: each cut's numbers as its kind's cut steps take them (``nums``, its kind's scalar numbers in
#: order, :meth:`~linkdyn.joints.JointKind.own`, padded with zeros). Then every number
#: (:attr:`Layout.NUMBERS`) with the design axis last, D = 1 for one mechanism: ``joint_point``,
#: ``origin``, ``com`` (n, 2, D), ``mass``, ``inertia`` (n, D), ``cut_pa``, ``cut_pb``
#: (n_cut, 2, D), ``size`` (D,), ``gravity`` (2, D), and each joint number of the kinds
#: (:data:`linkdyn.joints.NUMBERS`) per tree joint under its name (``axis`` (n, 2, D), ``angle``
#: (n, D)) and per cut joint with ``cut_`` before it (``cut_axis``, ``cut_angle``).
View = namedtuple("View", (
    "parent", "kind", "sign", "angular", "tree_joint", "driver_of", "ancestors", "dependent",
    "driven", "cut_a", "cut_b", "cut_kind", "cut_row", "cut_rows", "cut_joint", "cut_metres",
    "side", "dyad_shape", "dyad_cut", "dyad_upper", "dyad_lower", "dyad_on_b", "cut_own")
    + BODY_NUMBERS + tuple(jk.NUMBERS) + tuple(f"cut_{k}" for k in jk.NUMBERS),
    module=__name__)


@dataclass(frozen=True)
class Layout:
    """The numeric layout: a model's numbers for its topology, SI, in tree order (index 0 =
    ground), read by both backends (the numpy solvers index an entity's row, the compiled
    kernels their named view of the whole arrays, :attr:`view`).

    Per body, one array each (entity first): ``joint_point`` (n, 2): body i's parent's joint
    point relative to O_parent, parent frame; ``origin`` (n, 2): O_i in body i's own frame;
    ``com`` (n, 2), ``mass``, ``inertia`` (n,). ``points[i]``: dict of body i's named points
    relative to O_i, body frame. Per tree joint, each number the joint kinds declare
    (:data:`linkdyn.joints.NUMBERS`) in ``joint_numbers[name]`` (n,) + its shape, as the kind
    puts it in the parent's frame (:meth:`~linkdyn.joints.JointKind.tree_numbers`; a kind's
    default where its kind has none), also read as an attribute: ``axis`` (n, 2), the slider
    axis in the parent's frame, ``angle`` (n,). Per cut joint (``topo.cut``): ``cut_kind``,
    ``cut_a``, ``cut_b`` (kinds and tree indices of its bodies), ``cut_pa``, ``cut_pb``
    (n_cut, 2) its points relative to O_a, O_b, and its numbers in ``cut_numbers[name]``,
    also read as ``cut_<name>`` (``cut_axis`` (n_cut, 2) in a's frame, ``cut_angle``);
    :attr:`cuts` views them as :class:`Cut` objects. ``size``: characteristic length, m.
    ``gravity``: (2,) m/s^2, global frame. ``motions[k]``: the motions of driver k
    (``model.drivers[k]``, moving tree joint ``topo.driven[k]``), one per design. ``loads``:
    one :class:`LoadRow` per ``model.loads`` entry.

    ``designs``: 0 for one mechanism; D for D stacked designs (:func:`stack_layouts`), where
    every number gains a design axis shaped to broadcast against ``(D, T)`` batches: ``(n, 2,
    D, 1)`` for vectors, ``(n, D, 1)`` for numbers (so ``joint_point[i]`` is ``(2, D, 1)``),
    ``size`` (D, 1), ``gravity`` (2, D, 1).

    The kernels' view (:attr:`view`, a :data:`View` of named arrays) is built once per
    layout, on first read.
    """

    __repr__ = brief_repr   # shapes, not every number (linkdyn.brief)

    topo: Topology
    kind: tuple[str, ...]
    joint_point: np.ndarray
    origin: np.ndarray
    points: tuple[dict, ...]
    com: np.ndarray
    mass: np.ndarray
    inertia: np.ndarray
    cut_kind: tuple[str, ...]
    cut_a: tuple[int, ...]
    cut_b: tuple[int, ...]
    cut_pa: np.ndarray
    cut_pb: np.ndarray
    size: Any
    dyads: tuple | None = None  # closed-form plan (linkdyn.dyads), None: Newton's method
    gravity: np.ndarray = field(default_factory=lambda: np.zeros(2))
    motions: tuple = ()
    loads: tuple = ()
    designs: int = 0
    joint_numbers: dict = field(default_factory=dict)
    cut_numbers: dict = field(default_factory=dict)

    # the numbers every design has its own of (the design axis -2 with designs)
    NUMBERS = BODY_NUMBERS + tuple(jk.NUMBERS) + tuple(f"cut_{k}" for k in jk.NUMBERS)

    def __getattr__(self, name: str):
        # the joints' numbers by name: ``axis`` (tree rows), ``cut_axis`` (cut rows)
        d = self.__dict__
        if "joint_numbers" not in d:
            raise AttributeError(name)
        if name in d["joint_numbers"]:
            return d["joint_numbers"][name]
        if name.startswith("cut_") and name[4:] in d["cut_numbers"]:
            return d["cut_numbers"][name[4:]]
        raise AttributeError(name)

    def __getstate__(self) -> dict:
        # without the cached view and cuts: an unpickled array is writable, and the kernels,
        # compiled for the read-only arrays of a view, would compile again for it
        return {k: v for k, v in self.__dict__.items() if k not in ("view", "cuts")}

    def with_numbers(self, **numbers) -> Layout:
        """A copy with the :attr:`NUMBERS` given replaced (the joints' by their attribute
        names, ``axis``, ``cut_axis``), and any other field."""
        tree = {k: numbers.pop(k) for k in list(numbers) if k in jk.NUMBERS}
        cut = {k[4:]: numbers.pop(k) for k in list(numbers)
               if k.startswith("cut_") and k[4:] in jk.NUMBERS}
        return replace(self, **numbers, joint_numbers={**self.joint_numbers, **tree},
                       cut_numbers={**self.cut_numbers, **cut})

    @cached_property
    def cuts(self) -> tuple[Cut, ...]:
        """Each cut joint's numbers as a :class:`Cut` (views of the cut arrays)."""
        return tuple(Cut(j, self.cut_kind[k], self.cut_a[k], self.cut_b[k], self.cut_pa[k],
                         self.cut_pb[k], {x: v[k] for x, v in self.cut_numbers.items()})
                     for k, j in enumerate(self.topo.cut))

    @property
    def n_joints(self) -> int:
        """Joints of the model: a tree joint per moving body and the cut joints."""
        return self.topo.n - 1 + self.topo.n_loops

    # --- the kernels' view of the layout ------------------------------------------------------
    def per_design(self, name: str) -> np.ndarray:
        """The number ``name`` (one of :attr:`NUMBERS`) with the design axis last: ``(n, 2,
        D)``, ``(n, D)``, ``(D,)``; D = 1 for one mechanism. A view (no copy) of the stored,
        C-contiguous array."""
        x = np.asarray(getattr(self, name), float)
        return x.reshape(x.shape[:-2] + (self.designs,)) if self.designs else x[..., None]

    @cached_property
    def view(self) -> View:
        """The kernels' view of this layout (:data:`View`): the topology's integer arrays and
        every number with the design axis last (:meth:`per_design`), each C-contiguous and
        read-only (numba compiles a kernel once per layout of its arrays); built once."""
        topo = self.topo
        n = topo.n
        kinds = [jk.get(k) if i else None for i, k in enumerate(self.kind)]
        driver_of = np.full(n, -1, np.int64)
        driver_of[list(topo.driven)] = np.arange(len(topo.driven))
        units = [jk.get(k).row_units for k in self.cut_kind]
        plan = self.dyads or ()
        anc = np.asarray(topo.ancestors, np.int64).reshape(n, n)

        def ints(xs, *shape):
            return np.array(xs, np.int64).reshape((len(xs),) + shape)
        out = dict(
            parent=ints(topo.parent), kind=ints([jk.CODES[k.name] if k else 0 for k in kinds]),
            sign=ints(topo.sign), angular=ints([int(bool(k) and k.angular) for k in kinds]),
            tree_joint=ints(topo.tree_joint), driver_of=driver_of, ancestors=anc,
            dependent=ints(topo.dependent), driven=ints(topo.driven),
            cut_a=ints(self.cut_a), cut_b=ints(self.cut_b),
            cut_kind=ints([jk.CODES[k] for k in self.cut_kind]),
            cut_row=ints([topo.row_slice(k).start for k in range(topo.n_loops)]),
            cut_rows=ints([len(u) for u in units]), cut_joint=ints(topo.cut),
            cut_metres=ints([[int(j < len(u) and u[j] == "m") for j in range(3)]
                             for u in units], 3),
            side=np.array([anc[b] - anc[a] for a, b in zip(self.cut_a, self.cut_b)],
                          float).reshape(-1, n),
            dyad_shape=ints([DYAD_SHAPES[x.shape] for x in plan]),
            dyad_cut=ints([x.cut for x in plan]), dyad_upper=ints([x.upper for x in plan]),
            dyad_lower=ints([x.lower for x in plan]),
            dyad_on_b=ints([int(x.side == "b") for x in plan]))
        out.update({k: self.per_design(k) for k in self.NUMBERS})
        # each cut's own numbers (its kind's scalars, padded), (n_cut, WIDTH, D)
        zero = np.zeros(max(self.designs, 1))
        own = [jk.get(kind).own({x: out[f"cut_{x}"][k] for x in jk.NUMBERS}, zero)
               for k, kind in enumerate(self.cut_kind)]
        out["cut_own"] = np.array(own, float).reshape(len(own), jk.WIDTH, zero.size)
        from ..compiled import pack   # one object for the kernels (numba's StructRef)

        return pack(View(**{k: fixed(v) for k, v in out.items()}))

    # --- designs ---------------------------------------------------------------------------
    def take(self, idx) -> Layout:
        """The designs ``idx`` (integer array) of stacked designs, stacked (every number's
        design axis is its axis -2; motions and load values keep those designs' functions)."""
        idx = np.asarray(idx, int)
        if not self.designs:
            raise ValueError("take(idx) needs a layout of stacked designs")

        def take(x):
            return x[..., idx, :]
        loads = tuple(replace(x, stiffness=take(x.stiffness), free_length=take(x.free_length),
                              damping=take(x.damping), values=tuple(x.values[i] for i in idx),
                              axis=None if x.axis is None else take(x.axis))
                      for x in self.loads)
        return self.with_numbers(**{f: take(getattr(self, f)) for f in self.NUMBERS},
                       points=tuple({k: take(v) for k, v in pts.items()} for pts in self.points),
                       loads=loads, motions=tuple(tuple(m[i] for i in idx) for m in self.motions),
                       designs=len(idx))

    def design(self, k: int) -> Layout:
        """Design k of stacked designs as the layout of that one mechanism (no design axis)."""
        if not self.designs:
            raise ValueError("design(k) needs a layout of stacked designs")
        k = range(self.designs)[k]   # an IndexError out of range; negative k counts back

        def one(x):   # (..., D, 1) -> (...), a contiguous copy
            return np.ascontiguousarray(np.asarray(x, float)[..., k, 0])

        def num(x):   # (D, 1) -> float
            return float(np.asarray(x, float)[k, 0])
        loads = tuple(replace(r, stiffness=num(r.stiffness), free_length=num(r.free_length),
                              damping=num(r.damping), values=(r.values[k],),
                              axis=None if r.axis is None else one(r.axis)) for r in self.loads)
        return self.with_numbers(
            **{f: one(getattr(self, f)) for f in self.NUMBERS if f != "size"},
            size=num(self.size),
            points=tuple({name: one(x) for name, x in pts.items()} for pts in self.points),
            motions=tuple((m[k],) for m in self.motions), loads=loads, designs=0)

    def driver_values(self, t: np.ndarray):
        """Driver coordinates, rates and accelerations at the times ``t`` (T,): each
        (n_drivers, T), or (n_drivers, D, T) with designs (rad or m, per s, per s^2); read-only
        views where the designs share a motion."""
        return motion_values(self.motions, t, self.designs)

    def load_values(self, row: LoadRow, t: np.ndarray) -> np.ndarray:
        """A load's value at the times ``t`` (T,), components first: (T,) for a torque, (2, T)
        for a force; with designs (D, T) and (2, D, T)."""
        t = np.asarray(t, dtype=float)
        comps = (2,) if row.kind == "force" else ()
        (v,) = evaluate_designs(row.values, t, partial(_load_value, comps=comps), self.designs)
        return np.moveaxis(v, -1, 0) if row.kind == "force" else v


def motion_values(motions: tuple, t: np.ndarray, designs: int = 0):
    """Coordinates, rates and accelerations of the drivers' ``motions`` (per driver, one motion
    per design) at the times ``t`` (T,): each (n_drivers, T), or (n_drivers, D, T) for D
    ``designs``; read-only views of a motion's arrays where they can be (one driver, or
    designs sharing a motion)."""
    t = np.asarray(t, dtype=float)
    shape = ((designs,) if designs else ()) + t.shape
    if not motions:
        z = np.zeros((0,) + shape)
        return z, z, z
    vals = [evaluate_designs(m, t, _motion_values, designs) for m in motions]
    if len(vals) == 1:   # one driver: views of its arrays, no copy
        return tuple(np.broadcast_to(x, shape)[None] for x in vals[0])
    return tuple(np.stack([np.broadcast_to(v[k], shape) for v in vals]) for k in range(3))


def _motion_values(motion, t):
    return motion.evaluate(t)


def _load_value(value, t, comps=()):
    """A load's ``value(t)``, broadcast to ``t.shape + comps`` (a constant may ignore t)."""
    return (np.broadcast_to(np.asarray(value(t), dtype=float), t.shape + comps),)


def _groups(functions) -> dict:
    """The designs sharing each function (equal objects; an unhashable one by identity):
    key -> list of design indices, in order of first use."""
    by_id: dict = {}   # the designs of a sweep share one object: grouped by identity first
    for d, f in enumerate(functions):
        by_id.setdefault(id(f), []).append(d)
    groups: dict = {}
    merged = set()
    for idx in by_id.values():   # then equal objects merged, each hashed once
        f = functions[idx[0]]
        try:
            key = (0, f, type(f))
            hash(key)
        except TypeError:
            key = (1, id(f))
        if key in groups:
            groups[key].extend(idx)
            merged.add(key)
        else:
            groups[key] = idx
    for key in merged:
        groups[key].sort()
    return groups


def motion_steps(motions: tuple, probe: np.ndarray) -> np.ndarray:
    """The largest travel ``|q(probe[j + 1]) - q(probe[j])|`` of each driver between
    consecutive probe times over all designs, (n_drivers, P - 1): each distinct motion evaluated
    once, and of the constant speeds only the fastest (memory of one design, any number of
    designs)."""
    out = []
    for funcs in motions:
        uniq = [funcs[idx[0]] for idx in _groups(funcs).values()]
        const = [f for f in uniq if type(f) is ConstantSpeed]
        if len(const) > 1:   # the fastest constant speed travels furthest at every step
            fastest = max(const, key=lambda f: abs(f.speed))
            uniq = [f for f in uniq if type(f) is not ConstantSpeed] + [fastest]
        out.append(np.max([np.abs(np.diff(f.evaluate(probe)[0])) for f in uniq], axis=0))
    return np.array(out).reshape(len(motions), len(probe) - 1)


def evaluate_designs(functions: tuple, t: np.ndarray, call: Callable, designs: int = 0):
    """Evaluate one function of time per design at the times ``t`` (T,).

    ``call(f, t)`` returns a tuple of arrays ``t.shape + extra`` for the function ``f``. With
    ``designs == 0`` (one mechanism) that tuple is returned as it is; else each array gains a
    leading design axis, (D, T, ...). Designs that share a function (equal objects) share one
    evaluation, returned as a read-only broadcast when all do; constant-speed motions of all
    designs are evaluated at once from their speeds and starts.
    """
    if not designs:
        return call(functions[0], t)
    if all(type(f) is ConstantSpeed for f in functions):
        # q = start + speed t, for every design at once
        speed = np.array([f.speed for f in functions])[:, None]
        start = np.array([f.start for f in functions])[:, None]
        return start + speed * t, np.broadcast_to(speed, (designs,) + t.shape), \
            np.zeros((designs,) + t.shape)
    groups = _groups(functions)
    if len(groups) == 1:
        return tuple(np.broadcast_to(v, (designs,) + v.shape) for v in call(functions[0], t))
    out = None
    for idx in groups.values():
        vals = call(functions[idx[0]], t)
        if out is None:
            out = [np.empty((designs,) + v.shape) for v in vals]
        for o, v in zip(out, vals):
            o[idx] = v
    return tuple(out)


def compile_layout(model: Model, topo: Topology | None = None, *, plan: bool = True) -> Layout:
    """Geometry of ``model`` arranged along the tree of ``topo`` (built if not given); with
    ``plan``, the closed-form dyad plan (which depends on the topology only)."""
    topo = topo or build(model)
    bodies = [model.body(name) for name in topo.bodies]
    pos = {name: k for k, name in enumerate(topo.bodies)}

    def own_point(j, i):
        jt = model.joints[j]
        return bodies[i].points[jt.point_b if topo.bodies[i] == jt.body_b else jt.point_a]

    origin = [np.zeros(2)] + [np.asarray(own_point(topo.tree_joint[i], i), float)
                              for i in range(1, topo.n)]
    kind, joint_point = [""], [np.zeros(2)]
    # each joint's numbers as its kind declares them (a number of another kind: its default;
    # the ground's row zero); a tree joint's as its kind puts them in the parent's frame
    tree_numbers = [{k: np.zeros(x.shape) for k, x in jk.NUMBERS.items()}]
    for i in range(1, topo.n):
        jt, p = model.joints[topo.tree_joint[i]], topo.parent[i]
        kind.append(jt.kind)
        joint_point.append(np.asarray(own_point(topo.tree_joint[i], p), float) - origin[p])
        tree_numbers.append(jk.get(jt.kind).tree_numbers(_numbers(jt), topo.sign[i]))
    cuts = [model.joints[j] for j in topo.cut]
    cut_numbers = [_numbers(jt) for jt in cuts]
    a = [pos[jt.body_a] for jt in cuts]
    b = [pos[jt.body_b] for jt in cuts]
    points = tuple({k: np.asarray(v, float) - origin[i] for k, v in b_.points.items()}
                   for i, b_ in enumerate(bodies))
    size = point_spread([v for b_ in model.bodies for v in b_.points.values()])
    lay = Layout(
        topo, tuple(kind), _rows(joint_point, (2,)), _rows(origin, (2,)), points,
        _rows([np.asarray(b_.com, float) - origin[i] for i, b_ in enumerate(bodies)], (2,)),
        _rows([float(b_.mass) for b_ in bodies], ()),
        _rows([float(b_.inertia) for b_ in bodies], ()),
        tuple(jt.kind for jt in cuts), tuple(a), tuple(b),
        _rows([np.asarray(bodies[a_].points[jt.point_a], float) - origin[a_]
               for jt, a_ in zip(cuts, a)], (2,)),
        _rows([np.asarray(bodies[b_].points[jt.point_b], float) - origin[b_]
               for jt, b_ in zip(cuts, b)], (2,)), size,
        gravity=np.asarray(model.gravity, float).reshape(2),
        motions=tuple((d.motion,) for d in model.drivers), loads=load_rows(model, topo),
        joint_numbers={k: _rows([v[k] for v in tree_numbers], x.shape)
                       for k, x in jk.NUMBERS.items()},
        cut_numbers={k: _rows([v[k] for v in cut_numbers], x.shape)
                     for k, x in jk.NUMBERS.items()})
    return replace(lay, dyads=dyads.plan(lay)) if plan else lay


def _numbers(jt) -> dict:
    """Every joint number (:data:`linkdyn.joints.NUMBERS`) of the joint ``jt``: its kind's
    own, the default of the others."""
    return {k: np.asarray(getattr(jt, k), float) for k in jk.NUMBERS}


def _rows(xs, shape: tuple) -> np.ndarray:
    """Per-entity numbers of one design as one array, entity first: ``(n,) + shape``."""
    return np.array(xs, float).reshape((len(xs),) + shape)


def fixed(x) -> np.ndarray | tuple:
    """``x`` (an array, or a tuple of them) as C-contiguous, read-only arrays of their dtype:
    views, copied only where not C-contiguous. numba compiles a kernel once per combination of
    its arguments' layouts ('C', 'A', 'F') and read-only flags; every array input of the
    kernels goes through this (the layout's :attr:`Layout.view` too), so each compiles once
    whatever the caller passed (a broadcast view, a column of a table, an unpickled layout, a
    sweep's design-last views)."""
    if isinstance(x, tuple):
        return tuple(fixed(a) for a in x)
    x = np.asarray(x)
    v = np.ascontiguousarray(x, dtype=x.dtype).view()
    v.flags.writeable = False
    return v


def load_rows(model: Model, topo: Topology) -> tuple[LoadRow, ...]:
    """The :class:`LoadRow` of each of ``model.loads`` (one design), bodies as tree indices."""
    pos = {name: k for k, name in enumerate(topo.bodies)}
    return tuple(LoadRow(ld.kind, ld.name, pos[ld.body], ld.point,
                         pos[ld.body2] if ld.body2 is not None else -1, ld.point2,
                         float(ld.stiffness), float(ld.free_length), float(ld.damping),
                         (ld.value,), *_in_joint(model, ld)) for ld in model.loads)


def _in_joint(model: Model, ld) -> tuple:
    """``(joint index, axis)`` of a load inside a joint, else ``(-1, None)``."""
    if not getattr(ld, "joint", ""):
        return -1, None
    k = [j.name for j in model.joints].index(ld.joint)
    return k, np.asarray(model.joints[k].axis, float)


def _shape(model: Model) -> dict[str, tuple]:
    """What designs of one batch must share, by what a message names: bodies, joints (name,
    kind, the bodies they connect), the driven joints, the loads' kinds and bodies, the cut."""
    return {
        "bodies": tuple(b.name for b in model.bodies),
        "joints": tuple((j.name, j.kind, j.body_a, j.body_b) for j in model.joints),
        "drivers": tuple(d.joint for d in model.drivers),
        "loads": tuple((ld.kind, ld.body, ld.body2) for ld in model.loads),
        "topology.cut": model.cut,
    }


def compile_designs(models: list[Model]) -> Layout:
    """The stacked layout (:func:`stack_layouts`) of D designs of one topology.

    Raises
    ------
    ModelError
        A design whose bodies, joints, driven joints, loads (kinds and bodies) or cut joints
        differ from design 0's, naming the design and what differs.
    """
    first = _shape(models[0])
    for k, m in enumerate(models[1:], 1):
        for what, value in _shape(m).items():
            if value != first[what]:
                raise ModelError(
                    f"design {k} differs from design 0 in its {what.split('.')[-1]}: "
                    f"{_differ(value, first[what])}", file=m.source, field=what,
                    fix="Designs of one batch vary numbers only (geometry, masses, gravity, "
                        "loads' values, drivers' motions); analyze other mechanisms separately")
    topo = build(models[0])
    # one tree and one dyad plan for all: stack_layouts keeps design 0's plan
    return stack_layouts([compile_layout(m, topo, plan=k == 0) for k, m in enumerate(models)])


def _differ(value, ref) -> str:
    """The first entry where ``value`` differs from ``ref``, as text."""
    if not isinstance(value, tuple) or not isinstance(ref, tuple):
        return f"{value!r} instead of {ref!r}"
    for a, b in zip(value, ref):
        if a != b:
            return f"{a!r} instead of {b!r}"
    return f"{len(value)} entries instead of {len(ref)}"


def stack_layouts(layouts: list[Layout]) -> Layout:
    """One layout for several designs of the same topology: every number gains a design axis,
    shaped to broadcast against ``(D, T)`` batches (per-entity vectors ``(n, 2, D, 1)``, numbers
    ``(n, D, 1)``, ``size`` (D, 1)); the motions and load values keep one function per design.
    """
    first = layouts[0]
    topo = first.topo
    for k, lay in enumerate(layouts[1:], 1):
        same = (lay.topo.bodies, lay.topo.parent, lay.topo.tree_joint, lay.topo.sign,
                lay.topo.cut, lay.kind) == (topo.bodies, topo.parent, topo.tree_joint, topo.sign,
                                            topo.cut, first.kind)
        if not same:
            raise ModelError(f"design {k} has a different topology from design 0",
                             field="designs", fix="Vary numbers only, not bodies or joints")
        if (len(lay.motions), [(r.kind, r.body, r.body2) for r in lay.loads]) != (
                len(first.motions), [(r.kind, r.body, r.body2) for r in first.loads]):
            raise ModelError(f"design {k} has other drivers or loads than design 0",
                             field="designs", fix="Vary the loads' and drivers' numbers only")

    def stacked(xs):   # (...) per design -> (..., D, 1)
        return np.ascontiguousarray(np.stack([np.asarray(x, float) for x in xs], axis=-1)[..., None])

    points = tuple({name: stacked([l.points[i][name] for l in layouts]) for name in first.points[i]}
                   for i in range(topo.n))
    loads = tuple(replace(row, stiffness=stacked([l.loads[k].stiffness for l in layouts]),
                          free_length=stacked([l.loads[k].free_length for l in layouts]),
                          damping=stacked([l.loads[k].damping for l in layouts]),
                          values=tuple(l.loads[k].values[0] for l in layouts),
                          # a joint_force's axis (the joint's, which designs may vary)
                          axis=None if row.axis is None else stacked([l.loads[k].axis
                                                                      for l in layouts]))
                  for k, row in enumerate(first.loads))
    return first.with_numbers(**{f: stacked([getattr(l, f) for l in layouts])
                                 for f in Layout.NUMBERS},
                   points=points, loads=loads,
                   motions=tuple(tuple(l.motions[k][0] for l in layouts)
                                 for k in range(len(first.motions))),
                   designs=len(layouts))
