"""A hostile REST client against a real uvicorn server while the fleet runs at 10x.

Bad input (deep nesting, huge numbers, wrong types, megabyte strings) gets only 4xx;
a storm of 600 concurrent requests starting, reading and stopping sessions gets only
2xx; the fleet keeps advancing throughout, and every session started over HTTP is
stopped over HTTP. Generated bodies (hypothesis) never get a 5xx either.
"""

from __future__ import annotations

import asyncio
import json
from typing import Any
from urllib.parse import quote

import httpx
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from agv_app.fleet import demo_source
from tests.dashboard.bodies import WITHIN, nested_definition, poll_body
from tests.dashboard.conftest import TestClient
from tests.dashboard.served import Served

STORM_CLIENTS = 200  # each starts, reads and stops one session: 600 requests
MEGABYTE = "x" * 1_000_000


def session_path(session_id: str) -> str:
    return f"/api/sessions/{quote(session_id, safe='')}"


def hostile_requests(node: str) -> list[tuple[str, str, dict[str, Any]]]:
    """(method, url, httpx keywords) of requests that must each be refused with a 4xx."""
    as_json = {"content-type": "application/json"}
    template = json.dumps(poll_body(node, None))
    out: list[tuple[str, str, dict[str, Any]]] = [
        (
            "POST",
            "/api/sessions",
            {"json": poll_body(node, {"type": "within", "distance": 1.797e308})},
        ),
        ("POST", "/api/sessions", {"json": poll_body(node, {"type": "within", "distance": True})}),
        ("POST", "/api/sessions", {"json": poll_body(node, {"type": "within", "distance": "2"})}),
        (
            "POST",
            "/api/sessions",
            {"json": poll_body(node, {"type": "within", "distance": 10**400})},
        ),
        ("POST", "/api/sessions", {"json": poll_body(node, {"type": "within", "distance": -1})}),
        ("POST", "/api/sessions", {"json": poll_body(MEGABYTE)}),
        ("POST", "/api/sessions", {"json": poll_body(node, params={"property": MEGABYTE})}),
        ("POST", "/api/sessions", {"json": poll_body(node, {"type": MEGABYTE})}),
        ("POST", "/api/sessions", {"json": poll_body(node, role=7)}),
        ("POST", "/api/sessions", {"json": poll_body(node, node_extra=1)}),
        ("POST", "/api/sessions", {"json": [poll_body(node)]}),
        ("POST", "/api/sessions", {"content": b"[" * 3000, "headers": as_json}),
        ("POST", "/api/sessions", {"content": b"{" * 50, "headers": as_json}),
        ("POST", "/api/sessions", {"content": b"\xff\xfe", "headers": as_json}),
        ("POST", "/api/sessions", {"content": "1" + "0" * 5000, "headers": as_json}),
        ("GET", "/api/groups/view", {"params": {"definition": "[" * 3000}}),
        ("GET", "/api/groups/view", {"params": {"definition": nested_definition(200)}}),
        (
            "GET",
            "/api/groups/view",
            {"params": {"definition": '{"type":"within","distance":1e999}'}},
        ),
        ("GET", "/api/groups/view", {"params": {"definition": "x" * 60_000}}),
        ("GET", "/api/groups/view", {"params": {"definition": json.dumps(WITHIN), "node": "?"}}),
        ("POST", "/api/sim/speed", {"json": {"factor": True}}),
        ("POST", "/api/sim/speed", {"json": {"factor": "2"}}),
        ("POST", "/api/sim/speed", {"json": {"factor": 1e-300}}),
        ("POST", "/api/sim/speed", {"content": '{"factor": 1e309}', "headers": as_json}),
        ("POST", "/api/tasks", {"json": {"station": MEGABYTE}}),
        ("POST", "/api/tasks", {"json": {"station": 5}}),
        ("GET", "/api/nodes/" + "n" * 20_000, {}),
        ("GET", session_path("x" * 20_000), {}),
        ("DELETE", session_path("agv-01#999999"), {}),
        ("POST", "/api/sim/" + "r" * 1000, {}),
    ]
    for levels in (40, 200, 480):
        text = template.replace('"definition": null', f'"definition": {nested_definition(levels)}')
        out.append(("POST", "/api/sessions", {"content": text, "headers": as_json}))
    return out


async def storm_client(http: httpx.AsyncClient, node: str, answers: list[tuple[str, int]]) -> str:
    r = await http.post("/api/sessions", json=poll_body(node))
    answers.append(("start", r.status_code))
    if r.status_code != 201:
        return ""
    sid = str(r.json()["id"])
    r = await http.get(session_path(sid))
    answers.append(("read", r.status_code))
    r = await http.delete(session_path(sid))
    answers.append(("stop", r.status_code))
    return sid if r.status_code == 200 else ""


@pytest.mark.slow
async def test_a_hostile_client_gets_4xx_and_the_fleet_runs_on() -> None:
    fleet = demo_source(agvs=12, seed=1)
    fleet.set_speed(10.0)
    limits = httpx.Limits(max_connections=100, max_keepalive_connections=100)
    with Served(fleet) as served:
        async with httpx.AsyncClient(
            base_url=served.url, headers=served.headers(), timeout=60, limits=limits
        ) as http:
            nodes = sorted(n["id"] for n in (await http.get("/api/nodes")).json())
            agvs = [n for n in nodes if n.startswith("agv-")]
            start = (await http.get("/api/metrics")).json()["sim"]["now"]

            refused = []
            for method, url, kw in hostile_requests(agvs[0]):
                r = await http.request(method, url, **kw)
                refused.append((method, url[:60], r.status_code, r.text[:200]))
            after_hostile = (await http.get("/api/metrics")).json()["sim"]

            answers: list[tuple[str, int]] = []
            stopped = await asyncio.gather(
                *(storm_client(http, agvs[i % len(agvs)], answers) for i in range(STORM_CLIENTS))
            )
            end = (await http.get("/api/metrics")).json()
            left = [s for s in (await http.get("/api/sessions")).json() if s["via_api"]]

    assert [r for r in refused if not 400 <= r[2] < 500] == []
    assert after_hostile["paused"] is False
    assert after_hostile["now"] > start
    assert len(answers) == 3 * STORM_CLIENTS
    assert [a for a in answers if not 200 <= a[1] < 300] == []
    assert all(stopped)
    assert left == []
    assert end["sim"]["paused"] is False
    assert end["sim"]["now"] > after_hostile["now"]
    assert end["advance_errors"] == 0


SCALARS = st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=30)
JSON_VALUES = st.recursive(
    SCALARS,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner),
    max_leaves=25,
)
DEFINITION_LIKE = st.recursive(
    st.fixed_dictionaries(
        {"type": st.sampled_from(["within", "circles_overlap", "property_equals", "square"])},
        optional={
            "distance": SCALARS,
            "position": SCALARS,
            "radius": SCALARS,
            "name": SCALARS,
            "value": JSON_VALUES,
        },
    ),
    lambda inner: st.fixed_dictionaries(
        {"type": st.sampled_from(["and", "or"]), "of": st.lists(inner, max_size=4)}
    ),
    max_leaves=10,
)
BODIES = st.fixed_dictionaries(
    {},
    optional={
        "node": st.sampled_from(["agv-1", "agv-2", "ghost"]) | SCALARS,
        "role": st.just("poll") | SCALARS,
        "participant_role": st.just("poll-responder") | SCALARS,
        "definition": DEFINITION_LIKE | JSON_VALUES,
        "params": st.just({"property": "status"}) | JSON_VALUES,
    },
)


@settings(
    max_examples=150,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(body=BODIES)
def test_generated_session_bodies_never_get_a_5xx(client: TestClient, body: Any) -> None:
    r = client.post("/api/sessions", content=json.dumps(body, allow_nan=True))
    assert r.status_code < 500, (body, r.text)
    if r.status_code == 201:
        assert client.delete(session_path(r.json()["id"])).status_code == 200
    else:
        assert 400 <= r.status_code < 500
        assert r.json()["detail"]


@settings(
    max_examples=100,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
@given(definition=DEFINITION_LIKE | JSON_VALUES | st.text(max_size=50))
def test_generated_group_views_never_get_a_5xx(client: TestClient, definition: Any) -> None:
    text = definition if isinstance(definition, str) else json.dumps(definition, allow_nan=True)
    r = client.get("/api/groups/view", params={"node": "agv-1", "definition": text})
    assert r.status_code in (200, 400, 404, 422), (definition, r.text)
