"""``analyze(model, t)``: kinematics, loads, DeNOC inverse dynamics and reactions, composed.

This module is the one obvious entry point; each stage it calls can be used alone.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from functools import cached_property, partial

import numpy as np

from . import backend as backend_mod
from . import batch, kinematics, loads as loads_mod, reactions as reactions_mod
from . import friction as friction_mod, friction_compiled
from .dynamics import compiled as compiled_dynamics
from .dynamics import denoc
from .errors import (AssemblyError, InvalidValue, ModelError, quiet, quiet_numerics,  # noqa: F401
                     wrong_type)
from . import joints as jk
from .model import Model
from .kinematics.positions import singular
from .units import joint_units

SINGULAR = 1e-10  # relative pivot of J_dep below which forward dynamics' state is singular


def regular(kin, dyn) -> np.ndarray:
    """The samples (...) bool that ``analyze`` solves: closed (``kin.valid``) and neither at
    nor within the closure's resolution of a singular position: the smaller relative pivot of
    ``J_dep`` (kinematics) and ``J_dep^T`` (dynamics) weighed against the sample's closure
    residual by :func:`.kinematics.positions.singular`, the test of spatial models too."""
    return kin.valid & ~singular(np.minimum(kin.pivot, dyn.pivot), kin.residual)


@dataclass(frozen=True)
class Solution:
    """Everything computed for a model at the times ``t``.

    For a batch of D designs (``analyze([m0, m1, ...], t)``) every per-sample array has a
    leading design axis, ``(D, T, ...)``; ``design(k)`` gives design k's own solution.

    Attributes
    ----------
    model : Model
        The mechanism (design 0 of a batch: it names the columns, which all designs share).
    kin : kinematics.KinematicSolution
    loads : loads.Loads
    dyn : dynamics.DynamicSolution
    react : reactions.Reactions or callable
        The reactions, or the reactions stage still to run (a function of no argument), run
        when ``reactions`` is first read (``analyze_layout(..., reactions=False)``).
    reactions : reactions.Reactions
        Every joint's reaction.
    valid : ndarray (T,) or (D, T) bool
        Samples where the loops close and the position is not singular.
    designs : tuple of Model
        The D models of a batch; empty for a single mechanism.
    friction : friction.Friction or None
        The friction loads' efforts, power and Newton's iterations (None without friction).
    """

    model: Model
    kin: kinematics.KinematicSolution
    loads: loads_mod.Loads
    dyn: denoc.DynamicSolution
    react: reactions_mod.Reactions | Callable
    valid: np.ndarray
    designs: tuple = ()
    friction: friction_mod.Friction | None = None

    @cached_property
    def reactions(self) -> reactions_mod.Reactions:
        return self.react() if callable(self.react) else self.react

    # --- designs ----------------------------------------------------------------------------
    @property
    def batched(self) -> bool:
        """Whether this is a batch of designs (arrays with a leading design axis)."""
        return bool(self.designs)

    @property
    def n_designs(self) -> int:
        """Number of designs: D for a batch, 1 for a single mechanism."""
        return len(self.designs) if self.designs else 1

    def design(self, k: int) -> Solution:
        """Design k's own solution out of a batch: every array sliced to that design
        (``(T, ...)``), its model as ``model``, and so its ``columns``, ``to_dataframe()``,
        ``effort()`` ... as if it had been solved alone. Negative ``k`` counts from the end;
        a single mechanism is its own design 0.
        """
        k = batch.check_index(k, self.n_designs)
        if not self.batched:
            return self
        kin = batch.kinematics(self.kin, k)
        return Solution(self.designs[k], kin, batch.loads(self.loads, k, kin.layout),
                        batch.dynamics(self.dyn, k),
                        partial(_design_reactions, self, k) if callable(self.react)
                        else batch.reactions(self.react, k),
                        self.valid[k],
                        friction=None if self.friction is None else self.friction.design(k))

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
        """Reaction by the joint's first body on its second, global components.

        Returns
        -------
        ndarray (T, 2) ``[Fx, Fy]`` N for a revolute joint (which transmits no moment), or
        (T, 3) ``[Fx, Fy, M]`` (N, N and N m, the moment about the second body's joint point)
        for a prismatic joint: the ``Fx_``, ``Fy_`` (and ``M_``) columns of ``results.csv``.
        """
        k = self._joint(joint)
        force = self.reactions.force[..., k, :]
        if "M" not in jk.get(self.model.joints[k].kind).reaction:
            return force
        return np.concatenate([force, self.reactions.moment[..., k, None]], axis=-1)

    def reaction_local(self, joint: str) -> np.ndarray:
        """The joint's reaction force in its second body's frame (bearing loads).

        The force by the joint's first body on its second, ``f_b = R(-phi_b) f``, where ``f``
        is :meth:`reaction`'s global force and ``phi_b`` the second body's absolute angle (0
        for the ground): component 0 lies along the body's x axis (along a link drawn on its x
        axis), component 1 across it. Over a cycle its tip traces the pin's polar load diagram.

        Returns
        -------
        ndarray (T, 2) ``[F_along, F_across]`` N (``(D, T, 2)`` for a batch).
        """
        k = self._joint(joint)
        f = self.reactions.force[..., k, :]
        b = self.model.joints[k].body_b
        phi = np.zeros(f.shape[:-1]) if b == self.topology.bodies[0] else self.phi(b)
        c, s = np.cos(phi), np.sin(phi)
        # f_b = R(-phi_b) f = [c fx + s fy, -s fx + c fy]
        return np.stack([c * f[..., 0] + s * f[..., 1], c * f[..., 1] - s * f[..., 0]], axis=-1)

    def instant_centre(self, body: str, rtol: float = 1e-9) -> np.ndarray:
        """Instant centre of velocity (T, 2) of a moving body, global frame, m.

        ``r_IC = r_O + perp(v_O) / omega`` for the body's origin O (velocity ``v_O``, angular
        velocity ``omega``; ``perp`` turns by +90 deg), the point of the body that is at rest.
        NaN where the body barely turns, ``|omega| <= rtol`` times the fastest body's peak
        ``|omega|`` over the run (a translating body's centre is at infinity), and where the
        sample is not valid.
        """
        i = self.body_index(body)
        tw = self.kin.twists[i]
        w = tw[0]
        scale = max((float(np.nanmax(np.abs(self.kin.twists[j][0]), initial=0.0))
                     for j in range(1, self.topology.n)), default=0.0)
        turning = (np.abs(w) > rtol * scale) & np.asarray(self.valid, bool)
        w_safe = np.where(turning, w, 1.0)
        r = self.kin.pose.r[i]
        # r_IC = r_O + perp(v_O) / omega, perp(v) = (-v_y, v_x)
        ic = np.stack([r[0] - tw[2] / w_safe, r[1] + tw[1] / w_safe], axis=-1)
        return np.where(turning[..., None], ic, np.nan)

    def point_velocity(self, body: str, point: str) -> np.ndarray:
        """Velocity (T, 2) of a named point, global components, m/s."""
        return self.kin.point_velocity(body, point)

    def point_acceleration(self, body: str, point: str) -> np.ndarray:
        """Acceleration (T, 2) of a named point, global components, m/s^2."""
        return self.kin.point_acceleration(body, point)

    def _joint(self, name: str) -> int:
        return [j.name for j in self.model.joints].index(name)

    @property
    def kinetic_energy(self) -> np.ndarray:
        return self.dyn.kinetic_energy

    @property
    def potential_energy(self) -> np.ndarray:
        return self.loads.potential_energy

    @property
    def driver_powers(self) -> np.ndarray:
        """Power of each driver (T, n_drivers), W: its effort times its joint's rate,
        ``tau qd`` (driver order)."""
        idx = [self._joint(d.joint) for d in self.model.drivers]
        return self.dyn.tau * self.kin.qd[..., idx]

    @property
    def driver_power(self) -> np.ndarray:
        """Total power of the drivers (T,), W."""
        qd = self.kin.joint_motion[1]
        return sum((self.dyn.tau[..., k] * qd[self._joint(d.joint)]
                    for k, d in enumerate(self.model.drivers)), np.zeros(self.kin.shape))

    # --- tables -----------------------------------------------------------------------------
    @cached_property
    def _table(self) -> tuple[dict[str, np.ndarray], dict[str, str]]:
        """The result columns and their units, built together (one place names both)."""
        m, kin = self.model, self.kin
        cols: dict[str, np.ndarray] = {}
        units: dict[str, str] = {}

        def put(name, values, unit):
            cols[name], units[name] = values, unit

        put("t", self.t, "s")
        q, qd, qdd = kin.joint_motion
        for k, j in enumerate(m.joints):
            u = "rad" if jk.get(j.kind).angular else "m"
            put(f"q_{j.name}", q[k], u)
            put(f"qd_{j.name}", qd[k], f"{u}/s")
            put(f"qdd_{j.name}", qdd[k], f"{u}/s^2")
        for b in m.moving_bodies:
            put(f"phi_{b.name}", self.phi(b.name), "rad")
            put(f"omega_{b.name}", self.omega(b.name), "rad/s")
            put(f"alpha_{b.name}", self.alpha(b.name), "rad/s^2")
        for k, d in enumerate(m.drivers):
            kind = jk.get(m.joint(d.joint).kind)
            put(f"{kind.effort}_{d.joint}", self.dyn.tau[..., k],
                "N m" if kind.angular else "N")
        for j, w in zip(m.joints, self.reactions.on_second):
            # the columns the joint's kind reports, of [M, Fx, Fy]
            for name in jk.get(j.kind).reaction:
                put(f"{name}_{j.name}", w[{"M": 0, "Fx": 1, "Fy": 2}[name]],
                    "N m" if name == "M" else "N")
        topo = kin.layout.topo
        for ci, j in enumerate(m.joints[c] for c in topo.cut):
            kind = jk.get(j.kind)   # a multiplier that is a generalized effort (a coupling's)
            if kind.column:
                put(f"{kind.column}_{j.name}", self.dyn.lam[..., topo.row_slice(ci).start],
                    kind.multipliers[0][1])
        points = [(b.name, p) for b in m.moving_bodies for p in b.points]
        for b, p in points:
            xy = self.point(b, p)
            put(f"x_{b}.{p}", xy[..., 0], "m")
            put(f"y_{b}.{p}", xy[..., 1], "m")
        put("kinetic_energy", self.kinetic_energy, "J")
        if self.loads.has_potential:
            put("potential_energy", self.potential_energy, "J")
        # beyond SPEC's list (which ends at kinetic_energy): each named point's velocity and
        # acceleration, global components
        for b, p in points:
            v, a = self.point_velocity(b, p), self.point_acceleration(b, p)
            put(f"vx_{b}.{p}", v[..., 0], "m/s")
            put(f"vy_{b}.{p}", v[..., 1], "m/s")
            put(f"ax_{b}.{p}", a[..., 0], "m/s^2")
            put(f"ay_{b}.{p}", a[..., 1], "m/s^2")
        # each driver's power tau qd; each load's value and power (loads.wrenches)
        for d, p in zip(m.drivers, np.moveaxis(self.driver_powers, -1, 0)):
            put(f"power_{d.joint}", p, "W")
        for ld, label, value, p in zip(m.loads, loads_mod.labels(m), self.loads.values,
                                       self.loads.powers):
            if ld.kind in loads_mod.REACTION_KINDS:
                continue   # the friction columns below
            names = loads_mod.VALUE_COLUMNS[ld.kind]
            for k, name in enumerate(names):
                put(f"{name}_{label}", value[k] if len(names) > 1 else value,
                    loads_mod.VALUE_UNITS[ld.kind])
            put(f"power_{label}", p, "W")
        if self.friction is not None:   # each friction load's effort and power
            for name, values, unit in friction_mod.columns(self.friction, m):
                put(name, values, unit)
        if m.output:   # the power into the output loads and the instantaneous efficiency
            p_out, eta = friction_mod.output_power(self)
            put("output_power", p_out, "W")
            put("efficiency", eta, "1")
        if not np.all(self.valid):  # samples kept with allow_singular are NaN rows
            cols = {k: v if k == "t" else np.where(self.valid, v, np.nan) for k, v in cols.items()}
        return cols, units

    @property
    def columns(self) -> dict[str, np.ndarray]:
        """All result columns of ``results.csv``, in order: name -> (T,) array, SI.

        SPEC's columns up to ``kinetic_energy``, then ``potential_energy`` (with gravity or
        springs), then each named point's velocity ``vx_<body>.<point>``, ``vy_`` (m/s) and
        acceleration ``ax_``, ``ay_`` (m/s^2), global components.
        """
        return self._table[0]

    @property
    def units(self) -> dict[str, str]:
        """Unit of every column of :attr:`columns` (``'rad/s'``, ``'N m'``, ``'m/s^2'``...)."""
        return self._table[1]

    def to_dataframe(self):
        """The result columns as a pandas DataFrame indexed by ``t`` (s).

        Every other column of ``results.csv`` is a column, in the same order; their units are
        in ``df.attrs["units"]`` (column name -> unit, ``t`` included). ``df.reset_index()``
        gives the exact table of ``results.csv``. Needs the optional ``pandas``.
        """
        try:
            import pandas as pd
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise ImportError("to_dataframe needs pandas: pip install 'linkdyn[pandas]'") from exc
        if self.valid.ndim > 1:
            raise ValueError("to_dataframe needs a single design; index the design first")
        names, data = self.to_array()  # one float block, not one block per column
        df = pd.DataFrame(data[:, 1:], columns=names[1:],
                          index=pd.Index(data[:, 0], name=names[0]))
        df.attrs["units"] = dict(self.units)
        return df

    def to_array(self) -> tuple[list[str], np.ndarray]:
        """Column names and a (T, n_columns) array, without pandas."""
        names = list(self.columns)
        return names, np.stack([self.columns[k] for k in names], axis=-1)

    # --- display in a notebook or a console -------------------------------------------------
    def _headline(self) -> str:
        m, t = self.model, np.asarray(self.t)
        lead = self.valid.shape[:-1]
        designs = f"{lead[0]} designs x " if lead else ""
        span = f"{t[0]:.4g}..{t[-1]:.4g} s" if t.size else "no samples"

        def count(n, one, many):
            return f"{n} {one if n == 1 else many}"

        return (f"{m.name or 'mechanism'}: {designs}{count(t.size, 'sample', 'samples')}, "
                f"t = {span}, {count(len(m.moving_bodies), 'moving body', 'moving bodies')}, "
                f"{count(len(m.joints), 'joint', 'joints')}, "
                f"{count(self.topology.n_loops, 'loop', 'loops')}")

    def key_numbers(self) -> list[tuple[str, str]]:
        """The few numbers to look at first, as ``(label, text)``: each driver effort's signed
        peak (largest magnitude) with its time, the largest joint force and the invalid
        samples. Empty for a batch of designs (index one design first)."""
        if self.valid.ndim > 1 or not len(self.t):
            return []
        t, rows = np.asarray(self.t), []
        cols, units = self.columns, self.units
        for d in self.model.drivers:
            name = next(n for n in (f"tau_{d.joint}", f"force_{d.joint}") if n in cols)
            k = _nanargmax(np.abs(cols[name]))
            if k is not None:
                rows.append((f"peak {name}", f"{cols[name][k]:+.4g} {units[name]} at "
                                             f"t = {t[k]:.4g} s"))
        f = np.linalg.norm(self.reactions.force, axis=-1)  # (T, n_joints)
        if f.size and np.any(np.isfinite(f)):
            k, j = np.unravel_index(np.nanargmax(f), f.shape)
            rows.append(("largest joint force", f"{f[k, j]:.4g} N at {self.model.joints[j].name}, "
                                                f"t = {t[k]:.4g} s"))
        ke = cols["kinetic_energy"]
        if np.any(np.isfinite(ke)):
            rows.append(("kinetic energy", f"{np.nanmin(ke):.4g}..{np.nanmax(ke):.4g} J"))
        bad = int(np.sum(~self.valid))
        if bad:
            rows.append(("invalid samples", f"{bad} (NaN rows)"))
        return rows

    def __repr__(self) -> str:
        rows = "".join(f"\n  {k}: {v}" for k, v in self.key_numbers())
        return f"<linkdyn.{type(self).__name__} {self._headline()}{rows}>"

    def _repr_html_(self) -> str:
        import html
        e = html.escape
        m = self.model
        rows = "".join(f"<tr><th style='text-align:left'>{e(k)}</th><td>{e(v)}</td></tr>"
                       for k, v in self.key_numbers())
        drivers = ", ".join(f"{d.joint}: {d.description}" for d in m.drivers)
        cut = ", ".join(m.joints[int(c)].name for c in self.topology.cut) or "none"
        return (f"<div class='linkdyn-solution'><b>linkdyn.Solution</b> "
                f"{e(self._headline())}<br>"
                f"<small>mobility {self.topology.mobility}; cut joints {e(cut)}; drivers "
                f"{e(drivers)}</small><table>{rows}</table>"
                f"<small>{len(self.units)} columns: <code>sol.to_dataframe()</code>; "
                f"units in <code>df.attrs['units']</code></small></div>")


def _nanargmax(x) -> int | None:
    """Index of the largest finite value of ``x``, or None if there is none."""
    x = np.asarray(x, float)
    return int(np.nanargmax(x)) if np.any(np.isfinite(x)) else None


def failure(model: Model, t_k: float, residual: float) -> AssemblyError:
    """The error of the first invalid sample, at time ``t_k`` (s) with closure ``residual``:
    a singular position if the loops close there, else a position the mechanism cannot reach.
    ``analyze`` raises it; a sweep records its text as an invalid design's reason."""
    drivers = {d.joint: float(v) for d, v in
               zip(model.drivers, kinematics.driver_values(model, np.array([float(t_k)]))[0][:, 0])}
    closes = bool(residual <= kinematics.ACCEPT)  # closes, but singular
    return AssemblyError(
        "the mechanism passes a singular (toggle or dead-centre) position" if closes else
        "the loops stop closing: the mechanism cannot reach this driver position",
        file=model.source, time=float(t_k), drivers=drivers, units=joint_units(model),
        fix=("Change the link lengths or the driver's range so it avoids the toggle, or pass "
             "--allow-singular to keep the other samples" if closes else
             "Limit the driver's range (duration) or change the link lengths"))


def times_argument(func: str, t) -> np.ndarray:
    """The times argument ``t`` of ``func`` as a float array; an :class:`ArgumentError` naming
    ``t`` for what is not an array of numbers (a str, None, a dict)."""
    if isinstance(t, (str, bytes, dict)) or t is None:
        raise wrong_type(func, "t", t, "an array of times (s)")
    try:
        return np.asarray(t, dtype=float)
    except (TypeError, ValueError):
        raise wrong_type(func, "t", t, "an array of times (s)") from None


def _arguments(model, t, allow_singular, backend):
    """``analyze``'s arguments checked and normalized: ``(model, t, backend)``, the backend
    chosen for the work (:func:`linkdyn.backend.choose`).

    Raises TypeError naming the parameter for a wrong type and ModelError (field ``model``,
    ``t``, ``backend`` or ``LINKDYN_BACKEND``) for a wrong value.
    """
    if isinstance(model, (str, os.PathLike)):
        from .io import load_model
        model = load_model(model)
    elif not isinstance(model, Model):
        if isinstance(model, (bytes, dict)) or not isinstance(model, Iterable):
            raise wrong_type("analyze", "model", model,
                             "a Model, a path to a model file or a sequence of Models")
        model = list(model)
        if not model:
            raise ModelError("no designs: model is an empty sequence", field="model",
                             fix="Pass a Model, a model file's path, or a non-empty list of Models")
        for k, m in enumerate(model):
            if not isinstance(m, Model):
                raise wrong_type("analyze", f"model[{k}]", m, "a Model")
    t = times_argument("analyze", t)
    if t.ndim != 1 or t.size < 1:
        raise ModelError(f"the times must be a 1-D array of at least one time, got shape "
                         f"{t.shape}", field="t",
                         fix="Pass t = numpy.linspace(0, duration, samples)")
    if not np.all(np.isfinite(t)):
        k = int(np.argmin(np.isfinite(t)))
        raise ModelError(f"t[{k}] = {t[k]} is not a finite time", field="t",
                         fix="Pass finite times, e.g. numpy.linspace(0, duration, samples)")
    if not isinstance(allow_singular, (bool, np.bool_)):
        raise wrong_type("analyze", "allow_singular", allow_singular, "True or False")
    if backend is not None and not isinstance(backend, (str, backend_mod.Backend)):
        raise wrong_type("analyze", "backend", backend, "a str")
    first = model if isinstance(model, Model) else model[0]
    designs = 1 if isinstance(model, Model) else len(model)
    be = backend_mod.choose(backend, backend_mod.Work(t.size * designs, len(first.bodies) - 1),
                            [j.kind for j in first.joints])
    return model, t, be


def _load_field(model, k: int) -> str:
    name = model.loads[k].name
    return f"loads.{name}" if name else f"loads[{k}]"


def _at(model, time: float) -> dict:
    """Where an AssemblyError happens: the file, the time and the drivers' values."""
    q = kinematics.driver_values(model, np.array([time]))[0][:, 0]
    return dict(file=model.source, time=time, units=joint_units(model),
                drivers={d.joint: float(v) for d, v in zip(model.drivers, q)})


def _check_drivers(model, time: float) -> None:
    """Raise, naming the driver, if a driver's motion is not finite at ``time``."""
    values = kinematics.driver_values(model, np.array([time]))
    for i, d in enumerate(model.drivers):
        if not all(np.isfinite(x[i, 0]) for x in values):
            raise AssemblyError(f"the motion of driver {d.joint} (drivers[{i}].motion) is not "
                                "finite at this time", **_at(model, time),
                                fix="Check its formula or table, or shorten the run")


def _finite(model, kin, applied, dyn, react, valid, stop: bool):
    """``valid`` and every output of the sample finite. With ``stop``, the first valid sample
    with a non-finite output raises an AssemblyError naming its time and its cause: a driver's
    motion, a load (by its field), gravity, or the output that overflows. Reactions not yet
    solved (``react`` still a function) are not looked at."""
    # the outputs as stored (no stacked copies): (array, axis holding other than samples)
    outputs = {"joint motion": [(x, None) for part in kin.joint_motion for x in part],
               "driver effort": [(dyn.tau, -1)],
               "reaction": [(w, 0) for w in ([] if callable(react) else react.on_second)],
               "kinetic energy": [(dyn.kinetic_energy, None)]}

    def finite(a, axis):  # (*valid.shape) bool: the sample's numbers of ``a`` are finite
        f = np.isfinite(a)
        return f if axis is None else np.all(f, axis=axis)

    ok = valid
    for arrays in outputs.values():
        for a, axis in arrays:
            if not np.isfinite(np.sum(a)):  # one pass when all is well; NaN rows land here too
                ok = ok & finite(a, axis)
    if not stop or not np.any(valid & ~ok):
        return ok
    k = int(np.argmax(valid & ~ok))
    tk = kin.t[k:k + 1]
    where = _at(model, float(tk[0]))
    _check_drivers(model, float(tk[0]))
    one = kinematics.solve(model, tk, backend="numpy") if kin.t.size > 1 else kin
    blame_loads(model, one, where)
    bad = next(name for name, arrays in outputs.items() for a, axis in arrays
               if not finite(a, axis)[k])
    raise AssemblyError(f"the {bad} is not finite at this time: a number of the model is too "
                        "large (or too small) to compute with", **where,
                        fix="Check the model's masses, inertias, lengths, loads and driver "
                            "speeds for extreme values")


def blame_loads(model, one, where: dict) -> None:
    """Raise an AssemblyError naming the first load of ``model`` (by its field), or gravity,
    whose wrench is not finite at the one state of the kinematics ``one``; ``where``: the
    error's file, time and drivers. Nothing when every load is finite there."""
    for i, load in enumerate(model.loads):
        w = loads_mod.wrenches(replace(model, loads=(load,), gravity=(0.0, 0.0)), one)
        if all(np.all(np.isfinite(x)) for x in w.wrenches + [w.on_ground]):
            continue
        if load.kind in ("spring", "damper") and load.body2 is not None:
            gap = one.point(load.body, load.point) - one.point(load.body2, load.point2)
            if np.all(gap == 0):  # coincident points: the line of action is undefined
                raise AssemblyError(
                    f"the {load.kind} {_load_field(model, i)} joins two points that coincide "
                    "at this time, so the direction of its force is undefined", **where,
                    fix="Attach it to points that stay apart" + (
                        ", or give it free_length = 0 (its force is then k times the "
                        "distance vector)" if load.kind == "spring" else ""))
        raise AssemblyError(f"the {load.kind} {_load_field(model, i)} is not finite at this "
                            "time", **where,
                            fix="Check its value or formula (a division by zero, the log of a "
                                "negative number, an overflow) and its numbers")
    w = loads_mod.wrenches(replace(model, loads=()), one)
    if not all(np.all(np.isfinite(x)) for x in w.wrenches):
        raise AssemblyError("gravity times a body's mass is not finite", **where,
                            fix="Check mechanism.gravity and the bodies' masses")


def _design_reactions(sol: Solution, k: int):
    """Design k's reactions out of the batch ``sol``'s (run when first read)."""
    return batch.reactions(sol.reactions, k)


def stage_functions(backend: backend_mod.Backend) -> tuple:
    """The dynamics and reactions stages of ``backend``, ``dynamics(kin, loads)`` and
    ``reactions(model, kin, loads, dyn)``: the compiled kernels or the numpy solvers (the one
    place that maps a backend to them; ``simulate``'s outputs ask it too)."""
    if backend.compiled:
        return _compiled_dynamics, _compiled_reactions
    return denoc.solve, _numpy_reactions


def _compiled_dynamics(kin, applied):
    dyn = compiled_dynamics.solve(kin, applied)
    backend_mod.mark_cached("dynamics")
    return dyn


def _compiled_reactions(model, kin, applied, dyn):
    react = compiled_dynamics.reactions(kin, applied, dyn)
    backend_mod.mark_cached("reactions")
    return react


def _numpy_reactions(model, kin, applied, dyn):
    return reactions_mod.solve(model, kin, dyn)


def _stages(model, t, backend: backend_mod.Backend, layout=None, reactions: bool = True,
            start=None):
    """The stages of an analysis composed: ``(kin, applied, dyn, react, valid, friction)``,
    ``valid`` the samples that close clear of a singular position (and, with friction loads,
    do not lock), ``friction`` the :class:`linkdyn.friction.Friction` or None. ``model``: a Model, or D Models (a batch;
    with ``layout``, their stacked layout, and the models only give their ``[assembly]``
    guesses and design 0's names). Without ``reactions``, ``react`` is the reactions stage
    still to run (a function of no argument), for :class:`Solution` to run when they are
    first read."""
    designs = not isinstance(model, Model)
    models = list(model) if designs else [model]
    # without reactions and applied loads, the compiled dynamics runs in the kinematics'
    # blocks (dynamics.compiled.sweep), and the kinematics keep less per sample
    fused = (backend.compiled and not reactions and layout is not None
             and compiled_dynamics.fusable(layout))
    kin = kinematics.solve(model, t, layout=layout, backend=backend, start=start,
                           run=compiled_dynamics.sweep if fused else None)
    # a batch: gravity, loads' values, springs and dampers from the layout, per design
    applied = loads_mod.wrenches(None if designs else model, kin)
    dynamics, reactions_stage = stage_functions(backend)
    swept = getattr(kin, "swept", None) is not None   # the dynamics already solved
    if swept:
        backend_mod.mark_cached("sweep")
    fr = None
    if friction_mod.present(models[0]):
        # friction grows with the reactions: efforts, reactions and friction solved together
        applied, dyn, react, fr = friction_mod.solve(models, kin, applied, dynamics,
                                                     reactions_stage, friction_compiled.solve
                                                     if backend.compiled else None)
        valid = regular(kin, dyn) & ~fr.locked
        return kin, applied, dyn, react, valid, fr
    if reactions and backend.compiled and not swept:   # both stages in one kernel
        dyn, react = compiled_dynamics.inverse(kin, applied)
        backend_mod.mark_cached("dynamics")
        backend_mod.mark_cached("reactions")
        valid = regular(kin, dyn)
        return kin, applied, dyn, react, valid, fr
    dyn = compiled_dynamics.swept(kin, applied) if swept else dynamics(kin, applied)
    react = partial(reactions_stage, models[0], kin, applied, dyn)
    valid = regular(kin, dyn)
    return kin, applied, dyn, react() if reactions else react, valid, fr


def layout_stages(layout, reactions: bool) -> tuple[str, ...]:
    """The stages (:data:`linkdyn.backend.STAGES`) that :func:`analyze_layout` runs compiled
    for ``layout``: the sweep kernel alone without reactions and applied loads (gravity
    aside), else the kinematics, the dynamics and, if asked, the reactions."""
    if not reactions and compiled_dynamics.fusable(layout):
        return ("sweep",)
    return ("kinematics", "dynamics") + (("reactions",) if reactions else ())


def analyze_layout(models, layout, t, *, backend: str | None = None, designs=None,
                   reactions: bool = True, start=None) -> Solution:
    """``analyze`` of a batch of designs given by their stacked layout (for instance built
    from parameter arrays by :mod:`linkdyn.studies.vectorize`), without a Model per design.

    Parameters
    ----------
    models : sequence of Model
        D models whose ``[assembly]`` guesses the designs start from (they may all be one
        model); ``models[0]`` names the columns.
    layout : kinematics.Layout
        The D designs' stacked layout (``layout.designs == D``).
    t : array_like (T,)
        Sample times, s.
    designs : sequence of Model, optional
        What ``Solution.designs`` holds (a sequence that builds design k's model when read);
        default ``models``.
    reactions : bool
        Solve the joint reactions now (and count a sample whose reactions are not finite as
        not valid). With False the reactions stage runs only if ``Solution.reactions`` is read
        (a sweep whose metrics need no reaction skips it), and ``valid`` does not look at them.
    start : ndarray (n, D), optional
        The designs' assembly at t = 0 if already solved
        (:func:`linkdyn.kinematics.positions.assemble` with ``raise_error=False``).

    Returns
    -------
    Solution
        As ``analyze(list_of_models, t, backend=backend)`` (designs that do not assemble or
        pass a singular position flagged in ``valid``, never raised).
    """
    t = np.asarray(t, dtype=float)
    models = list(models)
    be = backend_mod.choose(backend, backend_mod.Work(t.size * layout.designs,
                                                      len(models[0].bodies) - 1,
                                                      stages=layout_stages(layout, reactions)),
                            [j.kind for j in models[0].joints])
    kin, applied, dyn, react, valid, fr = _stages(models, t, be, layout, reactions, start)
    valid = _finite(models[0], kin, applied, dyn, react, valid, False)
    return Solution(models[0], kin, applied, dyn, react, valid,
                    designs if designs is not None else tuple(models), friction=fr)


@quiet
def _spatial(model, t, backend, allow_singular=False):
    """``analyze`` of a spatial model (:func:`linkdyn.spatial.analyze`, numpy only)."""
    if backend == "compiled":
        raise ModelError("the compiled backend is not yet for spatial models", field="backend",
                         fix="Use backend='numpy' (or leave it unset)")
    from . import spatial
    return spatial.analyze(model, t, allow_singular=allow_singular)


@quiet
def analyze(model, t, *, allow_singular: bool = False, backend: str | None = None) -> Solution:
    """Kinematics and inverse dynamics of ``model`` at the times ``t`` (T,) s.

    Parameters
    ----------
    model : Model, str, PathLike or sequence of Model
        One mechanism (or the path of its model file), or D designs of one topology (the same
        bodies, joints, drivers, cut joints and load kinds), each with its own numbers: geometry, masses, inertias, gravity,
        load values (constant or formulas), spring and damper constants and free lengths,
        driver motions. With designs every per-sample array has shape (D, T, ...) (a list of
        one model too), a design that cannot be assembled or passes a singular position is
        flagged in ``valid`` (NaN rows), never raised, and ``Solution.design(k)`` gives one
        design's solution.
    t : array_like (T,)
        Sample times, s.
    allow_singular : bool
        Keep samples that do not close or are singular as NaN rows instead of raising.
    backend : {'auto', 'numpy', 'compiled'}, optional
        Run the per-sample work in numpy array passes or in the compiled kernels of
        :mod:`linkdyn.compiled` (default ``LINKDYN_BACKEND`` or ``'auto'``: the one expected
        to finish first for this many samples and bodies, counting the kernels' first
        compilation unless numba's cache holds them, :func:`linkdyn.backend.choose`). Both
        give the same numbers to rounding.

    Raises
    ------
    ModelError
        Designs whose topology differs (naming the design and what differs).
    AssemblyError
        The mechanism cannot be assembled, stops closing, passes a singular position, or gives a
        non-finite number (a load formula, an overflow), at the first such time (unless
        ``allow_singular``, which leaves NaN rows flagged in ``valid``).
    ModelError
        A model file that cannot be read (``model`` given as a path), an empty sequence of
        designs, times that are not finite, an unknown backend.
    TypeError
        An argument of the wrong type (the message names it).
    """
    asked = backend
    model, t, backend = _arguments(model, t, allow_singular, backend)
    if isinstance(model, Model) and model.space == "spatial":
        return _spatial(model, t, asked, allow_singular)
    if not isinstance(model, Model) and any(m.space == "spatial" for m in model):
        raise ModelError("batches of designs are not yet for spatial models", field="model",
                         fix="Analyze each spatial model alone")
    designs = not isinstance(model, Model)
    models = list(model) if designs else [model]
    if not models:
        raise ModelError("no designs to solve", fix="Pass a model or a non-empty list of models")
    t = np.asarray(t, dtype=float)
    kin, applied, dyn, react, valid, fr = _stages(models if designs else model, t, backend)
    model = models[0]
    # a sample that fails stops the run, unless allowed; so does a run left with none
    if not designs and not np.all(valid) and (not allow_singular or not np.any(valid)):
        k = int(np.argmin(valid))
        _check_drivers(model, float(kin.t[k]))  # a motion that overflows, not the loops
        if fr is not None and fr.locked[k]:
            raise friction_mod.locked_error(model, fr, k, _at(model, float(kin.t[k])))
        if not np.isfinite(kin.residual[k]):   # no branch from t = 0: a singular start?
            from .kinematics.layout import compile_layout
            from .kinematics.positions import singular_start, starts_singular
            lay = compile_layout(model)
            if starts_singular(model, lay):
                raise singular_start(model, lay)
        raise failure(model, kin.t[k], kin.residual[k])
    # every number finite, or the run stops naming the time and the cause
    valid = _finite(model, kin, applied, dyn, react, valid, not (allow_singular or designs))
    return Solution(model, kin, applied, dyn, react, valid, tuple(models) if designs else (),
                    friction=fr)
