"""Plain links on loopback (``insecure=True``): only holders of the fleet secret take
part; without it, a node hears nothing of the fleet and nothing it puts reaches a node.
The secret itself is never in Zenoh's config. (Mutual TLS: ``test_tls.py``.)"""

from __future__ import annotations

import asyncio
import stat

import msgpack
import pytest
import zenoh

from objectplaces.transport.zenoh_config import (
    CredentialsFile,
    ZenohOptions,
    ZenohSecurity,
    derive_credentials,
    zenoh_config,
)
from objectplaces.transport.zenoh_inbox import direct
from objectplaces.zenoh_node import ZenohNode, start_zenoh_node
from objectplaces.zenoh_router import start_router
from tests.waiting import until
from tests.zenoh.intruder import open_fleet_session

SECRET = b"the fleet secret, 32 bytes or more"
GUESS = b"a guess at the secret, 32 bytes long"


def dropped(node: ZenohNode) -> int:
    return sum(v for k, v in node.stats().counters.items() if k.startswith("dropped"))


async def test_a_peer_without_the_secret_hears_nothing_and_is_heard_by_nobody() -> None:
    a = await start_zenoh_node("a", insecure=True, secret=SECRET, property_interval=0.1)
    intruder = await start_zenoh_node(
        "x", insecure=True, secret=GUESS, connect=[a.address], property_interval=0.1
    )
    # A node with the secret, joining the same way right after: the control.
    ok = await start_zenoh_node(
        "ok", insecure=True, secret=SECRET, connect=[a.address], property_interval=0.1
    )
    try:
        for node, x in ((a, 0.0), (intruder, 1.0), (ok, 2.0)):
            node.update_node_property("position", (x, 0.0))
        await until(lambda: "ok" in a.view() and "a" in ok.view())
        await asyncio.sleep(0.3)  # three more heartbeats for the intruder to be heard
        assert "x" not in a.view()
        assert "x" not in ok.view()
        assert intruder.view() == {}
        assert intruder.peers() == []
        assert a.peers() == ["ok"]
    finally:
        for node in (a, intruder, ok):
            await node.close()


async def test_a_client_without_the_secret_is_refused_by_the_router() -> None:
    router = await start_router(insecure=True, secret=SECRET, listen=["tcp/127.0.0.1:0"])
    try:
        with pytest.raises(zenoh.ZError):
            await open_fleet_session(GUESS, router.endpoints)
        session = await open_fleet_session(SECRET, router.endpoints)
        await asyncio.to_thread(session.close)
    finally:
        await router.close()


async def test_the_router_passes_only_the_fleets_keys() -> None:
    router = await start_router(insecure=True, secret=SECRET, listen=["tcp/127.0.0.1:0"])
    sessions = []
    try:
        listener = await open_fleet_session(SECRET, router.endpoints)
        talker = await open_fleet_session(SECRET, router.endpoints)
        sessions += [listener, talker]
        heard: list[str] = []

        def hear(sample: zenoh.Sample) -> None:
            heard.append(str(sample.key_expr))

        for key in ("elsewhere/**", "objectplaces/default/**"):
            listener.declare_subscriber(key, direct(hear))
        await asyncio.sleep(0.3)
        talker.put("elsewhere/x", b"1")
        talker.put("objectplaces/default/x", b"1")  # the control: it passes
        await until(lambda: "objectplaces/default/x" in heard)
        await asyncio.sleep(0.2)
        assert heard == ["objectplaces/default/x"]
    finally:
        for session in sessions:
            await asyncio.to_thread(session.close)
        await router.close()


async def test_a_raw_session_without_the_secret_cannot_inject() -> None:
    a = await start_zenoh_node("a", insecure=True, secret=SECRET)
    frame = msgpack.packb([1, 1, {"position": ["x", "y"]}])  # refused and counted if heard
    sessions = []
    try:
        wrong = await open_fleet_session(GUESS, [a.address], mode="peer")
        sessions.append(wrong)
        right = await open_fleet_session(SECRET, [a.address])
        sessions.append(right)
        wrong.put("objectplaces/default/to/a/intruder", frame)
        wrong.put("objectplaces/default/all/intruder", frame)
        before = dropped(a)
        right.put("objectplaces/default/to/a/member", frame)
        await until(lambda: dropped(a) > before)
        await asyncio.sleep(0.2)
        assert dropped(a) == before + 1
        assert set(a.stats().dropped_by_peer) == {"member"}
    finally:
        for session in sessions:
            await asyncio.to_thread(session.close)
        await a.close()


def test_credentials_derive_from_the_secret_and_the_fleet_and_never_hold_it() -> None:
    one = derive_credentials(SECRET, "f")
    assert one == derive_credentials(SECRET, "f")
    assert one != derive_credentials(SECRET, "g")
    assert one != derive_credentials(b"other", "f")
    assert SECRET.decode() not in one.user + one.password
    file = CredentialsFile(one)
    try:
        config = str(zenoh_config(ZenohOptions(), ZenohSecurity(usrpwd=(one, file.path))))
        assert SECRET.decode() not in config
        assert stat.S_IMODE(file.path.stat().st_mode) == 0o600
        assert stat.S_IMODE(file.path.parent.stat().st_mode) == 0o700
        assert file.path.read_text() == f"{one.user}:{one.password}\n"
    finally:
        file.remove()
    assert not file.path.parent.exists()


async def test_closing_a_node_removes_its_credentials_file() -> None:
    node = await start_zenoh_node("a", insecure=True, secret=SECRET)
    path = node._transport._file.path if node._transport._file else None
    assert path is not None
    assert path.exists()
    await node.close()
    assert not path.exists()


@pytest.mark.parametrize(
    "kwargs",
    [
        {"mode": "router"},
        {"listen": "tcp/127.0.0.1:0"},
        {"connect": ["127.0.0.1:7447"]},
        {"interest_radius": 0.0},
        {"fleet": "a/b"},
        {"lease": 0.0},
    ],
)
async def test_bad_arguments_are_refused(kwargs: dict[str, object]) -> None:
    from objectplaces.core.errors import LocalProtocolError

    with pytest.raises(LocalProtocolError):
        await start_zenoh_node("a", insecure=True, secret=SECRET, **kwargs)  # type: ignore[arg-type]
