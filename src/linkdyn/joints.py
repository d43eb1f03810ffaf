"""The one place that knows joint kinds.

For a tree joint whose child is body i (``s = +1`` if the child is the joint's second body,
``-1`` if the first), this module gives

- the child's pose from the parent's (:func:`place_child`),
- the joint-motion propagation vector ``p_i`` of eq. (3) in the plane (revolute ``[s, 0, 0]``,
  prismatic ``[0, s e]``) and its rate,
- for a *cut* joint, its closure residual and the rows it constrains (the cut-row selection
  ``S``: a revolute keeps the two in-plane components of the relative velocity, a prismatic the
  relative rotation and the relative velocity normal to its axis), and the constraint wrench
  ``S^T lam`` those rows carry.

Arrays are component-first (see :mod:`linkdyn.planar`). The compiled kernels
(:mod:`linkdyn.compiled`) repeat these rules in scalar form; the tests hold the two to agree.
"""

from __future__ import annotations

import numpy as np

from .model import REVOLUTE
from .planar import dot, perp, rotate_cs, twist, wrap


def place_child(kind, s, q, angle, axis_p, phi_p, cos_p, sin_p, r_joint):
    """Pose of the child from its parent's pose and the joint coordinate.

    Parameters
    ----------
    kind : {'revolute', 'prismatic'}
    s : {+1, -1}
    q : ndarray (...)
        Joint coordinate, rad or m.
    angle : float
        Prismatic: fixed angle of the joint's second body relative to its first, rad.
    axis_p : ndarray (2,)
        Prismatic: unit axis expressed in the parent's frame.
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
        Prismatic: global unit axis.
    """
    if kind == REVOLUTE:
        # phi_i = phi_p + s q;  O_i coincides with the parent's joint point
        phi = phi_p + s * q
        return phi, np.cos(phi), np.sin(phi), r_joint, None
    # phi_i = phi_p + s angle;  O_i = joint point + s q e, e fixed in the joint's first body
    ca, sa = np.cos(s * angle), np.sin(s * angle)
    e = rotate_cs(cos_p, sin_p, axis_p)
    return (phi_p + s * angle, ca * cos_p - sa * sin_p, sa * cos_p + ca * sin_p,
            r_joint + (s * q) * e, e)


def motion_vector(kind, s, e, ndim):
    """Joint-motion propagation vector ``p_i`` (3, ...) of eq. (3); a revolute joint's is the
    constant ``[s, 0, 0]``, shaped ``(3, 1, ...)`` to broadcast over ``ndim`` batch axes."""
    if kind == REVOLUTE:
        return np.array([float(s), 0.0, 0.0]).reshape((3,) + (1,) * ndim)
    return twist(0.0, s * e)


def add_motion(kind, s, e, x, rate):
    """``x += p_i rate`` in place, for a twist or twist rate ``x`` (3, ...): a revolute joint
    adds ``s rate`` to the angular part, a prismatic one ``s rate e`` to the linear part."""
    if kind == REVOLUTE:
        x[0] += s * rate
    else:
        x[1:] += (s * rate) * e
    return x


def add_motion_rate(kind, s, e, w_axis, x, rate):
    """``x += pd_i rate`` in place: nothing for a revolute joint, ``s rate w perp(e)`` for a
    prismatic one, ``w_axis`` (...) being the angular velocity of the body carrying the axis."""
    if kind != REVOLUTE:
        x[1:] += (s * rate * w_axis) * perp(e)
    return x


def cut_residual(kind, angle, phi_a, phi_b, e_a, r_pa, r_pb):
    """Loop-closure residual (2, ...) of a cut joint: revolute ``r_Pb - r_Pa``; prismatic
    ``[phi_b - phi_a - angle (wrapped), (r_Pb - r_Pa) . n]`` with ``n = perp(e)``."""
    d = r_pb - r_pa
    if kind == REVOLUTE:
        return d
    return np.stack((wrap(phi_b - phi_a - angle), dot(d, perp(e_a))))


def cut_rows(kind, e_a, x):
    """Cut-row selection ``S x`` (2, ...) of a relative twist or twist rate ``x`` (3, ...) at the
    cut point: revolute ``[x_vx, x_vy]``; prismatic ``[x_w, n . x_v]``."""
    if kind == REVOLUTE:
        return x[1:]
    return np.stack(np.broadcast_arrays(x[0], dot(x[1:], perp(e_a))))


def cut_rows_rate(kind, e_a, w_a, x):
    """``(dS/dt) x`` (2, ...): zero for revolute; ``[0, n_dot . x_v]``, ``n_dot = -w_a e``."""
    if kind == REVOLUTE:
        return 0.0
    ndot_x = -w_a * dot(x[1:], e_a)
    return np.stack((np.zeros_like(ndot_x), ndot_x))


def cut_wrench(kind, e_a, lam):
    """Constraint wrench ``S^T lam`` (3, ...) on the second body at the cut point: revolute
    ``[0, lam_x, lam_y]``; prismatic ``[lam_0, lam_1 n]``."""
    if kind == REVOLUTE:
        return twist(0.0, lam)
    return twist(lam[0], lam[1] * perp(e_a))


def joint_motion(kind, e_a, a, b, points):
    """Coordinate, rate and acceleration (each (...)) of a cut joint from its bodies' motion.

    ``a``, ``b``: ``(phi, w, al)`` of the first and second body. A revolute joint's coordinate
    is ``phi_b - phi_a``. A slider's is ``s = d . e`` with ``d`` the second body's point from the
    first's and ``e`` (fixed in the first body) turning at ``w_a``:
    ``s' = d' . e + d . e'``, ``s'' = d'' . e + 2 d' . e' + d . e''``; ``points()`` gives
    ``(d, d', d'')``, each (2, ...), and is only called for a slider.
    """
    if kind == REVOLUTE:
        return b[0] - a[0], b[1] - a[1], b[2] - a[2]
    d, dd, ddd = points()
    ed = a[1] * perp(e_a)
    edd = a[2] * perp(e_a) - a[1] ** 2 * e_a
    return dot(d, e_a), dot(dd, e_a) + dot(d, ed), dot(ddd, e_a) + 2 * dot(dd, ed) + dot(d, edd)
