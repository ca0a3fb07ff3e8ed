"""The openTCS plant model (XML, model version 7) as read, before any conversion.

The XML is read with expat directly so that errors can name the line; DTDs and
entities are refused, which real plant models never use. Conversion into a layout is
:mod:`agv_app.layout.opentcs`.
"""

from __future__ import annotations

import math
import xml.parsers.expat
from dataclasses import dataclass, field
from pathlib import Path

from agv_app.geometry import XY
from agv_app.layout.elements import LayoutFileError

__all__ = [
    "PlantBlock",
    "PlantLocation",
    "PlantModel",
    "PlantPath",
    "PlantPoint",
    "parse_plant_model",
    "read_plant_model",
]


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
