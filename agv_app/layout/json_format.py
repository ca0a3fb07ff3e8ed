"""Layouts as JSON files (format in ``docs/layout-format.md``).

A file is checked in three passes, and the first problem found is raised as a
:class:`~agv_app.layout.LayoutFileError` whose ``where`` is a JSON path such as
``$.segments[3].end``:

1. it must parse as JSON (no ``NaN``/``Infinity``);
2. it must match ``agv_app/data/layout.schema.json`` (JSON Schema 2020-12);
3. it must make sense: unique ids, known references, no zero-length segment,
   every station reachable from every other.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from functools import cache
from importlib import resources
from pathlib import Path
from typing import Any, cast

import jsonschema

from agv_app.layout.elements import (
    LayoutError,
    LayoutFileError,
    Point,
    Segment,
    Station,
    StationKind,
)
from agv_app.layout.graph import MAX_FLOOR_COORDINATE_M, Layout

__all__ = [
    "FORMAT",
    "VERSION",
    "layout_from_json",
    "layout_schema",
    "layout_to_json",
    "load_any",
    "load_layout",
    "save_layout",
]

FORMAT = "objectplaces-layout"
"""Value of the ``format`` field."""

VERSION = 1
"""Value of the ``version`` field this module reads and writes."""


@cache
def layout_schema() -> Mapping[str, Any]:
    """Return the layout JSON schema (parsed once)."""
    text = resources.files("agv_app").joinpath("data", "layout.schema.json").read_text("utf-8")
    return cast("dict[str, Any]", json.loads(text))


@cache
def _validator() -> jsonschema.Draft202012Validator:
    return jsonschema.Draft202012Validator(layout_schema())


def _reject_constant(name: str) -> float:
    raise ValueError(f"{name} is not a number in this format")


def load_layout(path: str | Path) -> Layout:
    """Read and check a JSON layout file.

    Raises:
        LayoutFileError: the file cannot be read, is not valid JSON, breaks the
            schema or is inconsistent; the message names the JSON path.
    """
    p = Path(path)
    try:
        text = p.read_text("utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise LayoutFileError(f"cannot read layout file {str(p)!r}: {exc}") from exc
    try:
        data = json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        raise LayoutFileError(
            f"{p.name}: not valid JSON: {exc.msg}", where=f"line {exc.lineno} column {exc.colno}"
        ) from exc
    except ValueError as exc:
        raise LayoutFileError(f"{p.name}: {exc}") from exc
    return layout_from_json(data, default_name=p.stem)


def layout_from_json(data: object, *, default_name: str = "layout") -> Layout:
    """Build a layout from already parsed JSON data.

    Args:
        data: the parsed document.
        default_name: layout name if the document has none.

    Raises:
        LayoutFileError: as :func:`load_layout`.
    """
    errors = sorted(_validator().iter_errors(data), key=lambda e: list(e.absolute_path))
    if errors:
        err = jsonschema.exceptions.best_match(errors)
        assert err is not None
        raise LayoutFileError(err.message, where=err.json_path)
    doc = cast("dict[str, Any]", data)
    _check_semantics(doc)
    try:
        return Layout(
            [
                Point(p["id"], float(p["x"]), float(p["y"]), passing=p.get("passing", False))
                for p in doc["points"]
            ],
            [
                Segment(
                    s["id"],
                    s["start"],
                    s["end"],
                    bidirectional=s.get("bidirectional", False),
                    via=tuple((float(x), float(y)) for x, y in s.get("via", ())),
                )
                for s in doc["segments"]
            ],
            [
                Station(s["id"], s["point"], cast("StationKind", s.get("kind", "pickdrop")))
                for s in doc.get("stations", ())
            ],
            blocks=doc.get("blocks", {}),
            name=doc.get("name", default_name),
        )
    except LayoutFileError:
        raise
    except LayoutError as exc:
        where = "$.stations" if "reachable" in str(exc) else "$"
        raise LayoutFileError(str(exc), where=where) from exc


def _check_semantics(doc: Mapping[str, Any]) -> None:
    """The checks that need a path in the message; the rest is left to :class:`Layout`."""
    points: dict[str, tuple[float, float]] = {}
    for i, p in enumerate(doc["points"]):
        where = f"$.points[{i}]"
        if p["id"] in points:
            raise LayoutFileError(f"duplicate point id {p['id']!r}", where=f"{where}.id")
        for axis in ("x", "y"):
            fault = _coordinate_fault(p[axis])
            if fault is not None:
                raise LayoutFileError(f"point {p['id']!r}: {fault}", where=f"{where}.{axis}")
        points[p["id"]] = (p["x"], p["y"])
    seen: set[str] = set()
    for i, s in enumerate(doc["segments"]):
        where = f"$.segments[{i}]"
        if s["id"] in seen:
            raise LayoutFileError(f"duplicate segment id {s['id']!r}", where=f"{where}.id")
        seen.add(s["id"])
        for key in ("start", "end"):
            if s[key] not in points:
                raise LayoutFileError(
                    f"segment {s['id']!r}: unknown {key} point {s[key]!r}", where=f"{where}.{key}"
                )
        for j, vertex in enumerate(s.get("via", ())):
            for c, value in enumerate(vertex):
                fault = _coordinate_fault(value)
                if fault is not None:
                    raise LayoutFileError(
                        f"segment {s['id']!r}: via vertex {j}: {fault}",
                        where=f"{where}.via[{j}][{c}]",
                    )
        coords = [points[s["start"]], *(tuple(v) for v in s.get("via", ())), points[s["end"]]]
        for k in range(len(coords) - 1):
            (x0, y0), (x1, y1) = coords[k], coords[k + 1]
            if math.hypot(x1 - x0, y1 - y0) < 1e-6:
                raise LayoutFileError(
                    f"segment {s['id']!r}: zero length between vertices {k} and {k + 1}",
                    where=where,
                )
    stations: set[str] = set()
    for i, st in enumerate(doc.get("stations", ())):
        where = f"$.stations[{i}]"
        if st["id"] in stations:
            raise LayoutFileError(f"duplicate station id {st['id']!r}", where=f"{where}.id")
        stations.add(st["id"])
        if st["point"] not in points:
            raise LayoutFileError(
                f"station {st['id']!r}: unknown point {st['point']!r}", where=f"{where}.point"
            )
    for name, members in doc.get("blocks", {}).items():
        for k, m in enumerate(members):
            if m not in points and m not in seen and m not in stations:
                raise LayoutFileError(
                    f"block {name!r}: unknown member {m!r}", where=f"$.blocks[{name!r}][{k}]"
                )


def _coordinate_fault(value: float) -> str | None:
    """Why ``value`` (a JSON number, of any size) is no coordinate on a floor; None if it
    is one. Compared before any float conversion: a whole number of 400 digits is a JSON
    number too."""
    if isinstance(value, float) and not math.isfinite(value):
        return "non-finite position"
    if not abs(value) <= MAX_FLOOR_COORDINATE_M:
        shown = repr(value)
        if len(shown) > 24:
            shown = f"{shown[:8]}... ({len(shown)} characters)"
        return f"position {shown} lies beyond +-{MAX_FLOOR_COORDINATE_M:g} m"
    return None


def layout_to_json(layout: Layout) -> dict[str, Any]:
    """Return ``layout`` as a JSON-ready dict in this module's format.

    Defaults (``passing: false``, ``bidirectional: false``, empty ``via``) are
    left out; ``layout_from_json(layout_to_json(x))`` rebuilds an equal layout.
    """
    points: list[dict[str, Any]] = []
    for p in layout.points.values():
        item: dict[str, Any] = {"id": p.id, "x": p.x, "y": p.y}
        if p.passing:
            item["passing"] = True
        points.append(item)
    segments: list[dict[str, Any]] = []
    for s in layout.segments.values():
        seg: dict[str, Any] = {"id": s.id, "start": s.start, "end": s.end}
        if s.bidirectional:
            seg["bidirectional"] = True
        if s.via:
            seg["via"] = [[x, y] for x, y in s.via]
        segments.append(seg)
    doc: dict[str, Any] = {
        "format": FORMAT,
        "version": VERSION,
        "name": layout.name,
        "points": points,
        "segments": segments,
        "stations": [
            {"id": s.id, "point": s.point, "kind": s.kind} for s in layout.stations.values()
        ],
    }
    if layout.blocks:
        doc["blocks"] = {name: sorted(m) for name, m in sorted(layout.blocks.items())}
    return doc


def save_layout(layout: Layout, path: str | Path) -> None:
    """Write ``layout`` to ``path`` as indented JSON (see :func:`layout_to_json`)."""
    Path(path).write_text(json.dumps(layout_to_json(layout), indent=1) + "\n", "utf-8")


def load_any(path: str | Path) -> Layout:
    """Load a layout by file suffix: ``.json`` (this format) or ``.xml`` (openTCS).

    The name ``demo`` (no suffix, no such file) gives the built-in demo warehouse.

    Raises:
        LayoutFileError: unknown suffix, or whatever the chosen loader raises.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix == ".json":
        return load_layout(p)
    if suffix == ".xml":
        from agv_app.layout.opentcs import load_opentcs

        return load_opentcs(p)
    if str(path) == "demo" and not p.exists():
        from agv_app.layout.demo import demo_warehouse

        return demo_warehouse()
    raise LayoutFileError(
        f"cannot tell the format of {str(p)!r}: expected a .json or .xml file, or 'demo'"
    )
