"""Transport tasks: the auction among idle AGVs, the stations that run it, the task
book that follows every task, and the desk that creates them.
"""

from __future__ import annotations

from agv_app.tasks.auction import (
    Bidder,
    TaskAgent,
    TaskAnnouncer,
    TaskSpec,
    bidder_group,
)
from agv_app.tasks.book import (
    DEFAULT_HISTORY,
    TASK_STATES,
    TaskBook,
    TaskRecord,
    TaskState,
)
from agv_app.tasks.desk import (
    TaskDesk,
    drop_stations,
    pick_stations,
)
from agv_app.tasks.station import (
    Station,
)

__all__ = [
    "DEFAULT_HISTORY",
    "TASK_STATES",
    "Bidder",
    "Station",
    "TaskAgent",
    "TaskAnnouncer",
    "TaskBook",
    "TaskDesk",
    "TaskRecord",
    "TaskSpec",
    "TaskState",
    "bidder_group",
    "drop_stations",
    "pick_stations",
]
