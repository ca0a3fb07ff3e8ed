"""The display feed: what an AGV process shows goes to the observer alone, over a session."""

from __future__ import annotations

from typing import Any

from agv_app.fleet.display_feed import (
    DISPLAY_ROLE,
    DisplayCollector,
    DisplayFeed,
    DisplayReporter,
    display_group,
)
from agv_app.protocol import AGV_KIND, OBSERVER_KIND
from objectplaces import RoleActivator
from objectplaces.sim import SimulatedNetwork


def _agv(net: SimulatedNetwork, node_id: str, x: float) -> tuple[RoleActivator, DisplayFeed]:
    node = net.add_node(node_id)
    node.update_node_property("kind", AGV_KIND)
    node.update_node_property("position", (x, 0.0))
    feed = DisplayFeed()
    node.set_participant_factory(DISPLAY_ROLE, feed.reporter)
    return node, feed


def _fleet() -> tuple[SimulatedNetwork, DisplayCollector, dict[str, DisplayFeed]]:
    net = SimulatedNetwork(seed=4, property_interval=1.0)
    feeds = {}
    for i, node_id in enumerate(("agv-1", "agv-2")):
        _, feeds[node_id] = _agv(net, node_id, 10.0 * i)
    observer = net.add_node("observer")
    observer.update_node_property("kind", OBSERVER_KIND)  # heard, so it lives for the AGVs
    collector = DisplayCollector()
    observer.start_interaction(collector, display_group(), DISPLAY_ROLE)
    return net, collector, feeds


def test_each_agv_shows_the_observer_what_changed() -> None:
    net, collector, feeds = _fleet()
    feeds["agv-1"].set("state", "idle")
    feeds["agv-1"].set("locked", [[[0, 0], [1, 0], [1, 1]]])
    net.run_for(1.0)
    feeds["agv-1"].flush()
    net.run_for(0.5)
    assert collector.reports["agv-1"] == {"state": "idle", "locked": [[[0, 0], [1, 0], [1, 1]]]}
    feeds["agv-1"].set("state", "driving")
    feeds["agv-1"].set("position", [3.5, 0.0])
    feeds["agv-1"].flush()
    net.run_for(0.5)
    assert collector.reports["agv-1"]["state"] == "driving"
    assert collector.reports["agv-1"]["position"] == (3.5, 0.0)  # as the view holds one
    assert "agv-2" not in collector.reports or collector.reports["agv-2"] == {}


def test_only_the_observer_hears_the_display() -> None:
    # Every change as a property was a frame to every node that hears the AGV.
    def run(show: bool) -> tuple[dict[str, Any], dict[str, Any]]:
        net, _, feeds = _fleet()
        net.run_for(1.0)
        for step in range(20):
            if show:
                feeds["agv-1"].set("position", [step * 0.5, 0.0])
                feeds["agv-1"].set("route", [[step, 0.0], [20.0, 0.0]])
                feeds["agv-1"].flush()
            net.run_for(0.5)
        per_node = net.stats().per_node
        return dict(per_node["agv-2"].received), dict(per_node["agv-1"].sent)

    (other, sent), (other_quiet, sent_quiet) = run(True), run(False)
    assert other == other_quiet  # the other AGV hears not a byte more
    frames = sent["channel"][0] - sent_quiet.get("channel", (0, 0))[0]
    assert frames == 20  # each flush one frame, to the observer alone


def test_a_reporter_that_joins_later_gets_the_whole_display() -> None:
    net, collector, feeds = _fleet()
    net.run_for(1.0)
    feeds["agv-2"].set("size", [2.0, 1.0])
    feeds["agv-2"].set("heading", 1.5)
    feeds["agv-2"].flush()
    net.run_for(0.5)
    node, late = _agv(net, "agv-3", 5.0)
    late.set("size", [2.0, 1.0])
    late.set("state", "waiting")
    net.run_for(2.0)  # heard, activated: the reporter owes all it holds
    assert collector.reports["agv-3"] == {"size": [2.0, 1.0], "state": "waiting"}
    assert collector.reports["agv-2"] == {"size": [2.0, 1.0], "heading": 1.5}
    net.remove_node("agv-3")
    net.run_for(5.0)  # it failed: it leaves the session, and its display goes
    assert "agv-3" not in collector.reports
    assert node.node_id == "agv-3"


class _Refusing(DisplayReporter):
    """A reporter whose channel refuses the first send (its buffer full)."""

    refused = False

    def send(self, message: Any) -> bool:
        if not self.refused:
            self.refused = True
            return False
        return super().send(message)


def test_a_refused_send_goes_with_the_next_flush_merged() -> None:
    net = SimulatedNetwork(seed=5, property_interval=1.0)
    node = net.add_node("agv-1")
    node.update_node_property("kind", AGV_KIND)
    feed = DisplayFeed()
    node.set_participant_factory(DISPLAY_ROLE, lambda: _Refusing(feed))
    collector = DisplayCollector()
    observer = net.add_node("observer")
    observer.update_node_property("kind", OBSERVER_KIND)
    observer.start_interaction(collector, display_group(), DISPLAY_ROLE)
    feed.set("state", "idle")
    net.run_for(1.0)  # joined: the whole display refused, kept
    assert collector.reports.get("agv-1", {}) == {}
    feed.set("state", "driving")
    feed.set("heading", 0.5)
    feed.flush()
    net.run_for(0.5)
    assert collector.reports["agv-1"] == {"state": "driving", "heading": 0.5}


def test_the_collector_keeps_only_what_a_display_may_carry() -> None:
    reports: list[tuple[str, dict[str, Any]]] = []
    collector = DisplayCollector(on_report=lambda node, r: reports.append((node, dict(r))))
    net = SimulatedNetwork(seed=6, property_interval=1.0)
    agv = net.add_node("agv-1")
    agv.update_node_property("kind", AGV_KIND)
    agv.update_node_property("position", (1.0, 2.0))
    sent: list[DisplayReporter] = []

    def reporter() -> DisplayReporter:
        sent.append(DisplayReporter(DisplayFeed()))
        return sent[-1]

    agv.set_participant_factory(DISPLAY_ROLE, reporter)
    observer = net.add_node("observer")
    observer.update_node_property("kind", OBSERVER_KIND)
    observer.start_interaction(collector, display_group(), DISPLAY_ROLE)
    net.run_for(1.0)
    [role] = sent
    for hostile in ([1, 2], "state", None, {"kind": "station", "position": [1], "state": 7}):
        role.send(hostile)
    role.send({"position": [4.0, 5.0], "state": "driving", 3: "x"})
    net.run_for(1.0)
    assert collector.refused == 3
    assert collector.reports["agv-1"] == {"position": (4.0, 5.0), "state": "driving"}
    # Merged over the properties; a malformed position fell back to the property.
    shown = collector.shown("agv-1", {"kind": AGV_KIND, "position": (1.0, 2.0)})
    assert shown == {"kind": AGV_KIND, "position": (4.0, 5.0), "state": "driving"}
    assert reports[0] == ("agv-1", {"position": None, "state": 7})
    assert collector.shown("agv-9", {"kind": AGV_KIND}) == {"kind": AGV_KIND}
