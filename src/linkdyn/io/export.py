"""``linkdyn export``: a mechanism as another tool's file (MuJoCo's MJCF, SVG, DXF).

One entry point for the command line and Python: :func:`export` returns the file's text and
what it leaves out; writing it is the caller's (the command line writes it all or nothing,
:func:`linkdyn.outputs.write_file`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..model import Model

#: The formats, with the file suffix each is written under by default.
FORMATS = {"mjcf": ".xml", "svg": ".svg", "dxf": ".dxf"}


@dataclass(frozen=True)
class Exported:
    """An exported file's text and the notes a user should read (what it leaves out)."""

    text: str
    notes: tuple[str, ...] = ()


def export(model: Model, to: str, *, at: float = 0.0, plane: str | None = None) -> Exported:
    """``model`` as a ``to`` file at the time ``at``.

    Parameters
    ----------
    model : Model
    to : {'mjcf', 'svg', 'dxf'}
        MuJoCo's MJCF (:func:`linkdyn.io.mjcf.mjcf`: bodies at their pose at ``at``, SI), or
        the drawing at ``at`` with the traced paths over one run (:mod:`linkdyn.io.drawing`,
        the model file's length unit).
    at : float
        Time, s.
    plane : str, optional
        The drawing of a spatial model: the plane of the global axes it is projected on
        (:data:`linkdyn.io.drawing.PLANES`, default ``"xy"``: x right, y up).

    Raises
    ------
    ModelError
        An unknown format or ``at`` not finite (field ``--to``, ``--at``); a joint MJCF
        cannot close (naming it); a ``plane`` with MJCF, unknown, or not xy for a planar
        model (field ``--plane``).
    AssemblyError
        The mechanism cannot be assembled at ``at`` (or, for a drawing, during the run).
    """
    if to not in FORMATS:
        raise ModelError(f"unknown export format '{to}'", field="--to",
                         fix="Give --to " + ", ".join(FORMATS))
    if not np.isfinite(at):
        raise ModelError(f"--at must be a finite time in s, got {at}", field="--at",
                         fix="Give --at a time in s, e.g. --at 0")
    if to == "mjcf":
        if plane is not None:
            raise ModelError("--plane is the projection of a drawing (svg, dxf); an MJCF "
                             "keeps every axis", field="--plane", fix="Drop --plane")
        from .mjcf import mjcf
        out = mjcf(model, at=at)
        notes = tuple(f"left out of the MJCF (MuJoCo cannot hold it): {x}" for x in out.omitted)
        frame = ("the model's axes (x, y, z)" if model.space == "spatial"
                 else "the mechanism's plane (x, y) is MuJoCo's (x, z)")
        return Exported(out.text, notes + (
            f"MJCF in SI units; {frame}; "
            "cut joints closed by connect: " + (", ".join(out.cut) or "none"),))
    from . import drawing
    d = drawing.drawing(model, at=at, plane=plane)
    text = drawing.svg(d) if to == "svg" else drawing.dxf(d)
    view = "" if d.plane is None else f", projected on the {d.plane} plane"
    return Exported(text, (f"drawing at t = {d.at:g} s in {d.unit}{view}; paths of "
                           + (", ".join(d.paths) or "no traced point"),))
