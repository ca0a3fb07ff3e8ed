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

The XML is read with expat directly so that errors can name the line; DTDs and
entities are refused, which real plant models never use.
"""

from __future__ import annotations

import math
import re
import xml.parsers.expat
from collections.abc import Sequence
from dataclasses import dataclass, field
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

__all__ = [
    "PlantBlock",
    "PlantLocation",
    "PlantModel",
    "PlantPath",
    "PlantPoint",
    "import_notes",
    "load_opentcs",
    "parse_plant_model",
    "plant_model_to_layout",
    "read_plant_model",
]

_BEZIER_PIECES = 8
_SAME_SHAPE_MM = 1.0


@dataclass(frozen=True, slots=True)
class PlantPoint:
    """A ``<point>``: name, position in mm, openTCS point type."""

    name: str
    x_mm: float
    y_mm: float
    type: str
    line: int


@dataclass(frozen=True, slots=True)
class PlantPath:
    """A ``<path>``: one-way from ``source`` to ``destination``.

    ``control_points`` are in visual-layout units, as in the file.
    """

    name: str
    source: str
    destination: str
    locked: bool
    max_reverse_velocity: float
    connection_type: str
    control_points: tuple[XY, ...]
    line: int


@dataclass(frozen=True, slots=True)
class PlantLocation:
    """A ``<location>``: name, type name, linked point names."""

    name: str
    type: str
    links: tuple[str, ...]
    line: int


@dataclass(frozen=True, slots=True)
class PlantBlock:
    """A ``<block>``: name, openTCS block type, member names."""

    name: str
    type: str
    members: tuple[str, ...]


@dataclass(frozen=True, slots=True)
class PlantModel:
    """A parsed plant model, before conversion (see :func:`plant_model_to_layout`).

    Attributes:
        location_types: type name -> allowed operation names.
        vehicle_size_mm: ``(length, width)`` of the first ``<vehicle>``'s bounding
            box, or None if the model has no vehicle.
        scale_x_mm: millimetres per visual-layout unit (x).
        scale_y_mm: millimetres per visual-layout unit (y).
    """

    name: str
    version: str
    points: tuple[PlantPoint, ...]
    paths: tuple[PlantPath, ...]
    locations: tuple[PlantLocation, ...]
    location_types: dict[str, tuple[str, ...]] = field(hash=False)
    blocks: tuple[PlantBlock, ...]
    vehicle_size_mm: tuple[float, float] | None = None
    scale_x_mm: float = 50.0
    scale_y_mm: float = 50.0


# -- XML reading --------------------------------------------------------------------


@dataclass(slots=True)
class _Node:
    tag: str
    attrib: dict[str, str]
    line: int
    children: list[_Node] = field(default_factory=list)

    def describe(self) -> str:
        name = self.attrib.get("name")
        return f"<{self.tag} name={name!r}>" if name is not None else f"<{self.tag}>"


def _refuse_dtd(*_args: object) -> None:
    raise _DtdRefused


class _DtdRefused(Exception):
    pass


def _parse_xml(data: bytes, source: str) -> _Node:
    parser = xml.parsers.expat.ParserCreate()
    stack: list[_Node] = []
    root: list[_Node] = []

    def start(tag: str, attrib: dict[str, str]) -> None:
        node = _Node(tag, attrib, parser.CurrentLineNumber)
        if stack:
            stack[-1].children.append(node)
        else:
            root.append(node)
        stack.append(node)

    def end(_tag: str) -> None:
        stack.pop()

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    parser.StartDoctypeDeclHandler = _refuse_dtd
    parser.EntityDeclHandler = _refuse_dtd
    try:
        parser.Parse(data, True)
    except xml.parsers.expat.ExpatError as exc:
        raise LayoutFileError(
            f"{source}: not well-formed XML: {xml.parsers.expat.errors.messages[exc.code]}",
            where=f"line {exc.lineno}",
        ) from exc
    except _DtdRefused:
        raise LayoutFileError(
            f"{source}: DTDs and entities are not allowed in a plant model",
            where=f"line {parser.CurrentLineNumber}",
        ) from None
    return root[0]


def _attr(node: _Node, key: str, source: str) -> str:
    try:
        return node.attrib[key]
    except KeyError:
        raise LayoutFileError(
            f"{source}: {node.describe()} lacks attribute {key!r}", where=f"line {node.line}"
        ) from None


def _number(node: _Node, key: str, source: str, *, default: float | None = None) -> float:
    if key not in node.attrib and default is not None:
        return default
    raw = _attr(node, key, source)
    try:
        value = float(raw)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        raise LayoutFileError(
            f"{source}: {node.describe()} attribute {key}={raw!r} is not a finite number",
            where=f"line {node.line}",
        )
    return value


def parse_plant_model(data: bytes | str, *, source: str = "<plant model>") -> PlantModel:
    """Parse plant-model XML.

    Args:
        data: the XML document.
        source: file name used in error messages.

    Raises:
        LayoutFileError: malformed XML, a root other than ``<model>``, a model
            version other than 7.x, a missing or non-numeric attribute; the
            message names the element and ``where`` the line.
    """
    raw = data.encode("utf-8") if isinstance(data, str) else data
    root = _parse_xml(raw, source)
    if root.tag != "model":
        raise LayoutFileError(
            f"{source}: not an openTCS plant model: root element is <{root.tag}>, expected <model>",
            where=f"line {root.line}",
        )
    version = _attr(root, "version", source)
    if version.split(".")[0] != "7":
        raise LayoutFileError(
            f"{source}: unsupported plant model version {version!r} (expected 7.x)",
            where=f"line {root.line}",
        )
    points: list[PlantPoint] = []
    paths: list[PlantPath] = []
    locations: list[PlantLocation] = []
    types: dict[str, tuple[str, ...]] = {}
    blocks: list[PlantBlock] = []
    scale_x = scale_y = 50.0
    vehicle_size: tuple[float, float] | None = None
    for node in root.children:
        match node.tag:
            case "point":
                points.append(
                    PlantPoint(
                        _attr(node, "name", source),
                        _number(node, "positionX", source),
                        _number(node, "positionY", source),
                        node.attrib.get("type", "HALT_POSITION"),
                        node.line,
                    )
                )
            case "path":
                paths.append(_read_path(node, source))
            case "location":
                links = tuple(_attr(c, "point", source) for c in node.children if c.tag == "link")
                locations.append(
                    PlantLocation(
                        _attr(node, "name", source), _attr(node, "type", source), links, node.line
                    )
                )
            case "locationType":
                ops = tuple(
                    _attr(c, "name", source) for c in node.children if c.tag == "allowedOperation"
                )
                types[_attr(node, "name", source)] = ops
            case "block":
                members = tuple(
                    _attr(c, "name", source) for c in node.children if c.tag == "member"
                )
                blocks.append(
                    PlantBlock(_attr(node, "name", source), node.attrib.get("type", ""), members)
                )
            case "vehicle" if vehicle_size is None:
                for c in node.children:
                    if c.tag == "boundingBox":
                        vehicle_size = (_number(c, "length", source), _number(c, "width", source))
            case "visualLayout":
                scale_x = _number(node, "scaleX", source, default=50.0)
                scale_y = _number(node, "scaleY", source, default=50.0)
            case _:
                pass
    return PlantModel(
        name=root.attrib.get("name", Path(source).stem),
        version=version,
        points=tuple(points),
        paths=tuple(paths),
        locations=tuple(locations),
        location_types=types,
        blocks=tuple(blocks),
        vehicle_size_mm=vehicle_size,
        scale_x_mm=scale_x,
        scale_y_mm=scale_y,
    )


def _read_path(node: _Node, source: str) -> PlantPath:
    connection = "DIRECT"
    controls: list[XY] = []
    for child in node.children:
        if child.tag == "pathLayout":
            connection = child.attrib.get("connectionType", "DIRECT")
            controls = [
                (_number(c, "x", source), _number(c, "y", source))
                for c in child.children
                if c.tag == "controlPoint"
            ]
    return PlantPath(
        name=_attr(node, "name", source),
        source=_attr(node, "sourcePoint", source),
        destination=_attr(node, "destinationPoint", source),
        locked=node.attrib.get("locked", "false").lower() == "true",
        max_reverse_velocity=_number(node, "maxReverseVelocity", source, default=0.0),
        connection_type=connection,
        control_points=tuple(controls),
        line=node.line,
    )


def read_plant_model(path: str | Path) -> PlantModel:
    """Read and parse a plant-model file (see :func:`parse_plant_model`).

    Raises:
        LayoutFileError: unreadable file, or as :func:`parse_plant_model`.
    """
    p = Path(path)
    try:
        data = p.read_bytes()
    except OSError as exc:
        raise LayoutFileError(f"cannot read plant model {str(p)!r}: {exc}") from exc
    return parse_plant_model(data, source=p.name)


# -- conversion -------------------------------------------------------------------------


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
