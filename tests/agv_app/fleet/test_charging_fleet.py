"""A fleet at load 0.7 for 2 simulated hours keeps every battery above 0, with the
chargers shared fairly: every AGV charges, no two at one charger at a time, nobody waits
long for one; no collision, no lock overlap. Virtual time."""

from __future__ import annotations

import itertools
import math

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout.demo import demo_warehouse
from agv_app.vehicle.battery import BatterySpec

pytestmark = pytest.mark.slow

AGVS = 5
HOURS = 2.0
# Drained fast enough that every AGV needs a charge within the two hours.
BATTERY = BatterySpec(
    drain_per_m=0.04,
    drain_per_load_s=0.05,
    drain_idle_per_s=0.002,
    charge_per_s=0.2,
    charge_below=30.0,
    charge_to=90.0,
)
MAX_CHARGER_WAIT_S = 600.0


def test_two_hours_at_load_0_7_keep_every_battery_above_0_with_chargers_shared_fairly() -> None:
    cfg = FleetConfig(agvs=AGVS, seed=5, load=0.7, batteries=BATTERY, fail_on_violation=True)
    fleet = Fleet(demo_warehouse(), cfg)
    chargers = fleet.chargers
    assert chargers is not None
    fleet.run(HOURS * 3600)
    summary = fleet.summary()
    stats = chargers.stats
    assert summary["collisions"] == summary["lock_overlaps"] == 0
    assert stats.ran_empty == 0
    assert not chargers.alarms
    assert stats.min_state_of_charge > 0.0
    assert all(b.state_of_charge(fleet.now) > 0.0 for b in chargers.batteries.values())
    # Every AGV charged, and none waited long for a charger.
    charged = {agv for _, agv, _, _ in stats.sessions}
    assert charged == set(fleet.agvs)
    assert stats.max_charger_wait <= MAX_CHARGER_WAIT_S
    # No two at one charger at a time.
    by_charger = sorted(stats.sessions)
    for point, sessions in itertools.groupby(by_charger, key=lambda s: s[0]):
        spans = sorted((start, end) for _, _, start, end in sessions)
        for (_, end), (start, _) in itertools.pairwise(spans):
            assert end <= start, f"two AGVs charged at {point} at once"
        assert all(end == math.inf or end > start for start, end in spans)
    assert summary["tasks_completed"] > 0
    assert summary["deadlocks"] == 0
