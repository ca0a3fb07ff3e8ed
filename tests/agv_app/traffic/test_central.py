"""The central baseline: one scheduler grants locks first come, first served."""

from __future__ import annotations

import functools
import json
from pathlib import Path
from typing import Any

import pytest
import shapely

from agv_app.fleet import Fleet, FleetConfig
from agv_app.geometry import Area
from agv_app.traffic import LockBook, LockEntry, RequestEntry
from agv_app.traffic.central import CentralScheduler
from objectplaces.cli import main
from tests.agv_app.two_way_floors import single_track, two_docks_one_lane
from tuplespace import ANY, TupleSpace


def box(x0: float, x1: float) -> Area:
    return Area(shapely.box(x0, -0.5, x1, 0.5))


class Books:
    """Lock books of a few AGVs, each in its own tuplespace, and what each was told."""

    def __init__(self, *agvs: str) -> None:
        self.spaces = {a: TupleSpace() for a in agvs}
        self.outcomes: dict[str, list[str]] = {a: [] for a in agvs}
        self.scheduler = CentralScheduler()
        for agv in agvs:
            self.scheduler.register(agv, functools.partial(self.book, agv))

    def book(self, agv: str) -> LockBook:
        return LockBook(self.spaces[agv])

    def stand(self, agv: str, area: Area) -> None:
        self.book(agv).set_locks(LockEntry(1, 0.0, area))

    def ask(self, agv: str, area: Area, since: float) -> RequestEntry:
        entry = RequestEntry(2, 5.0, area, (since, agv))
        self.book(agv).add_request(entry)
        request = self.scheduler.submit(agv, entry, self.outcomes[agv].append)
        request.check()
        return entry


def test_a_free_area_is_granted_at_once_and_becomes_a_lock() -> None:
    books = Books("a", "b")
    books.stand("a", box(0, 2))
    books.stand("b", box(20, 22))
    books.ask("a", box(2, 8), since=1.0)
    assert books.outcomes["a"] == ["locked"]
    assert books.book("a").request() is None
    assert books.book("a").lock_end() == 5.0


def test_an_area_under_another_lock_waits_and_tells_the_owner_it_is_in_the_way() -> None:
    books = Books("a", "b")
    books.stand("a", box(0, 2))
    books.stand("b", box(6, 8))
    books.ask("a", box(2, 10), since=1.0)
    assert books.outcomes["a"] == []
    assert books.spaces["b"].rdp(("in_the_way", "a")) is not None
    books.stand("b", box(30, 32))  # b drove off
    books.scheduler.grant_waiting()
    assert books.outcomes["a"] == ["locked"]


def test_of_two_requests_for_the_same_area_the_first_come_wins() -> None:
    books = Books("a", "b", "c")
    books.stand("a", box(0, 2))
    books.stand("b", box(20, 22))
    books.stand("c", box(9, 11))  # holds both requests up
    books.ask("b", box(4, 20), since=5.0)
    books.ask("a", box(2, 12), since=3.0)
    books.stand("c", box(40, 42))
    books.scheduler.grant_waiting()
    assert books.outcomes["a"] == ["locked"]  # waiting since 3.0, before b
    assert books.outcomes["b"] == []
    waiting = books.scheduler.pending("b")
    assert waiting is not None
    assert waiting.blocked_by == frozenset({"a"})


def test_a_withdrawn_request_leaves_the_book() -> None:
    books = Books("a", "b")
    books.stand("a", box(0, 2))
    books.stand("b", box(6, 8))
    books.ask("a", box(2, 10), since=1.0)
    waiting = books.scheduler.pending("a")
    assert waiting is not None
    waiting.withdraw()
    assert books.outcomes["a"] == ["withdrawn"]
    assert books.spaces["a"].rdp(("request", ANY, ANY, ANY, ANY)) is None


def test_central_fleet_swaps_the_two_docks_by_yielding() -> None:
    """The dead-end finding under the central scheduler: safe, and done by yielding."""
    cfg = FleetConfig(
        agvs=2, seed=1, task_interval=1e9, start_tasks=0, fail_on_violation=True, traffic="central"
    )
    fleet = Fleet(two_docks_one_lane(), cfg, homes=["pa", "pb"], starts=["da", "db"])
    fleet.create_task("dock-a", "dock-b")
    fleet.create_task("dock-b", "dock-a")
    fleet.run(240.0)
    figures = fleet.summary()
    assert figures["tasks_completed"] == 2
    assert figures["collisions"] == figures["lock_overlaps"] == figures["deadlocks"] == 0


def test_central_fleet_on_a_single_track_stays_safe_and_delivers() -> None:
    floor = single_track(4, 14.0, "p1n p1s p2n p2s")
    cfg = FleetConfig(
        agvs=4,
        seed=327,
        task_interval=60.0,
        start_tasks=4,
        task_until=200.0,
        fail_on_violation=True,
        traffic="central",
    )
    fleet = Fleet(floor.layout, cfg)
    fleet.run(400.0)
    figures = fleet.summary()
    assert figures["collisions"] == figures["lock_overlaps"] == 0
    assert figures["tasks_completed"] >= 4


def test_sim_command_runs_the_central_baseline(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    made: list[FleetConfig] = []
    real_init = Fleet.__init__

    def spy(self: Fleet, *args: Any, **kwargs: Any) -> None:
        real_init(self, *args, **kwargs)
        made.append(self.config)

    monkeypatch.setattr(Fleet, "__init__", spy)
    out = tmp_path / "central.json"
    args = ["sim", "--agvs", "3", "--minutes", "0.5", "--traffic", "central"]
    code = main([*args, "--quiet", "--json", str(out)])
    assert code == 0
    assert [c.traffic for c in made] == ["central"]
    assert json.loads(out.read_text())["lock_overlaps"] == 0
    with pytest.raises(SystemExit):
        main(["sim", "--traffic", "nobody", "--quiet"])
