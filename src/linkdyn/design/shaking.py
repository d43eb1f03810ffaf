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

from ..model import GROUND
from ..planar import cross, first, last
from .free_body import effort_wrench, mass_centre


def shaking_wrench(sol) -> np.ndarray:
    """Resultant load of the moving links on the ground, (T, 3) ``[n_z, fx, fy]``.

    ``n_z`` is the moment about the global origin (N m), ``f`` the force (N), global components.
    Included: every ground joint's reaction on the ground, the reaction of its driver (torque
    or force) and every ground-anchored spring or damper. See the module docstring.
    """
    m = sol.model
    drivers = {d.joint: k for k, d in enumerate(m.drivers)}
    out = np.zeros(sol.kin.shape + (3,))
    for k, j in enumerate(m.joints):
        if (j.body_a == GROUND) == (j.body_b == GROUND):
            continue
        # wrench by the first body on the second, about the second body's joint point
        f = np.array(sol.reactions.force[..., k, :])
        n = np.array(sol.reactions.moment[..., k])
        if j.name in drivers:
            # the actuator's tau p (p of the second body; a slider's axis is fixed in the first
            # body and its line passes the joint points)
            dn, df = effort_wrench(sol, j, sol.dyn.tau[..., drivers[j.name]])
            n, f = n + dn, f + df
        r = sol.point(j.body_b, j.point_b)
        sign = 1.0 if j.body_b == GROUND else -1.0
        out[..., 0] += sign * (n + cross(first(r), first(f)))
        out[..., 1:] += sign * f
    return out + last(sol.loads.on_ground)  # springs and dampers anchored on the ground


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
    kin = sol.kin
    lay = kin.layout
    out = np.zeros((3,) + sol.kin.shape)
    for i in range(1, lay.topo.n):
        r_g, a_g = mass_centre(sol, i)
        out[1:] -= lay.mass[i] * a_g
        out[0] -= lay.mass[i] * cross(r_g, a_g) + lay.inertia[i] * kin.rates[i][0]
    return last(out)
