"""The load the moving links put on the ground (the frame), and its inertia part.

Shaking force and moment (:func:`shaking_wrench`, :func:`shaking_force`, :func:`shaking_moment`)
    The resultant load the moving links exert on the ground (the frame), moment about the global
    origin: at every joint between the ground and a moving body, the joint's reaction on the
    ground plus the reaction of the joint's driver (minus the driver torque, or minus the
    driver force along the slider axis, for the ground as the joint's second body the effort
    itself); plus the force of every spring and damper anchored on the ground. Loads applied
    directly to the ground are not transmitted by the mechanism and are left out. By the moving
    links' momentum balance it equals the sum over moving links of the applied loads that do not
    come from the ground (gravity, point forces, torques) minus the rate of their momentum,
    ``sum(m g + F) - sum(m a_G)``. :func:`inertia_wrench` is the inertia part alone,
    ``-sum(m a_G)`` and ``-sum(r_G x m a_G + I_G alpha)``, the target of mass balancing.
"""

from __future__ import annotations

import numpy as np

from ..model import GROUND, REVOLUTE


# components last: (..., 2) vectors

def _cross(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _perp(a):
    return np.stack((-a[..., 1], a[..., 0]), axis=-1)


def _rot(phi, v):
    """Rotate the local vector ``v`` (2,) by the angles ``phi`` (...) -> (..., 2)."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack((c * v[0] - s * v[1], s * v[0] + c * v[1]), axis=-1)


def _spring_forces_on_ground(sol):
    """Force (T, 2) on the ground and its moment about the origin (T,) of every spring or damper
    with one end on the ground."""
    m = sol.model
    f_tot = np.zeros(sol.t.shape + (2,))
    n_tot = np.zeros(sol.t.shape)
    for load in m.loads:
        if load.kind not in ("spring", "damper") or (load.body == GROUND) == (load.body2 == GROUND):
            continue
        r1, r2 = sol.point(load.body, load.point), sol.point(load.body2, load.point2)
        v1 = sol.kin.point_velocity(load.body, load.point)
        v2 = sol.kin.point_velocity(load.body2, load.point2)
        d = r2 - r1
        length = np.linalg.norm(d, axis=-1)
        u = d / length[..., None]
        if load.kind == "spring":  # tension k (l - l0) pulls the two ends together
            tension = load.stiffness * (length - load.free_length)
        else:  # damper: tension c dl/dt
            tension = load.damping * np.sum(u * (v2 - v1), axis=-1)
        # end 1 is pulled towards end 2 (+u), end 2 towards end 1 (-u)
        f, r = ((tension[..., None] * u, r1) if load.body == GROUND
                else (-tension[..., None] * u, r2))
        f_tot += f
        n_tot += _cross(r, f)
    return f_tot, n_tot


def shaking_wrench(sol) -> np.ndarray:
    """Resultant load of the moving links on the ground, (T, 3) ``[n_z, fx, fy]``.

    ``n_z`` is the moment about the global origin (N m), ``f`` the force (N), global components.
    Included: every ground joint's reaction on the ground, the reaction of its driver (torque
    or force) and every ground-anchored spring or damper. See the module docstring.
    """
    m = sol.model
    drivers = {d.joint: k for k, d in enumerate(m.drivers)}
    out = np.zeros(sol.t.shape + (3,))
    for k, j in enumerate(m.joints):
        if (j.body_a == GROUND) == (j.body_b == GROUND):
            continue
        # wrench by the first body on the second, about the second body's joint point
        f = np.array(sol.reactions.force[..., k, :])
        n = np.array(sol.reactions.moment[..., k])
        if j.name in drivers:
            tau = sol.dyn.tau[..., drivers[j.name]]
            if j.kind == REVOLUTE:
                n = n + tau
            else:  # along the axis, fixed in the first body; its line passes the joint points
                f = f + tau[..., None] * _rot(sol.phi(j.body_a), np.asarray(j.axis, float))
        r = sol.point(j.body_b, j.point_b)
        sign = 1.0 if j.body_b == GROUND else -1.0
        out[..., 0] += sign * (n + _cross(r, f))
        out[..., 1:] += sign * f
    f_s, n_s = _spring_forces_on_ground(sol)
    out[..., 0] += n_s
    out[..., 1:] += f_s
    return out


def shaking_force(sol) -> np.ndarray:
    """Shaking force (T, 2) on the ground, N, global (see :func:`shaking_wrench`)."""
    return shaking_wrench(sol)[..., 1:]


def shaking_moment(sol) -> np.ndarray:
    """Shaking moment (T,) on the ground about the global origin, N m, driver reaction included
    (see :func:`shaking_wrench`)."""
    return shaking_wrench(sol)[..., 0]


def inertia_wrench(sol) -> np.ndarray:
    """Inertia load of the moving links, (T, 3): ``[-sum(r_G x m a_G + I_G alpha), -sum m a_G]``,
    moment about the global origin. Equals the shaking wrench when no loads act."""
    m = sol.model
    out = np.zeros(sol.t.shape + (3,))
    for b in m.moving_bodies:
        phi, w, al = sol.phi(b.name), sol.omega(b.name), sol.alpha(b.name)
        # mass centre from any named point P of the body: a_G = a_P + alpha perp(d) - w^2 d
        p_name, p_loc = next(iter(b.points.items()))
        d = _rot(phi, np.asarray(b.com, float) - np.asarray(p_loc, float))
        r_g = sol.point(b.name, p_name) + d
        a_g = (sol.kin.point_acceleration(b.name, p_name) + al[..., None] * _perp(d)
               - (w ** 2)[..., None] * d)
        out[..., 1:] -= b.mass * a_g
        out[..., 0] -= b.mass * _cross(r_g, a_g) + b.inertia * al
    return out
