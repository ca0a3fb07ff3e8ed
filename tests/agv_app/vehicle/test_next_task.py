"""An AGV that finishes a task while tasks wait takes the next one without going home."""

from __future__ import annotations

from collections.abc import Callable

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout.demo import demo_warehouse
from agv_app.vehicle.controller import DEFAULT_ADVANCE_M, AgvController


def one_agv(advance_m: float = DEFAULT_ADVANCE_M) -> tuple[Fleet, AgvController]:
    """One AGV resting at the N lane's parking spot N0800n, no tasks of its own, its
    requests ``advance_m`` long."""
    cfg = FleetConfig(
        agvs=1,
        seed=1,
        task_interval=1e9,
        start_tasks=0,
        advance_m=advance_m,
        fail_on_violation=True,
    )
    fleet = Fleet(demo_warehouse(), cfg, homes=["N0800n"])
    return fleet, fleet.agvs["agv-01"]


def run_until(
    fleet: Fleet, done: Callable[[], bool], limit_s: float = 600.0
) -> list[tuple[str, str]]:
    """Step until ``done()`` is true; the (phase, point) seen at each step."""
    agv = fleet.agvs["agv-01"]
    seen = []
    end = fleet.now + limit_s
    while not done():
        assert fleet.now < end, "timed out"
        fleet.step()
        seen.append((agv.phase, agv.point))
    return seen


def test_an_agv_dwelling_at_the_drop_station_bids_and_sets_off_for_the_next_pick() -> None:
    fleet, agv = one_agv()
    fleet.create_task("pick-A1-1", "drop-A5-3")
    run_until(fleet, lambda: agv.phase == "at_drop")
    assert agv.status == "idle"  # free for the next task while it dwells
    second = fleet.create_task("pick-A6-1", "drop-A6-3")
    seen = run_until(fleet, lambda: agv.task is not None and agv.task.id == second)
    assert [p for p, _ in seen if p not in ("at_drop",)] == ["to_pick"]
    assert fleet.desk.book.get(second).vehicle == "agv-01"  # type: ignore[union-attr]


def test_an_agv_awarded_a_task_on_its_way_home_turns_off_at_the_first_good_point() -> None:
    fleet, agv = one_agv()
    fleet.create_task("pick-A1-1", "drop-A5-3")
    run_until(fleet, lambda: agv.phase == "to_home")
    fleet.step()
    assert agv.phase == "to_home"
    assert agv.pending_task is None
    # Home is up A5, round the upper loop (E, P, W) and back along the N lane; the
    # pick station A6-1 is down the next aisle from the N lane.
    second = fleet.create_task("pick-A6-1", "drop-A6-3")
    seen = run_until(fleet, lambda: agv.phase == "at_pick")
    assert agv.task is not None
    assert agv.task.id == second
    assert all(point != "N0800n" for _, point in seen)  # never back home
    turned = [point for phase, point in seen if phase == "home"]
    assert turned, "it never stopped to turn off"
    assert turned[0].startswith("N")  # on the N lane, past aisle A5
    assert turned[0] != "N0800n"


def test_a_way_home_cut_short_for_a_task_is_a_route_to_the_turn_point() -> None:
    """The plan, the vehicle's path and the route all end at the turn point, so an AGV
    held up there may drive on from the route's points (``_drive_on`` read a route
    that had been dropped, and failed, on 50 AGVs at saturation)."""
    fleet, agv = one_agv()
    fleet.create_task("pick-A1-1", "drop-A5-3")
    run_until(fleet, lambda: agv.phase == "to_home")
    fleet.step()
    fleet.create_task("pick-A6-1", "drop-A6-3")
    run_until(fleet, lambda: agv.pending_task is not None)
    route, plan = agv._route, agv._plan
    assert route is not None
    assert plan is not None
    assert route.end == agv._dest != "N0800n"
    assert route.length + agv._route_shift == plan.length == agv.vehicle.route.length
