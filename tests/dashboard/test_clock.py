"""``wall_seconds`` and ``sim_speed`` measured live by the driver (``dashboard.clock``)."""

from __future__ import annotations

import pytest

from dashboard.app import create_app
from dashboard.clock import RunClock
from tests.dashboard.conftest import NetworkSource
from tests.dashboard.login import logged_in


def test_a_clock_that_never_ran_reports_zero() -> None:
    assert RunClock().figures() == {"wall_seconds": 0.0, "sim_speed": 0.0}


def test_paused_time_does_not_count() -> None:
    clock = RunClock()
    clock.tick(0.0, 0.0, paused=False)
    clock.tick(1.0, 2.0, paused=False)
    clock.tick(5.0, 2.0, paused=True)
    clock.tick(1.0, 4.0, paused=False)
    assert clock.figures() == {"wall_seconds": 2.0, "sim_speed": 2.0}


def test_live_metrics_report_the_wall_time_and_the_speed_achieved(source: NetworkSource) -> None:
    app = create_app(source, tick_s=0.01)
    client = logged_in(app)
    source.set_speed(4.0)
    driver = app.state.driver
    for i in range(21):  # 20 steps of 0.05 s of wall time: 1 s
        driver.step(i * 0.05)
    metrics = client.get("/api/metrics").json()["metrics"]
    assert metrics["wall_seconds"] == pytest.approx(1.0)
    assert metrics["sim_speed"] == pytest.approx(4.0, rel=0.01)
    client.post("/api/sim/pause", json={})
    for i in range(21, 41):
        driver.step(i * 0.05)
    assert client.get("/api/metrics").json()["metrics"]["wall_seconds"] == pytest.approx(1.0)


def test_the_feed_shows_the_same_figures(source: NetworkSource) -> None:
    app = create_app(source)
    for i in range(11):
        app.state.driver.step(i * 0.1)
    captured = app.state.dashboard.capture()
    assert captured.metrics["wall_seconds"] == pytest.approx(1.0)
    assert captured.metrics["sim_speed"] == pytest.approx(1.0, rel=0.01)
