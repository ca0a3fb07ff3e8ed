"""Transport frames of the WebSocket mesh: handshake, membership gossip, subscriptions.

They share the codec's framing (a msgpack array with a leading type code) and use the
codes from ``codec.FIRST_TRANSPORT_TYPE`` up, so one peek at the type code tells a mesh
frame from a middleware frame. Layouts::

    32  [32, version, node, address, incarnation, nonce]   hello (dialer -> listener)
    33  [33, version, node, address, incarnation, nonce]   challenge (listener -> dialer)
    34  [34, mac]                                          auth (dialer proves the secret)
    35  [35, mac]                                          welcome (listener proves it)
    36  [36, [[node, address, incarnation], ...]]          gossip: peers the sender has
    37  [37, [cx, cy, cx, cy, ...] | None]                 the sender's cell subscription
    38  [38, [frame, frame, ...]]                          frames queued together, sent as one

Authentication is a challenge/response over both nonces: each side sends a fresh random
nonce and proves the shared secret with an HMAC-SHA256 over both nonces and both ids,
labelled by direction so one side's proof can never be replayed as the other's. The
secret itself never travels. Every decoder here rejects bad input with ``DecodeError``.
"""

from __future__ import annotations

import hashlib
import hmac
from dataclasses import dataclass
from typing import Any, Final

import msgpack

from objectplaces.core import codec
from objectplaces.core.errors import DecodeError

__all__ = [
    "AUTH",
    "BATCH",
    "CHALLENGE",
    "GOSSIP",
    "HELLO",
    "NONCE_SIZE",
    "PROTOCOL_VERSION",
    "SUBSCRIBE",
    "WELCOME",
    "Auth",
    "Batch",
    "Gossip",
    "Hello",
    "PeerAddress",
    "SubscribeCells",
    "TransportFrame",
    "VersionMismatch",
    "decode_transport",
    "encode_auth",
    "encode_batch",
    "encode_gossip",
    "encode_hello",
    "encode_subscribe",
    "handshake_macs",
    "parse_address",
]

PROTOCOL_VERSION: Final = 2
NONCE_SIZE: Final = 16
HELLO, CHALLENGE, AUTH, WELCOME, GOSSIP, SUBSCRIBE, BATCH = range(
    codec.FIRST_TRANSPORT_TYPE, codec.FIRST_TRANSPORT_TYPE + 7
)
_MAX_ID: Final = 256
MAX_TAG: Final = 128
"""Characters of a fleet tag at most (``Hello.tag``)."""
_MAX_GOSSIP: Final = 4096
_MAX_CELLS: Final = 1 << 16

Cell = tuple[int, int]


class VersionMismatch(DecodeError):
    """A handshake frame of a protocol version this node does not speak."""


@dataclass(frozen=True, slots=True)
class Hello:
    """A hello (``challenge=False``) or the listener's challenge (``challenge=True``)."""

    challenge: bool
    node: str
    address: str
    incarnation: int
    nonce: bytes
    tag: str = ""
    """What the sender's application says every member of its fleet shares (e.g. the
    digest of the AGVs' layout); a peer with another tag is refused."""


@dataclass(frozen=True, slots=True)
class Auth:
    """A handshake proof: the dialer's (``welcome=False``) or the listener's."""

    welcome: bool
    mac: bytes


@dataclass(frozen=True, slots=True)
class PeerAddress:
    """Where one node listens, and which run of it (a restart has a higher incarnation)."""

    node: str
    address: str
    incarnation: int


@dataclass(frozen=True, slots=True)
class Gossip:
    """Peers the sender is linked to (itself included)."""

    peers: tuple[PeerAddress, ...]


@dataclass(frozen=True, slots=True)
class SubscribeCells:
    """The sender's subscription: grid cells, or None for everything."""

    cells: frozenset[Cell] | None


@dataclass(frozen=True, slots=True)
class Batch:
    """Several frames that were queued together, carried in one WebSocket message."""

    frames: tuple[bytes, ...]


TransportFrame = Hello | Auth | Gossip | SubscribeCells | Batch


def _mac(secret: bytes, parts: list[bytes]) -> bytes:
    message = b"".join(len(p).to_bytes(2, "big") + p for p in parts)
    return hmac.new(secret, message, hashlib.sha256).digest()


def handshake_macs(
    secret: bytes, dialer: str, listener: str, nonce_d: bytes, nonce_l: bytes
) -> tuple[bytes, bytes]:
    """The dialer's and the listener's proofs of the secret for one handshake.

    Each is an HMAC-SHA256 over a direction label, both ids and both nonces.
    """
    parts = [dialer.encode(), listener.encode(), nonce_d, nonce_l]
    return _mac(secret, [b"objectplaces dialer", *parts]), _mac(
        secret, [b"objectplaces listener", *parts]
    )


def _pack(frame: list[Any]) -> bytes:
    return msgpack.packb(frame, use_bin_type=True)  # type: ignore[no-any-return]


def encode_hello(
    *, challenge: bool, node: str, address: str, incarnation: int, nonce: bytes, tag: str = ""
) -> bytes:
    """Encode a hello, or with ``challenge=True`` the listener's answer to one."""
    code = CHALLENGE if challenge else HELLO
    return _pack([code, PROTOCOL_VERSION, node, address, incarnation, nonce, tag])


def encode_auth(mac: bytes, *, welcome: bool = False) -> bytes:
    """Encode the dialer's proof, or with ``welcome=True`` the listener's."""
    return _pack([WELCOME if welcome else AUTH, mac])


def encode_gossip(peers: list[PeerAddress]) -> bytes:
    """Encode the list of peers the sender is linked to."""
    return _pack([GOSSIP, [[p.node, p.address, p.incarnation] for p in peers]])


def encode_subscribe(cells: frozenset[Cell] | None) -> bytes:
    """Encode a cell subscription (None: everything)."""
    flat: list[int] | None = None
    if cells is not None:
        flat = [n for cell in sorted(cells) for n in cell]
    return _pack([SUBSCRIBE, flat])


def encode_batch(frames: list[bytes]) -> bytes:
    """Wrap frames queued for one peer so they travel as one WebSocket message."""
    return _pack([BATCH, frames])


def parse_address(address: Any) -> tuple[str, int]:
    """Split ``"host:port"``.

    Raises:
        DecodeError: not a string of that form with a port in 0-65535.
    """
    if not isinstance(address, str) or len(address) > 300:
        raise DecodeError(f"address must be a 'host:port' string, got {address!r:.80}")
    host, sep, port = address.rpartition(":")
    if not sep or not host or not port.isdigit() or not 0 <= int(port) <= 65535:
        raise DecodeError(f"address must be 'host:port', got {address!r}")
    return host.strip("[]"), int(port)


def _node(value: Any) -> str:
    if isinstance(value, str) and 0 < len(value) <= _MAX_ID:
        return value
    raise DecodeError(f"node id must be a short non-empty string, got {value!r:.80}")


def _uint(value: Any, what: str) -> int:
    if isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 1 << 64:
        return value
    raise DecodeError(f"{what} must be a non-negative 64-bit integer, got {value!r:.80}")


def _int(value: Any) -> int:
    if isinstance(value, int) and not isinstance(value, bool) and -(1 << 40) < value < 1 << 40:
        return value
    raise DecodeError(f"cell coordinate must be an integer, got {value!r:.80}")


def _bytes(value: Any, what: str, size: int | None = None) -> bytes:
    if isinstance(value, bytes) and (size is None or len(value) == size):
        return value
    raise DecodeError(f"{what} must be {size or 'some'} bytes, got {value!r:.80}")


def _decode_hello(frame: list[Any]) -> Hello:
    if len(frame) < 2 or frame[1] != PROTOCOL_VERSION:
        version = frame[1] if len(frame) >= 2 else None
        raise VersionMismatch(
            f"protocol version {version!r:.40} not supported (this node speaks {PROTOCOL_VERSION})"
        )
    if len(frame) != 7:
        raise DecodeError(f"hello has {len(frame)} fields, expected 7")
    parse_address(frame[3])
    tag = frame[6]
    if not isinstance(tag, str) or len(tag) > MAX_TAG:
        raise DecodeError(f"a hello's tag must be text of at most {MAX_TAG} characters")
    return Hello(
        frame[0] == CHALLENGE,
        _node(frame[2]),
        frame[3],
        _uint(frame[4], "incarnation"),
        _bytes(frame[5], "nonce", NONCE_SIZE),
        tag,
    )


def _decode_gossip(frame: list[Any]) -> Gossip:
    if len(frame) != 2 or not isinstance(frame[1], list) or len(frame[1]) > _MAX_GOSSIP:
        raise DecodeError("gossip must be [36, [[node, address, incarnation], ...]]")
    peers = []
    for entry in frame[1]:
        if not isinstance(entry, list) or len(entry) != 3:
            raise DecodeError(f"gossip entry must be [node, address, incarnation]: {entry!r:.80}")
        parse_address(entry[1])
        peers.append(PeerAddress(_node(entry[0]), entry[1], _uint(entry[2], "incarnation")))
    return Gossip(tuple(peers))


def _decode_subscribe(frame: list[Any]) -> SubscribeCells:
    if len(frame) != 2:
        raise DecodeError(f"subscribe has {len(frame)} fields, expected 2")
    flat = frame[1]
    if flat is None:
        return SubscribeCells(None)
    if not isinstance(flat, list) or len(flat) % 2 or len(flat) > 2 * _MAX_CELLS:
        raise DecodeError("subscribe cells must be a flat list of coordinate pairs")
    values = [_int(v) for v in flat]
    return SubscribeCells(frozenset(zip(values[::2], values[1::2], strict=True)))


def decode_transport(data: bytes, *, max_size: int = codec.DEFAULT_MAX_FRAME) -> TransportFrame:
    """Decode one mesh frame.

    Raises:
        VersionMismatch: a hello of another protocol version.
        DecodeError: the frame is oversized, malformed, or not a mesh frame.
    """
    frame = codec.unpack_frame(data, max_size=max_size)
    match frame[0]:
        case 32 | 33:
            return _decode_hello(frame)
        case 34 | 35:
            if len(frame) != 2:
                raise DecodeError(f"auth has {len(frame)} fields, expected 2")
            return Auth(frame[0] == WELCOME, _bytes(frame[1], "mac", 32))
        case 36:
            return _decode_gossip(frame)
        case 37:
            return _decode_subscribe(frame)
        case 38:
            inner = frame[1] if len(frame) == 2 else None
            if not isinstance(inner, list) or not inner:
                raise DecodeError("a batch carries a non-empty list of frames")
            if not all(isinstance(f, bytes) for f in inner):
                raise DecodeError("every frame in a batch is a byte string")
            return Batch(tuple(inner))
        case code:
            raise DecodeError(f"unknown mesh frame type {code!r}")
