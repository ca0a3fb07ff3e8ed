"""A hand-driven mesh peer for the tests: it can authenticate, or misbehave on purpose."""

from __future__ import annotations

import os

from websockets.asyncio.client import ClientConnection, connect
from websockets.asyncio.server import ServerConnection

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
    ws: ClientConnection, secret: bytes, *, node: str = "intruder", address: str = "127.0.0.1:9"
) -> Hello:
    """Run the dialer's side of the handshake; returns the listener's challenge."""
    nonce = os.urandom(16)
    await ws.send(
        encode_hello(challenge=False, node=node, address=address, incarnation=1, nonce=nonce)
    )
    challenge = decode_transport(await ws.recv(decode=False))
    assert isinstance(challenge, Hello)
    mac = handshake_macs(secret, node, challenge.node, nonce, challenge.nonce)[0]
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
    dialer_mac, listener_mac = handshake_macs(secret, hello.node, node, hello.nonce, nonce)
    assert auth.mac == dialer_mac
    await ws.send(encode_auth(listener_mac, welcome=True))
    return hello
