"""Floor geometry: polylines, AGV hulls, hull projections and their wire form.

Everything is in metres and radians on the floor plane. A vehicle's *hull* is the
rectangle it covers, centred on its reference position and aligned with its
heading. A *hull projection* is the area the hull sweeps while the vehicle drives
a stretch of its route (DESIGN.md, "The AGV application").

The modules: :mod:`~agv_app.geometry.area` (poses, areas, overlap),
:mod:`~agv_app.geometry.polyline`, :mod:`~agv_app.geometry.projection` (hulls and
hull projections) and :mod:`~agv_app.geometry.wire` (the wire form).
"""

from __future__ import annotations

from agv_app.geometry.area import (
    DEFAULT_OVERLAP_TOLERANCE_M2,
    XY,
    Area,
    Pose,
    Spine,
    hull_length,
    overlaps,
)
from agv_app.geometry.polyline import (
    Polyline,
)
from agv_app.geometry.projection import (
    hull,
    hull_projection,
    hull_projection_sampled,
    projection_ahead,
)
from agv_app.geometry.wire import (
    WIRE_MARGIN_M,
    Coords,
    coords_to_polygon,
    polygon_to_coords,
)

__all__ = [
    "DEFAULT_OVERLAP_TOLERANCE_M2",
    "WIRE_MARGIN_M",
    "XY",
    "Area",
    "Coords",
    "Polyline",
    "Pose",
    "Spine",
    "coords_to_polygon",
    "hull",
    "hull_length",
    "hull_projection",
    "hull_projection_sampled",
    "overlaps",
    "polygon_to_coords",
    "projection_ahead",
]
