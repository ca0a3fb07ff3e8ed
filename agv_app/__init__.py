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

from objectplaces.extras import require

require("fleet", "the AGV fleet application (agv_app)")  # else: which extra to install

# The imports come after the check, so a missing extra is named before shapely fails;
# the package's face is every name of geometry and of layout.
from agv_app import geometry, layout  # noqa: E402
from agv_app.geometry import *  # noqa: E402, F403
from agv_app.layout import *  # noqa: E402, F403
from agv_app.vehicle import Vehicle, VehicleSpec  # noqa: E402

__all__ = ["Vehicle", "VehicleSpec"]
__all__ += geometry.__all__
__all__ += layout.__all__
