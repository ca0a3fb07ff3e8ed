"""A certified AGV that lies cannot make the fleet unsafe or stall it.

Its certificate proves who it is, not what it says: positions that jump further than
any vehicle drives, hull lengths beyond any vehicle's, and votes never sent are refused
or outwaited (agv_app.traffic.plausibility), counted per peer, and the rest of the
fleet keeps its locks apart and gets its work done.
"""

from __future__ import annotations

from typing import Any, ClassVar

import pytest

from agv_app.fleet import Fleet, FleetConfig
from agv_app.layout.demo import demo_warehouse
from agv_app.traffic.lockbook import LockBook
from agv_app.traffic.plausibility import PeerWatch
from agv_app.vehicle.controller import AgvController
from objectplaces import Participant, RoleActivator
from tuplespace import TupleSpace

LIAR = "agv-03"


class _Mute(Participant):
    """A voter that never answers."""

    def receive(self, message: Any) -> None:
        pass


class _MuteAgv(AgvController):
    """One AGV of the fleet votes on nothing: it is activated and stays silent."""

    mute: ClassVar[frozenset[str]] = frozenset({LIAR})

    def attach(self, node: RoleActivator) -> None:
        super().attach(node)
        if node.node_id in self.mute:
            node.set_participant_factory("voter", _Mute)


def _fleet(vehicle: type[AgvController] = AgvController, seconds: float = 400.0) -> Fleet:
    config = FleetConfig(agvs=12, seed=3, load=0.7, fail_on_violation=True)
    fleet = Fleet(demo_warehouse(), config, vehicle=vehicle)
    fleet.run(seconds)
    return fleet


def _distrust(fleet: Fleet, what: str) -> int:
    return sum(agv.distrust.get(what, 0) for agv in fleet.agvs.values())


@pytest.mark.slow
def test_a_voter_that_never_answers_is_outwaited_and_the_fleet_works_on() -> None:
    honest = _fleet()
    muted = _fleet(_MuteAgv)  # fail_on_violation: any overlap or collision raises
    assert _distrust(honest, "silent_voters") == 0
    assert _distrust(muted, "silent_voters") > 0
    done, done_honest = muted.summary()["tasks_completed"], honest.summary()["tasks_completed"]
    assert done >= 0.5 * done_honest, (done, done_honest)
    assert muted.summary()["lock_overlaps"] == 0


def test_a_position_that_jumps_is_refused_by_every_agv_that_hears_it() -> None:
    fleet = _fleet(seconds=60.0)
    liar = fleet.nodes()[LIAR]
    true = liar.properties["position"]
    liar.update_node_property("position", (true[0] + 500.0, true[1] + 500.0))
    liar.update_node_property("hull_length", 200.0)
    fleet.run(5.0)
    heard = [agv for agv in fleet.agvs.values() if LIAR in agv.node.view()]
    assert heard, "someone hears the liar"
    for agv in heard:
        seen = agv.node.view()[LIAR]
        assert seen["position"] != (true[0] + 500.0, true[1] + 500.0)
        assert seen["hull_length"] != 200.0
        assert agv.node.stats().dropped_by_peer.get(LIAR, 0) >= 1
    assert _distrust(fleet, "refused_positions") >= len(heard)
    assert _distrust(fleet, "refused_hull_lengths") >= len(heard)


def test_peer_watch_believes_what_a_vehicle_can_drive() -> None:
    counted: list[str] = []
    watch = PeerWatch(
        LockBook(TupleSpace()),
        dict,
        top_speed_m_s=1.5,
        max_hull_length_m=30.0,
        count=counted.append,
    )
    assert watch.check("a", "position", (0.0, 0.0), 0.0)
    assert watch.check("a", "position", (10.0, 0.0), 1.0)  # within the slack
    assert not watch.check("a", "position", (100.0, 0.0), 2.0)  # 90 m in a second
    assert watch.check("a", "position", (100.0, 0.0), 60.0)  # 90 m in a minute: it drove
    assert watch.check("a", "hull_length", 30.0, 60.0)
    assert not watch.check("a", "hull_length", 500.0, 60.0)
    watch.forget("a")
    assert watch.check("a", "position", (-400.0, 0.0), 61.0)  # a new run starts anywhere
    assert counted == ["refused_positions", "refused_hull_lengths"]
