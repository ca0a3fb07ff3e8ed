"""The link policy alone, on a fake clock: what an open link may send, and the counts."""

from __future__ import annotations

import msgpack
import pytest

from objectplaces.core import codec
from objectplaces.core.messages import Leave, PropertyUpdate
from objectplaces.transport.directory import PeerCounters
from objectplaces.transport.mesh_frames import (
    Gossip,
    PeerAddress,
    SubscribeCells,
    encode_auth,
    encode_batch,
    encode_gossip,
    encode_subscribe,
)
from objectplaces.transport.options import MeshOptions
from objectplaces.transport.policing import Delivered, LinkPolicy, Refusal, TokenBucket

MOVE = codec.encode(PropertyUpdate(1, {"position": (1.0, 2.0)}))


def policy() -> tuple[LinkPolicy, PeerCounters]:
    counters = PeerCounters()
    options = MeshOptions(max_frame=256, flood_rate=10.0, flood_burst=5.0)
    return LinkPolicy(options, counters, now=0.0), counters


def test_frames_alone_or_batched_become_items_in_order() -> None:
    p, counters = policy()
    gossip = encode_gossip([PeerAddress("x", "h:1", 3)])
    batch = encode_batch([MOVE, gossip, encode_subscribe(None)])
    items, refusal = p.read(batch, now=0.0)
    assert refusal is None
    assert items == [
        Delivered(codec.decode(MOVE), len(MOVE)),
        Gossip((PeerAddress("x", "h:1", 3),)),
        SubscribeCells(None),
    ]
    items, refusal = p.read(codec.encode(Leave()), now=0.0)
    assert items == [Delivered(Leave(), 2)]
    assert (counters.messages_in, counters.bytes_in) == (4, len(batch) + 2)


@pytest.mark.parametrize(
    ("data", "code", "reason"),
    [
        ("text", 1003, "text frames are not accepted"),
        (b"x" * 257, 1009, "frame of 257 bytes over 256"),
        (b"\x93\xc1\xc1", 1002, "malformed frame"),
        (msgpack.packb([20, 1]), 1002, "unknown message type 20"),
        (msgpack.packb([codec.FIRST_TRANSPORT_TYPE + 20]), 1002, "unknown mesh frame type 52"),
        (encode_auth(b"k" * 32), 1002, "handshake frame on an open link"),
        (encode_batch([encode_batch([MOVE])]), 1002, "a batch inside a batch"),
        (encode_batch([b"\x93\xc1\xc1"]), 1002, "malformed frame"),
    ],
)
def test_a_message_that_breaks_the_rules_is_refused_with_its_reason(
    data: bytes | str, code: int, reason: str
) -> None:
    p, counters = policy()
    items, refusal = p.read(data, now=0.0)
    assert items == []
    assert isinstance(refusal, Refusal)
    assert refusal.code == code
    assert reason in refusal.reason
    assert counters.messages_in == 1


def test_frames_before_a_bad_one_in_a_batch_still_count() -> None:
    p, _ = policy()
    items, refusal = p.read(encode_batch([MOVE, b"\x93\xc1\xc1", MOVE]), now=0.0)
    assert items == [Delivered(codec.decode(MOVE), len(MOVE))]
    assert refusal is not None
    assert refusal.code == 1002


def test_the_flood_limit_allows_the_burst_then_the_rate() -> None:
    p, _ = policy()
    items, refusal = p.read(encode_batch([MOVE] * 5), now=0.0)
    assert (len(items), refusal) == (5, None)
    items, refusal = p.read(MOVE, now=0.05)  # half a token earned
    assert items == []
    assert refusal == Refusal(1008, "flood: over 10 frames/s (burst 5)")
    p, _ = policy()
    p.read(encode_batch([MOVE] * 5), now=0.0)
    for n in range(1, 20):  # exactly the rate: never refused
        items, refusal = p.read(MOVE, now=n * 0.1)
        assert refusal is None, n


def test_a_token_bucket_refills_up_to_its_burst() -> None:
    bucket = TokenBucket(rate=2.0, burst=3.0, now=0.0)
    assert [bucket.take(0.0) for _ in range(4)] == [True, True, True, False]
    assert bucket.take(0.5)  # one token back
    assert not bucket.take(0.5)
    assert [bucket.take(100.0) for _ in range(4)] == [True, True, True, False]
