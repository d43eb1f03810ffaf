"""The joint-kind protocol: everything the solvers ask of a joint, in one class.

A joint joins body ``a`` (first, ``connect[0]``) and body ``b`` (second, ``connect[1]``). As a
*tree joint* it places its child (body i, ``s = +1`` if the child is the joint's second body,
``-1`` if the first) from its parent by one coordinate ``q``; as a *cut joint* it contributes
:attr:`JointKind.rows` loop-closure rows. A kind that cannot be a tree joint (``tree = False``,
e.g. a pin in a slot, which leaves two relative freedoms) is always cut.

For a tree joint (eqs. 1-3 of the seed paper, planar)

- :meth:`JointKind.place_child`: the child's pose from the parent's and ``q``;
- :meth:`JointKind.motion_vector`: the joint-motion propagation vector ``p_i`` (3, ...), and
  :meth:`JointKind.add_motion`, :meth:`JointKind.add_motion_rate`: ``x += p_i rate`` and
  ``x += pd_i rate`` in place, as the twist recursions use them.

For a cut joint at the second body's point P, with ``x`` the relative twist of b to a at P

- :meth:`JointKind.cut_residual`: the position closure residual (rows, ...);
- :meth:`JointKind.cut_rows`: the cut-row selection ``S x`` (rows, ...) and
  :meth:`JointKind.cut_rows_rate`: ``(dS/dt) x``;
- :meth:`JointKind.cut_wrench`: the constraint wrench ``S^T lam`` on b at P;
- :meth:`JointKind.joint_motion`: the joint's coordinate, rate and acceleration from its
  bodies' motion (a cut joint's ``q`` is an output, not an unknown).

Arrays are component-first (see :mod:`linkdyn.planar`): a planar vector is ``(2, ...)``, a
twist ``[w, vx, vy]`` or wrench ``[n, fx, fy]`` is ``(3, ...)``; ``e_a`` is the joint's axis,
fixed in its first body, in global components. A kind module defines one subclass and one
instance ``KIND``; :mod:`linkdyn.joints` registers it.
"""

from __future__ import annotations

import numpy as np

from ..planar import dot, perp


class JointKind:
    """Base class of the joint kinds; the attributes describe the kind to the rest of the code.

    Attributes
    ----------
    name : str
        The model file's ``type``.
    freedoms : int
        Relative freedoms the joint leaves its two bodies (of the plane's three).
    rows : int
        Loop-closure rows when cut: ``3 - freedoms``; Grübler–Kutzbach counts them.
    tree : bool
        Whether it can be a tree joint (one coordinate places the child); if not, it is always cut.
    angular : bool
        Its coordinate ``q`` is an angle (rad; else a length, m).
    keys : tuple[str, ...]
        Model-file keys it accepts beyond ``name``, ``type``, ``connect``.
    row_units : tuple[str, ...]
        ``'rad'`` or ``'m'`` for each cut row (the closure residual is scaled by them).
    reaction : tuple[str, ...]
        Reaction columns it reports, from ``('Fx', 'Fy', 'M')``.
    multipliers : tuple[tuple[str, str], ...]
        ``(label, unit)`` of each cut row's multiplier, in row order.
    effort : str or None
        Prefix of a driver's effort column (``'tau'`` N m, ``'force'`` N); None: not drivable.
    dyad : str or None
        Its letter in the closed-form dyads of :mod:`linkdyn.kinematics.dyads` (``'R'``,
        ``'P'``); None: loops it closes use Newton's method.
    """

    name = ""
    freedoms = 1
    tree = True
    angular = True
    keys: tuple[str, ...] = ()
    row_units: tuple[str, ...] = ()
    reaction: tuple[str, ...] = ("Fx", "Fy")
    multipliers: tuple[tuple[str, str], ...] = ()
    effort: str | None = None
    dyad: str | None = None

    @property
    def rows(self) -> int:
        return 3 - self.freedoms

    def __repr__(self) -> str:
        return f"<joint kind {self.name!r}>"

    # --- as a tree joint --------------------------------------------------------------------
    def place_child(self, s, q, angle, axis_p, phi_p, cos_p, sin_p, r_joint):
        """Pose of the child from its parent's pose and the joint coordinate.

        Parameters
        ----------
        s : {+1, -1}
        q : ndarray (...)
            Joint coordinate, rad or m.
        angle : float
            Fixed angle of the joint's second body relative to its first, rad (if the kind has one).
        axis_p : ndarray (2,)
            Unit axis expressed in the parent's frame (if the kind has one).
        phi_p, cos_p, sin_p : ndarray (...)
            Parent's absolute angle, its cosine and sine.
        r_joint : ndarray (2, ...)
            Global position of the parent's joint point, m.

        Returns
        -------
        phi, cos, sin : ndarray (...)
            Child's absolute angle, its cosine and sine.
        r : ndarray (2, ...)
            Child's reference point O_i (its own joint point), m.
        e : ndarray (2, ...) or None
            Global unit axis, if the kind has one.
        """
        raise NotImplementedError(f"a {self.name} joint cannot be a tree joint")

    def motion_vector(self, s, e, ndim):
        """Joint-motion propagation vector ``p_i`` (3, ...) of eq. (3); a constant one is shaped
        ``(3, 1, ...)`` to broadcast over ``ndim`` batch axes. ``e``: global axis or None."""
        raise NotImplementedError(f"a {self.name} joint cannot be a tree joint")

    def add_motion(self, s, e, x, rate):
        """``x += p_i rate`` in place for a twist or twist rate ``x`` (3, ...); returns ``x``."""
        raise NotImplementedError(f"a {self.name} joint cannot be a tree joint")

    def add_motion_rate(self, s, e, w_axis, x, rate):
        """``x += pd_i rate`` in place (``w_axis`` (...): angular velocity of the body carrying
        the axis); returns ``x``."""
        raise NotImplementedError(f"a {self.name} joint cannot be a tree joint")

    # --- as a cut joint ---------------------------------------------------------------------
    def cut_residual(self, angle, phi_a, phi_b, e_a, r_pa, r_pb):
        """Loop-closure residual (rows, ...) from the bodies' angles and the cut points
        ``r_pa``, ``r_pb`` (2, ...) (m, rad as :attr:`row_units`)."""
        raise NotImplementedError

    def cut_rows(self, e_a, x):
        """Cut-row selection ``S x`` (rows, ...) of a relative twist or twist rate ``x`` (3, ...)
        of the second body to the first at the cut point."""
        raise NotImplementedError

    def cut_rows_rate(self, e_a, w_a, x):
        """``(dS/dt) x`` (rows, ...) or a scalar 0, ``w_a`` (...) the first body's angular
        velocity (the axis turns with it)."""
        raise NotImplementedError

    def cut_wrench(self, e_a, lam):
        """Constraint wrench ``S^T lam`` (3, ...) on the second body about the cut point, from
        the multipliers ``lam`` (rows, ...)."""
        raise NotImplementedError

    def joint_motion(self, e_a, a, b, points):
        """Coordinate, rate and acceleration (each (...)) of a cut joint from its bodies' motion.

        ``a``, ``b``: ``(phi, w, al)`` of the first and second body; ``points()`` gives the
        second body's point relative to the first's, its rate and acceleration ``(d, d', d'')``,
        each (2, ...) (called only by kinds that need it).
        """
        raise NotImplementedError

    # --- explicit matrices, for the dense reference -----------------------------------------
    def selection(self, e_a) -> np.ndarray:
        """The cut-row selection matrix ``S`` (rows, 3) at one sample, ``e_a`` (2,): the cut
        rows of the identity's columns."""
        return np.asarray(self.cut_rows(np.asarray(e_a, float), np.eye(3))).reshape(self.rows, 3)


def line_motion(e_a, w_a, al_a, points):
    """Coordinate, rate and acceleration of a point sliding on a line fixed in body a.

    ``s = d . e`` with ``d`` the second body's point from the first's and ``e`` (2, ...) turning
    at ``w_a``: ``s' = d' . e + d . e'``, ``s'' = d'' . e + 2 d' . e' + d . e''`` with
    ``e' = w_a perp(e)``, ``e'' = al_a perp(e) - w_a^2 e``.
    """
    d, dd, ddd = points()
    ed = w_a * perp(e_a)
    edd = al_a * perp(e_a) - w_a ** 2 * e_a
    return dot(d, e_a), dot(dd, e_a) + dot(d, ed), dot(ddd, e_a) + 2 * dot(dd, ed) + dot(d, edd)
