"""A task as the order store keeps it in a row (:mod:`agv_app.tasks.store`): its
history, bounded; its number; the record read back."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, cast

from agv_app.tasks.auction import TaskSpec
from agv_app.tasks.book import TASK_STATES, TaskRecord, TaskState
from agv_app.tasks.store_file import StoreError

__all__ = ["HISTORY_LIMIT", "append_history", "row_item", "task_number", "task_record"]

HISTORY_LIMIT = 64
"""Entries of a task's history kept: the first, then the latest (a task returned over and
over should not grow its row without end)."""

_ROW_KEYS = ("id", "pick", "drop", "creator", "state", "vehicle", "history", "closed")


def append_history(history: list[list[Any]], entry: list[Any]) -> None:
    """Add ``entry`` to a task's history, dropping the oldest but the first past
    :data:`HISTORY_LIMIT`."""
    history.append(entry)
    if len(history) > HISTORY_LIMIT:
        del history[1]


def task_number(task_id: str) -> int:
    """The number at the end of a task id (``T-17``: 17), or 0."""
    _, _, digits = task_id.rpartition("-")
    return int(digits) if digits.isdigit() else 0


def task_record(row: tuple[Any, ...], offset: float, path: Path) -> TaskRecord:
    """The record of a row (id, pick, drop, creator, state, vehicle, history), times on
    the clock ``offset`` seconds behind the wall clock.

    Raises:
        StoreError: the row is not one the store wrote (the store at ``path``).
    """
    task_id, pick, drop, creator, state, vehicle, history = row
    if state not in TASK_STATES:
        raise StoreError(f"order store {path} is damaged: task {task_id!r} is {state!r}")
    times: dict[TaskState, float] = {}
    for entry in json.loads(history):
        if entry[0] in TASK_STATES:
            times[cast(TaskState, entry[0])] = float(entry[1]) - offset
    times.setdefault("created", times.get(state, -offset))
    return TaskRecord(TaskSpec(task_id, pick, drop), state, vehicle, times, creator)


def row_item(row: tuple[Any, ...]) -> dict[str, Any]:
    """A row with its closing number, as a dict (``OrderStore.task_rows``)."""
    item = dict(zip(_ROW_KEYS, row, strict=True))
    item["history"] = json.loads(item["history"])
    return item
