"""Membership over real Zenoh sessions: a token report lost (links churning while many
processes start on a loaded machine) is made good by the periodic liveliness query; a
token withdrawn and redeclared within the grace (routes changing) costs no group its
member; one that stays away makes its node leave."""

from __future__ import annotations

import asyncio
import contextlib
import time
from collections.abc import AsyncIterator

import pytest

from objectplaces import Participant, groups
from objectplaces.transport import zenoh_membership
from objectplaces.zenoh_node import ZenohNode, start_zenoh_node
from tests.mesh.test_links import Recorder
from tests.waiting import until

SECRET = b"a fleet secret of 32 bytes or more"


async def until_peers(node: ZenohNode, peers: list[str], within: float = 10.0) -> None:
    deadline = time.monotonic() + within
    while node.peers() != peers:
        assert time.monotonic() < deadline, f"{node.node_id} has {node.peers()}, not {peers}"
        await asyncio.sleep(0.01)


@contextlib.asynccontextmanager
async def linked_pair(
    monkeypatch: pytest.MonkeyPatch, reconcile_every: float, token_grace: float = 1.0
) -> AsyncIterator[tuple[ZenohNode, ZenohNode]]:
    """Nodes a and b, b connected to a, each a peer of the other; both closed after."""
    monkeypatch.setattr(zenoh_membership, "RECONCILE_EVERY", reconcile_every)
    a = await start_zenoh_node("a", insecure=True, secret=SECRET, token_grace=token_grace)
    b = await start_zenoh_node("b", insecure=True, secret=SECRET, connect=[a.address])
    try:
        await until_peers(a, ["b"])
        yield a, b
    finally:
        await b.close()
        await a.close()


async def test_a_lost_token_report_is_made_good(monkeypatch: pytest.MonkeyPatch) -> None:
    async with linked_pair(monkeypatch, 0.2) as (a, b):
        table = a._transport.membership._table  # as if the token had never been reported:
        table.token_down("b", b._transport.incarnation, 0.0, 0)
        table.expire(table.grace)
        assert a.peers() == []
        await until_peers(a, ["b"])


async def test_a_node_that_left_is_not_brought_back(monkeypatch: pytest.MonkeyPatch) -> None:
    async with linked_pair(monkeypatch, 0.05) as (a, b):
        await b.close()
        await until_peers(a, [])
        await asyncio.sleep(0.5)  # several queries, some sent before b went
        assert a.peers() == []


class Member(Participant):
    """Plays along."""


async def session_of_a_with_b(a: ZenohNode, b: ZenohNode) -> Recorder:
    """A session of ``a`` whose group holds ``b``, once ``b`` is in it."""
    b.set_participant_factory("member", Member)
    a.update_node_property("position", (0.0, 0.0))
    b.update_node_property("position", (1.0, 0.0))
    recorder = Recorder()
    a.start_interaction(recorder, groups.within(5.0), "member")
    await until(lambda: recorder.log == [("in", "b")])
    return recorder


def flap(a: ZenohNode, b: ZenohNode, kind: str) -> None:
    """Hand ``a`` the report Zenoh gives when ``b``'s token goes ("gone") or is back."""
    a._transport._on_items([(kind, "b", b._transport.incarnation, "")])


async def test_a_token_back_within_the_grace_costs_no_group_its_member(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    async with linked_pair(monkeypatch, 60.0) as (a, b):
        recorder = await session_of_a_with_b(a, b)
        flap(a, b, "gone")
        await asyncio.sleep(0.2)
        flap(a, b, "alive")
        await asyncio.sleep(1.5)  # the grace is 1 s
        assert recorder.log == [("in", "b")]
        assert a.peers() == ["b"]
        assert a._transport.counters.get("tokens_gone", 0) == 0


async def test_without_a_grace_the_same_flap_makes_the_member_leave_and_come_back(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    async with linked_pair(monkeypatch, 60.0, token_grace=0.0) as (a, b):
        recorder = await session_of_a_with_b(a, b)
        flap(a, b, "gone")
        await asyncio.sleep(0.2)
        flap(a, b, "alive")
        await until(lambda: recorder.log == [("in", "b"), ("out", "b"), ("in", "b")])


async def test_a_token_that_stays_away_makes_its_node_leave_after_the_grace(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    async with linked_pair(monkeypatch, 60.0, token_grace=0.5) as (a, b):
        recorder = await session_of_a_with_b(a, b)
        grace = 0.5
        went = time.monotonic()
        flap(a, b, "gone")
        await until(lambda: ("out", "b") in recorder.log, within=grace + 5.0)
        assert time.monotonic() - went >= grace
        assert a.peers() == []
        assert a._transport.counters["tokens_gone"] == 1
