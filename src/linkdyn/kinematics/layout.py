"""Geometry compiled from a model along its spanning tree, for one design or a batch of designs."""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import ModelError
from ..model import Model
from ..planar import rotate
from ..topology import Topology, build
from . import dyads


@dataclass(frozen=True)
class Cut:
    """Geometry of one cut joint: bodies ``a``, ``b`` (tree indices), points relative to O_a, O_b
    in the bodies' frames."""

    joint: int
    kind: str
    a: int
    b: int
    pa: np.ndarray
    pb: np.ndarray
    axis: np.ndarray
    angle: float


@dataclass(frozen=True)
class Layout:
    """Geometry compiled from a model for its topology, SI, in tree order (index 0 = ground).

    ``joint_point[i]``: body i's parent's joint point relative to O_parent, parent frame, (2,).
    ``points[i]``: dict of body i's named points relative to O_i, body frame.
    ``axis[i]``: slider axis of body i's tree joint in the parent's frame.
    ``origin[i]``: O_i in body i's own frame. ``size``: characteristic length, m.
    """

    topo: Topology
    kind: tuple[str, ...]
    joint_point: tuple[np.ndarray, ...]
    axis: tuple[np.ndarray, ...]
    angle: tuple[float, ...]
    origin: tuple[np.ndarray, ...]
    points: tuple[dict, ...]
    com: tuple[np.ndarray, ...]
    mass: tuple[float, ...]
    inertia: tuple[float, ...]
    cuts: tuple[Cut, ...]
    size: float
    dyads: tuple | None = None  # closed-form plan (linkdyn.dyads), None: Newton's method


def compile_layout(model: Model, topo: Topology | None = None) -> Layout:
    """Geometry of ``model`` arranged along the tree of ``topo`` (built if not given)."""
    topo = topo or build(model)
    bodies = [model.body(name) for name in topo.bodies]
    pos = {name: k for k, name in enumerate(topo.bodies)}

    def own_point(j, i):
        jt = model.joints[j]
        return bodies[i].points[jt.point_b if topo.bodies[i] == jt.body_b else jt.point_a]

    origin = [np.zeros(2)] + [np.asarray(own_point(topo.tree_joint[i], i), float)
                              for i in range(1, topo.n)]
    kind, joint_point, axis, angle = [""], [np.zeros(2)], [np.zeros(2)], [0.0]
    for i in range(1, topo.n):
        jt, p = model.joints[topo.tree_joint[i]], topo.parent[i]
        kind.append(jt.kind)
        joint_point.append(np.asarray(own_point(topo.tree_joint[i], p), float) - origin[p])
        # a slider's axis is fixed in the joint's first body; store it in the parent's frame
        ax = np.asarray(jt.axis, float)
        if topo.sign[i] < 0:
            ax = rotate(np.asarray(-jt.angle), ax)
        axis.append(ax)
        angle.append(float(jt.angle))
    cuts = []
    for j in topo.cut:
        jt = model.joints[j]
        a, b = pos[jt.body_a], pos[jt.body_b]
        cuts.append(Cut(j, jt.kind, a, b, np.asarray(bodies[a].points[jt.point_a], float) - origin[a],
                        np.asarray(bodies[b].points[jt.point_b], float) - origin[b],
                        np.asarray(jt.axis, float), float(jt.angle)))
    points = tuple({k: np.asarray(v, float) - origin[i] for k, v in b.points.items()}
                   for i, b in enumerate(bodies))
    com = tuple(np.asarray(b.com, float) - origin[i] for i, b in enumerate(bodies))
    allpts = np.array([v for b in model.bodies for v in b.points.values()], float)
    size = float(np.max(np.ptp(allpts, axis=0))) if len(allpts) > 1 else 1.0
    lay = Layout(topo, tuple(kind), tuple(joint_point), tuple(axis), tuple(angle), tuple(origin),
                 points, com, tuple(float(b.mass) for b in bodies),
                 tuple(float(b.inertia) for b in bodies), tuple(cuts), size if size > 0 else 1.0)
    return replace(lay, dyads=dyads.plan(lay))


def stack_layouts(layouts: list[Layout]) -> Layout:
    """One layout for several designs of the same topology: every number gains a design axis,
    shaped to broadcast against ``(D, T)`` batches (vectors ``(2, D, 1)``, scalars ``(D, 1)``).
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

    def vec(xs):
        return np.stack([np.asarray(x, float) for x in xs], axis=-1)[..., None]

    def num(xs):
        return np.asarray(xs, float)[:, None]

    def per_body(name):
        return tuple(vec([getattr(l, name)[i] for l in layouts]) for i in range(topo.n))

    def per_body_num(name):
        return tuple(num([getattr(l, name)[i] for l in layouts]) for i in range(topo.n))

    cuts = tuple(Cut(c.joint, c.kind, c.a, c.b, vec([l.cuts[k].pa for l in layouts]),
                     vec([l.cuts[k].pb for l in layouts]), vec([l.cuts[k].axis for l in layouts]),
                     num([l.cuts[k].angle for l in layouts]))
                 for k, c in enumerate(first.cuts))
    points = tuple({name: vec([l.points[i][name] for l in layouts]) for name in first.points[i]}
                   for i in range(topo.n))
    return Layout(topo, first.kind, per_body("joint_point"), per_body("axis"),
                  per_body_num("angle"), per_body("origin"), points, per_body("com"),
                  per_body_num("mass"), per_body_num("inertia"), cuts,
                  num([l.size for l in layouts]), first.dyads)
