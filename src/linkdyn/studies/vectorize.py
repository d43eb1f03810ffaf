"""Designs as arrays: the stacked layout of a chunk of designs, built at once from its parameters.

A design parameter is a number of the model file. Through the loader (units, parallel-axis
theorem, a com given as a point) and :func:`linkdyn.kinematics.layout.compile_layout` (points
relative to each body's origin, slider axes in the parent's frame) it reaches a few numbers of the
numeric layout, and for nearly every parameter it reaches them affinely::

    z(v) = z(b) + A (v - b)

with ``z`` every number of the layout of one design (points, joint points, origins, mass centres,
masses, inertias, cut geometry, gravity, spring and damper constants, the constant components of
load values, constant driver speeds and starts, the ``[assembly]`` guesses), ``v`` the parameter
values (P,) in the file's units and ``b`` the file's own. The map ``A`` (P, N) is not written out
by hand: :func:`derive` reads it off the per-design path (``model_from_dict`` then
``compile_layout``, the single source of truth) once per study, by solving the file itself at a
few values of each parameter within the study's range, and checks on the way that the map is
affine (each parameter at three values) and additive (all parameters moved at once). A chunk of
D designs is then one matrix product ``Z = z(b) + (V - b) A`` and a reshape into the stacked
layout (:meth:`Builder.layout`), with no Python per design. The one number that is not affine,
the characteristic size (the largest spread of the points), is computed from the stacked points
by the same function as for one design (:func:`linkdyn.kinematics.layout.point_spread`).

A parameter the map cannot carry (one that changes anything but these numbers, or enters them
non-affinely, such as a body's ``inertia_about`` point or a slider's axis component) leaves the
study on the per-design path, with the reason in :attr:`Builder.why`.

The loader's checks of a design's numbers are applied to the arrays: masses, inertias,
spring and damper constants not negative, every number finite and within the file's
magnitude limits, no link of zero length. A design that fails one is built by the per-design path,
so its reason is the loader's own message.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from .. import joints as jk
from ..errors import ModelError
from ..io.reader import MAX_MAGNITUDE, MIN_MAGNITUDE
from ..kinematics.layout import Layout, compile_layout
from ..model import Model, point_spread
from ..motion import ConstantSpeed
from ..topology import build

if TYPE_CHECKING:   # a study's Space is read, never built, here: params imports this module
    from .params import Space

RTOL = 1e-12  # affine and additive to this fraction of each number's scale over the probes


# --- the numbers of one design's layout, flat ---------------------------------------------------

#: the layout's numbers per tree body and per cut joint, with each one's shape: the bodies' and
#: every number the joint kinds declare (linkdyn.joints.NUMBERS), which the map carries alike
_PER_BODY = {"joint_point": (2,), "origin": (2,), "com": (2,), "mass": (), "inertia": (),
             **{k: x.shape for k, x in jk.NUMBERS.items()}}
_PER_CUT = {"pa": (2,), "pb": (2,), **{k: x.shape for k, x in jk.NUMBERS.items()}}


def _load_constants(row) -> tuple[int, ...]:
    """Indices of a load value's constant components (a number in the file), else ()."""
    f = row.values[0]
    comps = getattr(f, "components", None)
    if comps is None:
        return ()
    return tuple(k for k, c in enumerate(comps) if isinstance(c, float))


def _entries(model: Model, lay: Layout) -> list[tuple[tuple, np.ndarray]]:
    """Every number of one design's layout that a design parameter may change, as ``(key,
    1-D array)`` in a fixed order (the keys depend on the topology and the file's structure only).
    """
    out = []
    n = lay.topo.n
    for name in _PER_BODY:
        out += [((name, i), np.asarray(getattr(lay, name)[i], float).reshape(-1))
                for i in range(n)]
    for i in range(n):
        out += [(("points", i, p), np.asarray(x, float)) for p, x in lay.points[i].items()]
    for k, c in enumerate(lay.cuts):
        out += [(("cut", k, f), np.asarray(getattr(c, f), float).reshape(-1))
                for f in _PER_CUT]
    out.append((("gravity",), np.asarray(lay.gravity, float)))
    for k, r in enumerate(lay.loads):
        out += [(("load", k, f), np.array([getattr(r, f)], float))
                for f in ("stiffness", "free_length", "damping")]
        if r.axis is not None:   # a joint_force's axis (its joint's)
            out.append((("load", k, "axis"), np.asarray(r.axis, float)))
        idx = _load_constants(r)
        if idx:
            comps = r.values[0].components
            out.append((("load_value", k), np.array([comps[j] for j in idx], float)))
    for k, m in enumerate(lay.motions):
        if type(m[0]) is ConstantSpeed:
            out.append((("motion", k), np.array([m[0].speed, m[0].start], float)))
    out += [(("assembly_phi", b), np.array([v], float)) for b, v in model.assembly_phi.items()]
    out += [(("assembly_q", j), np.array([v], float)) for j, v in model.assembly_q.items()]
    # the model's own points (each body's frame), for the characteristic size
    out += [(("raw", b.name, p), np.asarray(x, float)) for b in model.bodies
            for p, x in b.points.items()]
    return out


def _frame(model: Model, lay: Layout) -> tuple:
    """What a design parameter carried by the map must leave unchanged: the structure of the
    model and of its layout, everything but the numbers of :func:`_entries`."""
    def value_shape(f):
        comps = getattr(f, "components", None)
        if comps is None:
            return ("other", f)
        return (getattr(f, "vector", None), getattr(f, "state", None),
                tuple("number" if isinstance(c, float) else c for c in comps))

    return (
        model.name, model.cut, model.duration, model.cycles, model.samples, model.path_point,
        model.path_range, tuple(sorted(model.initial_q.items())),
        tuple(sorted(model.initial_qd.items())), model.length_unit, model.angle_unit,
        tuple((b.name, tuple(b.points)) for b in model.bodies),
        tuple((j.name, j.kind, j.body_a, j.point_a, j.body_b, j.point_b) for j in model.joints),
        tuple((d.joint, type(d.motion).__name__,
               None if type(d.motion) is ConstantSpeed else d.motion) for d in model.drivers),
        tuple((r.kind, r.name, r.body, r.point, r.body2, r.point2, r.joint, r.axis is None,
               value_shape(r.values[0])) for r in lay.loads),
        tuple(model.assembly_phi), tuple(model.assembly_q),
        # friction numbers are read from each design's model, not from the layout: a parameter
        # that changes one leaves the study on the per-design path
        tuple((ld.coefficient, ld.radius, ld.transition_speed, ld.static_coefficient,
               ld.stiction_speed, ld.viscous, ld.preload)
              for ld in model.loads if ld.kind == "friction"),
        lay.topo.bodies, lay.topo.parent, lay.topo.tree_joint, lay.topo.sign, lay.topo.cut,
        lay.kind,
    )


# --- the builder --------------------------------------------------------------------------------

@dataclass(frozen=True)
class Builder:
    """The stacked layouts of designs of one study, from their parameter values.

    Attributes
    ----------
    space : Space
    base : Model
        The file's model (every design's structure, its columns and names).
    layout : Layout
        The file's layout (one design), with the dyad plan all designs share.
    keys : tuple
        The layout numbers in order, each ``(key, start, stop)`` into the flat vector.
    z0 : ndarray (N,)
        The file's numbers.
    A : ndarray (P, N)
        Change of each number per unit of each parameter (file units).
    why : str
        Empty when the map carries every parameter; else why the study stays on the per-design
        path (then ``A`` is None).
    """

    space: Space
    base: Model
    layout: Layout
    keys: tuple
    z0: np.ndarray
    A: np.ndarray | None
    why: str = ""

    @property
    def vectorized(self) -> bool:
        return not self.why

    def numbers(self, values) -> np.ndarray:
        """The layout numbers (D, N) of designs ``values`` (D, P)."""
        v = np.asarray(values, float).reshape(-1, len(self.space.params))
        b = np.array([p.base for p in self.space.params])
        return self.z0 + (v - b) @ self.A

    def stacked(self, Z: np.ndarray) -> tuple[Layout, dict]:
        """The stacked layout of numbers ``Z`` (D, N), and the assembly guesses (key -> (D,))."""
        D = len(Z)
        lay = self.layout
        col = {key: Z[:, a:b] for key, a, b in self.keys}

        def vec(key):     # (D, 2) -> (2, D, 1)
            return np.ascontiguousarray(col[key].T)[..., None]

        def num(key):     # (D, 1) -> (D, 1)
            return np.ascontiguousarray(col[key])

        n, nc = lay.topo.n, lay.topo.n_loops

        def rows(key, count, shape):   # one number per entity -> (count,) + shape + (D, 1)
            return np.stack([vec(key(i)) if shape else num(key(i)) for i in range(count)]) \
                if count else np.zeros((0,) + shape + (D, 1))
        loads = []
        for k, r in enumerate(lay.loads):
            values = (r.values[0],) * D
            if ("load_value", k) in col:
                f, idx = r.values[0], _load_constants(r)
                v = col[("load_value", k)]
                if np.any(v != v[:1]):   # one function per design where they differ
                    values = tuple(_with_constants(f, idx, row) for row in v.tolist())
            loads.append(replace(r, stiffness=num(("load", k, "stiffness")),
                                 free_length=num(("load", k, "free_length")),
                                 damping=num(("load", k, "damping")), values=values,
                                 axis=None if r.axis is None else vec(("load", k, "axis"))))
        motions = []
        for k, m in enumerate(lay.motions):
            same = (m[0],) * D
            if ("motion", k) in col:
                ss = col[("motion", k)]
                if np.any(ss != ss[:1]):
                    same = tuple(ConstantSpeed(s, start=q) for s, q in ss.tolist())
            motions.append(same)
        raw = np.stack([col[k].T for k, *_ in self.keys if k[0] == "raw"])  # (points, 2, D)
        guesses = {k: col[k][:, 0] for k, *_ in self.keys if k[0] in ("assembly_phi", "assembly_q")}
        out = lay.with_numbers(
            **{f: rows(lambda i, f=f: (f, i), n, shape) for f, shape in _PER_BODY.items()},
            **{f"cut_{f}": rows(lambda k, f=f: ("cut", k, f), nc, shape)
               for f, shape in _PER_CUT.items()},
            points=tuple({p: vec(("points", i, p)) for p in lay.points[i]} for i in range(n)),
            size=point_spread(raw)[:, None], gravity=vec(("gravity",)),
            motions=tuple(motions), loads=tuple(loads), designs=D)
        return out, guesses

    def guess_models(self, guesses: dict, D: int) -> list[Model]:
        """The models the assembly reads its guesses from: the file's, or per design where the
        study varies a guess."""
        if not guesses or all(np.all(g == g[:1]) for g in guesses.values()):
            return [self.base] * D
        out = []
        for k in range(D):
            phi = dict(self.base.assembly_phi)
            q = dict(self.base.assembly_q)
            for (kind, name), g in guesses.items():
                (phi if kind == "assembly_phi" else q)[name] = float(g[k])
            out.append(replace(self.base, assembly_phi=phi, assembly_q=q))
        return out

    def suspect(self, values, Z: np.ndarray, lay: Layout) -> np.ndarray:
        """Designs (D,) bool that may fail a check of the loader: a parameter not finite or
        beyond the file's magnitude limits, a mass or inertia negative, a spring or damper
        constant negative, a number not finite, a link of zero length. They are built by the
        per-design path, whose message is the design's reason (or which accepts them)."""
        from ..io.linkage import link_pairs, short_links

        v = np.asarray(values, float).reshape(len(Z), -1)
        a = np.abs(v)
        bad = ~np.all(np.isfinite(v) & (a <= MAX_MAGNITUDE) & ((a == 0) | (a >= MIN_MAGNITUDE)),
                      axis=1)
        bad |= ~np.all(np.isfinite(Z), axis=1)
        for i in range(1, lay.topo.n):
            bad |= ~(lay.mass[i][:, 0] >= 0) | ~(lay.inertia[i][:, 0] >= 0)
        for r in lay.loads:
            for x in (r.stiffness, r.free_length, r.damping):
                bad |= ~(x[:, 0] >= 0)
        points = {(k[1], k[2]): Z[:, a:b].T for k, a, b in self.keys if k[0] == "raw"}
        for _, short in short_links(link_pairs(self.base.bodies, self.base.joints), points,
                                    lay.size[:, 0]):
            bad |= short
        return bad


def _with_constants(f, idx, row):
    comps = list(f.components)
    for j, x in zip(idx, row):
        comps[j] = float(x)
    return replace(f, components=tuple(comps))


# --- deriving the map -----------------------------------------------------------------------------

def _flat(model: Model, lay: Layout) -> tuple[list, np.ndarray]:
    ent = _entries(model, lay)
    return [k for k, _ in ent], np.concatenate([x for _, x in ent]) if ent else np.zeros(0)


def _probe(space: Space, values, topo):
    """``(keys, numbers, frame)`` of the design ``values`` by the per-design path, or None if the
    loader refuses it."""
    try:
        m = space.model(values)
    except ModelError:
        return None
    lay = compile_layout(m, topo, plan=False)
    keys, z = _flat(m, lay)
    return keys, z, _frame(m, lay)


def derive(space: Space, lo=None, hi=None) -> Builder:
    """The :class:`Builder` of a study whose parameters range over ``lo``..``hi`` (P,) (file
    units; default: the file's values), read off the per-design path.

    Each parameter is set, the others at the file's values, to the candidates ``hi``, ``lo``,
    their midpoint and the quarter points, and to the midpoint between the file's value and the
    farthest candidate the loader accepts; its column of ``A`` comes from the farthest, and the
    others must lie on that line (to ``RTOL`` of each number's scale). Then every parameter is
    moved at once (to its farthest accepted value, else halfway), which must give the sum of the
    single moves. Any failure leaves the study on the per-design path, with the reason.
    """
    base = space.model()
    topo = build(base)
    lay = compile_layout(base, topo)
    keys, z0 = _flat(base, lay)
    frame0 = _frame(base, lay)
    sizes = [len(x) for _, x in _entries(base, lay)]
    stops = np.cumsum(sizes)
    key_slices = tuple((k, int(s - n), int(s)) for k, n, s in zip(keys, sizes, stops))
    P = len(space.params)
    b = np.array([p.base for p in space.params])
    lo = b.copy() if lo is None else np.asarray(lo, float).reshape(P)
    hi = b.copy() if hi is None else np.asarray(hi, float).reshape(P)

    def builder(A, why=""):
        return Builder(space, base, lay, key_slices, z0, A, why)

    def scale(*zs):
        return np.max(np.abs(np.stack(zs)), axis=0)

    A = np.zeros((P, len(z0)))
    far = b.copy()
    for k, p in enumerate(space.params):
        cands = [hi[k], lo[k], 0.5 * (lo[k] + hi[k]), 0.75 * lo[k] + 0.25 * hi[k],
                 0.25 * lo[k] + 0.75 * hi[k]]
        seen: dict[float, np.ndarray] = {}
        for c in cands:
            if not np.isfinite(c) or c == b[k] or c in seen:
                continue
            v = b.copy()
            v[k] = c
            got = _probe(space, v, topo)
            if got is None:
                continue
            if got[0] != keys or got[2] != frame0:
                return builder(None, f"{p.path} changes more than the layout's numbers")
            seen[float(c)] = got[1]
        if not seen:
            continue   # the file's value only (or none the loader accepts): no column needed
        f = max(seen, key=lambda c: abs(c - b[k]))
        far[k] = f
        mid = 0.5 * (b[k] + f)
        if mid != b[k] and mid not in seen:
            v = b.copy()
            v[k] = mid
            got = _probe(space, v, topo)
            if got is not None and got[0] == keys and got[2] == frame0:
                seen[mid] = got[1]
        A[k] = (seen[f] - z0) / (f - b[k])
        for c, z in seen.items():
            pred = z0 + A[k] * (c - b[k])
            if np.any(np.abs(pred - z) > RTOL * scale(z0, z, seen[f])):
                return builder(None, f"{p.path} does not enter the layout affinely")
        if len(seen) < 2:
            return builder(None, f"{p.path}: too few values the loader accepts to check the map")
    if P > 1 and np.any(far != b):
        for trial in (far, 0.5 * (b + far)):
            got = _probe(space, trial, topo)
            if got is not None:
                break
        else:
            return builder(None, "no design with every parameter moved is accepted by the loader")
        if got[0] != keys or got[2] != frame0:
            return builder(None, "the parameters together change more than the layout's numbers")
        pred = z0 + (trial - b) @ A
        if np.any(np.abs(pred - got[1]) > RTOL * scale(z0, got[1], pred)):
            return builder(None, "the parameters do not add up (they interact in the layout)")
    return builder(A)
