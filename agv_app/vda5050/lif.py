"""Export a layout as a VDA LIF file (Layout Interchange Format 1.0), for a master control.

Nodes are the layout's points, edges its segments as :mod:`agv_app.vda5050.mapping`
names them (a two-way segment is two directed edges), stations its stations at their
point. A curved segment carries its ``via`` vertices as a degree-1 NURBS trajectory.
One vehicle type, ``<manufacturer>.<seriesName>`` as the factsheet says.

```
python -m agv_app.vda5050.lif [LAYOUT.json] > layout.lif.json
```
"""

from __future__ import annotations

import itertools
import json
import math
import sys
from typing import Any

from agv_app.geometry import XY
from agv_app.layout.demo import demo_warehouse
from agv_app.layout.graph import Layout
from agv_app.layout.json_format import load_layout
from agv_app.vda5050.mapping import REVERSE_SUFFIX
from agv_app.vda5050.messages import SERIES_NAME, timestamp
from agv_app.vda5050.topics import MANUFACTURER

__all__ = ["LIF_VERSION", "VEHICLE_TYPE_ID", "layout_to_lif", "main"]

LIF_VERSION = "1.0.0"
"""The LIF version written."""

VEHICLE_TYPE_ID = f"{MANUFACTURER}.{SERIES_NAME}"
"""The one vehicle type of the fleet."""


def _trajectory(coords: tuple[XY, ...]) -> dict[str, Any]:
    """A degree-1 NURBS through ``coords``: clamped knots at the vertices' arc lengths."""
    lengths = [0.0, *itertools.accumulate(math.dist(a, b) for a, b in itertools.pairwise(coords))]
    total = lengths[-1] or 1.0
    inner = [round(s / total, 6) for s in lengths[1:-1]]
    return {
        "degree": 1,
        "knotVector": [0.0, 0.0, *inner, 1.0, 1.0],
        "controlPoints": [{"x": x, "y": y, "weight": 1.0} for x, y in coords],
    }


def _edge(
    edge_id: str, start: str, end: str, coords: tuple[XY, ...], max_speed: float
) -> dict[str, Any]:
    props: dict[str, Any] = {
        "vehicleTypeId": VEHICLE_TYPE_ID,
        "rotationAllowed": False,
        "maxSpeed": max_speed,
    }
    if len(coords) > 2:
        props["trajectory"] = _trajectory(coords)
    return {
        "edgeId": edge_id,
        "startNodeId": start,
        "endNodeId": end,
        "vehicleTypeEdgeProperties": [props],
    }


def layout_to_lif(
    layout: Layout, *, max_speed_m_s: float = 1.5, creator: str = MANUFACTURER
) -> dict[str, Any]:
    """The LIF document of ``layout`` (one layout, ``layoutId`` its name)."""
    nodes = [
        {
            "nodeId": p.id,
            "mapId": layout.name,
            "nodePosition": {"x": p.x, "y": p.y},
            "vehicleTypeNodeProperties": [{"vehicleTypeId": VEHICLE_TYPE_ID}],
        }
        for p in sorted(layout.points.values(), key=lambda p: p.id)
    ]
    edges = []
    for seg in sorted(layout.segments.values(), key=lambda s: s.id):
        coords = layout.segment_coords(seg.id)
        edges.append(_edge(seg.id, seg.start, seg.end, coords, max_speed_m_s))
        if seg.bidirectional:
            back = tuple(reversed(coords))
            edges.append(_edge(seg.id + REVERSE_SUFFIX, seg.end, seg.start, back, max_speed_m_s))
    stations = []
    for st in sorted(layout.stations.values(), key=lambda s: s.id):
        point = layout.point(st.point)
        stations.append(
            {
                "stationId": st.id,
                "stationName": st.kind,
                "interactionNodeIds": [st.point],
                "stationPosition": {"x": point.x, "y": point.y},
            }
        )
    return {
        "metaInformation": {
            "projectIdentification": layout.name,
            "creator": creator,
            "exportTimestamp": timestamp(),
            "lifVersion": LIF_VERSION,
        },
        "layouts": [
            {
                "layoutId": layout.name,
                "layoutName": layout.name,
                "layoutVersion": "1",
                "nodes": nodes,
                "edges": edges,
                "stations": stations,
            }
        ],
    }


def main(argv: list[str] | None = None) -> int:
    """Print the LIF of a layout file (default: the demo warehouse) on stdout."""
    args = sys.argv[1:] if argv is None else argv
    layout = load_layout(args[0]) if args else demo_warehouse()
    json.dump(layout_to_lif(layout), sys.stdout, indent=1)
    sys.stdout.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
