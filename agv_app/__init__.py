"""The AGV fleet application: layouts, geometry and vehicle kinematics.

Import from here; the submodules are the implementation:

* :mod:`agv_app.layout`: the floor plan graph, routing, passing places, errors;
* :mod:`agv_app.geometry`: polylines, hulls, hull projections, wire encoding;
* :mod:`agv_app.vehicle`: kinematics that never pass the end of a lock;
* :mod:`agv_app.layout.demo`: the built-in demo warehouse;
* :mod:`agv_app.layout.json_format`: the JSON layout format;
* :mod:`agv_app.layout.opentcs`: openTCS plant-model import.
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
from agv_app.layout.demo import (
    DEMO_VEHICLE_LENGTH_M,
    DEMO_VEHICLE_WIDTH_M,
    demo_warehouse,
)
from agv_app.layout.graph import (
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
from agv_app.layout.json_format import (
    FORMAT,
    VERSION,
    layout_from_json,
    layout_schema,
    layout_to_json,
    load_any,
    load_layout,
    save_layout,
)
from agv_app.layout.opentcs import (
    PlantBlock,
    PlantLocation,
    PlantModel,
    PlantPath,
    PlantPoint,
    import_notes,
    load_opentcs,
    parse_plant_model,
    plant_model_to_layout,
    read_plant_model,
)
from agv_app.vehicle.kinematics import (
    Vehicle,
    VehicleSpec,
)

__all__ = [
    "DEFAULT_OVERLAP_TOLERANCE_M2",
    "DEMO_VEHICLE_LENGTH_M",
    "DEMO_VEHICLE_WIDTH_M",
    "FORMAT",
    "STATION_KINDS",
    "VERSION",
    "WIRE_MARGIN_M",
    "XY",
    "Area",
    "Layout",
    "LayoutError",
    "LayoutFileError",
    "NoRouteError",
    "PassingExtent",
    "PlantBlock",
    "PlantLocation",
    "PlantModel",
    "PlantPath",
    "PlantPoint",
    "Point",
    "Polyline",
    "Pose",
    "Route",
    "Segment",
    "Station",
    "StationKind",
    "Vehicle",
    "VehicleSpec",
    "coords_to_polygon",
    "demo_warehouse",
    "hull",
    "hull_length",
    "hull_projection",
    "hull_projection_sampled",
    "import_notes",
    "layout_from_json",
    "layout_schema",
    "layout_to_json",
    "load_any",
    "load_layout",
    "load_opentcs",
    "overlaps",
    "parse_plant_model",
    "plant_model_to_layout",
    "polygon_to_coords",
    "projection_ahead",
    "read_plant_model",
    "save_layout",
]
