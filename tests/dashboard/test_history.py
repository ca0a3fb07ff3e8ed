"""The metrics history: the ring, the wait-time bins, and ``GET /api/metrics/history``."""

from __future__ import annotations

import csv
import io
import math
import time

import pytest

from agv_app.fleet import Fleet, FleetConfig
from dashboard.app import create_app
from dashboard.history import (
    WAIT_EDGES_S,
    HistorySampler,
    MetricsHistory,
    order_waits,
    wait_histogram,
)
from tests.dashboard.conftest import NetworkSource, TestClient
from tests.dashboard.login import logged_in

URL = "/api/metrics/history"


def test_samples_are_kept_at_most_every_interval_and_the_ring_is_bounded() -> None:
    history = MetricsHistory(every_s=5.0, capacity=3)
    kept = [history.record(t, {"m": t}, {"data": int(t)}) for t in (0.0, 2.0, 5.0, 9.0, 10.0, 15.0)]
    assert kept == [True, False, True, False, True, True]
    assert [s.time for s in history.samples()] == [5.0, 10.0, 15.0]
    assert history.dropped == 1
    assert [s.time for s in history.samples(2)] == [10.0, 15.0]
    assert history.samples(0) == []


def test_non_finite_figures_are_left_out_and_a_clock_that_went_back_starts_afresh() -> None:
    history = MetricsHistory(every_s=1.0)
    history.record(10.0, {"ok": 1.0, "nan": math.nan, "inf": math.inf}, {})
    assert history.samples()[0].metrics == {"ok": 1.0}
    assert history.due(3.0), "an earlier time is a restarted fleet"
    assert history.record(3.0, {"ok": 2.0}, {})
    assert [s.time for s in history.samples()] == [3.0]
    assert history.dropped == 1


@pytest.mark.parametrize(("every_s", "capacity"), [(0.0, 10), (-1.0, 10), (math.nan, 10), (1.0, 1)])
def test_a_history_refuses_a_bad_interval_or_capacity(every_s: float, capacity: int) -> None:
    with pytest.raises(ValueError, match="must be"):
        MetricsHistory(every_s=every_s, capacity=capacity)


def test_csv_has_one_column_per_metric_and_kind_and_blanks_for_what_a_sample_lacks() -> None:
    history = MetricsHistory(every_s=1.0)
    history.record(0.0, {"b": 1.0}, {"data": 3})
    history.record(1.0, {"a": 0.5, "b": 2.0}, {"ack": 1, "data": 4})
    rows = list(csv.reader(io.StringIO(history.as_csv())))
    assert rows[0] == ["time", "a", "b", "sent:ack", "sent:data"]
    assert rows[1] == ["0.0", "", "1.0", "", "3"]
    assert rows[2] == ["1.0", "0.5", "2.0", "1", "4"]


def test_waits_fall_in_their_bins_and_the_last_bin_is_open() -> None:
    counts = wait_histogram([0.0, 1.9, 2.0, 59.0, 300.0, 1e6, -1.0, math.nan])
    assert len(counts) == len(WAIT_EDGES_S)
    assert counts[0] == 2  # 0.0 and 1.9
    assert counts[1] == 1  # 2.0
    assert counts[WAIT_EDGES_S.index(30.0)] == 1  # 59
    assert counts[-1] == 2  # 300 and 1e6
    assert sum(counts) == 6, "a negative or non-finite wait is left out"


def fleet_with_history() -> tuple[Fleet, TestClient, HistorySampler]:
    fleet = Fleet(config=FleetConfig(agvs=4, seed=3, task_until=0.0))
    app = create_app(fleet)
    # Not entered: no real-time driver or sampler; the test advances and samples itself.
    client = logged_in(app)
    return fleet, client, HistorySampler(app.state.dashboard, app.state.history)


def test_the_api_serves_samples_taken_as_the_fleet_runs_with_messages_by_kind() -> None:
    fleet, client, sampler = fleet_with_history()
    assert client.get(URL).json()["samples"] == []
    r = client.post("/api/tasks", json={"station": "pick-A1-1"})
    assert r.status_code == 201, r.text
    for _ in range(8):
        fleet.advance(5.0)
        assert sampler.sample()
    assert not sampler.sample(), "no time passed: nothing due"
    body = client.get(URL).json()
    assert body["every_s"] == 5.0
    samples = body["samples"]
    assert len(samples) == 8
    times = [s["time"] for s in samples]
    assert times == sorted(times)
    last = samples[-1]
    assert last["metrics"]["tasks_created"] == 1.0
    assert last["sent"], "frames sent by kind, over every node"
    assert all(isinstance(v, int) and v >= 0 for v in last["sent"].values())
    first_total, last_total = (sum(s["sent"].values()) for s in (samples[0], last))
    assert last_total > first_total
    waits = body["wait_times"]
    assert waits["edges_s"] == list(WAIT_EDGES_S)
    assert waits["orders"] == len(order_waits(fleet)) == 1, "the order went to a vehicle"
    assert sum(waits["counts"]) == 1
    assert len(client.get(URL, params={"limit": 3}).json()["samples"]) == 3


def test_csv_export_parses_and_matches_the_json() -> None:
    fleet, client, sampler = fleet_with_history()
    for _ in range(3):
        fleet.advance(5.0)
        sampler.sample()
    r = client.get(URL, params={"format": "csv"})
    assert r.status_code == 200
    assert r.headers["content-type"].startswith("text/csv")
    assert "attachment" in r.headers["content-disposition"]
    rows = list(csv.DictReader(io.StringIO(r.text)))
    samples = client.get(URL).json()["samples"]
    assert [float(row["time"]) for row in rows] == [s["time"] for s in samples]
    assert float(rows[-1]["agvs"]) == samples[-1]["metrics"]["agvs"] == 4.0
    kinds = [k for k in rows[0] if k.startswith("sent:")]
    assert kinds
    assert all(int(rows[-1][k]) >= 0 for k in kinds)


def test_json_download_is_a_file_that_parses() -> None:
    fleet, client, sampler = fleet_with_history()
    fleet.advance(5.0)
    sampler.sample()
    r = client.get(URL, params={"download": "true"})
    assert r.status_code == 200
    assert 'filename="metrics-history.json"' in r.headers["content-disposition"]
    assert len(r.json()["samples"]) == 1


@pytest.mark.parametrize(
    "params",
    [
        {"format": "xml"},
        {"format": ""},
        {"format": "JSON "},
        {"limit": "0"},
        {"limit": "-3"},
        {"limit": "10001"},
        {"limit": "ten"},
        {"limit": "1e3"},
        {"download": "maybe"},
    ],
)
def test_bad_input_is_refused_with_422(params: dict[str, str]) -> None:
    client = logged_in(create_app(NetworkSource()))
    r = client.get(URL, params=params)
    assert r.status_code == 422, r.text
    assert "detail" in r.json()


def test_a_fleet_without_a_task_book_has_no_waits_and_still_samples() -> None:
    source = NetworkSource()
    app = create_app(source)
    sampler = HistorySampler(app.state.dashboard, app.state.history)
    assert sampler.sample()
    body = logged_in(app).get(URL).json()
    assert body["wait_times"]["orders"] == 0
    assert len(body["samples"]) == 1


def test_the_running_app_samples_by_itself() -> None:
    source = NetworkSource()
    app = create_app(source)
    with logged_in(app) as client:
        for _ in range(100):
            if client.get(URL).json()["samples"]:
                break
            time.sleep(0.05)
        assert client.get(URL).json()["samples"], "the sampler runs with the app"
