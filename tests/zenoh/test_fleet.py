"""``objectplaces demo --processes N --transport zenoh``: AGV processes on Zenoh take a
task and drive it, seen by the observer node, and leave cleanly."""

from __future__ import annotations

import asyncio
import json
import math

import pytest

from agv_app.fleet import OBSERVER_ID, MeshFleet
from agv_app.fleet.agv_process import StepLag, parse_args, process_liveness
from agv_app.fleet.liveness import REPUBLISH_BEATS, REST_BEAT_S
from agv_app.tasks import BASE_ID
from objectplaces.cli import build_parser
from tests.agv_app.fleet.ready import heard_by_all

pytestmark = pytest.mark.processes

AGVS = ["agv-01", "agv-02", "agv-03"]


def test_demo_takes_the_transport_flag() -> None:
    args = build_parser().parse_args(["demo", "--processes", "3", "--transport", "zenoh"])
    assert args.transport == "zenoh"


def test_an_unknown_zenoh_mode_is_refused() -> None:
    with pytest.raises(ValueError, match="zenoh_mode"):
        MeshFleet(agvs=1, transport="zenoh", zenoh_mode="router")


@pytest.mark.parametrize("mode", ["client", "peer"])
async def test_agv_processes_on_zenoh_take_a_task(mode: str) -> None:
    fleet = MeshFleet(
        agvs=3, seed=2, task_interval=None, run_seconds=80.0, transport="zenoh", zenoh_mode=mode
    )
    await fleet.start()
    try:
        await heard_by_all(fleet)
        assert set(fleet.nodes()) == {OBSERVER_ID, BASE_ID, *AGVS}
        assert fleet.observer is not None
        # A client has no address of its own: it reaches the fleet through the router.
        assert (fleet.observer.address == "") == (mode == "client")
        task = fleet.create_task("pick-A3-1")
        taken = None
        async with asyncio.timeout(30):
            while taken is None:
                fleet.advance(0.1)
                taken = next((v for v in fleet.vehicles() if v.task_id == task), None)
                await asyncio.sleep(0.1)
        start = (taken.x, taken.y)
        async with asyncio.timeout(20):
            while True:
                now = next(v for v in fleet.vehicles() if v.id == taken.id)
                if math.dist(start, (now.x, now.y)) > 1.0:
                    break
                await asyncio.sleep(0.1)
        fleet.check()
        metrics = fleet.metrics()
        assert metrics["collisions"] == 0
        assert metrics["messages"] > 0, "what the observer and the stations put and heard"
        assert metrics["bytes"] > 0
        assert metrics["lock_overlaps"] == 0
    finally:
        await fleet.stop()
    assert fleet.exit_codes() == dict.fromkeys(AGVS, 0), "each left the fleet gracefully"
    closed = [
        json.loads(line)
        for log in fleet.final_logs.values()
        for line in log.splitlines()
        if line.startswith('{"event": "closed"')
    ]
    assert len(closed) == len(AGVS)
    assert all(c["steps"] > 0 and c["late_steps"] <= c["steps"] for c in closed)


def test_step_lag_counts_the_late_steps() -> None:
    lag = StepLag()
    for seconds in (0.0, 0.05, 0.3, 0.01):
        lag.note(seconds, dt=0.1)
    assert lag.fields() == {"steps": 4, "late_steps": 1, "max_lag_s": 0.3}


def test_agv_processes_live_by_beats_and_rest_unless_told_otherwise() -> None:
    usual = process_liveness(1.0)
    assert (usual.beat_interval, usual.property_interval) == (1.0, REPUBLISH_BEATS * 1.0)
    assert usual.rest_beat_interval == REST_BEAT_S
    assert process_liveness(2.0, rest_beat=1.0).rest_beat_interval == 2.0  # never below
    assert process_liveness(1.0, rest_beat=None).rest_beat_interval is None
    plain = process_liveness(0.5, 0)  # no beats: every property each t-update, no rest
    assert (plain.beat_interval, plain.property_interval) == (None, 0.5)
    assert plain.rest_beat_interval is None
    assert plain.failure_timeout == 1.5


def test_the_rest_beat_of_an_agv_process_is_checked() -> None:
    base = ["--id", "a", "--secret-file", "s", "--home", "P"]
    assert parse_args(base).rest_beat == REST_BEAT_S
    assert parse_args([*base, "--rest-beat", "none"]).rest_beat is None
    assert parse_args([*base, "--rest-beat", "8"]).rest_beat == 8.0
    for bad in ("0", "-1", "inf", "nan", "soon"):
        with pytest.raises(SystemExit):
            parse_args([*base, "--rest-beat", bad])


def test_the_poll_interval_of_an_agv_process_is_bounded() -> None:
    base = ["--id", "a", "--secret-file", "s", "--home", "P"]
    assert parse_args([*base, "--poll-interval", "0"]).poll_interval == 0.0
    with pytest.raises(SystemExit):
        parse_args([*base, "--poll-interval", "2"])


def test_the_areas_of_a_display_are_worked_out_again_only_when_they_change() -> None:
    from shapely.geometry import box

    from agv_app.fleet.agv_display import _AreaCoords
    from agv_app.geometry import Area

    coords = _AreaCoords()
    lock = Area(box(0, 0, 1, 1))
    first = coords([lock])
    assert coords([lock]) is first  # the same area objects: the union is not redone
    moved = coords([Area(box(0, 0, 2, 1))])
    assert moved != first
    assert coords([]) == []


def test_a_larger_fleet_publishes_its_poses_less_often() -> None:
    from agv_app.fleet.mesh import POSES_PER_SECOND, pose_interval_for

    assert pose_interval_for(6) == pose_interval_for(20) == 0.2
    assert pose_interval_for(50) == pytest.approx(0.5)
    assert 50 / pose_interval_for(50) == pytest.approx(POSES_PER_SECOND)
    assert MeshFleet(agvs=50, transport="zenoh").publish_interval == pytest.approx(0.5)
    assert MeshFleet(agvs=50, publish_interval=0.3).publish_interval == 0.3


def test_an_agv_hears_everyone_when_its_radius_spans_the_floor() -> None:
    from agv_app.fleet.agv_process import dissemination_radius
    from agv_app.layout.demo import DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M, demo_warehouse
    from agv_app.layout.loop import long_loop
    from agv_app.vehicle.controller import AgvConfig
    from agv_app.vehicle.kinematics import VehicleSpec

    spec, config = VehicleSpec(DEMO_VEHICLE_LENGTH_M, DEMO_VEHICLE_WIDTH_M), AgvConfig()
    resting, awake = process_liveness(1.0), process_liveness(1.0, rest_beat=None)
    demo = demo_warehouse()  # 56 m by 37.5 m: the radius from "auto" spans it
    assert dissemination_radius("auto", demo, spec, config, resting) is None
    assert dissemination_radius(40.0, demo, spec, config, resting) == 40.0
    assert dissemination_radius("none", demo, spec, config, resting) is None
    wide = long_loop(300.0)
    radius = dissemination_radius("auto", wide, spec, config, resting)
    assert radius is not None
    assert radius < 300.0
    # A resting peer's crash is found later: the radius allows for the longer silence.
    shorter = dissemination_radius("auto", wide, spec, config, awake)
    assert shorter is not None
    assert shorter < radius


def test_a_parked_agv_process_shows_its_traffic_as_of_parking() -> None:
    # Its counters change with every frame it hears, its own reports included: it
    # would report them every interval for as long as it stands.
    from agv_app.fleet import Fleet, FleetConfig
    from agv_app.fleet.agv_process import DisplayPublisher
    from agv_app.fleet.remote import traffic_wire

    fleet = Fleet(config=FleetConfig(agvs=1, start_tasks=0, load=0.01))
    [agv] = fleet.agvs.values()
    display = DisplayPublisher(agv, traffic_interval_s=1.0)
    display.publish()  # not stepped yet, so not at rest: the counters go out
    first = display.feed.get("traffic")
    assert first is not None
    for _ in range(20):
        fleet.run(1.0)
        display.publish()
    assert agv.at_rest
    assert display.feed.get("traffic") == first
    assert traffic_wire(agv.node.stats()) != first  # the node went on counting
    fleet.create_task(next(iter(fleet.stations)))
    for _ in range(30):
        fleet.run(1.0)
        display.publish()
        if not agv.at_rest:
            break
    assert not agv.at_rest  # the only AGV took the task
    assert display.feed.get("traffic") == traffic_wire(agv.node.stats())
