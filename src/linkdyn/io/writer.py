"""Write a :class:`~linkdyn.Model` back as a model file: ``save(model, path)`` (TOML).

:func:`model_to_dict` turns a model into the structure of a model file (the inverse of
:func:`linkdyn.model_from_dict`), in the units of the file it came from (``Model.length_unit``,
``Model.angle_unit``; SI for a model built in Python); :func:`save` writes it as TOML. Loading the
written file gives the same model to rounding of the unit conversion (a few ulp), so the same
analysis. What a file states in a second way is written in the first: an inertia given about a
point (``inertia_about``) is written about the mass centre, a speed given in rpm as ``speed``. A
driver's motion table is written beside the model as ``<stem>.<joint>.csv``.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from .. import expr as _expr
from .. import joints as jk
from .. import motion as _motion
from ..errors import ModelError, wrong_type
from ..model import GROUND, Model
from ..spatial import writer as _spatial
from ..topology import registry
from .loads import _TimeFunction
from .units import ANGLE_UNITS, LENGTH_UNITS

__all__ = ["model_to_dict", "save", "dumps_toml"]


def _from_bars(b) -> bool:
    """Whether body ``b``'s mass properties are still those of its bars (a body changed in
    Python after reading keeps its bars but not their numbers: then the numbers are written)."""
    from ..model import bar_mass
    if not b.bars:
        return False
    m, c, i = bar_mass(b.points, b.bars)
    scale = max(abs(b.mass), 1e-300)
    return (abs(m - b.mass) <= 1e-12 * scale and abs(i - b.inertia) <= 1e-12 * max(abs(i), 1e-300)
            and bool(np.all(np.abs(c - b.com) <= 1e-12 * max(float(np.max(np.abs(c))), 1e-300))))


def _num(x) -> float | int:
    x = float(x)
    return int(x) if x.is_integer() and abs(x) < 2 ** 53 else x


def _vec(v, scale: float = 1.0) -> list:
    return [_num(c / scale) for c in np.asarray(v, float)]


def _load_value(value, vector: bool):
    """A load value as written: numbers or formula texts."""
    if not isinstance(value, _TimeFunction):
        raise ValueError("a load value given as a Python function cannot be written to a model "
                         "file; give it as numbers or formulas of t")
    comps = [str(c) if isinstance(c, _expr.Expr) else _num(c) for c in value.components]
    return comps if vector else comps[0]


def _back(si: float, read) -> float | int:
    """The shortest decimal ``x`` that the reader turns back into ``si`` exactly (``read(x) ==
    si``): ``rpm = 120`` stays 120, not 119.99999999999999; the plain quotient if none does."""
    for digits in range(1, 18):
        x = float(f"{si / read(1.0):.{digits}g}")
        if read(x) == si:
            return _num(x)
    return _num(si / read(1.0))


def _motion_dict(motion, scale: float, table_file: str | None):
    if isinstance(motion, _motion.ConstantSpeed):
        start = _back(motion.start, lambda x: x * scale)
        if motion.rpm:   # the file's own speed unit (io.drivers reads rpm x 2 pi / 60)
            return {"kind": "constant_speed",
                    "rpm": _back(motion.speed, lambda x: x * 2 * math.pi / 60), "start": start}
        return {"kind": "constant_speed", "speed": _back(motion.speed, lambda x: x * scale),
                "start": start}
    if isinstance(motion, _motion.ExpressionMotion):
        text = motion.text.strip()
        if motion.scale != scale:  # q = motion.scale * f(t) in SI; the file multiplies by scale
            text = f"{motion.scale / scale!r}*({text})"
        return {"kind": "expression", "q": text}
    if isinstance(motion, _motion.SegmentMotion):
        segs = [{"law": x.law, "time": _num(x.time)} if x.law == "dwell" else
                {"law": x.law, "to": _num(x.to / scale), "time": _num(x.time)}
                for x in motion.segments]
        return {"kind": "segments", "start": _num(motion.start / scale), "segments": segs,
                "repeat": motion.repeat}
    if isinstance(motion, _motion.TableMotion):
        if table_file is None:
            raise ValueError("a motion table is written beside the model file; give save() a path")
        return {"kind": "table", "file": table_file}
    raise ValueError(f"a driver motion of type {type(motion).__name__} cannot be written to a "
                     f"model file")


def model_to_dict(model: Model, *, table_files: dict[str, str] | None = None) -> dict:
    """The model as the structure of a model file, in the model's own units.

    Parameters
    ----------
    model : Model
    table_files : dict, optional
        File name (relative to the model file) of each table-driven joint's motion table.

    Returns
    -------
    dict
        Sections as :func:`linkdyn.model_from_dict` reads them; numbers in ``model.length_unit``
        and ``model.angle_unit`` (mass kg, inertia kg length^2).
    """
    L, A = LENGTH_UNITS[model.length_unit], ANGLE_UNITS[model.angle_unit]
    spatial = getattr(model, "space", "planar") == "spatial"
    kinds = registry(model.space)
    table_files = table_files or {}
    out: dict = {"mechanism": {"name": model.name}}
    if spatial:
        out["mechanism"]["space"] = "spatial"
    if model.description:
        out["mechanism"]["description"] = model.description
    out["mechanism"]["gravity"] = _vec(model.gravity)
    out["units"] = {"length": model.length_unit, "angle": model.angle_unit}
    if spatial:   # design poses, 3-vectors, inertia tensors, axes
        out["bodies"] = _spatial.bodies(model, L, A, _num, _vec)
        out["joints"] = _spatial.joints(model, _num, _vec)
    else:
        out["bodies"], out["joints"] = _bodies(model, L), _joints(model, L, A)

    def scale_of(joint: str) -> float:
        # a spatial [initial] names joint coordinates (J3.1, J2.s), a driver its joint
        ang = _spatial.angular(model, joint) if spatial else None
        if ang is not None:
            return A if ang else L
        return A if kinds.get(model.joint(joint).kind).angular else L

    out["drivers"] = [{"joint": d.joint, "motion": _motion_dict(d.motion, scale_of(d.joint),
                                                                table_files.get(d.joint))}
                      for d in model.drivers]
    loads = []
    for ld in model.loads:
        entry = {"kind": ld.kind}
        if ld.name:
            entry["name"] = ld.name
        if ld.kind in ("joint_torque", "joint_force"):   # inside a joint: named by the joint
            entry.update(joint=ld.joint, value=_load_value(ld.value, False))
            loads.append(entry)
            continue
        if ld.kind == "friction":   # in a joint, in the file's units
            angular = kinds.get(model.joint(ld.joint).kind).angular
            entry.update(joint=ld.joint, coefficient=_num(ld.coefficient))
            if angular:
                entry["radius"] = _num(ld.radius / L)
            rate = A if angular else L
            entry["transition_speed"] = _num(ld.transition_speed / rate)
            if ld.static_coefficient is not None:
                entry["static_coefficient"] = _num(ld.static_coefficient)
            if ld.stiction_speed is not None:
                entry["stiction_speed"] = _num(ld.stiction_speed / rate)
            if ld.viscous:
                entry["viscous"] = _num(ld.viscous * rate)
            if ld.preload:
                entry["preload"] = _num(ld.preload)
            loads.append(entry)
            continue
        entry["body"] = ld.body
        if ld.point is not None:
            entry["point"] = ld.point
        if ld.kind in ("force", "torque"):
            entry["value"] = _load_value(ld.value, ld.kind == "force" or spatial)
        elif ld.kind in ("spring", "damper"):
            entry.update(body2=ld.body2, point2=ld.point2)
            if ld.kind == "spring":  # N/m -> N/length unit; m -> length unit
                entry.update(stiffness=_num(ld.stiffness * L), free_length=_num(ld.free_length / L))
            else:
                entry["damping"] = _num(ld.damping * L)
        else:
            raise ValueError(f"a load of kind '{ld.kind}' cannot be written to a model file yet")
        loads.append(entry)
    out["loads"] = loads
    assembly = {}
    if model.assembly_phi:
        assembly["phi"] = {b: _num(v / A) for b, v in model.assembly_phi.items()}
    if model.assembly_q:
        assembly["q"] = {j: _num(v / scale_of(j)) for j, v in model.assembly_q.items()}
    if assembly:
        out["assembly"] = assembly
    initial = {}
    if model.initial_q:
        initial["q"] = {j: _num(v / scale_of(j)) for j, v in model.initial_q.items()}
    if model.initial_qd:
        initial["qd"] = {j: _num(v / scale_of(j)) for j, v in model.initial_qd.items()}
    if initial:
        out["initial"] = initial
    if model.cut is not None:
        out["topology"] = {"cut": list(model.cut)}
    analysis: dict = {}
    if model.duration is not None:
        analysis["duration"] = _num(model.duration)
    if model.cycles is not None:
        analysis["cycles"] = _num(model.cycles)
    if model.samples is not None:
        analysis["samples"] = int(model.samples)
    if model.path_point is not None:
        analysis["path_point"] = model.path_point
    if model.path_range is not None:
        s = scale_of(model.drivers[0].joint) if model.drivers else A
        analysis["path_range"] = [_num(x / s) for x in model.path_range]
    if model.output:
        analysis["output"] = list(model.output)
    if analysis:
        out["analysis"] = analysis
    return {k: v for k, v in out.items() if v != []}


def _bodies(model: Model, L: float) -> list[dict]:
    """``[[bodies]]`` of a planar model (length unit ``L`` m)."""
    bodies = []
    for b in model.bodies:
        entry: dict = {"name": b.name, "points": {k: _vec(v, L) for k, v in b.points.items()}}
        if b.name != GROUND and _from_bars(b):   # the bars it was given by
            entry["bars"] = [{"between": [x.start, x.end]} | (
                {"mass": _num(x.mass)} if x.mass is not None else
                {"mass_per_length": _num(x.mass_per_length * L)}) for x in b.bars]
        elif b.name != GROUND:
            entry.update(mass=_num(b.mass), com=_vec(b.com, L), inertia=_num(b.inertia / L ** 2))
        bodies.append(entry)
    return bodies


def _joints(model: Model, L: float, A: float) -> list[dict]:
    """``[[joints]]`` of a planar model (the kinds' numbers in the file's units)."""
    joints = []
    for j in model.joints:
        entry = {"name": j.name, "type": j.kind}
        if jk.get(j.kind).couples:   # a coupling names its joints (its bodies are theirs)
            entry["joints"] = list(j.coupled)
        else:
            entry["connect"] = [f"{j.body_a}.{j.point_a}", f"{j.body_b}.{j.point_b}"]
        for x in (x for x in jk.get(j.kind).numbers if not x.derived):   # in the file's units
            scale = {"angle": A, "length": L, "pressure": 1.0 / L ** 2}.get(x.unit, 1.0)
            v = j.numbers[x.name]
            entry[x.name] = (x.choices[int(v)] if x.choices else
                             _vec(v, scale) if x.shape else _num(v / scale))
        joints.append(entry)
    return joints


# --- TOML -------------------------------------------------------------------------------------

def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"cannot write the non-finite number {v} to a model file")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v, ensure_ascii=False)  # a TOML basic string
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{_key(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def _key(k: str) -> str:
    return k if k and all(c.isalnum() or c in "_-" for c in k) else json.dumps(k)


def dumps_toml(data: dict) -> str:
    """TOML text of a model-file structure: ``[section]`` tables, ``[[section]]`` arrays of
    tables, every nested table written inline."""
    lines: list[str] = []
    for name, section in data.items():
        entries = section if isinstance(section, list) else [section]
        header = f"[[{name}]]" if isinstance(section, list) else f"[{name}]"
        for entry in entries:
            lines.append(header)
            lines.extend(f"{_key(k)} = {_toml_value(v)}" for k, v in entry.items())
            lines.append("")
    return "\n".join(lines)


def save(model: Model, path: str | os.PathLike) -> Path:
    """Write ``model`` as a model file that :func:`linkdyn.load` reads back to it: TOML for
    ``*.toml``, JSON (the same structure) for ``*.json``.

    Parameters
    ----------
    model : Model
    path : str or os.PathLike
        The ``.toml`` or ``.json`` file to write (another suffix raises a ModelError naming
        ``path``). A driver's motion table goes beside it as
        ``<stem>.<joint>.csv`` (t in s, q in the file's angle or length unit).

    Returns
    -------
    Path
        The file written.
    """
    if not isinstance(model, Model):
        raise wrong_type("save", "model", model, "a Model")
    if not isinstance(path, (str, os.PathLike)):
        raise wrong_type("save", "path", path, "a str or os.PathLike")
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in (".toml", ".json"):
        raise ModelError(f"cannot write a model file named *{path.suffix or '(no suffix)'}: "
                         "linkdyn.load reads *.toml and *.json only", file=str(path),
                         field="path", fix="Name the file *.toml (TOML) or *.json (JSON)")
    L, A = LENGTH_UNITS[model.length_unit], ANGLE_UNITS[model.angle_unit]
    tables = {d.joint: d.motion for d in model.drivers if isinstance(d.motion, _motion.TableMotion)}
    names = {j: f"{path.stem}.{j}.csv" for j in tables}
    data = model_to_dict(model, table_files=names)
    # JSON with the same structure for *.json, as load reads it
    text = (json.dumps(data, indent=2, allow_nan=False) + "\n" if suffix == ".json"
            else dumps_toml(data))
    files = {}
    for j, motion in tables.items():
        unit = A if registry(model.space).get(model.joint(j).kind).angular else L
        q = np.asarray(motion.q) * (motion.scale / unit)  # table units -> the file's unit
        rows = "\n".join(f"{ti!r},{qi!r}" for ti, qi in zip(motion.t.tolist(), q.tolist()))
        files[path.parent / names[j]] = "t,q\n" + rows + "\n"
    files[path] = text
    _write_all(files, path)
    return path


def _write_all(files: dict[Path, str], path: Path) -> None:
    """Write every ``{file: text}`` all or nothing: each into a temporary file beside it, then
    each moved into place (an atomic replace); on a failure the temporary files are removed
    and nothing is written. Raises a ModelError naming ``path`` for what the system refuses
    (a missing folder, a folder at the path, no permission)."""
    import tempfile

    done: dict[Path, str] = {}
    try:
        for target, text in files.items():
            fd, tmp = tempfile.mkstemp(prefix=f".{target.name}-", dir=target.parent)
            done[target] = tmp
            with os.fdopen(fd, "w", encoding="utf-8") as f:
                f.write(text)
            os.chmod(tmp, 0o666 & ~_umask())   # as a plain open() would create it
        for target, tmp in done.items():
            os.replace(tmp, target)
    except OSError as err:
        for tmp in done.values():
            try:
                os.unlink(tmp)
            except OSError:
                pass
        raise ModelError(f"cannot write the model file: {err.strerror or err}", file=str(path),
                         field="path", fix="Give the path of a file in a folder that exists and "
                                           "that you can write to") from None


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
