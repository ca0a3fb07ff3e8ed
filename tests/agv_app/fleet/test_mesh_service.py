"""Out of service and sent home in a fleet of AGV processes: the vehicle hears the
control over the observer's properties, hands back a task it has not loaded, and another
vehicle sets off with it (the order completing on another vehicle, parking, and a loaded
vehicle refused: tests/agv_app/fleet/test_service.py, in virtual time).

Real processes on 127.0.0.1. Every wait is for an event, with a generous bound; a
vehicle is stopped (held) before it is judged loaded or not, so that what it reports
cannot change under the test.
"""

from __future__ import annotations

import asyncio
from collections.abc import Mapping
from typing import Any

import pytest

from agv_app.fleet import MeshFleet
from tests.agv_app.fleet.ready import heard_by_all
from tests.waiting import until

pytestmark = pytest.mark.processes


def _view(fleet: MeshFleet, agv_id: str) -> Mapping[str, Any]:
    return fleet.seen.view(agv_id) or {}


async def _held_with(fleet: MeshFleet, task_id: str, *, loaded: bool) -> str:
    """Wait for the vehicle of ``task_id`` to report it (``loaded`` as asked), stop it,
    and wait until it reports standing; its id."""

    def reported() -> bool:
        agv = fleet.assignment(task_id)
        view = {} if agv is None else _view(fleet, agv)
        return (
            view.get("task") == task_id
            and view.get("loaded") is loaded
            and view.get("state") == "driving"  # it has left home
        )

    await until(reported, within=90)
    agv_id = fleet.assignment(task_id)
    assert agv_id is not None
    fleet.stop_vehicles([agv_id])
    await until(lambda: _view(fleet, agv_id).get("held") is True, within=20)
    view = _view(fleet, agv_id)
    assert (view.get("task"), view.get("loaded")) == (task_id, loaded), "held as it was"
    return agv_id


async def _taken_by_another(fleet: MeshFleet, task_id: str, agv_id: str) -> str:
    """Wait until another vehicle has set off with ``task_id``; its id."""

    def taken() -> bool:
        record = fleet.desk.book.get(task_id)
        return record is not None and record.state == "driving" and record.vehicle != agv_id

    await until(taken, within=60)
    assert fleet.desk.book.double_assignments == 0, "never held by two at once"
    other = fleet.assignment(task_id)
    assert other is not None
    return other


@pytest.mark.timeout(180)
async def test_agv_processes_hand_back_out_of_service_and_sent_home() -> None:
    fleet = MeshFleet(agvs=3, seed=2, task_interval=None, run_seconds=170.0, dwell=2.0)
    await fleet.start()
    try:
        await heard_by_all(fleet)
        first_pick, second_pick = sorted(fleet.stations)[:2]

        task = fleet.create_task(first_pick)
        retired = await _held_with(fleet, task, loaded=False)
        fleet.set_service([retired], in_service=False)
        await until(lambda: _view(fleet, retired).get("task") is None, within=20)
        fleet.resume_vehicles([retired])
        await _taken_by_another(fleet, task, retired)
        assert _view(fleet, retired).get("in_service") is False  # it parks: test_service.py

        fleet.set_service([retired], in_service=True)
        # Another station: the first calls no AGV for it until the first task has left.
        task = fleet.create_task(second_pick)
        sent = await _held_with(fleet, task, loaded=False)
        fleet.send_home(sent)
        await until(lambda: not fleet.orders.homeward.pending, within=20)  # it answered
        await until(lambda: _view(fleet, sent).get("task") is None, within=20)  # handed back
        fleet.resume_vehicles([sent])
        await _taken_by_another(fleet, task, sent)
        assert _view(fleet, sent).get("in_service") is True, "sent home, it stays in service"

        fleet.set_service([sent], in_service=False)
        with pytest.raises(ValueError, match="out of service"):
            fleet.send_home(sent)
        assert not fleet.orders.homeward.pending
    finally:
        await fleet.stop()


@pytest.mark.timeout(120)
async def test_agv_processes_with_batteries_report_their_state_of_charge() -> None:
    fleet = MeshFleet(agvs=1, seed=3, task_interval=None, run_seconds=100.0, batteries=True)
    await fleet.start()
    try:
        async with asyncio.timeout(40):
            await fleet.wait_ready()

        def full() -> bool:
            levels = [v.battery for v in fleet.vehicles()]
            return len(levels) == 1 and levels[0] is not None and levels[0] >= 99.9

        await until(full, within=20)  # standing, it uses a thousandth of a percent a second
        fleet.create_task(sorted(fleet.stations)[0])

        def drained() -> bool:
            level = fleet.vehicles()[0].battery
            return level is not None and level < 99.9  # driven some ten metres

        await until(drained, within=60)
    finally:
        await fleet.stop()
