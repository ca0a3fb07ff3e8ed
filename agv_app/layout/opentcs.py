"""Import openTCS plant models (XML, model version 7) as layouts.

How the model maps onto a :class:`~agv_app.layout.Layout`:

* **points** keep their names; positions are millimetres in the model and metres
  here (``positionX / 1000``); the model's y axis already points north.
* **paths** are one-way ``sourcePoint -> destinationPoint``. Two opposite paths
  between the same points with the same shape become **one bidirectional
  segment** named after the path whose name sorts first: they are the same strip
  of floor, and deadlock avoidance must see that vehicles can meet head-on on it.
  A path with ``maxReverseVelocity > 0`` may be driven backwards, so it is
  bidirectional too. ``locked="true"`` paths are closed and left out.
* path **shapes**: ``DIRECT``, ``ELBOW`` and ``SLANTED`` are straight;
  ``POLYPATH`` goes through its control points; ``BEZIER`` (one cubic) and
  ``BEZIER_3`` (a chain of cubics) are sampled into short straight pieces.
  Control points are in the visual layout's units: multiplied by its
  ``scaleX``/``scaleY`` (mm per unit, default 50) with y flipped.
* **locations** become stations at each point they link to (named after the
  location, or ``location@point`` if it links to several). The kind follows the
  location type's name and allowed operations: charge -> ``charging``, park ->
  ``parking``, load and unload -> ``pickdrop``, only load/pick -> ``pick``, only
  unload/drop -> ``drop``; anything else ``pickdrop``. Locations without links
  (peripherals such as doors) are skipped.
* points of type ``PARK_POSITION`` also get a ``parking`` station named after
  the point.
* **blocks** are kept as ``layout.blocks``: name -> ids of the points, segments
  and stations that survived the import.
* vehicles, envelopes, layers and properties are ignored.

Stations that cannot all reach each other are allowed here (real plants have
one-way corners); :meth:`Layout.usable_stations` names the largest group that
can, and :func:`import_notes` lists everything skipped or merged.

Reading the XML is :mod:`agv_app.layout.plant_model`.
"""

from __future__ import annotations

import math
import re
from collections.abc import Sequence
from pathlib import Path

from agv_app.geometry import XY
from agv_app.layout.elements import (
    LayoutError,
    LayoutFileError,
    Point,
    Segment,
    Station,
    StationKind,
)
from agv_app.layout.graph import Layout
from agv_app.layout.plant_model import PlantModel, PlantPath, read_plant_model

__all__ = [
    "import_notes",
    "load_opentcs",
    "plant_model_to_layout",
]

_BEZIER_PIECES = 8
_SAME_SHAPE_MM = 1.0


def _cubic(p0: XY, p1: XY, p2: XY, p3: XY) -> list[XY]:
    """Interior sample points of a cubic Bezier curve (ends excluded)."""
    out: list[XY] = []
    for k in range(1, _BEZIER_PIECES):
        t = k / _BEZIER_PIECES
        u = 1 - t
        a, b, c, d = u * u * u, 3 * u * u * t, 3 * u * t * t, t * t * t
        out.append(
            (
                a * p0[0] + b * p1[0] + c * p2[0] + d * p3[0],
                a * p0[1] + b * p1[1] + c * p2[1] + d * p3[1],
            )
        )
    return out


def _path_vertices_mm(model: PlantModel, path: PlantPath, start: XY, end: XY) -> list[XY]:
    """Vertices in mm from ``start`` to ``end``, ends included."""
    cps = [(x * model.scale_x_mm, -y * model.scale_y_mm) for x, y in path.control_points]
    kind = path.connection_type
    inner: list[XY] = []
    if kind == "POLYPATH":
        inner = cps
    elif kind == "BEZIER" and len(cps) == 2:
        inner = _cubic(start, cps[0], cps[1], end)
    elif kind == "BEZIER_3" and len(cps) >= 2 and len(cps) % 3 == 2:
        # A chain of cubics: start, c0, c1, c2 | c2, c3, c4, ... end.
        knots = [start, *cps, end]
        for i in range(0, len(knots) - 1, 3):
            inner.extend(_cubic(knots[i], knots[i + 1], knots[i + 2], knots[i + 3]))
            if i + 3 < len(knots) - 1:
                inner.append(knots[i + 3])
    pts = [start]
    for v in [*inner, end]:
        if math.dist(v, pts[-1]) >= _SAME_SHAPE_MM:
            pts.append(v)
    if pts[-1] != end:
        pts[-1] = end
    return pts


def _kind_for(type_name: str, operations: Sequence[str]) -> StationKind:
    words = " ".join([type_name, *operations]).lower()
    if re.search(r"charg", words):
        return "charging"
    if re.search(r"park", words):
        return "parking"
    ops = " ".join(operations).lower()
    unload = bool(re.search(r"unload|drop", ops))
    load = bool(re.search(r"(?<!un)load|pick", ops))
    if load and not unload:
        return "pick"
    if unload and not load:
        return "drop"
    return "pickdrop"


def _convert(model: PlantModel) -> tuple[Layout, list[str]]:
    notes: list[str] = []
    points: dict[str, Point] = {}
    for p in model.points:
        if p.name in points:
            raise LayoutFileError(f"duplicate point {p.name!r}", where=f"line {p.line}")
        points[p.name] = Point(p.name, p.x_mm / 1000, p.y_mm / 1000)
    shapes: dict[str, list[XY]] = {}
    open_paths: list[PlantPath] = []
    for path in model.paths:
        for end in (path.source, path.destination):
            if end not in points:
                raise LayoutFileError(
                    f"<path name={path.name!r}> refers to unknown point {end!r}",
                    where=f"line {path.line}",
                )
        if path.locked:
            notes.append(f"path {path.name!r} is locked: left out")
            continue
        a, b = points[path.source], points[path.destination]
        shapes[path.name] = _path_vertices_mm(
            model, path, (a.x * 1000, a.y * 1000), (b.x * 1000, b.y * 1000)
        )
        open_paths.append(path)
    by_ends = {(p.source, p.destination): p for p in open_paths}
    alias: dict[str, str] = {}
    segments: list[Segment] = []
    for path in sorted(open_paths, key=lambda p: p.name):
        if path.name in alias:
            continue
        twin = by_ends.get((path.destination, path.source))
        bidirectional = path.max_reverse_velocity > 0
        if twin is not None and twin.name not in alias and twin.name != path.name:
            mine, theirs = shapes[path.name], shapes[twin.name][::-1]
            same = len(mine) == len(theirs) and all(
                math.dist(u, v) <= _SAME_SHAPE_MM for u, v in zip(mine, theirs, strict=True)
            )
            if same:
                alias[twin.name] = path.name
                bidirectional = True
                notes.append(f"paths {path.name!r} and {twin.name!r}: one bidirectional segment")
        alias[path.name] = path.name
        via = tuple((x / 1000, y / 1000) for x, y in shapes[path.name][1:-1])
        segments.append(Segment(path.name, path.source, path.destination, bidirectional, via))
    stations: list[Station] = []
    location_ids: dict[str, list[str]] = {}
    for loc in model.locations:
        if not loc.links:
            notes.append(f"location {loc.name!r} links to no point: left out")
            continue
        kind = _kind_for(loc.type, model.location_types.get(loc.type, ()))
        for pt in loc.links:
            if pt not in points:
                raise LayoutFileError(
                    f"<location name={loc.name!r}> links to unknown point {pt!r}",
                    where=f"line {loc.line}",
                )
            sid = loc.name if len(loc.links) == 1 else f"{loc.name}@{pt}"
            stations.append(Station(sid, pt, kind))
            location_ids.setdefault(loc.name, []).append(sid)
    taken = {s.id for s in stations}
    for p in model.points:
        if p.type == "PARK_POSITION":
            sid = p.name if p.name not in taken else f"park@{p.name}"
            stations.append(Station(sid, p.name, "parking"))
    blocks: dict[str, set[str]] = {}
    for block in model.blocks:
        members: set[str] = set()
        for m in block.members:
            if m in alias:
                members.add(alias[m])
            elif m in points:
                members.add(m)
            elif m in location_ids:
                members.update(location_ids[m])
            else:
                notes.append(f"block {block.name!r}: member {m!r} not in the layout: dropped")
        blocks[block.name] = members
    try:
        layout = Layout(
            points.values(),
            segments,
            stations,
            blocks=blocks,
            name=model.name,
            require_connected_stations=False,
        )
    except LayoutFileError:
        raise
    except LayoutError as exc:
        raise LayoutFileError(f"plant model {model.name!r}: {exc}") from exc
    bad = layout.unreachable_stations()
    if bad:
        notes.append(
            "stations not mutually reachable with the rest: "
            + ", ".join(repr(s) for s in bad)
            + " (use layout.usable_stations())"
        )
    return layout, notes


def plant_model_to_layout(model: PlantModel) -> Layout:
    """Convert a parsed plant model into a layout (mapping in the module doc).

    Raises:
        LayoutFileError: a path or link names an unknown point, or the model is
            otherwise inconsistent.
    """
    return _convert(model)[0]


def import_notes(model: PlantModel) -> tuple[str, ...]:
    """What the conversion left out, merged or could not connect, in words."""
    return tuple(_convert(model)[1])


def load_opentcs(path: str | Path) -> Layout:
    """Read an openTCS plant-model file and convert it to a layout.

    Raises:
        LayoutFileError: see :func:`read_plant_model` and :func:`plant_model_to_layout`.
    """
    return plant_model_to_layout(read_plant_model(path))
