"""Polled reception (``poll_interval``): data subscribers keep their samples in Zenoh's
rings, and the loop hands everything received meanwhile on at once, in one batch."""

from __future__ import annotations

import asyncio
from dataclasses import dataclass
from typing import Any

import pytest

from objectplaces import groups
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.roles import Participant
from objectplaces.transport.zenoh_config import ZenohOptions
from objectplaces.transport.zenoh_inbox import Item, ZenohInbox, _Polled
from objectplaces.transport.zenoh_keys import FleetKeys
from objectplaces.zenoh_node import start_zenoh_node
from tests.waiting import until
from tests.zenoh.counting import Counter

SECRET = b"a fleet secret of 32 bytes or more"


@dataclass
class FakePayload:
    data: bytes

    def __len__(self) -> int:
        return len(self.data)

    def to_bytes(self) -> bytes:
        return self.data


@dataclass
class FakeSample:
    key_expr: str
    payload: FakePayload


class FakeSubscriber:
    """Stands in for a Zenoh subscriber with a ring: ``try_recv`` until empty."""

    def __init__(self) -> None:
        self.ring: list[FakeSample] = []
        self.undeclared = False

    def try_recv(self) -> FakeSample | None:
        return self.ring.pop(0) if self.ring else None

    def undeclare(self) -> None:
        self.undeclared = True


class FakeSession:
    def __init__(self) -> None:
        self.subscribers: list[FakeSubscriber] = []

    def declare_subscriber(self, key_expr: str, handler: Any) -> FakeSubscriber:
        sub = FakeSubscriber()
        self.subscribers.append(sub)
        return sub


def sample(keys: FleetKeys, source: str, data: bytes) -> FakeSample:
    """A frame from ``source`` on our inbox key (fleet "f")."""
    return FakeSample(FleetKeys("f", source).to(keys.node), FakePayload(data))


async def polled_inbox(
    batches: list[list[Item]], counters: dict[str, int]
) -> tuple[ZenohInbox, FleetKeys, FakeSession]:
    loop = asyncio.get_running_loop()
    inbox = ZenohInbox(loop, batches.append, counters, max_frame=64, poll_interval=0.01)
    return inbox, FleetKeys("f", "me"), FakeSession()


async def test_everything_received_between_two_polls_is_handed_on_in_one_batch() -> None:
    batches: list[list[Item]] = []
    counters: dict[str, int] = {}
    inbox, keys, session = await polled_inbox(batches, counters)
    try:
        first = inbox.declare_data(session, keys.inbox(), keys)  # type: ignore[arg-type]
        inbox.declare_data(session, keys.broadcasts(), keys)  # type: ignore[arg-type]
        assert isinstance(first, _Polled)
        one, two = session.subscribers
        one.ring += [sample(keys, "a", b"1"), sample(keys, "b", b"2")]
        props = FakeSample(FleetKeys("f", "c").props((4, -1)), FakePayload(b"3"))
        two.ring.append(props)
        await asyncio.sleep(0.05)
        assert batches == [
            [("frame", "a", b"1", None), ("frame", "b", b"2", None), ("frame", "c", b"3", (4, -1))]
        ]
    finally:
        inbox.close()


async def test_a_poll_counts_foreign_keys_and_oversize_frames_and_skips_our_own() -> None:
    batches: list[list[Item]] = []
    counters: dict[str, int] = {}
    inbox, keys, session = await polled_inbox(batches, counters)
    try:
        inbox.declare_data(session, keys.inbox(), keys)  # type: ignore[arg-type]
        (sub,) = session.subscribers
        sub.ring += [
            FakeSample("elsewhere/x", FakePayload(b"?")),
            sample(keys, "big", b"x" * 65),
            sample(keys, "me", b"echo"),
            sample(keys, "ok", b"fine"),
        ]
        await asyncio.sleep(0.05)
        assert batches == [[("frame", "ok", b"fine", None)]]
        assert counters == {"dropped_foreign_key": 1, "dropped_oversize": 1}
    finally:
        inbox.close()


async def test_an_undeclared_subscriber_is_polled_no_more() -> None:
    batches: list[list[Item]] = []
    inbox, keys, session = await polled_inbox(batches, {})
    try:
        handle = inbox.declare_data(session, keys.inbox(), keys)  # type: ignore[arg-type]
        (sub,) = session.subscribers
        handle.undeclare()
        assert sub.undeclared
        sub.ring.append(sample(keys, "a", b"late"))
        await asyncio.sleep(0.05)
        assert batches == []
        assert sub.ring  # nobody read it
    finally:
        inbox.close()


async def test_a_closed_inbox_polls_no_more() -> None:
    batches: list[list[Item]] = []
    inbox, keys, session = await polled_inbox(batches, {})
    inbox.declare_data(session, keys.inbox(), keys)  # type: ignore[arg-type]
    inbox.close()
    session.subscribers[0].ring.append(sample(keys, "a", b"x"))
    await asyncio.sleep(0.05)
    assert batches == []


@pytest.mark.parametrize("interval", [0.0, -1.0, 1.5])
def test_a_poll_interval_outside_its_range_is_refused(interval: float) -> None:
    with pytest.raises(LocalProtocolError, match="poll_interval"):
        ZenohOptions(poll_interval=interval)


@pytest.mark.parametrize("grace", [-0.1, 10.5, float("nan")])
def test_a_token_grace_outside_the_lease_is_refused(grace: float) -> None:
    with pytest.raises(LocalProtocolError, match="token_grace"):
        ZenohOptions(token_grace=grace)


class Talker(Participant):
    def in_group_of(self, initiator: object) -> None:
        self.send("hi")


async def test_polled_nodes_hear_properties_and_keep_sessions() -> None:
    # Scoped, so the cell subscribers are polled too, not only the inbox and broadcasts.
    a = await start_zenoh_node(
        "a", insecure=True, secret=SECRET, interest_radius=5.0, poll_interval=0.02
    )
    b = await start_zenoh_node(
        "b",
        insecure=True,
        secret=SECRET,
        connect=[a.address],
        interest_radius=5.0,
        poll_interval=0.02,
    )
    try:
        a.update_node_property("position", (1.0, 1.0))
        b.update_node_property("position", (2.0, 1.0))
        await until(lambda: "b" in a.view() and "a" in b.view())
        b.update_node_property("position", (3.0, 1.0))
        await until(lambda: a.view()["b"]["position"] == (3.0, 1.0))
        b.set_participant_factory("talk", Talker)
        counter = Counter()
        a.start_interaction(counter, groups.within(5.0), "talk")
        await until(lambda: counter.heard == 1)
    finally:
        await b.close()
        await a.close()


async def test_a_scoped_node_hears_its_cells_and_not_the_rest_of_their_rows() -> None:
    # The scoped node hears the cells around (2, 2) through one subscriber per row;
    # "far" publishes in (20, 0), a cell of row 0 it does not hear.
    here = await start_zenoh_node(
        "here", insecure=True, secret=SECRET, interest_radius=5.0, poll_interval=0.02
    )
    far = await start_zenoh_node(
        "far",
        insecure=True,
        secret=SECRET,
        connect=[here.address],
        interest_radius=5.0,
        poll_interval=0.02,
    )
    scoped = await start_zenoh_node(
        "scoped",
        insecure=True,
        secret=SECRET,
        connect=[here.address],
        interest_radius=5.0,
        poll_interval=0.02,
    )
    try:
        far.update_node_property("position", (501.0, 1.0))
        scoped.update_node_property("position", (2.0, 2.0))
        here.update_node_property("position", (1.0, 1.0))
        await until(lambda: "here" in scoped.view())
        n = 0

        def heard_far_and_dropped_it() -> bool:
            nonlocal n
            n += 1  # "far" keeps publishing in row 0
            far.update_node_property("position", (501.0 + n % 2, 1.0))
            return scoped.transport_counters().get("frames_outside_cells", 0) > 0

        await until(heard_far_and_dropped_it)
        here.update_node_property("position", (1.0, 1.5))
        await until(lambda: scoped.view()["here"]["position"] == (1.0, 1.5))
        assert "far" not in scoped.view()
    finally:
        for node in (scoped, far, here):
            await node.close()


async def test_a_poll_hands_on_the_inbox_after_the_updates() -> None:
    batches: list[list[Item]] = []
    inbox, keys, session = await polled_inbox(batches, {})
    try:
        inbox.declare_data(session, keys.inbox(), keys, directed=True)  # type: ignore[arg-type]
        inbox.declare_data(session, keys.broadcasts(), keys)  # type: ignore[arg-type]
        inbox.declare_data(session, keys.all_props(), keys)  # type: ignore[arg-type]
        directed, broadcasts, props = session.subscribers
        directed.ring.append(sample(keys, "a", b"snapshot"))
        broadcasts.ring.append(FakeSample(FleetKeys("f", "a").broadcast(), FakePayload(b"1")))
        props.ring.append(FakeSample(FleetKeys("f", "a").props((0, 0)), FakePayload(b"2")))
        await asyncio.sleep(0.05)
        assert [item[2] for item in batches[0]] == [b"1", b"2", b"snapshot"]
    finally:
        inbox.close()
