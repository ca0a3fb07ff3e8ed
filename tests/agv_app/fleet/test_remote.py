"""Nodes in other processes as the observer hears them: wire forms, stand-ins, failures."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import pytest
from shapely.geometry import box

from agv_app.fleet.remote import (
    MAX_SESSIONS,
    RemoteNode,
    roles_wire,
    sessions_wire,
    traffic_wire,
)
from agv_app.fleet.roster import FAILED, AgvRoster
from agv_app.geometry import Area, polygon_to_coords
from objectplaces import LocalProtocolError, NodeStats, ParticipationInfo, SessionInfo
from objectplaces.groups import circles_overlap

DEFINITION = circles_overlap().to_json()


def session(n: int, started: float) -> SessionInfo:
    return SessionInfo(
        f"agv-1#{n}", "agv-1", "Requester", "voter", frozenset({"agv-2", "agv-3"}),
        frozenset(), started, DEFINITION,
    )  # fmt: skip


def published(**extra: Any) -> dict[str, Any]:
    props: dict[str, Any] = {
        "kind": "agv",
        "position": (10.0, 9.0),
        "hull_length": 2.0,
        "state": "driving",
        "task": "t-1",
        "heading": 0.0,
        "size": [1.2, 0.8],
        "locked": None,
        "sessions": sessions_wire([session(1, 105.0), session(2, 106.5)]),
        "roles": roles_wire([ParticipationInfo("agv-2#4", "agv-2", "voter", 104.25)]),
        "traffic": traffic_wire(NodeStats({"data": (5, 500)}, {"ack": (3, 90)}, {"x": 1})),
    }
    props.update(extra)
    return props


def remote(props: Mapping[str, Any], offset: float = 100.0) -> RemoteNode:
    return RemoteNode("agv-1", lambda: props, clock_offset=offset)


def test_a_remote_node_reads_back_what_its_process_published_in_the_fleets_time() -> None:
    node = remote(published())
    assert node.node_id == "agv-1"
    assert [s.session_id for s in node.sessions()] == ["agv-1#1", "agv-1#2"]
    first = node.sessions()[0]
    assert first.initiator == "agv-1"
    assert first.initiator_role == "Requester"
    assert first.participant_role == "voter"
    assert first.members == {"agv-2", "agv-3"}
    assert first.started_at == pytest.approx(5.0)
    assert first.definition == DEFINITION
    assert node.participations() == [ParticipationInfo("agv-2#4", "agv-2", "voter", 4.25)]
    stats = node.stats()
    assert stats.sent == {"data": (5, 500)}
    assert stats.received == {"ack": (3, 90)}
    assert stats.messages_sent + stats.messages_received == 8
    assert "sessions" not in node.properties
    assert "traffic" not in node.properties
    assert node.properties["task"] == "t-1"
    assert node.view() == {}


def test_only_the_newest_sessions_travel() -> None:
    wire = sessions_wire([session(n, float(n)) for n in range(MAX_SESSIONS + 5)])
    assert len(wire) == MAX_SESSIONS
    assert wire[-1][0] == f"agv-1#{MAX_SESSIONS + 4}"


@pytest.mark.parametrize(
    "bad",
    [
        {"sessions": "nope", "roles": 3, "traffic": []},
        {"sessions": [[1, 2, 3]], "roles": [["a", "b"]], "traffic": {"sent": {"data": [1]}}},
        {
            "sessions": [[None, "r", "p", [], 1.0, None], ["s", "r", "p", "ab", "soon", None]],
            "roles": [["s", "i", "r", float("nan")]],
            "traffic": {"sent": {"data": [-1, 2], "x": [True, 1]}, "received": "lots"},
        },
    ],
)
def test_malformed_introspection_from_a_peer_is_left_out(bad: dict[str, Any]) -> None:
    node = remote(published(**bad))
    assert node.sessions() == []
    assert node.participations() == []
    assert node.stats().sent == {}
    assert node.stats().received == {}


def test_a_remote_node_refuses_to_act_and_ignores_role_registration() -> None:
    node = remote(published())
    node.set_participant_factory("poll-responder", None)
    with pytest.raises(LocalProtocolError, match="own process"):
        node.start_interaction(object(), circles_overlap(), "voter")  # type: ignore[arg-type]
    with pytest.raises(LocalProtocolError, match="own process"):
        node.stop_interaction("agv-1#1")
    with pytest.raises(LocalProtocolError, match="own process"):
        node.view_group(circles_overlap())


class Heard:
    """What a fake observer hears: AGV id -> properties."""

    def __init__(self) -> None:
        self.props: dict[str, dict[str, Any]] = {
            "agv-1": published(locked=polygon_to_coords(Area(box(9.0, 8.0, 11.0, 10.0)))),
            "agv-2": published(position=(20.0, 9.0), task=None, state="idle"),
        }

        self.looks = 0  # properties handed out, one per AGV each look
        self.views = 0  # looks at everyone

    def __call__(self) -> list[tuple[str, Mapping[str, Any]]]:
        self.views += 1
        self.looks += len(self.props)
        return sorted(self.props.items())

    def one(self, agv_id: str) -> Mapping[str, Any] | None:
        """One AGV as ``__call__`` gives it."""
        self.looks += 1
        return self.props.get(agv_id)


def roster_of(agv_ids: list[str], heard: Heard, offset: float = 0.0) -> AgvRoster:
    """A roster over the fake observer."""
    return AgvRoster(agv_ids, heard, heard.one, clock_offset=lambda: offset)


def test_an_exited_agv_stays_on_the_floor_as_failed_and_leaves_the_nodes() -> None:
    heard = Heard()
    roster = roster_of(["agv-1", "agv-2", "agv-3"], heard, 100.0)
    assert [v.id for v in roster.vehicles()] == ["agv-1", "agv-2"]
    assert sorted(roster.nodes()) == ["agv-1", "agv-2"]
    assert roster.vehicles()[0].locked
    roster.exited({"agv-1": -9, "agv-2": None})
    vehicles = {v.id: v for v in roster.vehicles()}
    assert vehicles["agv-1"].status == FAILED
    assert (vehicles["agv-1"].x, vehicles["agv-1"].y) == (10.0, 9.0)
    assert vehicles["agv-1"].locked == ()
    assert vehicles["agv-1"].task_id is None
    assert vehicles["agv-2"].status == "idle"
    assert sorted(roster.nodes()) == ["agv-2"]
    assert roster.failed() == ["agv-1"]
    del heard.props["agv-1"]  # the observer's failure timeout passes
    assert [v.id for v in roster.vehicles()] == ["agv-1", "agv-2"], "the wreck stays"
    assert roster.failed() == ["agv-1"]


def test_a_departed_agv_fails_and_is_alive_again_when_heard_again() -> None:
    heard = Heard()
    roster = roster_of(["agv-1", "agv-2"], heard)
    roster.vehicles()
    saved = heard.props.pop("agv-2")
    roster.departed("agv-2")
    roster.departed("someone-else")
    assert roster.failed() == ["agv-2"]
    assert {v.id: v.status for v in roster.vehicles()}["agv-2"] == FAILED
    heard.props["agv-2"] = saved
    assert roster.failed() == []
    assert {v.id: v.status for v in roster.vehicles()}["agv-2"] == "idle"
    assert sorted(roster.nodes()) == ["agv-1", "agv-2"]


def test_an_agv_that_exits_before_it_is_heard_counts_as_failed_without_a_wreck() -> None:
    heard = Heard()
    roster = roster_of(["agv-1", "agv-2", "agv-3"], heard)
    roster.exited({"agv-3": 1, "not-ours": -9})
    assert roster.failed() == ["agv-3"]
    assert [v.id for v in roster.vehicles()] == ["agv-1", "agv-2"]


def test_an_agv_whose_process_ended_its_run_has_left_and_did_not_fail() -> None:
    heard = Heard()
    roster = roster_of(["agv-1", "agv-2"], heard)
    roster.vehicles()
    roster.departed("agv-1")  # its node said goodbye before its exit status is seen
    del heard.props["agv-1"]
    assert roster.failed() == ["agv-1"]
    roster.exited({"agv-1": 0})
    assert roster.failed() == []
    assert roster.left() == ["agv-1"]
    assert [v.id for v in roster.vehicles()] == ["agv-2"]
    assert sorted(roster.nodes()) == ["agv-2"]


def test_reading_every_node_looks_at_each_agv_once_not_once_per_agv() -> None:
    heard = Heard()
    for k in range(3, 41):
        heard.props[f"agv-{k}"] = published(position=(float(k), 9.0), task=None, state="idle")
    roster = roster_of(sorted(heard.props), heard)
    nodes = roster.nodes()
    before = heard.looks
    for node in nodes.values():
        node.sessions()
        node.participations()
        node.stats()
    # Three reads of each of 40 nodes: 120 looks; through the whole view, 4,800.
    assert heard.looks - before == 3 * len(nodes) == 120
    assert nodes["agv-7"].properties["position"] == (7.0, 9.0)
