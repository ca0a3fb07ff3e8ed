"""The fleet driver, stepped by hand: no event loop, no sleeping, exact times."""

from __future__ import annotations

import logging
from collections.abc import Mapping

import pytest

from dashboard.driver import FleetDriver
from dashboard.poll import PollInitiator
from dashboard.state import ApiSession, DashboardState
from objectplaces import groups
from tests.dashboard.conftest import FailingSource, NetworkSource


class BrokenMetricsSource(NetworkSource):
    """A source whose metrics stop being numbers once ``broken`` is set."""

    broken = False

    def metrics(self) -> Mapping[str, float]:
        if self.broken:
            return {"broken": "not a number"}  # type: ignore[dict-item]
        return super().metrics()


def test_advances_by_wall_time_times_speed_capped_per_step() -> None:
    source = FailingSource(set())
    source.set_speed(10.0)
    driver = FleetDriver(DashboardState(source), max_step_s=0.1)
    for t in (100.0, 100.02, 100.04, 100.54):
        driver.step(t)
    # The first step only starts the clock; a stall of 0.5 s counts as 0.1 s.
    assert source.advanced == pytest.approx([0.2, 0.2, 1.0])


def test_a_paused_fleet_is_not_advanced() -> None:
    source = FailingSource(set())
    driver = FleetDriver(DashboardState(source))
    driver.step(1.0)
    source.pause()
    driver.step(1.02)
    source.resume()
    driver.step(1.04)
    assert source.advanced == pytest.approx([0.02])


def test_a_failing_advance_is_counted_and_the_fleet_keeps_going(
    caplog: pytest.LogCaptureFixture,
) -> None:
    source = FailingSource({2, 3, 4})
    driver = FleetDriver(DashboardState(source), report_every_s=10.0)
    now = source.now
    with caplog.at_level(logging.ERROR, logger="dashboard.driver"):
        for i in range(7):
            driver.step(i * 0.02)
    assert driver.advance_errors == 3
    assert not source.paused
    assert source.calls == 6
    assert source.now > now
    # The first failure with its traceback; the repeats within 10 s are only counted.
    assert len(caplog.records) == 1
    assert caplog.records[0].exc_info is not None


def test_repeated_failures_are_reported_at_most_every_interval(
    caplog: pytest.LogCaptureFixture,
) -> None:
    source = FailingSource(set(range(1, 1000)))
    driver = FleetDriver(DashboardState(source), report_every_s=1.0)
    with caplog.at_level(logging.ERROR, logger="dashboard.driver"):
        for i in range(251):  # five seconds of failures
            driver.step(i * 0.02)
    assert driver.advance_errors == 250
    assert len(caplog.records) == 5
    assert "failures since the last report" in caplog.records[-1].getMessage()


def test_housekeeping_forgets_http_sessions_that_ended_elsewhere() -> None:
    source = NetworkSource()
    state = DashboardState(source)
    node = source.nodes()["agv-1"]
    poll = PollInitiator("status")
    handle = node.start_interaction(poll, groups.within(10.0), "poll-responder")
    sid = str(handle.session_id)
    state.api.add(sid, ApiSession("agv-1", "poll", handle, poll, {"property": "status"}))
    driver = FleetDriver(state, housekeeping_s=0.25)
    driver.step(0.0)
    assert sid in state.api
    node.stop_interaction(handle)  # ended without the API
    assert sid in state.api, "nothing but the driver forgets it"
    assert sid not in state.sessions()
    driver.step(0.1)
    assert sid in state.api, "not before the next round of housekeeping"
    driver.step(0.3)
    assert sid not in state.api


def test_housekeeping_registers_the_poll_responder_on_new_nodes() -> None:
    source = NetworkSource()
    state = DashboardState(source)
    driver = FleetDriver(state)
    newcomer = source.net.add_node("agv-9")
    source.nodes()["agv-9"] = newcomer  # type: ignore[index]
    assert "poll-responder" not in newcomer.participant_roles
    driver.step(0.0)
    assert "poll-responder" in newcomer.participant_roles


def test_a_failing_capture_is_counted_and_the_fleet_keeps_going() -> None:
    source = BrokenMetricsSource()
    state = DashboardState(source)
    client = state.connect_feed()
    driver = FleetDriver(state)
    source.broken = True
    before = source.now
    driver.step(0.0)
    driver.step(0.06)
    assert driver.publish_errors == 2
    assert source.now > before
    assert client.feed.offered == 1  # only the state offered on connecting
