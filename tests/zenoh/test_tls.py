"""Mutual TLS on Zenoh, tried as an intruder would: real sessions on 127.0.0.1, with
certificates made here (a fleet CA, and trustme for a foreign one).

A member puts only on its own keys and reads of the per-node keys only its own inbox,
through a router (client mode) and in peer mode alike; a session without a certificate
of the fleet gets no link; a revoked member is cut off and stays so; plain links off
loopback and certificates of the wrong role are refused when a node starts.
"""

from __future__ import annotations

import asyncio
from collections.abc import AsyncIterator, Callable, Iterator
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

import msgpack
import pytest
import trustme
import zenoh

from objectplaces import groups
from objectplaces.core import codec
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.messages import PropertyUpdate
from objectplaces.security import CredentialError, Identity, TemporaryPki, revoke
from objectplaces.transport.zenoh_inbox import direct
from objectplaces.zenoh_node import ZenohNode, start_zenoh_node
from objectplaces.zenoh_router import ZenohRouter, start_router
from tests.waiting import until
from tests.zenoh.counting import Counter
from tests.zenoh.intruder import open_tls_session
from tests.zenoh.test_bad_input import Talker

FLEET = "f"
PREFIX = f"objectplaces/{FLEET}"
MEMBERS = ("a", "b", "c")
WITHIN = 30.0  # seconds: a loaded machine of 2 shared cores, never a speed


def forged(position: tuple[float, float], *, seq: int = 2**40) -> bytes:
    """A property update that would win over any other (a sequence number that high)."""
    return codec.encode(PropertyUpdate(seq=seq, values={"position": position}, full=True))


@pytest.fixture
def pki() -> Iterator[TemporaryPki]:
    """A fleet CA with a router and three members, all issued before anything starts."""
    with TemporaryPki(fleet=FLEET) as pki:
        pki.identity("r1", role="router", addresses=("127.0.0.1",))
        for node in MEMBERS:
            pki.identity(node, role="agv")
        yield pki


@dataclass
class Fleet:
    """Member nodes in one mode: clients of a router, or peers each linked to the first."""

    pki: TemporaryPki
    mode: str
    router: ZenohRouter | None = None
    nodes: dict[str, ZenohNode] = field(default_factory=dict)

    def link(self) -> dict[str, Any]:
        """``start_zenoh_node`` keywords that reach the fleet."""
        if self.router is not None:
            return {"mode": "client", "connect": self.router.endpoints}
        first = next(iter(self.nodes.values()), None)
        return {"connect": [first.address] if first else []}

    def entry(self) -> list[str]:
        """Where an intruder dials: the router, or the first peer."""
        if self.router is not None:
            return self.router.endpoints
        return [next(iter(self.nodes.values())).address]

    async def start(self, node_id: str, **kwargs: Any) -> ZenohNode:
        node = await start_zenoh_node(
            node_id, tls=self.pki.identity(node_id), property_interval=0.2, **self.link(), **kwargs
        )
        self.nodes[node_id] = node
        return node

    async def intruder(self, node_id: str) -> zenoh.Session:
        """A bare session presenting ``node_id``'s own certificate of the fleet."""
        d = self.pki.directory
        return await open_tls_session(
            self.entry(),
            ca=d / "ca.pem",
            cert=d / f"{node_id}.pem",
            key=d / f"{node_id}.key",
            mode="client" if self.router is not None else "peer",
            verify_name=self.router is not None,
        )


@pytest.fixture(params=["client", "peer"])
async def fleet(request: pytest.FixtureRequest, pki: TemporaryPki) -> AsyncIterator[Fleet]:
    fleet = Fleet(pki, request.param)
    if request.param == "client":
        fleet.router = await start_router(
            tls=pki.identity("r1", role="router"), listen=["tls/127.0.0.1:0"]
        )
    try:
        yield fleet
    finally:
        for node in fleet.nodes.values():
            await node.close()
        if fleet.router is not None:
            await fleet.router.close()


def recorder() -> tuple[list[str], zenoh.handlers.Callback[zenoh.Sample]]:
    """A list of the keys a subscriber hears, and its callback."""
    heard: list[str] = []

    def hear(sample: zenoh.Sample) -> None:
        heard.append(str(sample.key_expr))

    return heard, direct(hear)


def _ignore(_reply: zenoh.Reply) -> None:
    """Nodes answer on the asker's inbox, never by reply."""


ignore_reply = direct(_ignore)


async def close(session: zenoh.Session) -> None:
    await asyncio.to_thread(session.close)


def position_of(node: ZenohNode, peer: str) -> object:
    return node.view().get(peer, {}).get("position")


async def again_until(action: Callable[[], object], done: Callable[[], bool]) -> None:
    """``action()`` every half second until ``done()``: a put or a question made before
    the routes reached a fresh session may be dropped."""
    async with asyncio.timeout(WITHIN):
        while not done():
            action()
            await asyncio.sleep(0.5)


async def test_a_member_cannot_put_on_another_members_keys(fleet: Fleet) -> None:
    a = await fleet.start("a")
    b = await fleet.start("b")
    b.update_node_property("position", (1.0, 0.0))
    await until(lambda: position_of(a, "b") == (1.0, 0.0), within=WITHIN)
    seen: list[object] = []
    a.register_node_property_observer(lambda node, name, value: seen.append((node, value)))
    c = await fleet.intruder("c")  # a member of the fleet, with its own certificate
    try:
        # Its own key passes: the routes are up before it lies.
        own = partial(c.put, f"{PREFIX}/all/c", forged((4.0, 4.0)))
        await again_until(own, lambda: position_of(a, "c") == (4.0, 4.0))
        lie = forged((99.0, 99.0))
        for key in ("props/0,0/b", "props/3,3/b/left", "all/b", "to/a/b"):
            c.put(f"{PREFIX}/{key}", lie)
        # One link, in order: had a lie passed, it came before the truth about c.
        c.put(f"{PREFIX}/all/c", forged((5.0, 5.0), seq=2**40 + 1))
        await until(lambda: position_of(a, "c") == (5.0, 5.0), within=WITHIN)
        assert position_of(a, "b") == (1.0, 0.0)
        assert ("b", (99.0, 99.0)) not in seen
    finally:
        await close(c)


async def test_a_member_reads_no_inbox_but_its_own(fleet: Fleet) -> None:
    a = await fleet.start("a")
    b = await fleet.start("b")
    a.update_node_property("position", (0.0, 0.0))
    b.update_node_property("position", (1.0, 0.0))
    b.set_participant_factory("talk", Talker)
    counter = Counter()
    c = await fleet.intruder("c")
    heard, hear = recorder()
    try:
        for key in ("to/a/*", "to/b/*", "to/*/*", "to/**", "**", "to/c/*"):
            c.declare_subscriber(f"{PREFIX}/{key}", hear)
        await asyncio.sleep(0.5)  # the declarations on their way
        a.start_interaction(counter, groups.within(5.0), "talk")
        await until(lambda: counter.heard > 10, within=WITHIN)  # a and b talk on their inboxes
        # The control: a question of c's own is answered on c's own inbox.
        ask = partial(c.get, f"{PREFIX}/who/*/*", ignore_reply, payload=msgpack.packb(["c", None]))
        await again_until(ask, lambda: f"{PREFIX}/to/c/a" in heard)
        await asyncio.sleep(0.5)
        assert all(key.startswith(f"{PREFIX}/to/c/") for key in heard), heard
    finally:
        await close(c)


async def test_a_session_without_a_certificate_of_the_fleet_gets_no_link(
    fleet: Fleet, tmp_path: Path
) -> None:
    a = await fleet.start("a")
    a.update_node_property("position", (0.0, 0.0))
    foreign = trustme.CA()
    leaf = foreign.issue_cert(  # b's own name, from a CA the fleet does not trust
        "b.example", common_name="b", organization_name=FLEET, organization_unit_name="agv"
    )
    cert, key = tmp_path / "b.pem", tmp_path / "b.key"
    leaf.cert_chain_pems[0].write_to_path(str(cert))
    leaf.private_key_pem.write_to_path(str(key))
    ca = fleet.pki.directory / "ca.pem"
    attempts: list[tuple[Path | None, Path | None]] = [(None, None), (cert, key)]
    for own_cert, own_key in attempts:
        if fleet.router is not None:  # a client with no link to a router does not open
            with pytest.raises(zenoh.ZError):
                await open_tls_session(fleet.entry(), ca=ca, cert=own_cert, key=own_key)
            continue
        session = await open_tls_session(
            fleet.entry(), ca=ca, cert=own_cert, key=own_key, mode="peer", verify_name=False
        )
        heard, hear = recorder()
        try:
            session.declare_subscriber(f"{PREFIX}/**", hear)
            session.put(f"{PREFIX}/all/b", forged((99.0, 99.0)))
            await asyncio.sleep(2.0)  # a heartbeat of a's every 0.2 s
            assert list(session.info.peers_zid()) == []
            assert [key for key in heard if key != f"{PREFIX}/all/b"] == []  # but its own
            assert "b" not in a.view()
        finally:
            await close(session)


async def test_a_plain_session_gets_no_link_to_a_router(pki: TemporaryPki) -> None:
    async with await start_router(
        tls=pki.identity("r1", role="router"), listen=["tls/127.0.0.1:0"]
    ) as router:
        port = router.endpoints[0].rpartition(":")[2]
        config = zenoh.Config()
        config.insert_json5("mode", '"client"')
        config.insert_json5("connect/endpoints", f'["tcp/127.0.0.1:{port}"]')
        config.insert_json5("scouting/multicast/enabled", "false")
        with pytest.raises(zenoh.ZError):
            await asyncio.to_thread(zenoh.open, config)


async def test_a_revoked_member_is_cut_off_and_refused_afterwards(fleet: Fleet) -> None:
    a = await fleet.start("a")
    b = await fleet.start("b")
    c = await fleet.start("c")
    for node, x in ((a, 0.0), (b, 1.0), (c, 2.0)):
        node.update_node_property("position", (x, 0.0))
    await until(lambda: all(len(n.view()) == 2 for n in (a, b, c)), within=WITHIN)
    revoke(fleet.pki.directory, "c")
    await until(lambda: "c" not in a.view() and "c" not in b.view(), within=WITHIN)
    await until(lambda: "c" not in a.peers() and "c" not in b.peers(), within=WITHIN)
    # Cut off both ways: nothing c says reaches a, nothing a says reaches c.
    c.update_node_property("position", (2.0, 9.0))
    a.update_node_property("position", (0.0, 9.0))
    await until(lambda: position_of(b, "a") == (0.0, 9.0), within=WITHIN)  # the control
    await asyncio.sleep(1.0)  # five heartbeats more
    assert "c" not in a.view()
    assert position_of(c, "a") != (0.0, 9.0)
    # Refused from then on: c's certificate opens no way back in.
    again = await fleet.intruder("c")
    heard, hear = recorder()
    try:
        again.declare_subscriber(f"{PREFIX}/**", hear)
        again.liveliness().declare_token(f"{PREFIX}/alive/c/1/-")
        again.put(f"{PREFIX}/all/c", forged((7.0, 7.0)))
        a.update_node_property("position", (0.0, 8.0))
        await until(lambda: position_of(b, "a") == (0.0, 8.0), within=WITHIN)
        await asyncio.sleep(1.0)
        assert "c" not in a.view()
        assert "c" not in a.peers()
        assert [key for key in heard if key != f"{PREFIX}/all/c"] == []  # but its own put
    finally:
        await close(again)
    assert a.transport_counters().get("peers_revoked") == 1


async def test_routers_linked_by_tls_carry_the_fleet_and_no_forgery(pki: TemporaryPki) -> None:
    pki.identity("r2", role="router", addresses=("127.0.0.1",))
    r1 = await start_router(tls=pki.identity("r1"), listen=["tls/127.0.0.1:0"])
    r2 = await start_router(
        tls=pki.identity("r2"), listen=["tls/127.0.0.1:0"], connect=r1.endpoints
    )
    nodes: list[ZenohNode] = []
    try:
        for node_id, router in (("a", r1), ("b", r2)):
            node = await start_zenoh_node(
                node_id, tls=pki.identity(node_id), mode="client", connect=router.endpoints,
                property_interval=0.2,
            )  # fmt: skip
            nodes.append(node)
        a, b = nodes
        b.update_node_property("position", (1.0, 0.0))
        await until(lambda: position_of(a, "b") == (1.0, 0.0), within=WITHIN)
        d = pki.directory
        c = await open_tls_session(r2.endpoints, ca=d / "ca.pem", cert=d / "c.pem", key=d / "c.key")
        try:
            c.put(f"{PREFIX}/all/b", forged((99.0, 99.0)))
            c.put(f"{PREFIX}/all/c", forged((5.0, 5.0)))
            await until(lambda: position_of(a, "c") == (5.0, 5.0), within=WITHIN)
            assert position_of(a, "b") == (1.0, 0.0)
        finally:
            await close(c)
    finally:
        for node in nodes:
            await node.close()
        await r2.close()
        await r1.close()


async def test_a_member_issued_later_is_let_in(fleet: Fleet) -> None:
    a = await fleet.start("a")
    a.update_node_property("position", (0.0, 0.0))
    fleet.pki.identity("d", role="agv")  # issued while the fleet runs
    d = await fleet.start("d")
    d.update_node_property("position", (1.0, 0.0))
    await until(lambda: "d" in a.view() and "a" in d.view(), within=WITHIN)


async def test_a_router_certificate_cannot_join_as_a_node(pki: TemporaryPki) -> None:
    router = pki.identity("r1", role="router")
    with pytest.raises(CredentialError, match="role 'router'"):
        await start_zenoh_node("r1", tls=router)
    with pytest.raises(CredentialError, match="role 'agv'"):
        await start_router(tls=pki.identity("a"), listen=["tls/127.0.0.1:0"])
    with pytest.raises(CredentialError, match="names 'a'"):
        await start_zenoh_node("b", tls=pki.identity("a"))


async def test_a_members_certificate_cannot_pose_as_the_router(pki: TemporaryPki) -> None:
    """A client checks that the router it dialed is named for that address in its
    certificate: a member's (which names none) is refused, and so is a router of
    another CA that is."""
    pose = await start_zenoh_node("b", tls=pki.identity("b"))  # listens, as a router would
    try:
        with pytest.raises(OSError, match="zenoh"):
            await start_zenoh_node(
                "a", tls=pki.identity("a"), mode="client", connect=[pose.address]
            )
    finally:
        await pose.close()
    with TemporaryPki(fleet=FLEET) as other:
        impostor = await start_router(
            tls=other.identity("r1", role="router", addresses=("127.0.0.1",)),
            listen=["tls/127.0.0.1:0"],
        )
        try:
            with pytest.raises(OSError, match="zenoh"):
                await start_zenoh_node(
                    "a", tls=pki.identity("a"), mode="client", connect=impostor.endpoints
                )
        finally:
            await impostor.close()


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"listen": ["tcp/10.1.2.3:7447"]}, "loopback only, not on 10.1.2.3"),
        ({"connect": ["tcp/192.0.2.7:7447"]}, "loopback only, not on 192.0.2.7"),
        ({"listen": ["tcp/0.0.0.0:7447"]}, "loopback only"),
        ({"listen": ["tls/127.0.0.1:0"]}, "every endpoint is tcp/"),
    ],
)
async def test_plain_links_off_loopback_are_refused(kwargs: dict[str, Any], match: str) -> None:
    secret = b"a fleet secret of 32 bytes or more"
    with pytest.raises(LocalProtocolError, match=match):
        await start_zenoh_node("a", insecure=True, secret=secret, **kwargs)
    router_kwargs = {k: v for k, v in kwargs.items() if k == "listen"}
    if router_kwargs:
        with pytest.raises(LocalProtocolError, match=match):
            await start_router(insecure=True, secret=secret, **router_kwargs)


async def test_links_are_tls_unless_asked_otherwise(pki: TemporaryPki) -> None:
    with pytest.raises(LocalProtocolError, match="mutual TLS by default"):
        await start_zenoh_node("a")
    with pytest.raises(LocalProtocolError, match="mutual TLS by default"):
        await start_router()
    with pytest.raises(LocalProtocolError, match="every endpoint is tls/"):
        await start_zenoh_node("a", tls=pki.identity("a"), listen=["tcp/127.0.0.1:0"])
    with pytest.raises(CredentialError, match="at least 32"):
        await start_zenoh_node("a", insecure=True, secret=b"short")
    with pytest.raises(LocalProtocolError, match="fleet 'f', not 'g'"):
        await start_zenoh_node("a", tls=pki.identity("a"), fleet="g")
    node = await start_zenoh_node("a", tls=pki.identity("a"))
    try:
        assert node.address.startswith("tls/127.0.0.1:")
        assert node._transport._file is None  # no secret: no credentials file
    finally:
        await node.close()


async def test_a_secret_with_tls_is_a_second_factor(pki: TemporaryPki) -> None:
    secret = b"a fleet secret of 32 bytes or more"
    a = await start_zenoh_node("a", tls=pki.identity("a"), secret=secret, property_interval=0.2)
    link: dict[str, Any] = {"connect": [a.address], "property_interval": 0.2}
    b = await start_zenoh_node("b", tls=pki.identity("b"), secret=secret, **link)
    c = await start_zenoh_node("c", tls=pki.identity("c"), secret=b"x" * 40, **link)  # wrong
    try:
        file = a._transport._file
        assert file is not None
        assert file.path.exists()
        for node, x in ((a, 0.0), (b, 1.0), (c, 2.0)):
            node.update_node_property("position", (x, 0.0))
        await until(lambda: "b" in a.view(), within=WITHIN)
        await asyncio.sleep(1.0)
        assert "c" not in a.view()
    finally:
        for node in (c, b, a):
            await node.close()
    assert not file.path.exists()


async def test_a_pki_folder_without_its_members_file_is_refused(pki: TemporaryPki) -> None:
    (pki.directory / "members.json").unlink()
    identity = Identity.from_pki(pki.directory, "a")
    with pytest.raises(CredentialError, match=r"members\.json"):
        await start_zenoh_node("a", tls=identity)
    with pytest.raises(CredentialError, match=r"members\.json"):
        await start_router(tls=pki.identity("r1"), listen=["tls/127.0.0.1:0"])
