"""``/api/tasks``: transport orders, created at a station, listed, cancelled.

The orders come from the fleet's task book (``TaskBookSource``). A task is cancelled
only while no vehicle holds it: the desk then withdraws it from its station's queue and
auction. A task awarded to a vehicle (``assigned`` or ``driving``) stays with it; the
answer is 409, since making a vehicle drop work it has locked floor for is not safe to
do from the outside.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from fastapi import APIRouter, HTTPException, Path, Query

from agv_app.fleet.blocks import FloorBlocks
from agv_app.tasks.desk import BacklogFull
from dashboard.deps import State
from dashboard.errors import ERROR_RESPONSES
from dashboard.limits import shown
from dashboard.routes.blocks import blocks_of
from dashboard.schemas import ErrorOut, TaskIn, TaskOut, TaskRecordOut
from dashboard.source import TaskBookSource, TaskRecordView

__all__ = ["MAX_TASKS_LISTED", "TaskStateName", "router", "task_out"]

router = APIRouter(prefix="/api/tasks", tags=["tasks"])

TaskStateName = Literal["waiting", "assigned", "driving", "done", "failed", "cancelled"]
"""A task's state as the API names it (the book's ``created`` is ``waiting``)."""

MAX_TASKS_LISTED = 2000
"""Most tasks one ``GET /api/tasks`` answers."""

_FINISHED = frozenset({"done", "failed", "cancelled"})

TaskId = Annotated[str, Path(min_length=1, max_length=128)]


def task_out(record: TaskRecordView, blocks: FloorBlocks | None = None) -> dict[str, Any]:
    """One book record as ``TaskRecordOut`` (``waits`` from ``blocks``, if given)."""
    times = record.times
    finished = (
        times.get("done", times.get("cancelled")) if record.state in ("done", "cancelled") else None
    )
    return {
        "id": record.task.id,
        "creator": record.creator,
        "source": record.task.pick,
        "destination": record.task.drop,
        "state": "waiting" if record.state == "created" else record.state,
        "vehicle": record.vehicle,
        "created": times["created"],
        "started": times.get("driving"),
        "finished": finished,
        "waits": None
        if blocks is None or record.state in _FINISHED
        else blocks.waits(record.task.pick, record.task.drop),
    }


def _book(state: State) -> TaskBookSource | None:
    source = state.source
    return source if isinstance(source, TaskBookSource) else None


@router.get("", response_model=list[TaskRecordOut], responses=ERROR_RESPONSES)
async def list_tasks(
    state: State,
    task_state: Annotated[TaskStateName | None, Query(alias="state")] = None,
    limit: Annotated[int, Query(ge=1, le=MAX_TASKS_LISTED)] = 500,
) -> list[dict[str, Any]]:
    """Transport orders, oldest first: the most recent ``limit`` (of ``state`` only, if given).

    Finished orders are kept for a bounded history; open ones always.
    """
    book = _book(state)
    if book is None:
        return []
    blocks = blocks_of(state.source)
    tasks = sorted((task_out(r, blocks) for r in book.task_records()), key=lambda t: t["created"])
    if task_state is not None:
        tasks = [t for t in tasks if t["state"] == task_state]
    return tasks[-limit:]


@router.get("/{task_id}", response_model=TaskRecordOut, responses=ERROR_RESPONSES)
async def get_task(task_id: TaskId, state: State) -> dict[str, Any]:
    """One transport order."""
    book = _book(state)
    record = book.task_record(task_id) if book is not None else None
    if record is None:
        raise HTTPException(404, f"unknown task {shown(task_id)} (or finished long ago)")
    return task_out(record, blocks_of(state.source))


@router.post(
    "",
    status_code=201,
    response_model=TaskOut,
    responses={**ERROR_RESPONSES, 503: {"model": ErrorOut}},
)
async def create_task(body: TaskIn, state: State) -> TaskOut:
    """Create a transport task at a station (starts its task-assignment session); 503
    while the fleet holds as many open tasks as it takes (``BACKLOG_LIMIT``)."""
    try:
        task_id = state.source.create_task(body.station)
    except BacklogFull as exc:
        raise HTTPException(503, str(exc), headers={"Retry-After": "10"}) from exc
    except LookupError as exc:
        known = ", ".join(s["id"] for s in state.layout["stations"])
        raise HTTPException(404, f"unknown station {shown(body.station)} (known: {known})") from exc
    except ValueError as exc:
        raise HTTPException(422, str(exc)) from exc
    return TaskOut(task_id=str(task_id), station=body.station)


@router.delete(
    "/{task_id}",
    response_model=TaskRecordOut,
    responses=ERROR_RESPONSES,
)
async def cancel_task(task_id: TaskId, state: State) -> dict[str, Any]:
    """Cancel a transport order no vehicle holds yet; 409 once a vehicle holds it."""
    book = _book(state)
    record = book.task_record(task_id) if book is not None else None
    if book is None or record is None:
        raise HTTPException(404, f"unknown task {shown(task_id)} (or finished long ago)")
    if record.state in ("done", "cancelled"):
        raise HTTPException(409, f"task {shown(task_id)} is {record.state} already")
    try:
        book.cancel_task(task_id)
    except KeyError as exc:
        raise HTTPException(404, f"unknown task {shown(task_id)}") from exc
    except ValueError as exc:
        raise HTTPException(
            409,
            f"task {shown(task_id)} is {record.state} by {record.vehicle}: a task a vehicle "
            "holds cannot be cancelled (only waiting ones can)",
        ) from exc
    return task_out(record)
