"""The shaking force of a spatial mechanism: the resultant force the moving bodies put on the
ground (the frame), as :mod:`linkdyn.design.shaking` defines it for planar ones.

At every joint between the ground and a moving body, the joint's reaction on the ground plus
its driver's (a prismatic driver's effort along its axis; a revolute driver's is a couple), and
the force on the ground of every load anchored there (springs, dampers, joint forces), which
:func:`linkdyn.spatial.dynamics.loads` gathers as the ground's applied wrench. By the moving
bodies' momentum balance it equals ``sum(m g + F) - sum(m a_G)``, F the loads on them that do
not come from the ground.
"""

from __future__ import annotations

import numpy as np

from ..model import GROUND
from . import algebra as sa
from . import kinematics as sk


def shaking_force(sol) -> np.ndarray:
    """Shaking force (T, 3) on the ground, N, global, of a
    :class:`~linkdyn.spatial.SpatialSolution`."""
    m, p = sol.model, sol.plan
    drivers = {d.joint: k for k, d in enumerate(m.drivers)}
    # loads anchored on the ground: the force part of its applied wrench [n; f]
    out = np.array(sol.loads.w_ext[:, 0, 3:])
    for j, jt in enumerate(m.joints):
        if (jt.body_a == GROUND) == (jt.body_b == GROUND):
            continue
        # by A on B: the reaction, and a prismatic driver's effort along its axis
        f = np.array(sol.dynamics.reactions[:, j, :3])
        if jt.name in drivers and p.kinds[j].effort == "force":
            e = sa.matvec(sk.joint_pose(p, sol.motion.tree, j, jt).RA, p.geometry[j].e)
            f += sol.dynamics.tau[:, drivers[jt.name], None] * e
        out += f if jt.body_b == GROUND else -f
    return out
