"""Topology: spanning tree rooted at the ground, cut joints, drivers, mobility.

Bodies are renumbered so that the ground is body 0 and every body's parent comes before it
(``parent[i] < i``). Each moving body ``i`` hangs from its parent by its *tree joint*; the
joints left out of the tree are the *cut joints*, one per independent loop. Driven joints are
always kept in the tree.
"""

from __future__ import annotations

from collections import Counter, deque
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .errors import ModelError
from . import joints as jk
from .model import GROUND, Model


@dataclass(frozen=True)
class Topology:
    """Static integer description of the mechanism's graph (no geometry).

    Attributes
    ----------
    bodies : tuple[str, ...]
        Body names in tree order; ``bodies[0] == 'ground'``.
    parent : tuple[int, ...]
        Parent body index of each body (``-1`` for the ground); ``parent[i] < i``.
    tree_joint : tuple[int, ...]
        Index into ``model.joints`` of body i's tree joint (``-1`` for the ground).
    sign : tuple[int, ...]
        ``+1`` if body i is its tree joint's second body (``connect[1]``), ``-1`` if the first.
    cut : tuple[int, ...]
        Indices into ``model.joints`` of the cut joints.
    rows : tuple[int, ...]
        Loop-closure rows of each cut joint, from its kind (``JointKind.rows``).
    driven : tuple[int, ...]
        Body index whose tree joint each driver moves, in the order of ``model.drivers``.
    dependent : tuple[int, ...]
        Bodies whose tree joint is not driven (their rates follow from loop closure).
    mobility : int
        Grübler–Kutzbach: ``3 (n - 1)`` minus the rows every joint's kind removes.
    ancestors : ndarray (n, n) bool
        ``ancestors[i, k]``: body k's tree joint lies on the path from the ground to body i
        (k = i included). Computed on first read (it is quadratic in bodies; building the
        topology is linear).
    """

    bodies: tuple[str, ...]
    parent: tuple[int, ...]
    tree_joint: tuple[int, ...]
    sign: tuple[int, ...]
    cut: tuple[int, ...]
    rows: tuple[int, ...]
    driven: tuple[int, ...]
    dependent: tuple[int, ...]
    mobility: int

    @property
    def n(self) -> int:
        """Number of bodies, ground included."""
        return len(self.bodies)

    @property
    def n_loops(self) -> int:
        return len(self.cut)

    @property
    def n_rows(self) -> int:
        """Loop-closure rows of all cut joints together."""
        return sum(self.rows)

    def row_slice(self, k: int) -> slice:
        """The rows of cut joint k (``cut[k]``) in the stacked closure arrays."""
        start = sum(self.rows[:k])
        return slice(start, start + self.rows[k])

    def children(self, i: int) -> list[int]:
        return [k for k in range(1, self.n) if self.parent[k] == i]

    @cached_property
    def ancestors(self) -> np.ndarray:
        # row i = row parent[i] plus k = i itself (parent[i] < i, so rows fill in order)
        n = self.n
        out = np.zeros((n, n), dtype=bool)
        for i in range(1, n):
            out[i] = out[self.parent[i]]
            out[i, i] = True
        out.flags.writeable = False
        return out


def registry(space: str):
    """The joint kinds of a model's ``space``: the module :mod:`linkdyn.joints` (planar) or
    :mod:`linkdyn.spatial.joints`, each with ``get``, ``names``, ``UnknownJointKind`` and
    ``BODY_FREEDOMS`` (a free body's freedoms: 3 in the plane, 6 in space)."""
    if space == "spatial":
        from .spatial import joints as spatial_kinds
        return spatial_kinds
    return jk


def _kinds(model: Model) -> list:
    """The kind of each joint of ``model``, in file order; an unknown kind is a model error."""
    reg = registry(getattr(model, "space", "planar"))
    kinds = []
    for jt in model.joints:
        try:
            kinds.append(reg.get(jt.kind))
        except reg.UnknownJointKind as exc:
            raise ModelError(str(exc), file=model.source, field=f"joints.{jt.name}.type",
                             fix="Set type to one of " + ", ".join(reg.names())) from None
    return kinds


def mobility(model: Model) -> int:
    """Grübler–Kutzbach mobility of ``model``: ``f (n - 1)`` minus the rows every joint's kind
    removes (``JointKind.rows``: in the plane, f = 3, a revolute or prismatic joint 2, a pin
    in a slot 1; in space, f = 6, a revolute joint 5, a spherical one 3), n the bodies
    including the ground. The one count of the degrees of freedom that :func:`build`,
    ``check``, the summary and ``simulate`` report (a spatial model's true mobility, which
    redundant constraints raise above it, comes from the closure Jacobian's rank:
    :mod:`linkdyn.spatial.kinematics`).

    Raises
    ------
    ModelError
        An unknown joint kind.
    """
    f = registry(getattr(model, "space", "planar")).BODY_FREEDOMS
    return f * (len(model.bodies) - 1) - sum(k.rows for k in _kinds(model))


def build(model: Model) -> Topology:
    """Choose the spanning tree and cut joints of ``model`` and check its mobility.

    Kruskal's algorithm over the joints, driven joints first, sliders last, otherwise in file
    order, skipping joints the user asked to cut and kinds that cannot be tree joints (a slot):
    every joint that would close a cycle is cut.

    Raises
    ------
    ModelError
        An unknown joint kind, a body not connected to the ground, a driven joint that would have
        to be cut, or a mobility that differs from the number of drivers.
    """
    src = model.source
    names = [b.name for b in model.bodies]
    index = {name: k for k, name in enumerate(names)}
    joints = model.joints
    driven_names = [d.joint for d in model.drivers]
    driven_set = set(driven_names)
    user_cut = set(model.cut or ())
    kinds = _kinds(model)

    # union-find over bodies
    root = list(range(len(names)))

    def find(a: int) -> int:
        while root[a] != a:
            root[a] = root[root[a]]
            a = root[a]
        return a

    # driven joints first (never cut), then by the kinds' cut rank (planar: sliders last, as a
    # cut slider leaves loops that close in closed form, see kinematics.dyads; spatial:
    # spherical joints last, then universal ones), otherwise file order
    order = sorted(range(len(joints)), key=lambda j: (joints[j].name not in driven_set,
                                                      kinds[j].cut_rank, j))
    tree, cut = [], []
    for j in order:
        jt = joints[j]
        a, b = find(index[jt.body_a]), find(index[jt.body_b])
        if jt.name in driven_set and not kinds[j].tree:
            raise ModelError(
                f"joint '{jt.name}' is a {jt.kind} joint, which cannot be driven (it leaves "
                f"{kinds[j].freedoms} relative freedoms and is always cut)",
                file=src, field="drivers",
                fix="Drive a revolute or prismatic joint of the mechanism instead")
        if jt.name in user_cut or a == b or not kinds[j].tree:
            if jt.name in driven_set:
                raise ModelError(
                    f"driven joint '{jt.name}' closes a loop formed by other driven joints",
                    file=src, field="drivers",
                    fix="Drive joints that do not form a closed loop among themselves")
            cut.append(j)
        else:
            root[a] = b
            tree.append(j)

    for name in names:
        if find(index[name]) != find(index[GROUND]):
            linked = any(find(index[b]) == find(index[GROUND])
                         for j in cut if name in (joints[j].body_a, joints[j].body_b)
                         for b in (joints[j].body_a, joints[j].body_b))
            touching = [j for j, jt in enumerate(joints) if name in (jt.body_a, jt.body_b)]
            held = [joints[j] for j in touching]
            if touching and not any(kinds[j].tree for j in touching):
                raise ModelError(
                    f"body '{name}' is held only by {held[0].kind} joint(s) "
                    + ", ".join(f"'{jt.name}'" for jt in held) + f", which cannot place it (a "
                    f"{held[0].kind} joint leaves {kinds[joints.index(held[0])].freedoms} "
                    "relative freedoms)", file=src, field=f"bodies.{name}",
                    fix="Connect the body by a revolute or prismatic joint too, e.g. a guide")
            if user_cut and linked:
                raise ModelError(
                    f"cutting {sorted(user_cut)} leaves body '{name}' without a path to the ground",
                    file=src, field="topology.cut",
                    fix="Cut only joints that close a loop (one per loop), or omit [topology]")
            raise ModelError(
                f"body '{name}' is not connected to the ground by any chain of joints",
                file=src, field=f"bodies.{name}",
                fix="Add a joint that connects it, or remove the body")
    # breadth-first numbering from the ground gives parent[i] < i
    adj: dict[str, list[int]] = {name: [] for name in names}
    for j in tree:
        adj[joints[j].body_a].append(j)
        adj[joints[j].body_b].append(j)
    bodies, parent, tree_joint, sign = [GROUND], [-1], [-1], [0]
    number = {GROUND: 0}                                    # body name -> tree index
    queue = deque([GROUND])
    while queue:
        here = queue.popleft()
        for j in adj[here]:
            jt = joints[j]
            child, s = (jt.body_b, 1) if jt.body_a == here else (jt.body_a, -1)
            if child in number:
                continue
            number[child] = len(bodies)
            bodies.append(child)
            parent.append(number[here])
            tree_joint.append(j)
            sign.append(s)
            queue.append(child)
    n = len(bodies)

    mob = mobility(model)
    # spatial: redundant constraints make Grübler–Kutzbach too low; the closure Jacobian's
    # rank checks the mobility there (linkdyn.spatial.kinematics.assemble)
    if getattr(model, "space", "planar") == "planar" and mob != len(model.drivers):
        count = Counter(k.name for k in kinds)                  # kinds in order of first use
        terms = " - ".join(f"{k.rows}*{count[k.name]}" for k in {k.name: k for k in kinds}.values())
        need = "add" if mob > len(model.drivers) else "remove"
        raise ModelError(
            f"the mechanism has mobility {mob} (Grübler–Kutzbach: 3*({n}-1)"
            + (f" - {terms}" if terms else "") + f" with {n} bodies including the ground and "
            + ", ".join(f"{c} {name}" for name, c in count.items()) + " joints) but "
            f"{len(model.drivers)} driver(s)",
            file=src, field="drivers",
            fix=(f"{need.capitalize()} {abs(mob - len(model.drivers))} driver(s), "
                 "or check the joints: a mechanism needs one driver per degree of freedom"
                 if mob >= 0 else
                 "The joints over-constrain the bodies; remove joints or add bodies"))

    tree_of_joint = {tree_joint[i]: i for i in range(1, n)}
    joint_index = {jt.name: j for j, jt in enumerate(joints)}
    driven = tuple(tree_of_joint[joint_index[name]] for name in driven_names)
    driven_bodies = set(driven)
    dependent = tuple(i for i in range(1, n) if i not in driven_bodies)
    cut = tuple(sorted(cut))
    return Topology(tuple(bodies), tuple(parent), tuple(tree_joint), tuple(sign), cut,
                    tuple(kinds[j].rows for j in cut), driven, dependent, mob)


def joint_lines(model: Model, topo: Topology, free: tuple[str, ...] = ()) -> list[str]:
    """What ``linkdyn check`` says of the joints and the loops of either space: each joint's kind,
    the points it joins and its role (tree or cut, driven, free), the spanning tree, the cut
    joints."""
    driven = {d.joint for d in model.drivers}
    width = max(9, *(len(j.kind) for j in model.joints))
    lines = [f"joints ({len(model.joints)}):"]
    for k, j in enumerate(model.joints):
        role = (("cut" if k in topo.cut else "tree") + (", driven" if j.name in driven else "")
                + (", free" if j.name in free else ""))
        lines.append(f"  {j.name:8s} {j.kind:{width}s} {j.body_a}.{j.point_a} -> "
                     f"{j.body_b}.{j.point_b}  [{role}]")
    lines.append("spanning tree (parent <- body via joint):")
    lines += [f"  {topo.bodies[topo.parent[i]]} <- {topo.bodies[i]} via "
              f"{model.joints[topo.tree_joint[i]].name}" for i in range(1, topo.n)]
    cuts = ", ".join(model.joints[j].name for j in topo.cut) or "none"
    lines.append(f"loops: {topo.n_loops}; cut joints: {cuts}")
    return lines
