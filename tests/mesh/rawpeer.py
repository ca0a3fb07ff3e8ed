"""A hand-driven mesh peer for the tests: it can authenticate, or misbehave on purpose.

It speaks the plain links of ``insecure=True`` nodes: the handshake proves a key derived
from the secret (``derive_key(secret, "mesh handshake")``), as every node does.
"""

from __future__ import annotations

import os

from websockets.asyncio.client import ClientConnection, connect
from websockets.asyncio.server import ServerConnection

from objectplaces.security import derive_key
from objectplaces.transport.mesh_frames import (
    Auth,
    Hello,
    decode_transport,
    encode_auth,
    encode_hello,
    handshake_macs,
)


async def open_raw(address: str, *, max_size: int | None = None) -> ClientConnection:
    """A bare WebSocket connection to a node (no handshake yet)."""
    return await connect(
        f"ws://{address}", compression=None, proxy=None, max_size=max_size, open_timeout=10
    )


async def authenticate(
    ws: ClientConnection,
    secret: bytes,
    *,
    node: str = "intruder",
    address: str = "127.0.0.1:9",
    key: bytes | None = None,
) -> Hello:
    """Run the dialer's side of the handshake; returns the listener's challenge.

    ``key`` is the handshake key itself, when not derived from ``secret`` (a TLS mesh's).
    """
    nonce = os.urandom(16)
    await ws.send(
        encode_hello(challenge=False, node=node, address=address, incarnation=1, nonce=nonce)
    )
    challenge = decode_transport(await ws.recv(decode=False))
    assert isinstance(challenge, Hello)
    key = key if key is not None else derive_key(secret, "mesh handshake")
    mac = handshake_macs(key, node, challenge.node, nonce, challenge.nonce)[0]
    await ws.send(encode_auth(mac))
    welcome = decode_transport(await ws.recv(decode=False))
    assert isinstance(welcome, Auth)
    assert welcome.welcome
    return challenge


async def accept_handshake(
    ws: ServerConnection, secret: bytes, *, node: str, address: str = "127.0.0.1:9"
) -> Hello:
    """Run the listener's side of the handshake; returns the dialer's hello."""
    hello = decode_transport(await ws.recv(decode=False))
    assert isinstance(hello, Hello)
    assert not hello.challenge
    nonce = os.urandom(16)
    await ws.send(
        encode_hello(challenge=True, node=node, address=address, incarnation=1, nonce=nonce)
    )
    auth = decode_transport(await ws.recv(decode=False))
    assert isinstance(auth, Auth)
    key = derive_key(secret, "mesh handshake")
    dialer_mac, listener_mac = handshake_macs(key, hello.node, node, hello.nonce, nonce)
    assert auth.mac == dialer_mac
    await ws.send(encode_auth(listener_mac, welcome=True))
    return hello
