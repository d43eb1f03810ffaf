"""The solution of a spatial model: what ``linkdyn.analyze`` returns for ``space = "spatial"``,
with the result columns of docs/conventions.md ("Spatial mechanisms")."""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..model import GROUND
from . import algebra as sa
from . import dynamics as sd
from . import kinematics as sk


@dataclass(frozen=True)
class Redundancy:
    """What rigid-body statics leaves undetermined in a spatial model's reactions.

    Attributes
    ----------
    rows : tuple[str, ...]
        The redundant closure rows at t = 0, as ``<cut joint>.<row>`` (row labels of the
        joint's kind: ``Fx``, ``M1``, ...): each is a combination of the rows before it.
    labels : tuple[str, ...]
        The stacked reaction components, ``Fx_<joint>``, ..., ``Mz_<joint>``, model order.
    basis : ndarray (T, 6 n_joints, k)
        An orthonormal basis of the reaction components that satisfy every body's equations
        with no load (self-equilibrated sets): the reported reactions are orthogonal to it.
    components : tuple[str, ...]
        The labels with a part in the basis at t = 0 (the undetermined components).
    """

    rows: tuple
    labels: tuple
    basis: np.ndarray
    components: tuple

    def describe(self) -> dict:
        """The summary's description (JSON-ready)."""
        return {"redundant_rows": list(self.rows), "undetermined_dimension":
                int(self.basis.shape[2]), "undetermined_components": list(self.components)}


#: The SI unit of the results' columns by their prefix (``omega_x_<body>``: ``omega``) or
#: whole name.
_COLUMN_UNITS = {
    "t": "s", "quat": "1", "omega": "rad/s", "alpha": "rad/s^2", "tau": "N m", "force": "N",
    **{f"F{c}": "N" for c in "xyz"}, **{f"M{c}": "N m" for c in "xyz"},
    **{c: "m" for c in "xyz"}, **{f"v{c}": "m/s" for c in "xyz"},
    **{f"a{c}": "m/s^2" for c in "xyz"},
    "kinetic_energy": "J", "potential_energy": "J", "work": "J"}


class SpatialSolution:
    """Kinematics, efforts and reactions of a spatial model at the times ``t`` (SI, global).

    Every per-sample array has the samples first. ``columns()`` gives the results table;
    the methods give the same numbers as arrays.

    Of a batch of designs (:func:`linkdyn.spatial.analyze_designs`) the arrays' rows are each
    design's samples, design after design: ``batch`` is then ``(D, T)`` (reshape a row array
    to it for each design's), ``model`` the first design's; None for one design.
    """

    def __init__(self, model, plan: sk.Plan, motion: sk.Motion, coords: dict,
                 applied: sd.Loads, dyn: sd.Dynamics, redundant_rows: tuple, batch=None,
                 first: int = 0, moved: tuple = ()):
        self.batch = batch
        #: the joint coordinates driven beyond the model's drivers (``J3.1``: a mode's motion),
        #: their efforts after the drivers' in ``dynamics.tau``
        self.moved = tuple(moved)
        self.model, self.plan, self.motion = model, plan, motion
        self.coords, self.loads, self.dynamics = coords, applied, dyn
        self.t = motion.t
        self.space = "spatial"
        #: (T,) bool: the samples solved; False at a singular position, or past the sample
        #: where the loops stop closing, kept by ``allow_singular`` (:meth:`gaps`), whose
        #: numbers are NaN
        self.valid = np.ones(len(self.t), bool)
        labels = tuple(f"{c}_{j.name}" for j in model.joints
                       for c in ("Fx", "Fy", "Fz", "Mx", "My", "Mz"))
        basis = dyn.undetermined
        comps = ()
        if basis.shape[2]:
            # the components at the sample ``first`` (the first one solved)
            weight = np.linalg.norm(basis[first], axis=1)
            comps = tuple(lab for lab, w in zip(labels, weight) if w > 1e-9)
        self.redundancy = (Redundancy(redundant_rows, labels, basis, comps)
                           if redundant_rows or basis.shape[2] else None)

    def gaps(self, valid: np.ndarray) -> "SpatialSolution":
        """This solution with the samples not ``valid`` (T,) as gaps: every per-sample array
        of its stages NaN there (the times kept), ``valid`` set; the samples of
        ``linkdyn.analyze(..., allow_singular=True)`` it could not solve."""
        bad = ~np.asarray(valid, bool)
        T = len(self.t)

        def blank(x, name=""):
            if isinstance(x, np.ndarray):
                if name == "t" or not x.ndim or x.shape[0] != T or x.dtype.kind not in "fc":
                    return x
                x = x.copy()
                x[bad] = np.nan
                return x
            if dataclasses.is_dataclass(x) and not isinstance(x, type):
                return dataclasses.replace(x, **{f.name: blank(getattr(x, f.name), f.name)
                                                 for f in dataclasses.fields(x)})
            if isinstance(x, (list, tuple)):
                return type(x)(blank(v) for v in x)
            if isinstance(x, dict):
                return {k: blank(v) for k, v in x.items()}
            return x
        out = copy.copy(self)
        out.__dict__.pop("_columns", None)
        out.motion, out.coords = blank(self.motion), blank(self.coords)
        out.loads, out.dynamics = blank(self.loads), blank(self.dynamics)
        if self.redundancy is not None:
            out.redundancy = dataclasses.replace(self.redundancy,
                                                 basis=blank(self.redundancy.basis))
        out.valid = ~bad
        return out

    # ------------------------------------------------------------ arrays
    def _body(self, body: str) -> int:
        return self.plan.topo.bodies.index(body)

    def rotation(self, body: str) -> np.ndarray:
        """The body frame's rotation (T, 3, 3), body to global."""
        return self.motion.tree.R[:, self._body(body)]

    def quaternion(self, body: str) -> np.ndarray:
        """Unit quaternion (T, 4) ``[w, x, y, z]`` of :meth:`rotation`, continuous in time."""
        return sa.quaternion(self.rotation(body))

    def omega(self, body: str) -> np.ndarray:
        """Angular velocity (T, 3), rad/s."""
        return self.motion.V[:, self._body(body), :3]

    def alpha(self, body: str) -> np.ndarray:
        """Angular acceleration (T, 3), rad/s^2."""
        return self.motion.A[:, self._body(body), :3]

    def _point(self, body: str, point: str):
        return sd.point_of(self.plan, self.motion, body, self.model.body(body).points[point])

    def point(self, body: str, point: str) -> np.ndarray:
        """A named point's position (T, 3), m."""
        return self._point(body, point)[0]

    def point_velocity(self, body: str, point: str) -> np.ndarray:
        return self._point(body, point)[1]

    def point_acceleration(self, body: str, point: str) -> np.ndarray:
        return self._point(body, point)[2]

    def effort(self, joint: str) -> np.ndarray:
        """A driver's effort (T,): N m about its axis or N along it, on B, minus on A."""
        k = ([d.joint for d in self.model.drivers] + list(self.moved)).index(joint)
        return self.dynamics.tau[:, k]

    def reaction(self, joint: str) -> np.ndarray:
        """The reaction by A on B (T, 6): ``[Fx, Fy, Fz, Mx, My, Mz]``, N and N m about B's
        point (a spherical joint's couple is zero)."""
        j = [x.name for x in self.model.joints].index(joint)
        return self.dynamics.reactions[:, j]

    def joint(self, joint: str):
        """A joint's ``(q, qd, qdd)``, each (T, f), its kind's coordinates."""
        return self.coords[joint]

    def kinetic_energy(self) -> np.ndarray:
        return self.dynamics.kinetic_energy

    def potential_energy(self) -> np.ndarray:
        return self.loads.potential_energy

    # ------------------------------------------------------------ table
    @cached_property
    def _columns(self) -> dict:
        m = self.model
        out = {"t": self.t}
        for j in m.joints:
            kind = self.plan.kinds[[x.name for x in m.joints].index(j.name)]
            if kind.name == "spherical":
                continue
            q, qd, qdd = self.coords[j.name]
            for k, (suffix, _) in enumerate(kind.coordinates_named):
                for prefix, x in (("q", q), ("qd", qd), ("qdd", qdd)):
                    out[f"{prefix}_{j.name}{suffix}"] = x[:, k]
        for b in m.bodies:
            if b.name == GROUND:
                continue
            for c, x in zip("wxyz", self.quaternion(b.name).T):
                out[f"quat_{c}_{b.name}"] = x
            for name, x in (("omega", self.omega(b.name)), ("alpha", self.alpha(b.name))):
                for c, v in zip("xyz", x.T):
                    out[f"{name}_{c}_{b.name}"] = v
        for d in m.drivers:
            kind = self.plan.kinds[[x.name for x in m.joints].index(d.joint)]
            out[f"{kind.effort}_{d.joint}"] = self.effort(d.joint)
        if self.moved:              # a coordinate's effort: a torque about, a force along it
            from .reader import coordinate_names
            angular = {c: a for c, (_, _, a) in coordinate_names(m.joints).items()}
            for c in self.moved:
                out[f"{'tau' if angular[c] else 'force'}_{c}"] = self.effort(c)
        for j in m.joints:
            couple = not self.plan.kinds[[x.name for x in m.joints].index(j.name)].couple_free
            for c, v in zip(("Fx", "Fy", "Fz", "Mx", "My", "Mz")[:6 if couple else 3],
                            self.reaction(j.name).T):
                out[f"{c}_{j.name}"] = v
        for b in m.bodies:
            if b.name == GROUND:
                continue
            for p in b.points:
                for prefix, x in zip(("", "v", "a"), self._point(b.name, p)):
                    for c, v in zip("xyz", x.T):
                        out[f"{prefix}{c}_{b.name}.{p}"] = v
        out["kinetic_energy"] = self.kinetic_energy()
        out["potential_energy"] = self.potential_energy()
        return out

    def columns(self) -> dict:
        """The results table: column name -> (T,) array (docs/conventions.md)."""
        return dict(self._columns)

    def units(self) -> dict:
        """The SI unit of every column of :meth:`columns` (``'rad'``, ``'m/s'``, ``'N m'``,
        ``'1'`` for a quaternion's components), for ``--units model``
        (:func:`linkdyn.units.model_columns`)."""
        angular = {f"{j.name}{suffix}": ang for j in self.model.joints
                   for suffix, ang in self.plan.kinds[
                       [x.name for x in self.model.joints].index(j.name)].coordinates_named}
        out = {}
        for name in self._columns:
            # every column but t and the energies is <prefix>_<rest>, the prefix one of
            # _COLUMN_UNITS or q, qd, qdd of a joint coordinate
            prefix, _, rest = name.partition("_")
            if prefix in ("q", "qd", "qdd") and rest in angular:
                base = "rad" if angular[rest] else "m"
                out[name] = base + {"q": "", "qd": "/s", "qdd": "/s^2"}[prefix]
            else:
                out[name] = _COLUMN_UNITS.get(name, _COLUMN_UNITS.get(prefix, ""))
        return out

    def to_dataframe(self):
        import pandas as pd
        return pd.DataFrame(self.columns())
