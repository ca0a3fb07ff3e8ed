"""The operator's log and the fleet watch that feeds it: pure, with ``now`` given; the
log on an order store outlives its process."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from agv_app.tasks.store import OrderStore
from dashboard.app import create_app
from dashboard.eventlog import EventLog
from dashboard.watch import WAITING_ALARM_S, FleetWatch
from tests.dashboard.conftest import NetworkSource
from tests.dashboard.login import logged_in

NODES = {"agv-1", "agv-2", "st:S1"}


def texts(log: EventLog) -> list[str]:
    return [e.text for e in log.events]


def watched() -> tuple[EventLog, FleetWatch]:
    log = EventLog()
    watch = FleetWatch(log)
    watch.observe(0.0, nodes=NODES, statuses={"agv-1": "idle", "agv-2": "idle"}, paused=False)
    return log, watch


def test_history_is_bounded_and_counts_what_it_dropped() -> None:
    log = EventLog(history=3)
    for i in range(5):
        log.record(float(i), "info", "fleet", f"event {i}")
    assert texts(log) == ["event 2", "event 3", "event 4"]
    assert [e.seq for e in log.events] == [2, 3, 4]
    assert log.dropped == 2


def test_history_must_hold_one_event() -> None:
    with pytest.raises(ValueError, match="history must be 1 or more, got 0"):
        EventLog(history=0)


@given(st.lists(st.sampled_from(["raise a", "raise b", "clear a", "clear b", "note"])))
def test_alarms_are_unique_per_key_and_memory_stays_bounded(actions: list[str]) -> None:
    log = EventLog(history=8)
    for t, action in enumerate(actions):
        verb, _, key = action.partition(" ")
        if verb == "raise":
            log.raise_alarm(key, float(t), key, f"{key} up")
        elif verb == "clear":
            log.clear_alarm(key, float(t), f"{key} down")
        else:
            log.record(float(t), "info", "fleet", "note")
    assert len(log.events) <= 8
    keys = [a.key for a in log.alarms]
    assert len(keys) == len(set(keys))
    assert set(keys) <= {"a", "b"}


def test_alarms_list_most_severe_first() -> None:
    log = EventLog()
    log.raise_alarm("waiting:agv-1", 1.0, "agv-1", "waits", severity="warning")
    log.raise_alarm("failed:agv-2", 2.0, "agv-2", "failed")
    assert [a.key for a in log.alarms] == ["failed:agv-2", "waiting:agv-1"]
    assert not log.raise_alarm("failed:agv-2", 3.0, "agv-2", "failed again")
    assert len(log.events) == 2


def test_nodes_joining_and_leaving_are_logged() -> None:
    log, watch = watched()
    watch.observe(1.0, nodes=NODES | {"agv-3"}, statuses={}, paused=False)
    watch.observe(2.0, nodes={"agv-3"}, statuses={}, paused=False)
    assert texts(log) == [
        "watching 3 nodes",
        "node agv-3 joined",
        "node agv-1 left",
        "node agv-2 left",
        "node st:S1 left",
    ]
    assert [e.severity for e in log.events][-3:] == ["warning"] * 3


def test_a_failed_vehicle_raises_an_alarm_until_it_recovers_or_leaves() -> None:
    log, watch = watched()
    watch.observe(1.0, nodes=NODES, statuses={"agv-1": "failed", "agv-2": "failed"}, paused=False)
    watch.observe(2.0, nodes=NODES, statuses={"agv-1": "failed", "agv-2": "failed"}, paused=False)
    assert [a.key for a in log.alarms] == ["failed:agv-1", "failed:agv-2"]
    watch.observe(3.0, nodes=NODES - {"agv-2"}, statuses={"agv-1": "idle"}, paused=False)
    assert log.alarms == []
    assert texts(log)[-3:] == [
        "node agv-2 left",
        "alarms of agv-2 cleared: it left",
        "agv-1 recovered (idle)",
    ]


def test_a_vehicle_waiting_too_long_raises_an_alarm_cleared_when_it_moves() -> None:
    log, watch = watched()
    for t in (10.0, 40.0, 10.0 + WAITING_ALARM_S - 0.5):
        watch.observe(t, nodes=NODES, statuses={"agv-1": "waiting"}, paused=False)
    assert log.alarms == []
    watch.observe(10.0 + WAITING_ALARM_S, nodes=NODES, statuses={"agv-1": "waiting"}, paused=False)
    (alarm,) = log.alarms
    assert alarm.key == "waiting:agv-1"
    assert alarm.event.text == "agv-1 waiting for over 60 s (since 10.0 s)"
    watch.observe(100.0, nodes=NODES, statuses={"agv-1": "driving"}, paused=False)
    assert log.alarms == []
    assert texts(log)[-1] == "agv-1 moves on after waiting 90 s"


def test_a_short_wait_leaves_no_trace() -> None:
    log, watch = watched()
    watch.observe(1.0, nodes=NODES, statuses={"agv-1": "waiting"}, paused=False)
    watch.observe(5.0, nodes=NODES, statuses={"agv-1": "driving"}, paused=False)
    assert texts(log) == ["watching 3 nodes"]


def test_pauses_are_logged_with_their_reason_once() -> None:
    log, watch = watched()
    watch.paused(1.0, True, "aisle blocked")
    watch.observe(2.0, nodes=NODES, statuses={}, paused=True)
    watch.observe(3.0, nodes=NODES, statuses={}, paused=False)
    assert texts(log)[1:] == ["fleet paused: aisle blocked", "fleet resumed by itself"]


def test_a_log_on_a_store_keeps_its_events_across_a_restart(tmp_path: Path) -> None:
    path = tmp_path / "orders.db"
    with OrderStore.open(path) as store:
        log = EventLog(history=3, store=store)
        for i in range(5):
            log.record(float(i), "info", "fleet", f"event {i}")
        log.raise_alarm("failed:agv-1", 5.0, "agv-1", "agv-1 failed")
    with OrderStore.open(path) as store:
        again = EventLog(history=3, store=store)
        assert texts(again) == ["event 3", "event 4", "agv-1 failed"]
        assert [e.seq for e in again.events] == [3, 4, 5]
        assert again.dropped == 3
        assert again.alarms == []  # conditions of the run that raised them
        assert again.record(6.0, "warning", "fleet", "resumed").seq == 6  # none reused
    with OrderStore.open(path) as store:
        assert [e.text for e in EventLog(store=store).events][-1] == "resumed"


def test_the_dashboard_serves_the_log_it_is_given(tmp_path: Path, source: NetworkSource) -> None:
    with OrderStore.open(tmp_path / "orders.db") as store:
        EventLog(store=store).record(1.0, "alarm", "agv-2", "agv-2 failed")
        client = logged_in(create_app(source, events=EventLog(store=store)))
        events = client.get("/api/events").json()["events"]
        assert [(e["severity"], e["text"]) for e in events] == [("alarm", "agv-2 failed")]


def test_a_vehicle_that_runs_empty_raises_an_alarm_once() -> None:
    log, watch = watched()
    statuses = {"agv-1": "empty", "agv-2": "idle"}
    watch.observe(5.0, nodes=NODES, statuses=statuses, paused=False)
    watch.observe(6.0, nodes=NODES, statuses=statuses, paused=False)
    assert [a.key for a in log.alarms] == ["empty:agv-1"]
    assert texts(log).count("agv-1 ran empty: stopped where it stands") == 1
