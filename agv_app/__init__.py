"""The AGV fleet application: layouts, geometry and vehicle kinematics.

Import from here; the submodules are the implementation.
"""

from __future__ import annotations

from agv_app.geometry import (
    DEFAULT_OVERLAP_TOLERANCE_M2,
    WIRE_MARGIN_M,
    XY,
    Area,
    Polyline,
    Pose,
    coords_to_polygon,
    hull,
    hull_length,
    hull_projection,
    hull_projection_sampled,
    overlaps,
    polygon_to_coords,
    projection_ahead,
)
from agv_app.layout import (
    STATION_KINDS,
    Layout,
    LayoutError,
    LayoutFileError,
    NoRouteError,
    PassingExtent,
    Point,
    Route,
    Segment,
    Station,
    StationKind,
)

__all__ = [
    "DEFAULT_OVERLAP_TOLERANCE_M2",
    "STATION_KINDS",
    "WIRE_MARGIN_M",
    "XY",
    "Area",
    "Layout",
    "LayoutError",
    "LayoutFileError",
    "NoRouteError",
    "PassingExtent",
    "Point",
    "Polyline",
    "Pose",
    "Route",
    "Segment",
    "Station",
    "StationKind",
    "coords_to_polygon",
    "hull",
    "hull_length",
    "hull_projection",
    "hull_projection_sampled",
    "overlaps",
    "polygon_to_coords",
    "projection_ahead",
]
