"""Design parameters: numbers of a model file named by the dotted field paths of its error messages.

A parameter is a path into the parsed model file, e.g. ``bodies.ground.points.O4[0]`` (the x of the
ground's point O4), ``bodies.crank.mass``, ``drivers[0].motion.rpm`` or ``loads.brake.value[1]``:
section, then an entry of an array of tables by its ``name`` or its ``[index]`` (0-based), then keys
and vector components. Values are in the file's units (a point in its ``[units] length``), exactly as
the file would give them; a design is the file with those numbers replaced, validated and built
by :func:`linkdyn.model_from_dict`, so every check of the loader applies to it and its messages name
the same path.
"""

from __future__ import annotations

import copy
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ModelError
from ..io import model_from_dict, read_model_data
from ..io.reader import _did_you_mean
from ..model import Model

_TOKEN = re.compile(r"([A-Za-z0-9_\-]+)((?:\[\d+\])*)\Z")


@dataclass(frozen=True)
class Parameter:
    """One design parameter.

    Attributes
    ----------
    path : str
        Dotted field path, e.g. ``'bodies.coupler.points.P[1]'``.
    keys : tuple
        Keys and indices into the parsed file, e.g. ``('bodies', 2, 'points', 'P', 1)``.
    base : float
        Its value in the file, in the file's units.
    unit : str
        The unit it is given in (e.g. ``'mm'``, ``'kg'``, ``'kg mm^2'``, ``'rev/min'``).
    """

    path: str
    keys: tuple
    base: float
    unit: str


@dataclass(frozen=True)
class Space:
    """The file a study starts from and the parameters it varies.

    Attributes
    ----------
    data : dict
        The parsed model file (never modified).
    source : str
        File name, for messages and each design's ``Model.source``.
    base_dir : str
        Directory of the file (motion tables are found relative to it).
    params : tuple[Parameter, ...]
    """

    data: dict
    source: str
    base_dir: str
    params: tuple[Parameter, ...]

    @property
    def paths(self) -> list[str]:
        return [p.path for p in self.params]

    @property
    def spatial(self) -> bool:
        """A spatial model (``[mechanism] space = "spatial"``): its designs are built by the
        loader, each its model, and solved as one batch
        (:func:`linkdyn.studies.runner.evaluate_models`), not by the planar vectorized map."""
        mech = self.data.get("mechanism", {})
        return isinstance(mech, dict) and mech.get("space") == "spatial"

    def model(self, values=None) -> Model:
        """The model of one design (``values`` (P,) in the file's units; None: the base model).

        Raises ModelError naming the file, the field path and the fix for an invalid design."""
        data = self.data if values is None else with_values(self.data, self.params, values)
        return model_from_dict(data, source=self.source, base_dir=self.base_dir)

    def models(self, values: np.ndarray) -> tuple[list, list]:
        """Models of D designs (``values`` (D, P)): ``(models, errors)``, each a list of D where
        a design is either a Model (error None) or None with its ModelError."""
        models, errors = [], []
        for row in np.asarray(values, float).reshape(-1, len(self.params)):
            try:
                models.append(self.model(row))
                errors.append(None)
            except ModelError as e:
                models.append(None)
                errors.append(e)
        return models, errors


def space(model, paths, *, source: str | None = None) -> Space:
    """Resolve parameter paths against a model.

    Parameters
    ----------
    model : str, os.PathLike, dict or Model
        A model file (its numbers and units as written), a parsed model dict, or a Model (written
        out with :func:`linkdyn.model_to_dict`, in its own units).
    paths : sequence of str
        Dotted field paths.

    Raises
    ------
    ModelError
        For an unknown path (with the closest valid spelling) or one that is not a number.
    """
    from ..io.writer import model_to_dict

    base_dir = "."
    if isinstance(model, Model):
        data, src = model_to_dict(model), model.source
        if model.source:
            base_dir = str(Path(model.source).parent)
    elif isinstance(model, dict):
        data, src = model, ""
    else:
        src = os.fspath(model)
        data, base_dir = read_model_data(src), str(Path(src).parent)
    src = src if source is None else source
    base = model_from_dict(data, source=src, base_dir=base_dir)  # it must be valid itself
    seen = set()
    params = []
    for p in paths:
        param = resolve(data, p, source=src)
        if param.keys in seen:
            raise ModelError(f"parameter '{p}' is given twice", file=src, field="--vary",
                             fix="Vary each field once")
        seen.add(param.keys)
        params.append(param)
    return Space(data, src, base_dir, tuple(params))


def _unit(data: dict, keys: tuple) -> str:
    units = data.get("units", {}) if isinstance(data.get("units"), dict) else {}
    L, A = units.get("length", "m"), units.get("angle", "rad")
    names = [k for k in keys if isinstance(k, str)]
    last = names[-1]
    if "points" in names[:-1] or last in ("com", "free_length", "origin"):
        return L
    if last in ("axis", "axis2"):
        return ""   # a direction (the loader makes it a unit vector)
    if last == "rotation":
        return A
    if last == "mass":
        return "kg"
    if last == "inertia":
        return f"kg {L}^2"
    if last == "gravity":
        return "m/s^2"
    if last == "rpm":
        return "rev/min"
    if last in ("stiffness", "damping"):
        return f"N/{L}" if last == "stiffness" else f"N s/{L}"
    if names[0] == "loads" and last == "value":
        return "N" if keys[-1] != "value" else "N m"
    if names[0] in ("drivers", "assembly", "joints"):
        return f"{A} or {L}"
    return ""


def resolve(data: dict, path: str, *, source: str = "") -> Parameter:
    """The :class:`Parameter` a dotted path names in a parsed model file.

    An entry of an array of tables is named by its ``name`` (bodies, joints, loads) or by
    ``[index]``; a driver by ``[index]`` or its joint's name.
    """
    def fail(message, fix):
        raise ModelError(message, file=source, field=path, fix=fix)

    if not isinstance(path, str) or not path:
        fail("a design parameter needs a path", "Write e.g. bodies.crank.mass")
    tokens = []
    for part in path.split("."):
        m = _TOKEN.match(part)
        if m is None:
            fail(f"cannot read the field path at '{part}'",
                 "Write keys joined by dots with [index] for list items, e.g. "
                 "bodies.ground.points.O4[0]")
        tokens.append(m.group(1))
        tokens.extend(int(i) for i in re.findall(r"\[(\d+)\]", m.group(2)))
    cur: Any = data
    keys: list = []
    done = ""
    for tok in tokens:
        here = ".".join(str(k) for k in keys)
        if isinstance(cur, dict):
            if not isinstance(tok, str) or tok not in cur:
                fail(f"no field '{tok}' in {done or 'the model'}",
                     _did_you_mean(str(tok), [k for k in cur if isinstance(k, str)],
                                   f"fields of {done or 'the model'}"))
            keys.append(tok)
            cur = cur[tok]
        elif isinstance(cur, list):
            if isinstance(tok, int):
                if tok >= len(cur):
                    fail(f"{done} has {len(cur)} {'entry' if len(cur) == 1 else 'entries'}, "
                         f"no [{tok}]",
                         f"Give an index from 0 to {len(cur) - 1}")
                keys.append(tok)
                cur = cur[tok]
            else:
                label = "joint" if done == "drivers" else "name"
                names = [e.get(label) for e in cur if isinstance(e, dict)]
                if tok not in names:
                    fail(f"no entry of {done} named '{tok}'",
                         _did_you_mean(tok, [n for n in names if isinstance(n, str)],
                                       f"names in {done}") + f", or use {done}[index]")
                idx = names.index(tok)
                keys.append(idx)
                cur = cur[idx]
        else:
            fail(f"{done or here} is a single value, it has no '{tok}'",
                 f"End the path at {done}")
        done = f"{done}.{tok}" if isinstance(tok, str) and done else (
            f"{done}[{tok}]" if isinstance(tok, int) else tok)
    if isinstance(cur, bool) or not isinstance(cur, (int, float)):
        what = ("a formula" if isinstance(cur, str) and keys[0] in ("loads", "drivers") else
                "a string" if isinstance(cur, str) else
                "a list" if isinstance(cur, list) else "a table" if isinstance(cur, dict) else
                repr(cur))
        fix = ("Vary a component: " + ", ".join(f"{path}[{i}]" for i in range(len(cur)))
               if isinstance(cur, list) and len(cur) <= 3 else
               "Vary a number of the file (a formula or a name cannot be varied)"
               if isinstance(cur, str)
               else "Continue the path to a number: " + ", ".join(
                   f"{path}.{k}" for k in cur)[:300] if isinstance(cur, dict) else
               "Vary a number of the file")
        fail(f"'{path}' is {what}, not a number", fix)
    return Parameter(path, tuple(keys), float(cur), _unit(data, tuple(keys)))


def with_values(data: dict, params, values) -> dict:
    """A copy of ``data`` with each parameter set to its value (the original is unchanged)."""
    out = dict(data)
    copied = {()}  # containers already copied: only those on a parameter's path are
    for p, v in zip(params, np.asarray(values, float).ravel()):
        cur = out
        for depth, k in enumerate(p.keys[:-1]):
            key = p.keys[:depth + 1]
            if key not in copied:
                cur[k] = copy.copy(cur[k])
                copied.add(key)
            cur = cur[k]
        cur[p.keys[-1]] = float(v)
    return out


def check_ranges(sp: Space, bounds) -> None:
    """Check that every bound of every parameter (others at their base values) gives a valid
    model, so a whole range is not lost to a typo (a negative mass, an infeasible inertia).

    Parameters
    ----------
    bounds : sequence of (lo, hi)
        One pair per parameter, in the file's units.

    Raises
    ------
    ModelError
        Naming the parameter, the bound and the loader's reason (field and fix); or the
        parameters whose ranges let a link's two joint points meet (a link of zero length).
    """
    base = np.array([p.base for p in sp.params])
    for k, (p, (lo, hi)) in enumerate(zip(sp.params, bounds)):
        if not (np.isfinite(lo) and np.isfinite(hi)):
            raise ModelError(f"range {lo}:{hi} is not finite", file=sp.source, field=p.path,
                             fix="Give finite bounds LO:HI")
        if lo > hi:
            raise ModelError(f"range {lo:g}:{hi:g} has LO > HI", file=sp.source, field=p.path,
                             fix=f"Write {p.path}={hi:g}:{lo:g}")
        for v in (lo, hi):
            x = base.copy()
            x[k] = v
            try:
                sp.model(x)
            except ModelError as e:
                fix = e.fix or "Narrow the range"
                raise ModelError(f"{p.path} = {v:g} {p.unit}".rstrip() + f" (a bound of its range) "
                                 f"gives an invalid model: {e.message}", file=sp.source,
                                 field=e.field or p.path,
                                 fix=f"Narrow the range of {p.path}; {fix[0].lower()}{fix[1:]}"
                                 ) from None
    _check_links(sp, np.array([b[0] for b in bounds], float),
                 np.array([b[1] for b in bounds], float))


def _check_links(sp: Space, lo: np.ndarray, hi: np.ndarray) -> None:
    """No design of the box ``lo``..``hi`` has a link of zero length (:func:`linkdyn.io.linkage.
    link_pairs`). A link's vector ``d(v) = d(b) + (v - b) A_d`` between its two points is affine
    in the parameters (the study's map, :mod:`.vectorize`); its smallest length over the box is
    a bounded linear least-squares problem."""
    from scipy.optimize import lsq_linear

    from ..io.linkage import SHORT_LINK, link_pairs
    from .vectorize import derive

    if sp.spatial:
        return   # each design is checked by the loader, and kept invalid with its reason
    builder = derive(sp, lo, hi)
    if not builder.vectorized:
        return   # each design is then checked by the loader, and kept invalid with its reason
    base = np.array([p.base for p in sp.params])
    cols = {k[1:]: (a, b) for k, a, b in builder.keys if k[0] == "raw"}
    size = builder.layout.size
    for body, p, q, jp, jq in link_pairs(builder.base.bodies, builder.base.joints):
        (a1, b1), (a2, b2) = cols[body, p], cols[body, q]
        d0 = builder.z0[a1:b1] - builder.z0[a2:b2]                  # (2,)
        Ad = builder.A[:, a1:b1] - builder.A[:, a2:b2]              # (P, 2)
        moved = np.flatnonzero(np.any(Ad != 0, axis=1) & (hi > lo))
        if not len(moved):
            continue
        # the smallest |d0 + Ad^T x| over x in [lo - b, hi - b] of the parameters that move it
        res = lsq_linear(Ad[moved].T, -d0, bounds=(lo[moved] - base[moved],
                                                    hi[moved] - base[moved]), method="bvls")
        if np.hypot(*(d0 + Ad[moved].T @ res.x)) > SHORT_LINK * size:
            continue
        at = ", ".join(f"{sp.params[k].path} = {base[k] + x:.6g} {sp.params[k].unit}".rstrip()
                       for k, x in zip(moved, res.x))
        names = ", ".join(sp.params[k].path for k in moved)
        raise ModelError(f"the range{'s' if len(moved) > 1 else ''} of {names} allow"
                         f"{'' if len(moved) > 1 else 's'} a link of zero length: the link of "
                         f"body '{body}' between joints {jp} (point {p}) and {jq} (point {q}) "
                         f"vanishes at {at}", file=sp.source, field=names,
                         fix=f"Narrow the range{'s' if len(moved) > 1 else ''} so that {p} and "
                             f"{q} of {body} stay apart")
