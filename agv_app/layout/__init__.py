"""The floor plan: the layout graph, its JSON and openTCS forms, the demo warehouse."""

from __future__ import annotations

from agv_app.layout.demo import (
    DEMO_VEHICLE_LENGTH_M,
    DEMO_VEHICLE_WIDTH_M,
    demo_warehouse,
)
from agv_app.layout.elements import (
    STATION_KINDS,
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
from agv_app.layout.graph import (
    Layout,
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
    import_notes,
    load_opentcs,
    plant_model_to_layout,
)
from agv_app.layout.plant_model import (
    PlantBlock,
    PlantLocation,
    PlantModel,
    PlantPath,
    PlantPoint,
    parse_plant_model,
    read_plant_model,
)
from agv_app.layout.search import (
    Arc,
    shortest_paths,
    strong_components,
)

__all__ = [
    "DEMO_VEHICLE_LENGTH_M",
    "DEMO_VEHICLE_WIDTH_M",
    "FORMAT",
    "STATION_KINDS",
    "VERSION",
    "Arc",
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
    "Route",
    "Segment",
    "Station",
    "StationKind",
    "demo_warehouse",
    "import_notes",
    "layout_from_json",
    "layout_schema",
    "layout_to_json",
    "load_any",
    "load_layout",
    "load_opentcs",
    "parse_plant_model",
    "plant_model_to_layout",
    "read_plant_model",
    "save_layout",
    "shortest_paths",
    "strong_components",
]
