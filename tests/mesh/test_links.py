"""Mesh links in one process: a dropped link comes back, a quick restart resynchronises,
forgotten peers leave nothing behind, a node whose mesh stops says it is closed, and a
closed node leaves no connection open, whatever stage it was at."""

from __future__ import annotations

import asyncio
import logging
from typing import Any

import pytest
from websockets.asyncio.server import ServerConnection, serve

from objectplaces import Initiator, Participant, groups
from objectplaces.core.messages import PropertyUpdate
from objectplaces.mesh import MeshNode, MeshOptions, start_mesh_node
from objectplaces.roles import ParticipantRef
from tests.credentials import TEST_SECRET
from tests.mesh.rawpeer import authenticate, open_raw
from tests.waiting import until

SECRET = TEST_SECRET


class Recorder(Initiator):
    def __init__(self) -> None:
        self.log: list[tuple[str, str]] = []

    def in_group(self, p: ParticipantRef) -> None:
        self.log.append(("in", p.node_id))

    def out_group(self, p: ParticipantRef) -> None:
        self.log.append(("out", p.node_id))

    def receive(self, p: ParticipantRef, message: Any) -> None:
        self.log.append(("rx", p.node_id))


class Greeter(Participant):
    def in_group_of(self, initiator: Any) -> None:
        self.send("hello")


async def node(node_id: str, join: list[str], **kwargs: Any) -> MeshNode:
    return await start_mesh_node(
        node_id,
        join=join,
        insecure=True,
        secret=SECRET,
        property_interval=0.2,
        failure_timeout=30.0,
        **kwargs,
    )


async def test_a_dropped_link_is_redialed_and_the_session_carries_on() -> None:
    a = await node("a", [])
    b = await node("b", [a.address])
    try:
        b.set_participant_factory("greeter", Greeter)
        a.update_node_property("position", (0.0, 0.0))
        b.update_node_property("position", (1.0, 0.0))
        recorder = Recorder()
        a.start_interaction(recorder, groups.within(5.0), "greeter")
        await until(lambda: ("rx", "b") in recorder.log)
        a._mesh._links["b"].ws.transport.abort()  # the TCP connection dies under the link
        await until(
            lambda: (
                a.peer_stats()["b"].reconnects == 1 == b.peer_stats()["a"].reconnects
                and a.peers() == ["b"]
                and b.peers() == ["a"]
            )
        )
        b.update_node_property("position", (2.0, 0.0))
        await until(lambda: a.view()["b"]["position"] == (2.0, 0.0))
        assert recorder.log == [("in", "b"), ("rx", "b")]
    finally:
        await b.close()
        await a.close()


async def test_a_quick_restart_replaces_the_old_run_at_once() -> None:
    a = await node("a", [])
    b = await node("b", [a.address])
    restarted: MeshNode | None = None
    try:
        b.set_participant_factory("greeter", Greeter)
        a.update_node_property("position", (0.0, 0.0))
        b.update_node_property("position", (1.0, 0.0))
        for n in range(20):  # b's sequence numbers run ahead of a new run's
            b.update_node_property("status", n)
            await asyncio.sleep(0)
        recorder = Recorder()
        a.start_interaction(recorder, groups.within(5.0), "greeter")
        await until(lambda: ("rx", "b") in recorder.log)
        # b vanishes without leaving (its machine never says goodbye) and comes back
        # long before the 30 s failure timeout.
        b._runner.close()
        await b._mesh.close()
        restarted = await node("b", [a.address])
        restarted.set_participant_factory("greeter", Greeter)
        restarted.update_node_property("position", (3.0, 0.0))
        await until(lambda: a.view().get("b", {}).get("position") == (3.0, 0.0), within=5.0)
        await until(lambda: recorder.log.count(("rx", "b")) == 2, within=5.0)
        assert recorder.log == [("in", "b"), ("rx", "b"), ("out", "b"), ("in", "b"), ("rx", "b")]
    finally:
        for each in (restarted, b, a):
            if each is not None:
                await each.close()


async def test_peers_without_a_link_are_forgotten_after_forget_after() -> None:
    # Long enough that a loaded machine still finds the visitors known before they go.
    options = MeshOptions(forget_after=2.0, gossip_interval=0.05)
    a = await node("a", [], options=options)
    try:
        for n in range(5):  # visitors that authenticate, then go
            ws = await open_raw(a.address)
            await authenticate(ws, SECRET, node=f"visitor-{n}")
            await ws.close()
        assert {f"visitor-{n}" for n in range(5)} <= set(a.peer_stats())
        b = await node("b", [a.address], options=options)
        await until(lambda: a.peers() == ["b"])
        await b.close()
        await until(lambda: not a.peer_stats()["b"].connected)
        await until(lambda: a.peer_stats() == {})
        assert len(a._mesh.directory) == 0
    finally:
        await a.close()


async def test_a_node_whose_mesh_fails_is_closed_and_says_why_once(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    a = await node("a", [])
    b = await node("b", [a.address])
    try:
        await until(lambda: a.peers() == ["b"] and b.peers() == ["a"])
        assert not a.closed

        def broken(now: float) -> None:
            raise RuntimeError("the directory broke")

        monkeypatch.setattr(a._mesh.directory, "tick", broken)
        with caplog.at_level(logging.ERROR, logger="objectplaces.mesh"):
            a._mesh._changed.set()
            await until(lambda: a.closed)
            await until(lambda: b.peers() == [])  # a dropped its links at once
        assert a.close_reason == "the mesh failed: RuntimeError: the directory broke"
        said = [r for r in caplog.records if "the node is closed" in r.getMessage()]
        assert len(said) == 1
    finally:
        await b.close()
        await a.close()
    assert a.closed


async def test_a_node_whose_mesh_task_is_cancelled_is_closed() -> None:
    a = await node("a", [])
    try:
        assert a._task is not None
        a._task.cancel()
        async with asyncio.timeout(10):
            assert await a.wait_closed() == "the mesh was cancelled"
        assert a.closed
    finally:
        await a.close()


def _reconnects(node: MeshNode, peer: str) -> int:
    stats = node.peer_stats().get(peer)
    return -1 if stats is None else stats.reconnects


async def test_a_frame_whose_handling_raises_costs_its_link_never_the_node(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    a = await node("a", [])
    failures: list[str] = []
    deliver = a._runner.deliver

    def deliver_failing_once(source: str, message: Any, size: int) -> None:
        # A fault in the node's handling (whatever the machine does with this frame).
        if isinstance(message, PropertyUpdate) and "poison" in message.values and not failures:
            failures.append(source)
            raise RuntimeError("poisoned")
        deliver(source, message, size)

    monkeypatch.setattr(a._runner, "deliver", deliver_failing_once)
    b = await node("b", [a.address])
    try:
        await until(lambda: a.peers() == ["b"])
        b.update_node_property("poison", 1)
        # b forgets nothing of a between two links, but its table may be read meanwhile.
        await until(lambda: _reconnects(b, "a") == 1 and a.peers() == ["b"])
        assert failures == ["b"]
        assert b.peer_stats()["a"].last_close == (
            "1011 failed handling PropertyUpdate: RuntimeError: poisoned"
        )
        assert a.transport_counters()["links_closed_failed"] == 1
        assert not a.closed
        b.update_node_property("position", (4.0, 0.0))
        await until(lambda: a.view().get("b", {}).get("position") == (4.0, 0.0))
    finally:
        await b.close()
        await a.close()


async def test_a_node_of_another_fleet_tag_is_refused_and_told_why() -> None:
    a = await node("a", [], tag="layout:aaaa")
    b = await node("b", [a.address], tag="layout:bbbb")
    try:
        await until(lambda: a.address in b.refusals())
        assert (
            b.refusals()[a.address]
            == "1008 another fleet: b runs 'layout:bbbb', a runs 'layout:aaaa'"
        )
        assert a.transport_counters()["refused_tag"] >= 1
        assert a.peers() == b.peers() == []
    finally:
        await b.close()
        await a.close()


async def turns_of_the_loop(count: int) -> None:
    """Let the event loop poll its sockets ``count`` times (whatever the machine's speed)."""
    for _ in range(count):
        await asyncio.sleep(0)


async def test_closing_drops_a_connection_still_in_its_opening_handshake() -> None:
    a = await node("a", [], options=MeshOptions(handshake_timeout=60.0))
    host, port = a.address.rsplit(":", 1)
    reader, writer = await asyncio.open_connection(host, int(port))
    try:
        writer.write(b"GET / HTTP/1.1\r\nHost: a\r\n")  # the request's end never comes
        await writer.drain()
        await turns_of_the_loop(20)  # a accepts it and waits for the rest
        await a.close()
        async with asyncio.timeout(10):  # not the 60 s a would wait for the request
            assert await reader.read() == b""
    finally:
        writer.close()
        await a.close()


async def test_closing_drops_a_dial_still_in_its_mesh_handshake() -> None:
    hello_received = asyncio.Event()
    closed_by_the_dialer = asyncio.Event()

    async def silent_peer(ws: ServerConnection) -> None:
        await ws.recv()  # the dialer's hello, never answered
        hello_received.set()
        await ws.wait_closed()
        closed_by_the_dialer.set()

    async with serve(silent_peer, "127.0.0.1", 0, compression=None) as peer:
        port = peer.sockets[0].getsockname()[1]
        a = await node("a", [f"127.0.0.1:{port}"], options=MeshOptions(handshake_timeout=60.0))
        try:
            async with asyncio.timeout(30):
                await hello_received.wait()
            await a.close()
            async with asyncio.timeout(10):  # not the 60 s of a's handshake timeout
                await closed_by_the_dialer.wait()
        finally:
            await a.close()
