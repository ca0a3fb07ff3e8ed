"""Transport tasks: the auction among idle AGVs, the stations that run it, the task
book that follows every task, the desk that creates them, who holds which (custody),
and the durable order book they are written to (store).
"""

from __future__ import annotations

from agv_app.tasks.admission import (
    LANE_M_PER_OPEN_TASK,
    AdaptiveLimit,
    carried_tasks,
)
from agv_app.tasks.auction import (
    Bidder,
    TaskAgent,
    TaskAnnouncer,
    TaskSpec,
    bidder_group,
)
from agv_app.tasks.book import (
    DEFAULT_HISTORY,
    FINAL_STATES,
    HELD_STATES,
    TASK_STATES,
    TaskBook,
    TaskRecord,
    TaskState,
)
from agv_app.tasks.capacity import (
    FREE_FLOW_RULES,
    FloorCapacity,
    FloorRules,
    floor_capacity,
    shared_part_seconds,
)
from agv_app.tasks.custody import (
    DEFAULT_HAND_BACK_AFTER,
    CustodyMachine,
    Delivered,
    HandBackReason,
    HandedBack,
    Verdict,
)
from agv_app.tasks.desk import (
    BASE_ID,
    TaskDesk,
    drop_stations,
    pick_stations,
    require_task_stations,
)
from agv_app.tasks.free_flow import (
    FreeFlowBound,
    FreeFlowTimer,
    mean_task_seconds,
)
from agv_app.tasks.journal import (
    StoredTasks,
    TaskJournal,
)
from agv_app.tasks.load import (
    DEFAULT_LOAD,
    TaskArrivals,
    check_load,
    initial_tasks,
    task_interval_for_load,
)
from agv_app.tasks.station import (
    Station,
)
from agv_app.tasks.store import (
    OrderStore,
    StoreError,
)

__all__ = [
    "BASE_ID",
    "DEFAULT_HAND_BACK_AFTER",
    "DEFAULT_HISTORY",
    "DEFAULT_LOAD",
    "FINAL_STATES",
    "FREE_FLOW_RULES",
    "HELD_STATES",
    "LANE_M_PER_OPEN_TASK",
    "TASK_STATES",
    "AdaptiveLimit",
    "Bidder",
    "CustodyMachine",
    "Delivered",
    "FloorCapacity",
    "FloorRules",
    "FreeFlowBound",
    "FreeFlowTimer",
    "HandBackReason",
    "HandedBack",
    "OrderStore",
    "Station",
    "StoreError",
    "StoredTasks",
    "TaskAgent",
    "TaskAnnouncer",
    "TaskArrivals",
    "TaskBook",
    "TaskDesk",
    "TaskJournal",
    "TaskRecord",
    "TaskSpec",
    "TaskState",
    "Verdict",
    "bidder_group",
    "carried_tasks",
    "check_load",
    "drop_stations",
    "floor_capacity",
    "initial_tasks",
    "mean_task_seconds",
    "pick_stations",
    "require_task_stations",
    "shared_part_seconds",
    "task_interval_for_load",
]
