"""Whole-fleet runs: seeded, in virtual time, with the safety monitor on every step."""

from __future__ import annotations

import dataclasses
import gc
import math
import os
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agv_app.fleet import Fleet, FleetConfig, demo_source
from agv_app.layout.demo import demo_warehouse
from agv_app.tasks import BASE_ID
from agv_app.traffic import SafetyViolation
from objectplaces.runtime.sim import GC_ALLOCATIONS

SEED = int(os.environ.get("OP_SEED", "1"))


@pytest.mark.slow
@pytest.mark.timeout(900)  # about 45 CPU seconds; generous for a loaded CI machine
def test_twenty_agvs_thirty_minutes_safe_and_every_task_done() -> None:
    print(f"OP_SEED={SEED}")
    cfg = FleetConfig(agvs=20, seed=SEED, task_interval=60.0, task_until=1200.0)
    fleet = Fleet(demo_warehouse(), cfg)
    fleet.run(1800.0)
    figures = fleet.summary()
    assert figures["collisions"] == 0
    assert figures["lock_overlaps"] == 0
    assert figures["deadlocks"] == 0
    assert figures["double_assignments"] == 0
    assert figures["tasks_created"] >= 15
    assert fleet.open_tasks == []
    assert figures["tasks_completed"] == figures["tasks_created"]


_LAYOUT = demo_warehouse()
_SPOTS = [s.point for s in _LAYOUT.stations_of_kind("parking")]


@settings(
    max_examples=8,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
@given(
    picks=st.lists(st.sampled_from(_SPOTS), min_size=8, max_size=8, unique=True),
    seed=st.integers(0, 1000),
    loss=st.sampled_from([0.0, 0.05]),
)
def test_random_starts_never_collide(picks: list[str], seed: int, loss: float) -> None:
    starts, homes = picks[:4], picks[4:]
    cfg = FleetConfig(agvs=4, seed=seed, loss=loss, fail_on_violation=True, task_interval=20.0)
    fleet = Fleet(_LAYOUT, cfg, homes=homes, starts=starts)
    fleet.run(150.0)
    assert fleet.monitor.collisions == fleet.monitor.lock_overlaps == 0


def test_demo_source_is_a_fleet_source_and_steps_in_fixed_increments() -> None:
    fleet = demo_source(agvs=3, seed=2, load=0.7)
    ids = set(fleet.nodes())
    assert {"agv-01", "agv-02", "agv-03", fleet.observer_id} <= ids
    assert BASE_ID in ids
    assert "position" in fleet.nodes()[BASE_ID].properties
    assert "position" not in fleet.nodes()[fleet.observer_id].properties
    fleet.advance(0.25)
    assert fleet.now == pytest.approx(0.2)
    fleet.advance(0.05)
    assert fleet.now == pytest.approx(0.3)
    task = fleet.create_task("dock-in-1")
    assert task in fleet.open_tasks
    with pytest.raises(KeyError):
        fleet.create_task("nowhere")
    with pytest.raises(ValueError, match="not a pick station"):
        fleet.create_task("park-S0350n")
    views = fleet.vehicles()
    assert [v.id for v in views] == ["agv-01", "agv-02", "agv-03"]
    assert len(views[0].hull) == 4
    assert views[0].locked
    assert fleet.metrics()["tasks_created"] == 3  # 2 at the start (load 0.7 of 3 AGVs), 1 here
    fleet.set_speed(4.0)
    assert fleet.speed == 4.0
    with pytest.raises(ValueError, match="positive"):
        fleet.set_speed(0)
    fleet.pause()
    assert fleet.paused
    fleet.resume()
    assert not fleet.paused
    assert fleet.initiator_roles() == {}


def test_the_dashboard_protocol_is_satisfied() -> None:
    from dashboard.source import FleetSource

    assert isinstance(demo_source(agvs=2, seed=1), FleetSource)


def test_a_run_spaces_the_collector_across_its_steps_and_restores_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    fleet = Fleet(config=FleetConfig(agvs=2, start_tasks=0))
    before = gc.get_threshold()
    seen: list[int] = []
    step = fleet.step

    def noting_step() -> list[SafetyViolation]:
        seen.append(gc.get_threshold()[0])  # also between the network's runs
        return step()

    monkeypatch.setattr(fleet, "step", noting_step)
    fleet.run(0.3)
    assert seen == [max(before[0], GC_ALLOCATIONS)] * 3
    assert gc.get_threshold() == before


@pytest.mark.parametrize("name", ["advance_m", "heartbeat", "republish", "interest_radius"])
@pytest.mark.parametrize("value", [0.0, -1.0, math.inf, math.nan])
def test_a_length_or_interval_that_is_not_a_positive_number_is_refused(
    name: str, value: float
) -> None:
    changes: dict[str, Any] = {name: value}
    with pytest.raises(ValueError, match=f"{name} must be a positive number"):
        dataclasses.replace(FleetConfig(), **changes)
