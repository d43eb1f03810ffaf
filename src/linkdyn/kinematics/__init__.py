"""Recursive kinematics of a planar closed-loop mechanism (seed paper, eqs. 1-7).

The loops are cut at the topology's cut joints, leaving a tree. Twists propagate along it
(:mod:`.recursion`); at every cut the relative twist of its two bodies must vanish, ``J qd = 0``,
which gives the dependent joint rates and, differentiated, their accelerations. The stage takes
a state: :func:`at_state` (:mod:`.state`) closes the loops at given independent coordinates and
solves the rates and accelerations. :func:`solve` (:mod:`.solution`) drives it by time: the
drivers' motions give the state, and the branch assembled at t = 0 from the ``[assembly]`` guess
and followed to every sample (:mod:`.positions`) gives the positions' guess, closed in closed
form where the loops are RRR dyads (:mod:`.dyads`). The geometry the recursions use is compiled
once per model (:mod:`.layout`).

Every function works on arrays with leading batch axes (samples, designs); the loops run over
bodies, never over samples.
"""

from ..planar import last
from .layout import Cut, Layout, compile_layout, stack_layouts
from .positions import ACCEPT, STEP_ANGLE, STEP_LENGTH, TOL, assemble, driver_values, newton
from .recursion import (Pose, closure_bias, closure_jacobian, closure_residual,
                        dependent_rates, forward_positions, forward_twist_rates, forward_twists,
                        motion_vectors, point_acceleration)
from .solution import solve
from .state import KinematicSolution, at_state, close, joint_values

__all__ = ["Cut", "Layout", "compile_layout", "stack_layouts", "Pose", "KinematicSolution",
           "solve", "at_state", "close", "assemble", "newton", "driver_values", "forward_positions",
           "closure_residual", "closure_jacobian", "closure_bias", "forward_twists",
           "forward_twist_rates", "motion_vectors", "dependent_rates", "point_acceleration",
           "joint_values", "last", "TOL", "ACCEPT", "STEP_ANGLE", "STEP_LENGTH"]
