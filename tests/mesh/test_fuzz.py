"""Fuzzing the decoders: whatever arrives, they return a message or raise ``DecodeError``."""

from __future__ import annotations

import contextlib

import msgpack
from hypothesis import given, settings
from hypothesis import strategies as st

from objectplaces.core import codec
from objectplaces.core.errors import DecodeError
from objectplaces.core.messages import ChannelAck, ChannelData, FrameKind, Leave, PropertyUpdate
from objectplaces.transport.mesh_frames import (
    PeerAddress,
    decode_transport,
    encode_auth,
    encode_gossip,
    encode_hello,
    encode_subscribe,
)

VALID = [
    codec.encode(PropertyUpdate(7, {"position": (1.5, -2.25), "hull_length": 3.0})),
    codec.encode(PropertyUpdate(8, {"position": (1.0, 2.0), "status": "idle", "n": [1, 2]})),
    codec.encode(PropertyUpdate(9, {"status": "busy"})),
    codec.encode(Leave()),
    codec.encode(ChannelData(True, 3, 1, 4, FrameKind.ROLE, {"a": [1, b"x", None]})),
    codec.encode(ChannelData(False, 3, 1, 5, FrameKind.ACTIVATED, None)),
    codec.encode(ChannelAck(True, 3, 1, 5)),
    encode_hello(challenge=False, node="n1", address="h:70", incarnation=5, nonce=b"n" * 16),
    encode_hello(challenge=True, node="n2", address="[::1]:7001", incarnation=6, nonce=b"m" * 16),
    encode_auth(b"k" * 32),
    encode_auth(b"k" * 32, welcome=True),
    encode_gossip([PeerAddress("n1", "127.0.0.1:7000", 5), PeerAddress("n3", "h:1", 2)]),
    encode_subscribe(frozenset({(0, 0), (-1, 3)})),
    encode_subscribe(None),
]


def decode_any(data: bytes) -> None:
    """Decode ``data`` the way a link does: peek, then the right decoder."""
    with contextlib.suppress(DecodeError):
        codec.decode(data, max_size=4096)
    with contextlib.suppress(DecodeError):
        decode_transport(data, max_size=4096)
    with contextlib.suppress(DecodeError):
        codec.frame_type(data)
    codec.message_kind(data)


@st.composite
def mutated(draw: st.DrawFn) -> bytes:
    data = bytearray(draw(st.sampled_from(VALID)))
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["flip", "insert", "delete", "truncate", "byte"]))
        at = draw(st.integers(0, max(0, len(data) - 1)))
        if op == "flip" and data:
            data[at] ^= 1 << draw(st.integers(0, 7))
        elif op == "insert":
            data[at:at] = draw(st.binary(min_size=1, max_size=8))
        elif op == "delete" and data:
            del data[at]
        elif op == "truncate":
            del data[at:]
        elif data:
            data[at] = draw(st.integers(0, 255))
    return bytes(data)


scalars = (
    st.none()
    | st.booleans()
    | st.integers(-(2**63), 2**64 - 1)
    | st.floats()
    | st.text(max_size=8)
    | st.binary(max_size=40)
)
plain = st.recursive(
    scalars,
    lambda inner: (
        st.lists(inner, max_size=4)
        | st.dictionaries(st.text(max_size=4) | st.integers(0, 9), inner, max_size=4)
    ),
    max_leaves=10,
)


@settings(max_examples=300)
@given(st.binary(max_size=200))
def test_random_bytes_only_raise_decode_error(data: bytes) -> None:
    decode_any(data)


@settings(max_examples=300)
@given(mutated())
def test_mutated_frames_only_raise_decode_error(data: bytes) -> None:
    decode_any(data)


@settings(max_examples=200)
@given(st.integers(0, 40), st.lists(plain, max_size=6))
def test_msgpack_of_any_shape_only_raises_decode_error(code: int, rest: list[object]) -> None:
    decode_any(msgpack.packb([code, *rest], use_bin_type=True))


def test_every_valid_frame_decodes() -> None:
    for data in VALID:
        if codec.frame_type(data) < codec.FIRST_TRANSPORT_TYPE:
            codec.decode(data)
        else:
            decode_transport(data)
