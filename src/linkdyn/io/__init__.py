"""Model files: read TOML or JSON, validate every field, convert to SI, build a :class:`Model`.

The format is documented key by key in ``docs/model-format.md``. Every problem raises
:class:`~linkdyn.errors.ModelError` naming the file, the field (a dotted path such as
``bodies.crank.mass`` or ``drivers[0].motion.q``) and how to fix it; misspelt keys and names get
the closest valid spelling. Checks that need the topology (mobility, loops) live in
:mod:`linkdyn.topology`, not here.

Reading is split by concept: :mod:`.syntax` (TOML or JSON text to a table of sections),
:mod:`.reader` (the validation context: type checks, messages, name suggestions), :mod:`.units`,
then one module per group of sections: :mod:`.linkage` (``[[bodies]]``, ``[[joints]]``),
:mod:`.drivers`, :mod:`.loads` and :mod:`.options` (``[assembly]``, ``[topology]``,
``[analysis]``). Each section's accepted keys are the constants re-exported here.
"""

from __future__ import annotations

import os
from pathlib import Path

from ..errors import ModelError, quiet, wrong_type
from ..model import Model
from .drivers import MOTION_KEYS, _drivers
from .linkage import BODY_KEYS, JOINT_KEYS, _bodies, _check_links, _joints, free_bodies
from .loads import LOAD_KEYS, _loads
from .options import _analysis, _assembly, _initial, _topology
from .files import MAX_FILE_BYTES, FileRefused, read_text
from .reader import _quote, _Reader, _shorten, _type_name
from .syntax import _parse_json, _parse_toml
from .units import ANGLE_UNITS, LENGTH_UNITS, _units

__all__ = ["load_model", "read_model_data", "model_from_dict", "LENGTH_UNITS", "ANGLE_UNITS", "SECTIONS",
           "BODY_KEYS", "JOINT_KEYS", "MOTION_KEYS", "LOAD_KEYS"]

SECTIONS = ("mechanism", "units", "bodies", "joints", "drivers", "loads", "assembly", "topology",
            "analysis", "initial")


@quiet
def load_model(path: str | os.PathLike, *, allow_outside: bool = False) -> Model:
    """Read a model file (``.toml`` or ``.json``), validate it and return it in SI units.

    Parameters
    ----------
    path : str or os.PathLike
        The model file: a regular file of at most 10 MB. Files it refers to (motion tables) are
        looked up relative to its directory.
    allow_outside : bool
        Allow motion tables outside the model file's directory (by ``..``, an absolute path or
        a symbolic link). By default a table must lie in that directory or below it.

    Returns
    -------
    Model

    Raises
    ------
    ModelError
        For any invalid content, naming the file, the field and the fix.
    """
    if not isinstance(path, (str, os.PathLike)):
        raise wrong_type("load", "path", path, "a str or os.PathLike")
    file = os.fspath(path)
    data = read_model_data(file)
    return model_from_dict(data, source=file, base_dir=Path(file).parent,
                           allow_outside=allow_outside)


def read_model_data(path: str | os.PathLike) -> dict:
    """The parsed structure of a model file (``.toml`` or ``.json``), not yet validated: what
    :func:`model_from_dict` takes. The same checks of the file as :func:`load_model`."""
    if not isinstance(path, (str, os.PathLike)):
        raise wrong_type("read_model_data", "path", path, "a str or os.PathLike")
    file = os.fspath(path)
    suffix = Path(file).suffix.lower()
    if suffix not in (".toml", ".json"):
        raise ModelError(f"unknown model file type {_quote(suffix or '(none)')}", file=file,
                         fix="Name the file *.toml (TOML) or *.json (JSON)")
    text = read_input(file, "model file")
    return _parse_toml(text, file) if suffix == ".toml" else _parse_json(text, file)


def read_input(file: str, what: str) -> str:
    """The text of the input file ``file`` (a ``what``: ``"model file"``, ``"pylinkage
    file"``), or one ModelError naming it: missing, not a regular file or too large, not
    readable or not UTF-8."""
    try:
        return read_text(file)
    except FileNotFoundError:
        raise ModelError("file not found", file=file,
                         fix="Check the path and the current directory") from None
    except FileRefused as e:
        raise ModelError(f"the {what} {e}", file=file,
                         fix=f"Give a {what} (a regular file of at most {MAX_FILE_BYTES:,} "
                             "bytes)") from None
    except (OSError, UnicodeDecodeError) as e:
        raise ModelError(f"cannot read the file ({_shorten(str(e), 120)})", file=file,
                         fix="Give a readable UTF-8 text file") from None


@quiet
def model_from_dict(data: dict, *, source: str = "", base_dir: str | os.PathLike = ".",
                    allow_outside: bool = False) -> Model:
    """Validate a parsed model (the structure of a model file) and return it in SI units.

    Parameters
    ----------
    data : dict
        The model, as ``tomllib.load`` or ``json.load`` would return it.
    source : str
        File name used in error messages and stored as ``Model.source``.
    base_dir : str or os.PathLike
        Directory that relative ``file`` paths (motion tables) are resolved against; tables must
        lie in it or below it unless ``allow_outside``.
    allow_outside : bool
        Allow motion tables outside ``base_dir``.
    """
    r = _Reader(source, Path(base_dir), allow_outside=allow_outside)
    if not isinstance(data, dict):
        r.fail("", f"expected a table of sections, got {_type_name(data)}",
               "Give the model as a dict such as {'bodies': [...], 'joints': [...]}")
    mech = r.table(data.get("mechanism", {}), "mechanism",
                   ("name", "gravity", "description", "space"))
    space = r.choice(mech.get("space", "planar"), "mechanism.space", ("planar", "spatial"),
                     "space")
    if space == "spatial":
        from ..spatial.reader import read
        return read(r, data, mech, source)
    r.table(data, "", SECTIONS, noun="section", what="sections")
    name = r.string(mech["name"], "mechanism.name") if "name" in mech else (
        Path(source).stem if source else "mechanism")
    gravity = r.vector(mech.get("gravity", [0.0, 0.0]), "mechanism.gravity", "m/s^2")
    description = r.string(mech.get("description", ""), "mechanism.description", empty=True)
    _units(r, data.get("units", {}))
    body_entries, joint_entries = free_bodies(r, data.get("bodies"), data.get("joints", []))
    bodies = _bodies(r, body_entries)
    joints = _joints(r, joint_entries, bodies)
    _check_links(r, bodies, joints)
    drivers = _drivers(r, data.get("drivers", []), joints)
    loads = _loads(r, data.get("loads", []), bodies, joints)
    phi, q = _assembly(r, data.get("assembly", {}), bodies, joints)
    initial_q, initial_qd = _initial(r, data.get("initial", {}), joints, drivers)
    cut = _topology(r, data.get("topology", {}), joints, drivers)
    duration, cycles, samples, path_point, path_range, output = _analysis(
        r, data.get("analysis", {}), drivers, bodies, joints, loads)
    return Model(name=name, bodies=tuple(bodies.values()), joints=tuple(joints.values()),
                 drivers=tuple(d for _, d in drivers.values()), loads=tuple(loads), gravity=gravity,
                 assembly_phi=phi, assembly_q=q, cut=cut, duration=duration, cycles=cycles,
                 samples=samples, source=source, description=description,
                 path_point=path_point, path_range=path_range, output=output,
                 length_unit=r.length_name,
                 angle_unit=r.angle_name, initial_q=initial_q, initial_qd=initial_qd)
