"""An AGV sets its next route while it still dwells, so it leaves as the dwell ends.

Its first request out of the station waits the safe time like every other; asked that
long before the dwell ends, it is granted as the dwell ends (docs/traffic.md,
"Throughput at load"). The task still counts as done when the dwell at the drop ends.
"""

from __future__ import annotations

from tests.agv_app.vehicle.test_next_task import one_agv, run_until


def test_an_agv_leaves_the_pick_station_as_its_dwell_ends() -> None:
    fleet, agv = one_agv()
    fleet.create_task("pick-A1-1", "drop-A5-3")
    run_until(fleet, lambda: agv.phase == "at_pick")
    dwell_end = agv._dwell_until
    run_until(fleet, lambda: fleet.now >= dwell_end + 0.3)
    assert agv.phase == "to_drop"
    assert agv.vehicle.speed > 0.0  # on its way right after the dwell


def test_the_vehicle_stands_until_the_dwell_ends_though_its_route_is_set() -> None:
    fleet, agv = one_agv()
    fleet.create_task("pick-A1-1", "drop-A5-3")
    run_until(fleet, lambda: agv.phase == "at_pick")
    dwell_end = agv._dwell_until
    run_until(fleet, lambda: agv.phase == "to_drop")
    assert fleet.now < dwell_end  # the route is set early ...
    start = agv.vehicle.s
    run_until(fleet, lambda: fleet.now >= dwell_end - 0.25)
    assert agv.vehicle.s == start  # ... but the vehicle has not moved
    assert agv.display_status() == "loading"


def test_a_task_counts_as_done_when_the_dwell_at_the_drop_ends() -> None:
    fleet, agv = one_agv()
    task = fleet.create_task("pick-A1-1", "drop-A5-3")
    run_until(fleet, lambda: agv.phase == "at_drop")
    dwell_end = agv._dwell_until
    run_until(fleet, lambda: agv.phase != "at_drop")
    assert fleet.now < dwell_end  # on its way home early ...
    assert agv.last_done is None  # ... but not done yet
    run_until(fleet, lambda: agv.last_done == task)
    assert fleet.now >= dwell_end
    assert agv.vehicle.speed == 0.0 or fleet.now - dwell_end < 0.2


def test_a_task_is_not_done_if_the_agv_crashes_before_the_dwell_at_the_drop_ends() -> None:
    fleet, agv = one_agv()
    fleet.create_task("pick-A1-1", "drop-A5-3")
    run_until(fleet, lambda: agv.phase == "at_drop")
    dwell_end = agv._dwell_until
    run_until(fleet, lambda: agv.phase != "at_drop")
    fleet.crash("agv-01")
    fleet.recover("agv-01")
    run_until(fleet, lambda: fleet.now >= dwell_end + 1.0)
    assert agv.last_done is None
