"""Five real node processes on 127.0.0.1: sessions follow movement, crashes and restarts."""

from __future__ import annotations

import os
import time
from pathlib import Path

import pytest

from tests.credentials import write_secret
from tests.mesh.procs import Cluster, Event, NodeProcess

pytestmark = pytest.mark.processes

INTERVAL = 0.2
FAILURE_TIMEOUT = 1.5
TIMING = ["--property-interval", str(INTERVAL), "--failure-timeout", str(FAILURE_TIMEOUT)]


@pytest.fixture
def secret_file(tmp_path: Path) -> Path:
    return write_secret(tmp_path, os.urandom(32).hex().encode())


@pytest.fixture
def cluster(secret_file: Path):
    cluster = Cluster(secret_file, run_seconds=60.0)
    try:
        yield cluster
    finally:
        cluster.close()


def group_events(collector: NodeProcess) -> list[tuple[str, str]]:
    return [
        (e["event"], e["peer"])
        for e in collector.events
        if e.get("event") in ("in_group", "out_group")
    ]


def check_only_members_speak(events: list[Event]) -> dict[str, int]:
    """Replay the collector's events: every message came from a member at that moment."""
    members: set[str] = set()
    heard: dict[str, int] = {}
    for event in events:
        match event.get("event"):
            case "in_group":
                members.add(event["peer"])
            case "out_group":
                members.discard(event["peer"])
            case "receive":
                assert event["peer"] in members, f"message from non-member: {event}"
                heard[event["peer"]] = heard.get(event["peer"], 0) + 1
    return heard


def test_session_follows_moves_crash_and_restart(cluster: Cluster) -> None:
    collector = cluster.start(
        "n0", "--role", "collector", "--group", "within:5", "--property", "position=[0,0]", *TIMING
    )
    seed = collector.address
    echo = ["--role", "echo", "--tick", "0.05", "--join", seed, *TIMING]
    voters = {
        f"n{i}": cluster.start(f"n{i}", *echo, "--property", f"position=[{100 * i},100]")
        for i in range(1, 5)
    }
    for node in [collector, *voters.values()]:
        node.wait_peers(4)

    def member_speaks(peer: str, since: int) -> None:
        collector.wait_for(
            lambda e: e.get("event") == "receive" and e["peer"] == peer and "tick" in e["message"],
            since=since,
        )

    # Gain n1, then n2; both talk.
    voters["n1"].send(cmd="move", x=1, y=0)
    mark = len(collector.events)
    collector.wait_event("in_group", peer="n1")
    member_speaks("n1", mark)
    voters["n2"].send(cmd="move", x=0, y=2)
    collector.wait_event("in_group", peer="n2")
    member_speaks("n2", mark)

    # Lose n1 (it moves away), gain n3.
    voters["n1"].send(cmd="move", x=50, y=50)
    collector.wait_event("out_group", peer="n1")
    voters["n1"].wait_event("out_group_of", initiator="n0")
    voters["n3"].send(cmd="move", x=3, y=0)
    mark = len(collector.events)
    collector.wait_event("in_group", peer="n3")
    member_speaks("n3", mark)

    # SIGKILL n2 mid-session: it leaves the group within the failure timeout.
    killed_at = collector.events[-1]["t"]
    voters["n2"].kill()
    gone = collector.wait_event("out_group", peer="n2")
    # Heard at most one interval before the kill; liveness is checked every timeout/3.
    assert gone["t"] - killed_at <= FAILURE_TIMEOUT * 4 / 3 + INTERVAL + 1.0

    # Restart n2 in range: it rejoins the mesh and the session.
    mark = len(collector.events)
    restarted = cluster.start("n2", *echo, "--property", "position=[0,1]")
    collector.wait_event("in_group", peer="n2", since=mark)
    member_speaks("n2", mark)
    restarted.wait_peers(4)

    collector.send(cmd="stop")
    collector.wait_event("stopped")
    voters["n3"].wait_event("out_group_of", initiator="n0")
    for node in [collector, restarted, voters["n1"], voters["n3"], voters["n4"]]:
        assert node.quit() == 0

    assert group_events(collector) == [
        ("in_group", "n1"),
        ("in_group", "n2"),
        ("out_group", "n1"),
        ("in_group", "n3"),
        ("out_group", "n2"),
        ("in_group", "n2"),
    ]
    heard = check_only_members_speak(collector.events)
    assert set(heard) == {"n1", "n2", "n3"}
    assert not any(e.get("event") == "in_group_of" for e in voters["n4"].events)


def test_a_node_that_beats_stays_in_view_between_rare_republications(cluster: Cluster) -> None:
    # Republications every 30 s, a failure timeout of 1.5 s: only beats keep a node
    # heard in between. c does not beat, so the others count it failed.
    quiet = [
        "--property-interval",
        "30",
        "--failure-timeout",
        "1.5",
        "--property",
        "position=[0,0]",
    ]
    a = cluster.start("a", *quiet, "--beat-interval", "0.4")
    b = cluster.start("b", *quiet, "--beat-interval", "0.4", "--join", a.address)
    c = cluster.start("c", *quiet, "--join", a.address)
    for node in (a, b, c):
        node.wait_peers(2)
    b.wait_event("departed", peer="c", timeout=10.0)
    time.sleep(3.0)  # two failure timeouts more
    departed = {e["peer"] for e in b.events if e.get("event") == "departed"}
    assert departed == {"c"}
