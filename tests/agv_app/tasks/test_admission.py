"""The limit that follows the floor: cut at long waits, raised while the floor delivers."""

from __future__ import annotations

import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.stalls import StallWatch
from agv_app.layout.demo import demo_warehouse
from agv_app.tasks.admission import CROWDED, AdaptiveLimit, carried_tasks, limit_for
from agv_app.tasks.desk import TaskDesk
from objectplaces.cli import main
from objectplaces.sim import SimulatedNetwork
from tests.agv_app.tasks.desks import demo_desk
from tests.agv_app.two_way_floors import two_docks_one_lane


def test_a_long_wait_cuts_to_three_quarters_of_the_tasks_on_the_floor() -> None:
    limit = AdaptiveLimit(20)
    limit.long_wait(on_floor=16, now=100.0)
    assert limit.limit == 12
    assert (limit.cuts, limit.lowest) == (1, 12)


def test_one_jam_is_one_cut() -> None:
    limit = AdaptiveLimit(20, hold_s=60.0)
    limit.long_wait(on_floor=20, now=100.0)
    limit.long_wait(on_floor=15, now=130.0)  # the same jam, seen by another AGV
    assert limit.limit == 15
    limit.long_wait(on_floor=15, now=160.5)
    assert limit.limit == 11
    assert limit.cuts == 2


def test_deliveries_raise_the_limit_only_while_it_holds_tasks_back() -> None:
    limit = AdaptiveLimit(10, hold_s=60.0)
    limit.delivered(held_back=False, now=5.0)
    assert limit.limit == 10
    limit.delivered(held_back=True, now=6.0)
    assert limit.limit == 11
    limit.long_wait(on_floor=11, now=10.0)
    assert limit.limit == 8
    limit.delivered(held_back=True, now=69.0)  # within the hold after the cut
    assert limit.limit == 8
    limit.delivered(held_back=True, now=70.0)
    assert limit.limit == 9


def test_the_limit_never_drops_below_its_floor() -> None:
    limit = AdaptiveLimit(3, floor=2, hold_s=0.0)
    for t in range(5):
        limit.long_wait(on_floor=1, now=float(t))
    assert limit.limit == 2


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"start": 0}, "at least 1"),
        ({"start": 5, "floor": 0}, "at least 1"),
        ({"start": 5, "hold_s": -1.0}, "hold_s"),
        ({"start": 5, "decrease": 1.0}, "decrease"),
        ({"start": 5, "decrease": 0.0}, "decrease"),
    ],
)
def test_bad_settings_are_refused(kwargs: dict[str, float], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        AdaptiveLimit(**kwargs)  # type: ignore[arg-type]


@settings(max_examples=100, deadline=None)
@given(
    start=st.integers(1, 60),
    events=st.lists(
        st.tuples(st.booleans(), st.integers(0, 80), st.floats(0.0, 30.0), st.booleans()),
        max_size=60,
    ),
)
def test_the_limit_stays_a_whole_number_at_or_above_its_floor(
    start: int, events: list[tuple[bool, int, float, bool]]
) -> None:
    limit = AdaptiveLimit(start, floor=2)
    now = 0.0
    for is_wait, on_floor, gap, held_back in events:
        now += gap
        before = limit.limit
        if is_wait:
            limit.long_wait(on_floor, now)
            assert limit.limit <= before
        else:
            limit.delivered(held_back=held_back, now=now)
            assert limit.limit - before in (0, 1)
        assert isinstance(limit.limit, int)
        assert limit.limit >= 2
        assert limit.lowest <= limit.limit


def test_the_stall_watch_tells_of_each_wait_once_as_it_passes_a_minute() -> None:
    told: list[tuple[str, float]] = []
    watch = StallWatch(on_long_wait=lambda agv, now: told.append((agv, now)))
    for t in range(0, 200, 10):
        watch.observe("agv-1", stalled=True, now=float(t))
    watch.observe("agv-1", stalled=False, now=200.0)
    watch.observe("agv-1", stalled=True, now=210.0)
    watch.observe("agv-1", stalled=True, now=280.0)
    assert told == [("agv-1", 70.0), ("agv-1", 280.0)]


def _auto_desk() -> tuple[TaskDesk, SimulatedNetwork]:
    return demo_desk(max_open="auto")


def test_an_automatic_desk_starts_at_what_the_lanes_carry_and_holds_the_rest() -> None:
    desk, _ = _auto_desk()
    carried = carried_tasks(desk.layout)
    assert carried is not None
    assert desk.limit == carried
    ids = [desk.create("dock-in-1") for _ in range(carried + 5)]
    assert desk.waiting == 5
    desk.long_wait(now=100.0)
    assert desk.limit == int(0.75 * carried)
    # Deliveries within the hold hand out no more than the cut limit lets through.
    for task_id in ids[:3]:
        desk.book.assign(task_id, "agv-1", now=101.0)
        assert desk.finish(task_id, now=101.0)
    assert desk.limit == int(0.75 * carried)
    assert desk.waiting == 5  # carried - 3 on the floor, still above the cut limit


def test_a_fixed_desk_ignores_long_waits() -> None:
    layout = demo_warehouse()
    desk = TaskDesk(layout, rng=random.Random(1), clock=lambda: 0.0, max_open=4)
    desk.long_wait(now=100.0)
    assert desk.limit == 4
    assert desk.admission is None


@pytest.mark.source_only("a limit of the wrong type")
@pytest.mark.parametrize("bad", ["often", 2.5, 0])
def test_a_desk_refuses_what_is_no_limit(bad: object) -> None:
    with pytest.raises(ValueError, match="'auto' or None"):
        TaskDesk(demo_warehouse(), rng=random.Random(1), clock=lambda: 0.0, max_open=bad)  # type: ignore[arg-type]


def test_the_cli_takes_auto_and_refuses_words(capsys: pytest.CaptureFixture[str]) -> None:
    args = ["sim", "--agvs", "2", "--minutes", "0.5", "--quiet", "--max-open-tasks"]
    assert main([*args, "auto"]) == 0
    assert "open_tasks_limit" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main([*args, "often"])
    assert "a whole number, 'auto', 'crowded' or 'none', got 'often'" in capsys.readouterr().err


def test_a_simulated_fleet_tells_its_desk_of_every_long_wait() -> None:
    fleet = Fleet(None, FleetConfig(agvs=4, seed=1, max_open_tasks="auto"))
    start = carried_tasks(fleet.layout)
    assert start is not None
    assert fleet.desk.limit == start
    fleet.stalls.observe("agv-1", stalled=True, now=0.0)
    fleet.stalls.observe("agv-1", stalled=True, now=61.0)
    assert fleet.desk.limit is not None
    assert fleet.desk.limit < start
    assert fleet.desk.admission is not None
    assert fleet.desk.admission.cuts == 1


def test_by_default_a_fleet_larger_than_its_floor_carries_has_the_automatic_limit() -> None:
    demo = demo_warehouse()
    carried = carried_tasks(demo)
    assert carried == 22
    assert limit_for(CROWDED, demo, carried) is None
    assert limit_for(CROWDED, demo, carried + 1) == "auto"
    for choice in (None, "auto", 5):
        assert limit_for(choice, demo, 50) == choice
    assert Fleet(None, FleetConfig(agvs=20, seed=1)).desk.admission is None
    assert Fleet(None, FleetConfig(agvs=50, seed=1)).desk.admission is not None
    # No lane to fill: every two-way run ends in a dead end.
    docks = two_docks_one_lane()
    assert carried_tasks(docks) is None
    assert limit_for(CROWDED, docks, 4) is None
