"""``analyze(model, t)``: kinematics, loads, DeNOC inverse dynamics and reactions, composed.

This module is the one obvious entry point; each stage it calls can be used alone.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from . import compiled, kinematics, loads as loads_mod, reactions as reactions_mod
from .dynamics import compiled as compiled_dynamics
from .dynamics import denoc
from .errors import AssemblyError
from . import joints as jk
from .model import Model

SINGULAR = 1e-10  # relative pivot of J_dep below which a position counts as singular


@dataclass(frozen=True)
class Solution:
    """Everything computed for a model at the times ``t``.

    Attributes
    ----------
    model : Model
    kin : kinematics.KinematicSolution
    loads : loads.Loads
    dyn : dynamics.DynamicSolution
    reactions : reactions.Reactions
    valid : ndarray (T,) bool
        Samples where the loops close and the position is not singular.
    """

    model: Model
    kin: kinematics.KinematicSolution
    loads: loads_mod.Loads
    dyn: denoc.DynamicSolution
    reactions: reactions_mod.Reactions
    valid: np.ndarray

    @property
    def t(self) -> np.ndarray:
        return self.kin.t

    @property
    def topology(self):
        return self.kin.layout.topo

    # --- named quantities -------------------------------------------------------------------
    def body_index(self, name: str) -> int:
        return self.topology.bodies.index(name)

    def phi(self, body: str) -> np.ndarray:
        """Absolute angle (T,) of a body, rad."""
        return self.kin.pose.phi[self.body_index(body)]

    def omega(self, body: str) -> np.ndarray:
        """Angular velocity (T,) of a body, rad/s."""
        return self.kin.twists[self.body_index(body)][0]

    def alpha(self, body: str) -> np.ndarray:
        """Angular acceleration (T,) of a body, rad/s^2."""
        return self.kin.rates[self.body_index(body)][0]

    def point(self, body: str, point: str) -> np.ndarray:
        """Path (T, 2) of a named point, m."""
        return self.kin.point(body, point)

    def effort(self, joint: str) -> np.ndarray:
        """Driver effort (T,) at a driven joint, N m or N."""
        k = [d.joint for d in self.model.drivers].index(joint)
        return self.dyn.tau[..., k]

    def reaction(self, joint: str) -> np.ndarray:
        """Force (T, 2) by the joint's first body on its second, N."""
        return self.reactions.force[..., self._joint(joint), :]

    def _joint(self, name: str) -> int:
        return [j.name for j in self.model.joints].index(name)

    @property
    def kinetic_energy(self) -> np.ndarray:
        return self.dyn.kinetic_energy

    @property
    def potential_energy(self) -> np.ndarray:
        return self.loads.potential_energy

    @property
    def driver_power(self) -> np.ndarray:
        """Total power of the drivers (T,), W."""
        qd = self.kin.joint_motion[1]
        return sum((self.dyn.tau[..., k] * qd[self._joint(d.joint)]
                    for k, d in enumerate(self.model.drivers)), np.zeros(self.kin.shape))

    # --- tables -----------------------------------------------------------------------------
    @cached_property
    def columns(self) -> dict[str, np.ndarray]:
        """All result columns of SPEC's ``results.csv``, in order: name -> (T,) array, SI."""
        m, kin = self.model, self.kin
        cols: dict[str, np.ndarray] = {"t": self.t}
        q, qd, qdd = kin.joint_motion
        for k, j in enumerate(m.joints):
            cols[f"q_{j.name}"], cols[f"qd_{j.name}"], cols[f"qdd_{j.name}"] = q[k], qd[k], qdd[k]
        for b in m.moving_bodies:
            cols[f"phi_{b.name}"] = self.phi(b.name)
            cols[f"omega_{b.name}"] = self.omega(b.name)
            cols[f"alpha_{b.name}"] = self.alpha(b.name)
        for k, d in enumerate(m.drivers):
            cols[f"{jk.get(m.joint(d.joint).kind).effort}_{d.joint}"] = self.dyn.tau[..., k]
        for j, w in zip(m.joints, self.reactions.on_second):
            # the columns the joint's kind reports, of [M, Fx, Fy]
            for name in jk.get(j.kind).reaction:
                cols[f"{name}_{j.name}"] = w[{"M": 0, "Fx": 1, "Fy": 2}[name]]
        for b in m.moving_bodies:
            for name in b.points:
                xy = self.point(b.name, name)
                cols[f"x_{b.name}.{name}"] = xy[..., 0]
                cols[f"y_{b.name}.{name}"] = xy[..., 1]
        cols["kinetic_energy"] = self.kinetic_energy
        if self.loads.has_potential:
            cols["potential_energy"] = self.potential_energy
        if not np.all(self.valid):  # samples kept with allow_singular are NaN rows
            cols = {k: v if k == "t" else np.where(self.valid, v, np.nan) for k, v in cols.items()}
        return cols

    def to_dataframe(self):
        """The columns as a pandas DataFrame (needs the optional ``pandas``)."""
        try:
            import pandas as pd
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise ImportError("to_dataframe needs pandas: pip install 'linkdyn[pandas]'") from exc
        if self.valid.ndim > 1:
            raise ValueError("to_dataframe needs a single design; index the design first")
        return pd.DataFrame(self.columns)

    def to_array(self) -> tuple[list[str], np.ndarray]:
        """Column names and a (T, n_columns) array, without pandas."""
        names = list(self.columns)
        return names, np.stack([self.columns[k] for k in names], axis=-1)


def analyze(model, t, *, allow_singular: bool = False, backend: str | None = None) -> Solution:
    """Kinematics and inverse dynamics of ``model`` at the times ``t`` (T,) s.

    Parameters
    ----------
    model : Model or sequence of Model
        One mechanism, or D designs of one topology (geometry, masses and inertias may
        differ; drivers and loads are the first design's). With designs every per-sample
        array has shape (D, T, ...) and bad designs are flagged in ``valid``, never raised.
    t : array_like (T,)
        Sample times, s.
    allow_singular : bool
        Keep samples that do not close or are singular as NaN rows instead of raising.
    backend : {'auto', 'numpy', 'compiled'}, optional
        Run the per-sample work in numpy array passes or in the compiled kernels of
        :mod:`linkdyn.compiled` (default ``LINKDYN_BACKEND`` or ``'auto'``: compiled when
        numba is installed and the batch is large). Both give the same numbers to rounding.

    Raises
    ------
    AssemblyError
        The mechanism cannot be assembled, stops closing, or passes a singular position, at the
        first such time (unless ``allow_singular``, which leaves NaN rows flagged in ``valid``).
    """
    designs = not isinstance(model, Model)
    models = list(model) if designs else [model]
    t = np.asarray(t, dtype=float)
    fast = compiled.use_compiled(backend, t.size * len(models), [j.kind for j in models[0].joints])
    kin = kinematics.solve(models if designs else model, t,
                           backend="compiled" if fast else "numpy")
    model = models[0]
    applied = loads_mod.wrenches(model, kin)
    if fast:
        dyn, react = compiled_dynamics.solve(kin, applied,
                                             compiled.pack(kin.layout, len(model.joints)))
    else:
        dyn = denoc.solve(kin, applied)
        react = reactions_mod.solve(model, kin, dyn)
    valid = kin.valid & (kin.pivot > SINGULAR) & (dyn.pivot > SINGULAR)
    if not (allow_singular or designs) and not np.all(valid):
        k = int(np.argmin(valid))
        drivers = {d.joint: float(v) for d, v in
                   zip(model.drivers, kinematics.driver_values(model, kin.t[k:k + 1])[0][0])}
        closes = bool(kin.residual[k] <= kinematics.ACCEPT)  # closes, but singular
        raise AssemblyError(
            "the mechanism passes a singular (toggle or dead-centre) position" if closes else
            "the loops stop closing: the mechanism cannot reach this driver position",
            file=model.source, time=float(kin.t[k]), drivers=drivers,
            fix=("Change the link lengths or the driver's range so it avoids the toggle, or pass "
                 "--allow-singular to keep the other samples" if closes else
                 "Limit the driver's range (duration) or change the link lengths"))
    return Solution(model, kin, applied, dyn, react, valid)
