"""MeshFleet: every AGV its own process on the WebSocket mesh, seen by an observer node.

Real processes on 127.0.0.1; every wait is bounded, and every child must be reaped.
"""

from __future__ import annotations

import asyncio
import math
import stat
import time
from pathlib import Path

import pytest

from agv_app.fleet import OBSERVER_ID, MeshFleet
from agv_app.tasks import BASE_ID
from dashboard.app import create_app
from tests.agv_app.fleet.ready import heard_by_all
from tests.dashboard.login import logged_in

pytestmark = pytest.mark.processes

AGVS = ["agv-01", "agv-02", "agv-03"]
PICK = "pick-A3-1"


def _alive(pid: int) -> bool:
    return Path(f"/proc/{pid}").exists()


def _cmdline(pid: int) -> bytes:
    return Path(f"/proc/{pid}/cmdline").read_bytes()


def _pki_dir(pid: int) -> Path:
    args = _cmdline(pid).split(b"\0")
    return Path(args[args.index(b"--pki") + 1].decode())


async def test_agv_processes_take_a_task_and_are_reaped() -> None:
    fleet = MeshFleet(agvs=3, seed=2, task_interval=None, run_seconds=80.0)
    await fleet.start()
    pids = fleet.pids()
    try:
        assert len(pids) == 3
        # Every link is mutual TLS: the run's throwaway CA issued each AGV its key,
        # which only its owner can read and which no command line holds.
        pki = _pki_dir(pids[0])
        key = pki / "agv-01.key"
        assert stat.S_IMODE(key.stat().st_mode) == 0o600
        assert key.read_bytes() not in _cmdline(pids[0])
        assert not (pki / "private").stat().st_mode & 0o077
        await heard_by_all(fleet)
        vehicles = {v.id: v for v in fleet.vehicles()}
        assert sorted(vehicles) == AGVS
        for v in vehicles.values():
            assert math.isfinite(v.x)
            assert math.isfinite(v.y)
            assert len(v.hull) == 4
            assert v.hull_length > 0
            assert v.status == "idle"
            assert v.task_id is None
            assert v.locked, f"{v.id} holds its own hull from the start"
        assert set(fleet.nodes()) == {OBSERVER_ID, BASE_ID, *AGVS}

        task = fleet.create_task(PICK)
        taken = None
        async with asyncio.timeout(30):
            while taken is None:
                fleet.advance(0.1)
                taken = next(
                    (v for v in fleet.vehicles() if v.task_id == task and v.status != "idle"),
                    None,
                )
                await asyncio.sleep(0.1)
        assert fleet.assignment(task) == taken.id
        start = (taken.x, taken.y)
        async with asyncio.timeout(20):
            while True:
                now = next(v for v in fleet.vehicles() if v.id == taken.id)
                if math.dist(start, (now.x, now.y)) > 1.0:
                    break
                await asyncio.sleep(0.1)
        record = fleet.desk.book.get(task)
        assert record is not None
        assert record.vehicle == taken.id
        assert record.state in ("driving", "done"), "seen setting off through the observer"
        fleet.check()
        metrics = fleet.metrics()
        assert metrics["tasks_created"] == 1
        assert metrics["agvs_seen"] == 3
        assert metrics["messages"] > 0
        assert metrics["bytes"] > 0
        assert metrics["collisions"] == 0
        assert metrics["lock_overlaps"] == 0
        assert metrics["deadlocks"] == 0
        assert metrics["stalls_60s"] == 0
        assert 0.0 <= metrics["max_wait"] < 60.0
        assert metrics["free_flow_tasks_per_hour"] >= 0.0
    finally:
        await fleet.stop()
    assert not any(_alive(pid) for pid in pids)
    assert fleet.exit_codes() == dict.fromkeys(AGVS, 0), "each left the mesh gracefully"
    assert not pki.exists(), "the throwaway CA is removed with the run"


async def test_speed_is_real_time_and_pause_stops_the_fleet() -> None:
    fleet = MeshFleet(agvs=1, seed=1)
    with pytest.raises(ValueError, match=r"speed is always 1\.0"):
        fleet.set_speed(2.0)
    fleet.set_speed(1.0)
    fleet.pause()
    assert fleet.paused
    assert fleet.fleet_stopped, "the vehicles hold (tests/agv_app/fleet/test_mesh_holding.py)"
    fleet.resume()
    assert not fleet.paused
    assert not fleet.fleet_stopped
    with pytest.raises(ValueError, match="not running"):
        fleet.create_task(PICK)
    with pytest.raises(KeyError):
        fleet.create_task("no-such-station")
    await fleet.stop()
    assert fleet.pids() == []


def test_dashboard_shows_the_agv_processes() -> None:
    fleet = MeshFleet(agvs=3, seed=5, task_interval=None, run_seconds=80.0)
    with logged_in(create_app(fleet)) as client:
        assert fleet.started  # the app's lifespan ran the optional start hook
        pids = fleet.pids()
        assert len(pids) == 3
        deadline = time.monotonic() + 40
        locks: list[dict[str, object]] = []
        while time.monotonic() < deadline:
            locks = client.get("/api/locks").json()
            # An AGV is heard (its properties) a moment before its display, which
            # carries its locks, reaches the observer.
            if len(locks) == 3 and all(lock["locked"] for lock in locks):
                break
            time.sleep(0.2)
        assert [lock["vehicle"] for lock in locks] == AGVS, fleet.child_logs()
        assert all(lock["locked"] for lock in locks)

        nodes = client.get("/api/nodes").json()
        assert OBSERVER_ID in [n["id"] for n in nodes]
        observer = client.get(f"/api/nodes/{OBSERVER_ID}").json()
        assert set(AGVS) <= set(observer["view"])
        assert observer["view"]["agv-01"]["kind"] == "agv"

        metrics = client.get("/api/metrics").json()
        assert metrics["metrics"]["collisions"] == 0
        reply = client.post("/api/sim/speed", json={"factor": 2.0})
        assert reply.status_code in (400, 409, 422), reply.text
        assert "1.0" in reply.text
    assert not any(_alive(pid) for pid in pids)
    assert not any(code is None for code in fleet.exit_codes().values())


def test_the_task_desk_of_a_mesh_fleet_takes_the_limit() -> None:
    assert MeshFleet(agvs=2, seed=1, max_open_tasks=4).desk.max_open == 4
    assert MeshFleet(agvs=2, seed=1).desk.max_open is None
    # By default, as the simulated fleet: the automatic limit once the fleet is larger
    # than the floor carries (22 tasks on the demo warehouse), none below.
    assert MeshFleet(agvs=22, seed=1).desk.admission is None
    assert MeshFleet(agvs=40, seed=1).desk.admission is not None
    assert MeshFleet(agvs=40, seed=1, max_open_tasks=None).desk.admission is None
    automatic = MeshFleet(agvs=2, seed=1, max_open_tasks="auto")
    assert automatic.desk.admission is not None
    # The fleet's stall watch tells the desk of a wait over a minute.
    automatic.stalls.observe("agv-1", stalled=True, now=0.0)
    automatic.stalls.observe("agv-1", stalled=True, now=61.0)
    assert automatic.desk.admission.cuts == 1
    with pytest.raises(ValueError, match="max_open must be a whole number >= 1"):
        MeshFleet(agvs=2, seed=1, max_open_tasks=0)


def test_a_mesh_fleet_checks_its_rest_beat() -> None:
    for bad in (0.0, -1.0, math.inf, math.nan):
        with pytest.raises(ValueError, match="rest_beat must be a positive number"):
            MeshFleet(agvs=2, seed=1, rest_beat=bad)


async def _frames_from_parked_agvs(fleet: MeshFleet, seconds: float) -> dict[str, int]:
    """Frames the observer received from each AGV over ``seconds``, once the fleet is
    ready and its AGVs have stood parked long enough to be at rest."""
    await fleet.start()
    async with asyncio.timeout(40):
        await fleet.wait_ready()
    observer = fleet.observer
    assert observer is not None
    await asyncio.sleep(5.0)  # the beats that announce a rest come at the usual interval
    before = {a: observer.peer_stats()[a].messages_in for a in fleet.agv_ids}
    await asyncio.sleep(seconds)
    return {a: observer.peer_stats()[a].messages_in - before[a] for a in fleet.agv_ids}


async def test_parked_agv_processes_beat_at_rest_and_stay_in_the_fleet() -> None:
    # Two fleets side by side, the same but for rest; 12 s is four failure timeouts of
    # the usual beat, so a node that granted no rest would have dropped the AGVs.
    resting = MeshFleet(agvs=2, seed=7, task_interval=None, run_seconds=80.0)
    awake = MeshFleet(agvs=2, seed=7, task_interval=None, run_seconds=80.0, rest_beat=None)
    try:
        rest_frames, awake_frames = await asyncio.gather(
            _frames_from_parked_agvs(resting, 12.0), _frames_from_parked_agvs(awake, 12.0)
        )
        # Both hear the mesh's gossip alike; beats: about 12 awake, 2 or 3 at rest
        # (plus the three after a republication, every 60 s).
        for agv in resting.agv_ids:
            assert rest_frames[agv] <= awake_frames[agv] - 6, (rest_frames, awake_frames)
        assert resting.seen.roster.failed() == []
        assert resting.missing() == []
        for sid, station in resting.desk.stations.items():
            assert set(resting.agv_ids) <= set(station.node.view()), sid
        resting.check()
    finally:
        await asyncio.gather(resting.stop(), awake.stop())
