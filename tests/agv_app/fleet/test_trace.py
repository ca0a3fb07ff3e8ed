"""Vehicles' own traces, merged after a run: locks, hulls and floor driven outside locks."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, ClassVar

from agv_app.fleet import Fleet, FleetConfig
from agv_app.fleet.trace import VehicleTrace, check_traces
from agv_app.layout.demo import demo_warehouse
from agv_app.vehicle.controller import AgvController


class _Traced(AgvController):
    """An AGV that writes its trace on the simulation's clock."""

    folder: ClassVar[Path]
    trace: VehicleTrace | None = None

    def step(self, dt: float) -> None:
        super().step(dt)
        if self.trace is None:
            self.trace = VehicleTrace(
                self, self.folder / f"{self.node_id}.jsonl", clock=self.node.now
            )
        self.trace.step()


def test_the_traces_of_a_safe_fleet_show_no_violation(tmp_path: Path) -> None:
    _Traced.folder = tmp_path
    fleet = Fleet(
        demo_warehouse(),
        FleetConfig(agvs=10, seed=2, load=0.9, fail_on_violation=True),
        vehicle=_Traced,
    )
    fleet.run(240.0)
    for agv in fleet.agvs.values():
        assert isinstance(agv, _Traced)
        assert agv.trace is not None
        agv.trace.close()
    report = check_traces(tmp_path.glob("*.jsonl"))
    assert report.vehicles == 10
    assert report.safe, report.details
    assert fleet.summary()["tasks_completed"] > 0


def _write(path: Path, records: list[dict[str, Any]]) -> None:
    path.write_text("".join(json.dumps(r) + "\n" for r in records))


def test_overlapping_locks_meeting_hulls_and_floor_outside_locks_are_found(tmp_path: Path) -> None:
    box = "POLYGON ((0 0, 4 0, 4 2, 0 2, 0 0))"
    other = "POLYGON ((3 0, 7 0, 7 2, 3 2, 3 0))"  # overlaps box by 2 m2
    _write(
        tmp_path / "a.jsonl",
        [
            {"t": 0.0, "k": "size", "m": [2.0, 1.0]},
            {"t": 0.0, "k": "locks", "w": box},
            {"t": 0.0, "k": "pose", "p": [1.0, 1.0, 0.0]},
            {"t": 2.0, "k": "pose", "p": [3.0, 1.0, 0.0]},
            {"t": 2.0, "k": "outside", "m": 0.5},
        ],
    )
    _write(
        tmp_path / "b.jsonl",
        [
            {"t": 0.0, "k": "size", "m": [2.0, 1.0]},
            {"t": 1.0, "k": "locks", "w": other},
            {"t": 0.0, "k": "pose", "p": [6.0, 1.0, 0.0]},
            {"t": 2.0, "k": "pose", "p": [4.0, 1.0, 0.0]},
            {"t": 3.0, "k": "locks", "w": "POLYGON EMPTY"},
        ],
    )
    report = check_traces(tmp_path.glob("*.jsonl"))
    assert report.lock_overlaps == 1
    assert report.collisions == 1
    assert report.outside_m == {"a": 0.5, "b": 0.0}
    assert not report.safe
    assert any("locks of a and b overlap" in line for line in report.details)
