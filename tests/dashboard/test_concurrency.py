"""Fifty REST clients at once against a real uvicorn server while the fleet runs at 10x.

Every client starts poll sessions, reads them back (the session, the session list, the
initiator's node) and stops them again, all over HTTP. Nothing may answer 5xx, every
session started over HTTP must be stoppable over HTTP, and simulated time moves on.
"""

from __future__ import annotations

import asyncio
import sys
from typing import Any
from urllib.parse import quote

import httpx
import pytest

from agv_app.fleet import demo_source
from tests.dashboard.served import Served

CLIENTS = 50
ROUNDS = 4


def session_path(session_id: str) -> str:
    return f"/api/sessions/{quote(session_id, safe='')}"


class Log:
    """Every answer the clients got, and the sessions they started and stopped."""

    def __init__(self) -> None:
        self.answers: list[tuple[str, str, int, str]] = []
        self.started: list[str] = []
        self.stopped: list[str] = []

    async def call(self, http: httpx.AsyncClient, method: str, url: str, **kw: Any) -> Any:
        r = await http.request(method, url, **kw)
        self.answers.append((method, url, r.status_code, r.text[:300]))
        return r

    def server_errors(self) -> list[tuple[str, str, int, str]]:
        return [a for a in self.answers if a[2] >= 500]


async def one_client(http: httpx.AsyncClient, log: Log, node: str, number: int) -> None:
    for round_ in range(ROUNDS):
        body = {
            "node": node,
            "role": "poll",
            "participant_role": "poll-responder",
            "definition": {"type": "within", "distance": 15.0 + number % 7 + round_},
            "params": {"property": "status"},
        }
        r = await log.call(http, "POST", "/api/sessions", json=body)
        if r.status_code != 201:
            continue
        sid = r.json()["id"]
        log.started.append(sid)
        await log.call(http, "GET", session_path(sid))
        await log.call(http, "GET", "/api/sessions")
        await log.call(http, "GET", f"/api/nodes/{node}")
        await log.call(http, "GET", "/api/nodes")
        r = await log.call(http, "DELETE", session_path(sid))
        if r.status_code == 200:
            log.stopped.append(sid)


@pytest.mark.slow
async def test_fifty_clients_start_read_and_stop_sessions_at_ten_times_speed() -> None:
    fleet = demo_source(agvs=20, seed=2)
    fleet.set_speed(10.0)
    log = Log()
    # Switch threads far more often than the default 5 ms, so that code touching the
    # fleet from two threads meets its races within this short run.
    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-5)
    limits = httpx.Limits(max_connections=CLIENTS, max_keepalive_connections=CLIENTS)
    try:
        with Served(fleet) as served:
            async with httpx.AsyncClient(
                base_url=served.url, headers=served.headers(), timeout=60, limits=limits
            ) as http:
                nodes = [n["id"] for n in (await http.get("/api/nodes")).json()]
                agvs = sorted(n for n in nodes if n.startswith("agv-"))
                assert len(agvs) == 20
                before = (await http.get("/api/metrics")).json()["sim"]
                await asyncio.gather(
                    *(one_client(http, log, agvs[i % len(agvs)], i) for i in range(CLIENTS))
                )
                after = (await http.get("/api/metrics")).json()["sim"]
                listed = (await http.get("/api/sessions")).json()
    finally:
        sys.setswitchinterval(switch)
    left = [s["id"] for s in listed if s["via_api"]]
    assert log.server_errors() == []
    assert len(log.started) == CLIENTS * ROUNDS, [a for a in log.answers if a[2] != 200][:5]
    assert sorted(log.stopped) == sorted(log.started)
    assert left == []
    assert after["paused"] is False
    assert after["now"] > before["now"]
