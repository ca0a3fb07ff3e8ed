"""Whatever a session holding the secret puts on our keys, the node carries on: bytes
that are no frame, oversized payloads, keys that are none of ours, bad queries and
fake liveliness tokens are dropped (and counted where the node can tell)."""

from __future__ import annotations

import asyncio
import os

import msgpack

from objectplaces import groups
from objectplaces.core.roles import Participant
from objectplaces.zenoh_node import start_zenoh_node
from tests.waiting import until
from tests.zenoh.counting import Counter
from tests.zenoh.intruder import open_fleet_session

SECRET = b"a fleet secret of 32 bytes or more"
PREFIX = "objectplaces/default"


class Talker(Participant):
    def in_group_of(self, initiator: object) -> None:
        self.call_later(0.02, self.talk)

    def talk(self) -> None:
        self.send("hi")
        self.call_later(0.02, self.talk)


async def test_hostile_puts_cost_the_sender_never_the_node() -> None:
    a = await start_zenoh_node(
        "a", insecure=True, secret=SECRET, property_interval=0.2, max_frame=4096
    )
    b = await start_zenoh_node(
        "b", insecure=True, secret=SECRET, connect=[a.address], property_interval=0.2
    )
    intruder = await open_fleet_session(SECRET, [a.address], mode="peer")
    try:
        a.update_node_property("position", (0.0, 0.0))
        b.set_participant_factory("talk", Talker)
        b.update_node_property("position", (1.0, 0.0))
        counter = Counter()
        a.start_interaction(counter, groups.within(5.0), "talk")
        await until(lambda: counter.heard > 0)

        garbage = [b"", b"\xc1", os.urandom(64), msgpack.packb([99, "x"]), msgpack.packb({})]
        for key in (f"{PREFIX}/to/a/evil", f"{PREFIX}/all/evil", f"{PREFIX}/props/0,0/evil"):
            for frame in garbage:
                intruder.put(key, frame)
        intruder.put(f"{PREFIX}/to/a/evil", b"\x00" * 10_000)  # above a's max_frame
        intruder.put(f"{PREFIX}/to/a/b", msgpack.packb([1, 1, {"position": [1e400, 0]}]))
        for key in (f"{PREFIX}/to/a/%ZZ", f"{PREFIX}/all/x/y", f"{PREFIX}/props/0,0"):
            intruder.put(key, b"\x01")
        for payload in (b"", b"\xc1", msgpack.packb(["x", [[1]]]), msgpack.packb([1, None])):
            intruder.get(f"{PREFIX}/who/**", lambda _r: None, payload=payload)
        tokens = [
            intruder.liveliness().declare_token(f"{PREFIX}/alive/ghost/notanumber"),
            intruder.liveliness().declare_token(f"{PREFIX}/alive/ghost/1/-"),
        ]

        def refused() -> int:
            counters = a.stats().counters
            own = a.transport_counters()
            return sum(v for k, v in {**counters, **own}.items() if k.startswith("dropped"))

        await until(lambda: refused() >= 15)
        # The node is whole: b still moves in its view, its session still talks.
        b.update_node_property("position", (2.0, 0.0))
        await until(lambda: a.view()["b"]["position"] == (2.0, 0.0))
        mark = counter.heard
        await until(lambda: counter.heard > mark + 3)
        assert not a.closed
        assert "evil" not in a.view()
        for token in tokens:
            token.undeclare()  # type: ignore[no-untyped-call]
        await until(lambda: "ghost" not in a.peers())
    finally:
        await asyncio.to_thread(intruder.close)
        await b.close()
        await a.close()
