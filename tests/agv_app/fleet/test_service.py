"""Out of service and sent home in the simulated fleet: a vehicle hands back a task it
has not loaded (another vehicle does it, once), delivers a loaded one first, then goes
home. Virtual time, seeded."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout.demo import demo_warehouse
from agv_app.vehicle.controller import AgvController


def _fleet() -> Fleet:
    cfg = FleetConfig(agvs=6, seed=3, fail_on_violation=True, task_interval=15.0)
    return Fleet(demo_warehouse(), cfg)


def _run_until(fleet: Fleet, found: Callable[[], bool], within_s: float, what: str) -> None:
    for _ in range(round(within_s / fleet.config.dt)):
        if found():
            return
        fleet.step()
    pytest.fail(f"{what} within {within_s} s")


def _driving_to_pick(fleet: Fleet) -> tuple[str, AgvController]:
    """Run until a vehicle is on its way to a pick station, well short of it."""
    found: list[tuple[str, AgvController]] = []

    def look() -> bool:
        found[:] = [
            (a, o)
            for a, o in sorted(fleet.agvs.items())
            if o.phase == "to_pick" and o.vehicle.speed > 0 and o.vehicle.remaining() > 10.0
        ]
        return bool(found)

    _run_until(fleet, look, 600.0, "no vehicle drove to a pick station")
    return found[0]


def _completes_on_another(fleet: Fleet, task_id: str, agv_id: str) -> None:
    def done() -> bool:
        record = fleet.desk.book.get(task_id)
        return record is not None and record.state == "done"

    _run_until(fleet, done, 900.0, f"{task_id} was not done")
    record = fleet.desk.book.get(task_id)
    assert record is not None
    assert record.vehicle != agv_id, "another vehicle did it"
    assert fleet.desk.book.double_assignments == 0, "never held by two at once"


def test_out_of_service_on_the_way_to_pick_hands_the_task_back_and_another_does_it() -> None:
    fleet = _fleet()
    agv_id, agv = _driving_to_pick(fleet)
    task = agv.task
    assert task is not None
    fleet.set_service([agv_id], in_service=False)
    assert agv.task is None, "handed back at once"
    assert agv.node.properties["returned"] == task.id
    assert agv.phase == "to_home"
    _completes_on_another(fleet, task.id, agv_id)
    _run_until(
        fleet,
        lambda: agv.display_status() == "out-of-service" and agv.point == agv.home,
        600.0,
        f"{agv_id} never parked",
    )
    assert agv.last_done != task.id, "it never did the task itself"
    fleet.run(300.0)
    assert agv.task is None
    assert agv.pending_task is None, "it takes no task out of service"
    assert fleet.summary()["collisions"] == 0


def test_out_of_service_loaded_delivers_first_then_parks() -> None:
    fleet = _fleet()
    _run_until(
        fleet,
        lambda: any(o.phase == "to_drop" and o.vehicle.speed > 0 for o in fleet.agvs.values()),
        600.0,
        "no vehicle carried a load",
    )
    agv_id, agv = next((a, o) for a, o in sorted(fleet.agvs.items()) if o.phase == "to_drop")
    task = agv.task
    assert task is not None
    fleet.set_service([agv_id], in_service=False)
    assert agv.task is task, "a loaded vehicle keeps its task"
    assert agv.node.properties.get("returned") is None
    _run_until(
        fleet,
        lambda: agv.display_status() == "out-of-service" and agv.point == agv.home,
        600.0,
        f"{agv_id} never parked",
    )
    record = fleet.desk.book.get(task.id)
    assert record is not None
    assert (record.state, record.vehicle) == ("done", agv_id), "it delivered its load"


def test_sent_home_hands_back_drives_home_and_takes_tasks_again() -> None:
    fleet = _fleet()
    agv_id, agv = _driving_to_pick(fleet)
    task = agv.task
    assert task is not None
    fleet.send_home(agv_id)
    assert agv.task is None
    assert agv.in_service, "sent home, it stays in service"
    assert fleet.service_asked(agv_id)
    _run_until(fleet, lambda: agv.at_rest, 600.0, f"{agv_id} never got home")
    assert agv.point == agv.home
    assert not agv.sent_home, "home: it bids again"
    _completes_on_another(fleet, task.id, agv_id)
    _run_until(fleet, lambda: agv.task is not None, 900.0, f"{agv_id} took no task again")


def test_send_home_is_refused_loaded_out_of_service_or_unknown() -> None:
    fleet = _fleet()
    _run_until(
        fleet,
        lambda: any(o.phase == "to_drop" for o in fleet.agvs.values()),
        600.0,
        "no vehicle carried a load",
    )
    loaded_id = next(a for a, o in sorted(fleet.agvs.items()) if o.phase == "to_drop")
    with pytest.raises(ValueError, match="is loaded"):
        fleet.send_home(loaded_id)
    assert not fleet.agvs[loaded_id].sent_home
    other = next(a for a in sorted(fleet.agvs) if a != loaded_id)
    fleet.set_service([other], in_service=False)
    with pytest.raises(ValueError, match="out of service"):
        fleet.send_home(other)
    with pytest.raises(KeyError, match="unknown vehicle 'agv-99'"):
        fleet.send_home("agv-99")


def test_a_fleet_stop_pauses_automatic_tasks_and_a_resume_resumes_them() -> None:
    fleet = _fleet()
    fleet.run(120.0)
    created = fleet.summary()["tasks_created"]
    assert created > 0
    fleet.stop_vehicles()
    assert not fleet.automatic_tasks
    fleet.run(300.0)
    assert fleet.summary()["tasks_created"] == created, "no automatic task while stopped"
    fleet.create_task(sorted(fleet.stations)[0])
    assert fleet.summary()["tasks_created"] == created + 1, "one asked for by name is taken"
    fleet.resume_vehicles()
    assert fleet.automatic_tasks
    fleet.run(120.0)
    assert fleet.summary()["tasks_created"] > created + 1
