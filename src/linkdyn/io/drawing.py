"""The mechanism's drawing for CAD: ``linkdyn export MODEL --to svg|dxf``.

A :class:`Drawing` holds, in the model file's length unit (``Model.length_unit``), the global
frame (x right, y up):

- each moving body at the time ``at`` as the outline of its named points (two points: a line;
  collinear points: a line through them in order; else their convex hull, closed), as the
  report draws it, on the body's own layer;
- each joint as a circle at its second body's point (``connect[1]``; for a revolute joint the
  two points coincide), layer ``joints``;
- each ground pivot (a ground point a joint uses) marked by a triangle under it, and each
  fixed guide (a prismatic or slot joint whose first body is the ground) as its line over the
  sliding point's travel during the run, layer ``ground``;
- the path of every point the report traces (:func:`linkdyn.report.data.traced_points`) over
  one run (the times ``linkdyn analyze`` solves by default), each on a layer
  ``path-<body>-<point>``.

:func:`svg` writes it as SVG (1:1 in the unit: ``width``/``height`` in mm, coordinates in the
unit, y flipped by one ``scale(1 -1)`` group), :func:`dxf` as ASCII DXF R12 (``LINE``,
``CIRCLE``, ``POLYLINE``/``VERTEX``; ``$INSUNITS`` names the unit). Coordinates are written
with round-trip precision.

A spatial model (``space = "spatial"``) is drawn as its projection on a named plane of the
global axes, ``plane`` (default ``"xy"``): its first axis drawn to the right, its second up
(``"xy"`` the view from +z, ``"xz"`` the one from -y, ...), every point, outline (of the
projected points), guide and path projected so; the files say which plane they show (an SVG
comment, a DXF ``999`` comment).
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from .. import joints as jk
from ..errors import ModelError
from ..model import GROUND, Model
from .units import LENGTH_UNITS

#: DXF ``$INSUNITS`` code of each length unit.
DXF_UNITS = {"in": 1, "mm": 4, "cm": 5, "m": 6}

#: The planes a spatial model is projected on: the global axes drawn right and up.
PLANES = {"xy": (0, 1), "yz": (1, 2), "zx": (2, 0), "xz": (0, 2), "yx": (1, 0), "zy": (2, 1)}


@dataclass(frozen=True)
class Drawing:
    """A mechanism's drawing at one time and its traced paths, in ``unit``.

    Attributes
    ----------
    unit : str
        The model file's length unit (``m``, ``mm``, ``cm``, ``in``).
    at : float
        Time of the drawn pose, s.
    lines : dict[str, list[ndarray (k, 2)]]
        Per layer (a body's name, or ``ground``) its polylines; a closed one repeats its first
        point at the end.
    joints : dict[str, ndarray (2,)]
        Each joint's position (its second body's point) at ``at``.
    pivots : dict[str, ndarray (2,)]
        The ground points joints use, ``ground.<point>``.
    paths : dict[str, ndarray (T, 2)]
        ``BODY.POINT`` -> its path over the run.
    radius : float
        Joint circle radius (2% of the drawing's size), in ``unit``.
    plane : str or None
        The plane of the global axes a spatial model is projected on (``"xy"``: x right, y
        up); None for a planar model, drawn in its own plane.
    """

    unit: str
    at: float
    lines: dict
    joints: dict
    pivots: dict
    paths: dict
    radius: float
    plane: str | None = None

    def describe(self) -> str:
        """What the drawing shows, as its files say: its time, unit and plane."""
        view = "" if self.plane is None else (
            f"; the projection of a spatial model on its {self.plane} plane ({self.plane[0]} "
            f"right, {self.plane[1]} up)")
        return f"linkdyn export at t = {self.at!r} s; coordinates in {self.unit}{view}"


def drawing(model: Model, *, at: float = 0.0, t=None, sol=None, run=None,
            plane: str | None = None) -> Drawing:
    """The drawing of ``model`` at the time ``at`` and its traced paths over the times ``t``.

    Parameters
    ----------
    model : Model
    at : float
        Time of the pose drawn, s.
    plane : str, optional
        A spatial model's projection plane, a key of :data:`PLANES` (default ``"xy"``); a
        planar model is drawn in its plane (only None or ``"xy"``).
    t : array_like (T,), optional
        Times of the paths, s; default the run ``linkdyn analyze`` solves
        (:func:`linkdyn.sampling.times` with no options).
    sol, run : Solution, optional
        ``analyze(model, [at])`` and ``analyze(model, t)``, solved here if not given.

    Raises
    ------
    ModelError
        An unknown ``plane``, or another plane than xy for a planar model (field ``--plane``).
    AssemblyError
        The mechanism cannot be assembled at ``at`` or during the run.
    """
    from ..analysis import analyze
    from ..report.data import body_shape, traced_points
    from ..sampling import times

    if sol is None:
        sol = analyze(model, np.array([float(at)]))
    if run is None:
        run = analyze(model, times(model, None, None, None) if t is None else t)
    spatial = model.space == "spatial"
    axes = _axes(plane, spatial)
    scale = 1.0 / LENGTH_UNITS[model.length_unit]         # m -> the file's unit

    def full(body, point):  # (2,) or (3,) at ``at``, global, in the file's unit
        if body == GROUND:
            return np.asarray(model.body(GROUND).points[point], float) * scale
        return np.asarray(sol.point(body, point)[-1], float) * scale

    def where(body, point):  # (2,) drawn: in the plane
        return full(body, point)[..., axes]

    lines = {}
    for b in model.moving_bodies:
        # a planar body's outline from its own points; a spatial one's projection's
        shape, outline = body_shape({p: where(b.name, p) for p in b.points} if spatial
                                    else b.points)
        P = np.array([where(b.name, p) for p in outline])
        lines[b.name] = [np.vstack([P, P[:1]]) if shape == "polygon" else P] if len(P) > 1 else []
    joints = {j.name: where(j.body_b, j.point_b) for j in model.joints}
    pivots = {}
    for j in model.joints:
        for body, point in ((j.body_a, j.point_a), (j.body_b, j.point_b)):
            if body == GROUND:
                pivots[f"{GROUND}.{point}"] = where(GROUND, point)
    paths = {pid: (np.asarray(run.point(*pid.split(".", 1)), float) * scale)[:, axes]
             for pid in traced_points(model)}
    every = [x[None] for x in (*joints.values(), *pivots.values())]
    every += [P for ps in lines.values() for P in ps] + list(paths.values())
    allxy = np.concatenate(every) if every else np.zeros((1, 2))
    size = float(max(np.max(np.ptp(allxy, axis=0)), 1e-12))
    r = 0.02 * size
    # a ground pivot's triangle: apex at the pivot, base 2.5 r below it
    lines[GROUND] = [np.array([c, c + (-1.5 * r, -2.5 * r), c + (1.5 * r, -2.5 * r), c])
                     for c in pivots.values()]
    # a fixed guide (a joint that slides, on the ground): the line o + s e over the travel of
    # the sliding point during the run, s = (r_B - o) . e, 2 r beyond each end (e the axis,
    # global: the ground's frame is the global one), drawn in the plane
    for j in model.joints:
        if j.body_a == GROUND and _slides(j.kind, spatial):
            o = full(GROUND, j.point_a)
            e = np.asarray(j.axis, float) / np.linalg.norm(j.axis)
            travel = (np.asarray(run.point(j.body_b, j.point_b)) * scale - o) @ e
            lo, hi = float(np.min(travel)) - 2 * r, float(np.max(travel)) + 2 * r
            lines[GROUND].append(np.array([o + lo * e, o + hi * e])[:, axes])
    return Drawing(model.length_unit, float(sol.t[-1]), lines, joints, pivots, paths, r,
                   plane=PLANES_NAME.get(axes) if spatial else None)


#: Each projection's name by its axes.
PLANES_NAME = {v: k for k, v in PLANES.items()}


def _axes(plane: str | None, spatial: bool) -> tuple[int, int]:
    """The global axes drawn right and up for ``plane`` (:data:`PLANES`)."""
    if plane is None:
        return (0, 1)
    if plane not in PLANES:
        raise ModelError(f"unknown plane '{plane}'", field="--plane",
                         fix="Give --plane " + ", ".join(PLANES))
    if not spatial and plane != "xy":
        raise ModelError(f"a planar model is drawn in its own plane (xy), not {plane}",
                         field="--plane", fix="Drop --plane")
    return PLANES[plane]


def _slides(kind: str, spatial: bool) -> bool:
    """Whether a joint of ``kind`` slides along its axis (a guide when on the ground): planar
    kinds with an axis (prismatic, slot), spatial ones with a length coordinate (prismatic,
    cylindrical)."""
    if spatial:
        from ..spatial import joints as sj
        return any(not ang for _, ang in sj.get(kind).coordinates_named)
    return "axis" in jk.get(kind).keys


def _n(x) -> str:
    return repr(float(x))


def _bounds(d: Drawing) -> tuple[np.ndarray, np.ndarray]:
    pts = [P for ps in d.lines.values() for P in ps] + list(d.paths.values())
    pts += [x[None] for x in d.joints.values()]
    P = np.concatenate(pts) if pts else np.zeros((1, 2))
    return P.min(0) - 2 * d.radius, P.max(0) + 2 * d.radius


def _xml(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;").replace('"', "&quot;")


def svg(d: Drawing) -> str:
    """The drawing as an SVG document (text).

    Coordinates are the drawing's, in its unit, inside ``<g transform="scale(1 -1)">`` (SVG's y
    points down); the document is ``width`` x ``height`` mm at 1:1. Each layer is a
    ``<g id="layer-...">``; each joint a ``<circle id="joint-NAME">``, each path a
    ``<polyline id="path-BODY.POINT">``.
    """
    lo, hi = _bounds(d)
    w, h = hi - lo
    mm = LENGTH_UNITS[d.unit] * 1e3                      # mm per unit
    stroke = _n(0.15 * d.radius)
    out = ['<?xml version="1.0" encoding="UTF-8"?>',
           f'<svg xmlns="http://www.w3.org/2000/svg" width="{_n(w * mm)}mm" '
           f'height="{_n(h * mm)}mm" viewBox="{_n(lo[0])} {_n(-hi[1])} {_n(w)} {_n(h)}">',
           f"<!-- {_xml(d.describe())} -->",
           f'<g transform="scale(1 -1)" fill="none" stroke="black" stroke-width="{stroke}">']
    for layer, polys in d.lines.items():
        out.append(f'<g id="layer-{_xml(layer)}">')
        for P in polys:
            for a, b in zip(P[:-1], P[1:]):
                out.append(f'<line x1="{_n(a[0])}" y1="{_n(a[1])}" x2="{_n(b[0])}" '
                           f'y2="{_n(b[1])}"/>')
        out.append("</g>")
    out.append('<g id="layer-joints">')
    for name, c in d.joints.items():
        out.append(f'<circle id="joint-{_xml(name)}" cx="{_n(c[0])}" cy="{_n(c[1])}" '
                   f'r="{_n(d.radius)}"/>')
    out.append("</g>")
    for pid, P in d.paths.items():
        pts = " ".join(f"{_n(x)},{_n(y)}" for x, y in P)
        out.append(f'<polyline id="path-{_xml(pid)}" stroke="blue" points="{pts}"/>')
    out += ["</g>", "</svg>", ""]
    return "\n".join(out)


def layer_name(name: str) -> str:
    """A DXF R12 layer name (letters, digits, ``$ - _``; upper case) for a body or path."""
    return re.sub(r"[^A-Za-z0-9$_-]", "-", name).upper()


def dxf(d: Drawing) -> str:
    """The drawing as ASCII DXF R12 (text): a HEADER (``$ACADVER`` AC1009, ``$INSUNITS``), the
    LTYPE table (``CONTINUOUS``), a LAYER table (one layer per body, ``JOINTS``, ``GROUND`` and one per path) and the ENTITIES:
    a ``LINE`` per outline edge, a ``CIRCLE`` per joint, a 2-D ``POLYLINE`` per path."""
    rows: list[tuple[int, str]] = []

    def put(*pairs):
        rows.extend((code, str(value)) for code, value in pairs)

    layers = ([layer_name(n) for n in d.lines] + ["JOINTS"]
              + [layer_name(f"path-{pid}") for pid in d.paths])
    layers = list(dict.fromkeys(layers))
    if d.plane is not None:       # a DXF comment: the projection a spatial model's drawing is
        put((999, d.describe()))
    put((0, "SECTION"), (2, "HEADER"), (9, "$ACADVER"), (1, "AC1009"),
        (9, "$INSUNITS"), (70, DXF_UNITS[d.unit]), (0, "ENDSEC"))
    put((0, "SECTION"), (2, "TABLES"), (0, "TABLE"), (2, "LTYPE"), (70, 1),
        (0, "LTYPE"), (2, "CONTINUOUS"), (70, 0), (3, "Solid line"), (72, 65), (73, 0),
        (40, "0.0"), (0, "ENDTAB"), (0, "TABLE"), (2, "LAYER"), (70, len(layers)))
    for k, name in enumerate(layers):
        put((0, "LAYER"), (2, name), (70, 0), (62, 1 + k % 7), (6, "CONTINUOUS"))
    put((0, "ENDTAB"), (0, "ENDSEC"), (0, "SECTION"), (2, "ENTITIES"))
    for layer, polys in d.lines.items():
        for P in polys:
            for a, b in zip(P[:-1], P[1:]):
                put((0, "LINE"), (8, layer_name(layer)), (10, _n(a[0])), (20, _n(a[1])),
                    (30, "0.0"), (11, _n(b[0])), (21, _n(b[1])), (31, "0.0"))
    for c in d.joints.values():
        put((0, "CIRCLE"), (8, "JOINTS"), (10, _n(c[0])), (20, _n(c[1])), (30, "0.0"),
            (40, _n(d.radius)))
    for pid, P in d.paths.items():
        layer = layer_name(f"path-{pid}")
        put((0, "POLYLINE"), (8, layer), (66, 1), (10, "0.0"), (20, "0.0"), (30, "0.0"),
            (70, 0))
        for x, y in P:
            put((0, "VERTEX"), (8, layer), (10, _n(x)), (20, _n(y)), (30, "0.0"))
        put((0, "SEQEND"), (8, layer))
    put((0, "ENDSEC"), (0, "EOF"))
    return "\n".join(f"{code:>3}\n{value}" for code, value in rows) + "\n"

