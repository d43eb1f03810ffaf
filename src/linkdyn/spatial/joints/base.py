"""The spatial joint-kind protocol and the closure rows the kinds are built of.

A joint joins body A (``connect[0]``, point p) and body B (``connect[1]``, point q). Its
constants (:class:`Geometry`): p in A's frame, q in B's, the unit ``axis`` e in A's frame and
its perpendiculars ``t1``, ``t2`` (A's frame), ``axis2`` in B's frame, and ``R0 = R_A0^T R_B0``,
B's orientation relative to A at the design pose.

As a **tree joint** a kind is a chain of elementary screws: ``relative(g, q)`` gives
``(R_rel, d)`` with ``R_B = R_A R_rel`` and ``r_Bq = r_Ap + R_A d`` (A's frame), and
``screws(g, R_A, R_B, c, q)`` the unit twists (..., f, 6) of its freedoms, global, about O, at
the joint's point ``c = r_Bq``: ``V_B = V_A + sum_k s_k qd_k``. Each ``s_k`` is fixed in the
chain's k-th intermediate body, so ``ds_k/dt = crm(V_k) s_k`` (``V_k`` the intermediate
body's twist). ``coordinates(g, R_rel, d)`` inverts ``relative`` (a cut joint's outputs).

As a **cut joint** it gives ``rows`` closure rows: ``closure(g, pose)`` returns the residual
(..., rows) and the constraint wrenches ``phi`` (..., rows, 6) (global, about O) with
``phi . (V_B - V_A) = dg/dt`` on the closed mechanism, and ``closure_rate(g, pose, motion)``
their rates ``dphi/dt``, so ``phi . (A_B - A_A) + dphi/dt . (V_B - V_A) = 0``. The rows are of
four sorts (the functions below): forces along the global axes at B's point (coincident
points), forces fixed in A at B's point (sliding), couples fixed in A perpendicular to the
axis (revolute, cylindrical), couples along the global axes (no relative rotation), and the
universal joint's one couple ``e2_B x e_A``. ``phi lam`` is then the wrench by A on B.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import algebra as sa


@dataclass(frozen=True)
class Geometry:
    """A joint's constants (SI): ``p`` (3,) in A's frame, ``q`` (3,) in B's frame, ``e``,
    ``t1``, ``t2`` (3,) an orthonormal right-handed triad in A's frame (``e`` the axis),
    ``e2`` (3,) in B's frame (universal; else zeros), ``R0`` (3, 3) B's design orientation
    relative to A."""

    p: np.ndarray
    q: np.ndarray
    e: np.ndarray
    t1: np.ndarray
    t2: np.ndarray
    e2: np.ndarray
    R0: np.ndarray


@dataclass(frozen=True)
class Pose:
    """What a cut joint's rows read of its bodies at the samples: rotations ``RA``, ``RB``
    (..., 3, 3), A's point ``rp`` and B's point ``rq`` (..., 3), global, m."""

    RA: np.ndarray
    RB: np.ndarray
    rp: np.ndarray
    rq: np.ndarray


@dataclass(frozen=True)
class Rates:
    """The bodies' twists ``VA``, ``VB`` (..., 6) and B's point's velocity ``vq`` (..., 3)."""

    VA: np.ndarray
    VB: np.ndarray
    vq: np.ndarray


def perpendiculars(e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit vectors ``t1, t2`` with ``(e, t1, t2)`` orthonormal and right-handed."""
    k = int(np.argmin(np.abs(e)))
    t1 = sa.cross(e, np.eye(3)[k])
    t1 /= np.linalg.norm(t1)
    return t1, sa.cross(e, t1)


def turned(R: np.ndarray, u: np.ndarray) -> np.ndarray:
    """The body-frame vector ``u`` (3,) in global components: ``R u`` (..., 3)."""
    return sa.matvec(R, u)


# ---------------------------------------------------------------- closure rows
def coincident(pose: Pose):
    """Coincident points: residual ``r_Bq - r_Ap`` (..., 3), rows: unit forces along the
    global axes at B's point ``[c x x_k; x_k]``."""
    axes = np.broadcast_to(np.eye(3), pose.rq.shape[:-1] + (3, 3))
    return pose.rq - pose.rp, sa.force_wrench(axes, pose.rq[..., None, :])


def coincident_rate(pose: Pose, m: Rates):
    """Rate of :func:`coincident`'s rows: ``[v_c x x_k; 0]``."""
    axes = np.broadcast_to(np.eye(3), pose.rq.shape[:-1] + (3, 3))
    return sa.free_vector(sa.cross(m.vq[..., None, :], axes), True)


def sliding(pose: Pose, t: np.ndarray):
    """Forces along directions ``t`` (..., k, 3) fixed in A at B's point: residual
    ``t . (r_Bq - r_Ap)``, rows ``[c x t; t]``."""
    return (np.sum(t * (pose.rq - pose.rp)[..., None, :], -1),
            sa.force_wrench(t, pose.rq[..., None, :]))


def sliding_rate(pose: Pose, m: Rates, t: np.ndarray):
    """Rate of :func:`sliding`'s rows: ``[v_c x t + c x (w_A x t); w_A x t]``."""
    td = sa.cross(m.VA[..., None, :3], t)
    return np.concatenate([sa.cross(m.vq[..., None, :], t) + sa.cross(pose.rq[..., None, :], td),
                           td], -1)


def aligned(eA: np.ndarray, eB: np.ndarray, t: np.ndarray):
    """Couples along ``t`` (..., k, 3) fixed in A, perpendicular to A's axis ``eA``, that keep
    B's copy of the axis ``eB`` on it: residual ``t . (e_A x e_B)``, rows ``[t; 0]``."""
    return np.sum(t * sa.cross(eA, eB)[..., None, :], -1), sa.free_vector(t, True)


def aligned_rate(m: Rates, t: np.ndarray):
    """Rate of :func:`aligned`'s rows: ``[w_A x t; 0]``."""
    return sa.free_vector(sa.cross(m.VA[..., None, :3], t), True)


def locked(pose: Pose, R0: np.ndarray):
    """No relative rotation: residual ``vee(R_B R0^T R_A^T)`` (the small rotation of B from
    its place), rows: couples along the global axes ``[x_k; 0]`` (constant)."""
    g = sa.vee(pose.RB @ sa.transpose(R0) @ sa.transpose(pose.RA))
    axes = np.broadcast_to(np.eye(3), g.shape[:-1] + (3, 3))
    return g, sa.free_vector(axes, True)


def locked_rate(pose: Pose):
    return np.zeros(pose.rq.shape[:-1] + (3, 6))


# ---------------------------------------------------------------- the protocol
class SpatialKind:
    """One spatial joint kind (a module's ``KIND``).

    Attributes
    ----------
    name : str
        The model file's ``type``.
    freedoms : int
        Relative freedoms it leaves (of six); ``rows = 6 - freedoms`` when cut.
    tree : bool
        Always True: every spatial kind can be a tree joint (a chain of elementary screws).
    angular : bool
        A one-freedom kind's coordinate is an angle (else a length); the topology's sort.
    coordinates_named : tuple[tuple[str, bool], ...]
        ``(suffix, angular)`` of each coordinate column ``q_<joint><suffix>``.
    keys : tuple[str, ...]
        Model-file keys beyond name, type, connect (``axis``, ``axis2``).
    effort : str or None
        ``'tau'`` or ``'force'`` when it can be driven (one freedom); None otherwise.
    cut_rank : int
        Loops are cut at the joint of highest rank (spherical, then universal, ...).
    row_labels : tuple[str, ...]
        A name for each closure row (``check`` names redundant rows by them): a force row's
        starts with ``F`` (its residual is a length, scaled by the mechanism's size), a
        couple row's with ``M`` (an angle).
    couple_free : bool
        Its reaction has no couple (spherical).
    """

    name = ""
    freedoms = 1
    tree = True
    angular = True
    coordinates_named: tuple = (("", True),)
    keys: tuple[str, ...] = ("axis",)
    effort: str | None = None
    cut_rank = 0
    row_labels: tuple[str, ...] = ()
    couple_free = False

    @property
    def rows(self) -> int:
        return 6 - self.freedoms

    def design_coordinates(self, g: Geometry, d0: np.ndarray) -> np.ndarray:
        """The coordinates (f,) at the design pose, ``d0 = R_A0^T (r_Bq0 - r_Ap0)``: rotations
        0, travels ``e . d0``."""
        return np.array([0.0 if ang else float(g.e @ d0) for _, ang in self.coordinates_named])

    def relative(self, g: Geometry, q: np.ndarray):
        raise NotImplementedError

    def screws(self, g: Geometry, RA, RB, c, q):
        raise NotImplementedError

    def coordinates(self, g: Geometry, R_rel, d):
        raise NotImplementedError

    def closure(self, g: Geometry, pose: Pose):
        raise NotImplementedError

    def closure_rate(self, g: Geometry, pose: Pose, m: Rates):
        raise NotImplementedError

