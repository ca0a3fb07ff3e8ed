"""Realistic load by default: the demo fleet is busy from its first seconds."""

from __future__ import annotations

import pytest

from agv_app.fleet import Fleet, FleetConfig, demo_source
from agv_app.tasks import DEFAULT_LOAD, initial_tasks


def test_the_default_load_is_realistic() -> None:
    assert DEFAULT_LOAD == 0.7
    assert FleetConfig().load == DEFAULT_LOAD
    assert initial_tasks(agvs=12, load=DEFAULT_LOAD) == 8


@pytest.mark.parametrize("seed", [1, 2])
def test_the_demo_shows_most_agvs_moving_within_ten_seconds(seed: int) -> None:
    fleet = demo_source(seed=seed)
    assert isinstance(fleet, Fleet)
    starts = {agv_id: agv.vehicle.pose() for agv_id, agv in fleet.agvs.items()}
    fleet.run(10.0)
    on_the_move = [
        agv_id
        for agv_id, agv in fleet.agvs.items()
        if agv.task is not None
        and agv.display_status() == "driving"
        and agv.vehicle.pose() != starts[agv_id]
    ]
    assert len(on_the_move) >= len(fleet.agvs) / 2, on_the_move
