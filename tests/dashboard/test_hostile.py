"""Hostile REST input: every bad request is a 4xx that says why, leaves nothing behind
and never stops the fleet; the fleet pauses only when asked.

Each test here goes through HTTP only (and the feed's own mailbox for the dead-sender
case), so it runs unchanged against any version of the app.
"""

from __future__ import annotations

import asyncio
import json
import re
import time
from pathlib import Path
from typing import Any
from urllib.parse import quote

import httpx
import pytest
from websockets.asyncio.client import ClientConnection, connect
from websockets.exceptions import ConnectionClosed

from agv_app.fleet import demo_source
from dashboard.app import create_app
from dashboard.feed import ClientFeed
from tests.dashboard.bodies import nested_definition, poll_body
from tests.dashboard.conftest import FailingSource, NetworkSource, TestClient
from tests.dashboard.login import logged_in
from tests.dashboard.served import Served

DOCS = Path(__file__).resolve().parents[2] / "docs" / "rest-api.md"
HUGE = 1.797e308


def poll(definition: Any, **overrides: Any) -> dict[str, Any]:
    # ``overrides`` may replace the node itself, so they apply after the body is built.
    return {**poll_body("agv-1", definition), **overrides}


def post_json(client: TestClient, url: str, text: str) -> httpx.Response:
    response = client.post(url, content=text, headers={"content-type": "application/json"})
    assert isinstance(response, httpx.Response)
    return response


def poll_text(definition: str) -> str:
    """``poll`` as JSON text, around a definition given as JSON text."""
    return json.dumps(poll(None)).replace('"definition": null', f'"definition": {definition}')


def sim_now(client: TestClient) -> float:
    return float(client.get("/api/metrics").json()["sim"]["now"])


def wait_for_time(client: TestClient, past: float) -> None:
    """Wait (bounded) until the running app's fleet is past simulated time ``past``."""
    deadline = time.monotonic() + 10
    while sim_now(client) <= past:
        assert time.monotonic() < deadline, f"simulated time stuck at or before {past}"
        time.sleep(0.02)  # polling a running server, not asserting a duration


@pytest.fixture
def running(source: NetworkSource) -> Any:
    """The app with its driver running: the fleet advances in real time."""
    with logged_in(create_app(source, tick_s=0.01), raise_server_exceptions=False) as client:
        yield client


def assert_still_running(client: TestClient) -> None:
    before = sim_now(client)
    wait_for_time(client, before + 0.1)
    assert client.get("/api/metrics").json()["sim"]["paused"] is False


def test_a_huge_within_distance_is_refused_and_leaves_nothing(running: TestClient) -> None:
    r = running.post("/api/sessions", json=poll({"type": "within", "distance": HUGE}))
    assert r.status_code == 422
    assert "distance" in r.json()["detail"]
    assert running.get("/api/sessions").json() == []
    assert_still_running(running)
    assert running.post("/api/sessions", json=poll({"type": "within", "distance": 10})).is_success


@pytest.mark.parametrize("distance", [10**400, True, "2", 0, -3.0, float("nan")], ids=repr)
def test_distances_that_are_no_sane_number_are_refused(client: TestClient, distance: Any) -> None:
    r = post_json(
        client, "/api/sessions", json.dumps(poll({"type": "within", "distance": distance}))
    )
    assert r.status_code == 422, r.text
    assert "distance" in r.json()["detail"]
    assert client.get("/api/sessions").json() == []


@pytest.mark.parametrize("levels", [33, 200, 480, 5000])
def test_deeply_nested_definitions_are_refused(running: TestClient, levels: int) -> None:
    r = post_json(running, "/api/sessions", poll_text(nested_definition(levels)))
    assert r.status_code in (413, 422), r.text
    assert re.search("at most|over", r.json()["detail"])
    assert running.get("/api/sessions").status_code == 200
    assert running.get("/api/sessions").json() == []
    assert running.get("/api/nodes/agv-1").status_code == 200
    assert_still_running(running)


def test_thirty_two_levels_are_accepted(client: TestClient) -> None:
    r = post_json(client, "/api/sessions", poll_text(nested_definition(32)))
    assert r.status_code == 201, r.text
    assert client.get("/api/nodes/agv-1").status_code == 200


@pytest.mark.parametrize(
    "definition",
    [
        "[" * 3000,
        nested_definition(200),
        json.dumps({"type": "within", "distance": HUGE}),
        '{"type": "within", "distance": 1e999}',
        json.dumps({"type": "within", "distance": True}),
        '{"type": "within", "distance": 1' + "0" * 5000 + "}",
        "x" * 60_000,
    ],
    ids=["brackets", "nested", "huge", "inf", "bool", "long-int", "60kB"],
)
def test_bad_group_views_are_4xx(client: TestClient, definition: str) -> None:
    r = client.get("/api/groups/view", params={"node": "agv-1", "definition": definition})
    assert 400 <= r.status_code < 500, r.text[:300]
    assert len(r.json()["detail"]) < 500


@pytest.mark.parametrize("factor", [True, "2", 1e-300, 0, 101, None, [2]], ids=repr)
def test_speeds_that_are_no_sane_number_are_refused(client: TestClient, factor: Any) -> None:
    r = client.post("/api/sim/speed", json={"factor": factor})
    assert r.status_code == 422, r.text
    assert "factor" in r.json()["detail"]
    assert client.get("/api/metrics").json()["sim"]["speed"] == 1.0


@pytest.mark.parametrize(
    "body",
    [
        {"node": True},
        {"node": "x" * 1_000_000},
        {"role": ["poll"]},
        {"participant_role": 7},
        {"params": {"property": "status", **{f"k{i}": i for i in range(100)}}},
        {"params": [1, 2]},
        {"definition": {"type": "property_equals", "name": "status", "value": {"a": 1}}},
    ],
    ids=["bool-node", "1MB-node", "list-role", "int-role", "many-params", "list-params", "obj"],
)
def test_wrong_types_and_sizes_in_a_session_are_4xx(
    client: TestClient, body: dict[str, Any]
) -> None:
    definition = body.pop("definition", {"type": "within", "distance": 10})
    r = client.post("/api/sessions", json=poll(definition, **body))
    assert 400 <= r.status_code < 500, r.text[:300]
    assert len(r.json()["detail"]) < 1000
    assert client.get("/api/sessions").json() == []


def test_a_failing_advance_does_not_pause_the_fleet() -> None:
    source = FailingSource({3})
    with logged_in(create_app(source, tick_s=0.01)) as client:
        wait_for_time(client, source.net.now + 0.3)
        body = client.get("/api/metrics").json()
    assert source.calls > 3
    assert body["sim"]["paused"] is False
    assert body["advance_errors"] == 1


def test_the_documented_curl_example_works_on_the_demo_fleet() -> None:
    text = DOCS.read_text()
    example = re.search(
        r"curl -X POST localhost:8000/api/sessions .*? -d \\\n\s+'(.*?)'", text, re.S
    )
    assert example is not None, "docs/rest-api.md lost its curl example"
    body = json.loads(example.group(1))
    fleet = demo_source(agvs=12, seed=1)
    client = logged_in(create_app(fleet))
    r = client.post("/api/sessions", json=body)
    assert r.status_code == 201, r.text
    sid = r.json()["id"]
    fleet.advance(1.0)
    assert client.get(f"/api/sessions/{quote(sid, safe='')}").json()["detail"]["answers"]
    # The read and stop lines name an id of the same node.
    for line in re.findall(r"curl (?:-X DELETE )?localhost:8000/api/sessions/(\S+)", text):
        assert line.startswith(quote(body["node"], safe="") + "%23"), line
    assert client.delete(f"/api/sessions/{quote(sid, safe='')}").status_code == 200


async def read_until_closed(ws: ClientConnection) -> None:
    """Read messages until the server closes the socket (at most 10 s)."""
    async with asyncio.timeout(10):
        while True:
            await ws.recv()


async def test_a_sender_that_dies_closes_its_socket(
    source: NetworkSource, monkeypatch: pytest.MonkeyPatch
) -> None:
    real_take = ClientFeed.take

    def take_then_fail(self: ClientFeed, now: float) -> Any:
        message = real_take(self, now)
        if message is not None and message["type"] == "delta":
            raise RuntimeError("the feed broke")
        return message

    monkeypatch.setattr(ClientFeed, "take", take_then_fail)
    with Served(source) as served:
        async with connect(
            served.url.replace("http", "ws") + "/ws/events", additional_headers=served.headers()
        ) as ws:
            assert json.loads(await ws.recv())["type"] == "snapshot"
            async with httpx.AsyncClient(base_url=served.url, headers=served.headers()) as http:
                r = await http.post("/api/sessions", json=poll({"type": "within", "distance": 10}))
                assert r.status_code == 201
            with pytest.raises(ConnectionClosed) as closed:
                await read_until_closed(ws)
        assert closed.value.rcvd is not None
        assert closed.value.rcvd.code == 1011
        deadline = time.monotonic() + 5
        while len(served.app.state.dashboard.hub):  # the handler unregisters it on its way out
            assert time.monotonic() < deadline, "the dead feed is still registered"
            await asyncio.sleep(0.01)
