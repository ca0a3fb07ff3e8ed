"""Transport tasks: the auction among idle AGVs and the stations that run it."""

from __future__ import annotations

from agv_app.tasks.auction import (
    Bidder,
    TaskAgent,
    TaskAnnouncer,
    TaskSpec,
    bidder_group,
)
from agv_app.tasks.station import (
    STATION_KIND,
    Station,
)

__all__ = [
    "STATION_KIND",
    "Bidder",
    "Station",
    "TaskAgent",
    "TaskAnnouncer",
    "TaskSpec",
    "bidder_group",
]
