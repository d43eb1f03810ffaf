"""Spatial mechanisms (``[mechanism] space = "spatial"``): the seed's 6-D DeNOC method.

:mod:`.algebra` (twists, wrenches, cross operators, spatial inertia about the global origin),
:mod:`.joints` (one module per kind and its registry), :mod:`.reader` (the model file),
:mod:`.kinematics` (tree poses and twists, closure by Newton's method with continuation,
rates and accelerations by least squares), :mod:`.dynamics` (loads, DeNOC inverse dynamics,
minimum-norm reactions), :mod:`.solution` (the result API and columns). The topology (tree
and cut joints) is :func:`linkdyn.topology.build`, shared with planar models.
"""

from __future__ import annotations

import numpy as np

from . import dynamics as sd
from . import kinematics as sk
from .solution import Redundancy, SpatialSolution

__all__ = ["analyze", "analyze_designs", "SpatialSolution", "Redundancy", "check"]


def analyze(model, t, allow_singular: bool = False) -> SpatialSolution:
    """Kinematics, inverse dynamics and reactions of the spatial ``model`` at the times ``t``
    (T,) s (numpy backend).

    ``allow_singular``: the samples at a singular position (the dependent joints' Jacobian
    loses rank there or within the closure's resolution, :func:`~.kinematics.singular_samples`)
    are kept as gaps, and so are the samples from the one where the loops stop closing on (the
    branch ends there), as ``linkdyn.analyze``
    keeps a planar model's: ``SpatialSolution.valid`` False and every per-sample array NaN
    there (``t`` kept), the other samples as the run without them gives them.

    Raises
    ------
    AssemblyError
        Where the mechanism cannot be assembled, or (unless ``allow_singular``) its loops stop
        closing or it passes a singular position (time and driver values named); with
        ``allow_singular`` too where no sample is kept.
    ModelError
        A mobility (from the closure Jacobian's rank) other than the number of drivers.
    """
    t = np.asarray(t, float)
    shown, model, p, moved = _coordinate_drivers(model)
    motion, kept, errors = sk.solve_designs([model], p, t)
    valid = np.ones(len(t), bool)
    if errors[0] is not None:
        # a run that passes a singular position or stops closing is kept (``kept``); one that
        # does not assemble is not
        if not (allow_singular and len(kept)):
            raise errors[0]
        valid = ~sk.singular_samples(p, motion)
        if not np.any(valid):
            raise errors[0]
    coords = sk.joint_coordinates(model, p, motion)
    applied = sd.loads(model, p, motion, coords)
    dyn = sd.solve(model, p, motion, applied)
    first = int(np.argmax(valid))        # the first regular sample: the redundant rows there
    sol = SpatialSolution(shown, p, motion, coords, applied, dyn,
                          sk.redundant_rows(model, p, motion.J[first]), first=first,
                          moved=moved)
    return sol if np.all(valid) else sol.gaps(valid)


def _coordinate_drivers(model):
    """The model :func:`analyze` solves where some drivers name one coordinate of a joint of
    several freedoms (``J3.1`` of a universal joint, ``J2.s`` of a cylindrical one: a mode's
    motion, :func:`linkdyn.modal.mode_motion`), as ``simulate`` keeps its free coordinates:
    those joints in the tree (:func:`.forward.partition`'s placeholder drivers, here with the
    coordinates' motions), the plan's driven coordinates the drivers' then those.

    Returns
    -------
    shown : Model
        ``model`` with the drivers of whole joints only (the solution's model).
    inner : Model
        The model the stages solve: those drivers, then one per named coordinate on its joint.
    plan : Plan
        ``inner``'s, its ``driven`` the drivers' coordinates then the named ones.
    moved : tuple[str, ...]
        The named coordinates, in ``inner``'s order (their efforts follow the drivers').

    Raises
    ------
    ModelError
        A driver naming neither a joint nor a joint coordinate.
    """
    from dataclasses import replace

    from ..errors import ModelError
    from .forward import _partition
    from .reader import coordinate_names

    joints = {j.name for j in model.joints}
    whole = tuple(d for d in model.drivers if d.joint in joints)
    named = tuple(d for d in model.drivers if d.joint not in joints)
    if not named:
        return model, model, sk.plan(model), ()
    known = coordinate_names(model.joints)
    for d in named:
        if d.joint not in known:
            raise ModelError(f"driver of '{d.joint}': no joint or joint coordinate has that "
                             "name", file=model.source, field="drivers",
                             fix=f"Name a joint or one of {', '.join(known)}")
    shown = replace(model, drivers=whole)
    part = _partition(shown, tuple(d.joint for d in named))
    held = part.inner.drivers[len(whole):]
    inner = replace(part.inner, drivers=whole + tuple(
        replace(h, motion=d.motion, description=d.description) for h, d in zip(held, named)))
    return shown, inner, part.plan, tuple(d.joint for d in named)


def analyze_designs(models, t):
    """:func:`analyze` of D designs of one spatial model (the same bodies, joints, kinds and
    drivers; other numbers) as one batch: every stage runs on all designs' samples at once
    (:func:`~.kinematics.designs`, :func:`~.kinematics.solve_designs`), each design's Newton
    solves converging on their own.

    Parameters
    ----------
    models : sequence of Model
        The D designs.
    t : array_like (T,)
        Times, s.

    Returns
    -------
    solution : SpatialSolution or None
        The designs ``kept`` solved together (``batch = (len(kept), T)``; None if no design
        assembles).
    kept : ndarray of int
        The designs solved (those that assemble; one that passes a singular position or whose
        loops stop closing along the run is kept too, its error given: its samples are not
        all the run's).
    errors : list
        Per design None, or the AssemblyError or ModelError :func:`analyze` raises for it.
    """
    t = np.asarray(t, float)
    models = list(models)
    p = sk.designs(models, len(t))
    motion, kept, errors = sk.solve_designs(models, p, t)
    if not len(kept):
        return None, kept, errors
    pr = sk.take(p, (kept[:, None] * len(t) + np.arange(len(t))).ravel())
    coords = sk.joint_coordinates(models[0], pr, motion)
    applied = sd.loads(models[0], pr, motion, coords)
    dyn = sd.solve(models[0], pr, motion, applied)
    return (SpatialSolution(models[0], pr, motion, coords, applied, dyn, (),
                            batch=(len(kept), len(t))), kept, errors)


def check(model) -> dict:
    """What ``linkdyn check`` reports of a spatial model: the topology, Grübler–Kutzbach's
    count, the assembly at t = 0, the mobility from the closure Jacobian's rank and the
    redundant rows."""
    from . import forward
    p = sk.plan(model)
    free = ()
    _, _, J = sk.closure(model, p, sk.poses(p, forward._closed_design(model, p)[None]))
    if p.n_q - int(sk.rank_of(p, J)[0]) > len(model.drivers):
        # free degrees of freedom (a model for simulate): closed at [initial]'s start
        part = forward.partition(model)
        free, q = part.free, forward.start_state(part)[None]
    else:
        qi, _, _ = sk.driver_motion(model, np.zeros(1))
        q = sk.assemble(model, p, np.zeros(1), qi)
    _, _, J = sk.closure(model, p, sk.poses(p, q))
    rank = int(sk.rank_of(p, J)[0])
    return {"plan": p, "gruebler": p.topo.mobility, "mobility": p.n_q - rank,
            "rows": J.shape[1], "rank": rank, "redundant": sk.redundant_rows(model, p, J[0]),
            "free": free}
