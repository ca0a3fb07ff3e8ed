"""Mutual TLS on the mesh, tried as an attacker would, with certificates made here.

A node's id is its certificate's: a member with a valid certificate for another id
cannot claim one it does not hold; a client without a certificate of the fleet CA, or
with a revoked one, gets no link; plain links are refused off loopback.
"""

from __future__ import annotations

import asyncio
import datetime
import ssl
from collections.abc import AsyncIterator, Iterator
from pathlib import Path
from typing import Any

import pytest
import trustme
from cryptography import x509
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.x509.oid import NameOID
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed, InvalidHandshake

from objectplaces import LocalProtocolError
from objectplaces.mesh import MeshNode, start_mesh_node
from objectplaces.security import (
    CredentialError,
    Identity,
    TemporaryPki,
    derive_key,
    issue,
    revoke,
)
from objectplaces.security.pki import write_private
from tests.credentials import TEST_SECRET
from tests.mesh.rawpeer import authenticate
from tests.waiting import until

FAST: dict[str, Any] = {"property_interval": 0.2, "failure_timeout": 30.0}


@pytest.fixture
def pki() -> Iterator[TemporaryPki]:
    with TemporaryPki(fleet="tls-tests") as made:
        yield made


@pytest.fixture
async def pair(pki: TemporaryPki) -> AsyncIterator[tuple[MeshNode, MeshNode]]:
    a = await start_mesh_node("a", tls=pki.identity("a", role="agv"), **FAST)
    b = await start_mesh_node("b", join=[a.address], tls=pki.identity("b", role="agv"), **FAST)
    try:
        a.update_node_property("position", (12.0, 3.0))
        await until(lambda: b.view().get("a", {}).get("position") == (12.0, 3.0), within=30)
        yield a, b
    finally:
        await b.close()
        await a.close()


def handshake_key(pki: TemporaryPki) -> bytes:
    """The key the handshake proves on a TLS mesh: anyone may know it (TLS proves who is
    who), so an attacker knows it too."""
    ca = x509.load_pem_x509_certificate((pki.directory / "ca.pem").read_bytes())
    return derive_key(ca.public_bytes(serialization.Encoding.DER), "mesh handshake")


def client_context(identity: Identity) -> ssl.SSLContext:
    return identity.client_context()


async def no_link(url: str, context: ssl.SSLContext | None) -> BaseException:
    """Try to open a WebSocket to ``url`` and read from it; the error that stopped it."""
    try:
        async with asyncio.timeout(20):
            ws = await connect(url, ssl=context, proxy=None, open_timeout=10)
            await ws.recv()
    except (OSError, InvalidHandshake, ConnectionClosed, TimeoutError) as exc:
        return exc
    raise AssertionError(f"{url}: a link was opened")


async def test_two_certified_nodes_link_over_tls_and_learn_each_others_ids(
    pair: tuple[MeshNode, MeshNode],
) -> None:
    a, b = pair
    assert a.peers() == ["b"]
    assert b.peers() == ["a"]


async def test_a_member_cannot_claim_an_id_its_certificate_does_not_name(
    pair: tuple[MeshNode, MeshNode], pki: TemporaryPki
) -> None:
    a, b = pair
    mallory = pki.identity("mallory", role="agv")  # a valid certificate, of another id
    for attempt in range(3):
        ws = await connect(
            f"wss://{b.address}", ssl=client_context(mallory), compression=None, proxy=None
        )
        with pytest.raises(ConnectionClosed) as info:
            await authenticate(ws, b"", node="a", key=handshake_key(pki))
        assert info.value.rcvd is not None
        assert info.value.rcvd.code == 1008
        assert "certificate names 'mallory', hello claims 'a'" in info.value.rcvd.reason
        assert b.transport_counters()["refused_identity"] == attempt + 1
    # b's link to the real a stays, and so does what b knows of a.
    assert b.peers() == ["a"]
    a.update_node_property("position", (13.0, 3.0))
    await until(lambda: b.view()["a"]["position"] == (13.0, 3.0), within=30)


async def test_no_certificate_or_one_of_another_ca_gets_no_link(
    pair: tuple[MeshNode, MeshNode],
) -> None:
    a, _b = pair
    # Plain ws:// to a TLS node: no WebSocket answers.
    assert isinstance(await no_link(f"ws://{a.address}", None), InvalidHandshake | OSError)
    # TLS without a client certificate: the server refuses it in the TLS handshake.
    anonymous = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    anonymous.check_hostname = False
    anonymous.verify_mode = ssl.CERT_NONE
    await no_link(f"wss://{a.address}", anonymous)
    # A certificate of another CA, even one naming "b".
    foreign = trustme.CA().issue_cert("b")
    impostor = ssl.SSLContext(ssl.PROTOCOL_TLS_CLIENT)
    impostor.check_hostname = False
    impostor.verify_mode = ssl.CERT_NONE
    foreign.configure_cert(impostor)
    await no_link(f"wss://{a.address}", impostor)
    assert a.peers() == ["b"]
    assert "refused_identity" not in a.transport_counters()  # never got past TLS


async def test_a_revoked_member_is_cut_off_and_refused_from_then_on(
    pair: tuple[MeshNode, MeshNode], pki: TemporaryPki
) -> None:
    a, _b = pair
    revoke(pki.directory, "b")
    await until(lambda: a.peers() == [], within=30)
    assert a.transport_counters()["links_closed_revoked"] >= 1
    # b keeps dialing a; a refuses each time, and never links again.
    await until(lambda: a.transport_counters().get("refused_revoked", 0) >= 1, within=30)
    assert a.peers() == []


async def test_a_router_certificate_cannot_join_as_a_node(pki: TemporaryPki) -> None:
    router = pki.identity("r1", role="router")
    with pytest.raises(CredentialError, match="role 'router'"):
        await start_mesh_node("r1", tls=router, **FAST)


async def test_an_identity_of_another_id_is_refused_at_the_call(pki: TemporaryPki) -> None:
    with pytest.raises(CredentialError, match="names 'a', not 'b'"):
        await start_mesh_node("b", tls=pki.identity("a"), **FAST)


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        ({}, "links are mutual TLS by default"),
        ({"insecure": True}, "needs a secret"),
        ({"insecure": True, "secret": b"short"}, "is 5 bytes; at least 32"),
        (
            {"insecure": True, "secret": TEST_SECRET, "listen": "0.0.0.0:0"},
            "plain links are allowed on loopback only, not on 0.0.0.0",
        ),
        (
            {"insecure": True, "secret": TEST_SECRET, "join": ["10.1.2.3:7000"]},
            "not on 10.1.2.3",
        ),
    ],
)
async def test_plain_links_are_had_only_by_name_with_a_secret_on_loopback(
    arguments: dict[str, Any], message: str
) -> None:
    with pytest.raises(LocalProtocolError, match=message):
        await start_mesh_node("a", **arguments)


def test_credential_files_are_refused_with_their_path_and_reason(
    pki: TemporaryPki, tmp_path: Path
) -> None:
    d = pki.directory
    pki.identity("a")
    (d / "a.key").chmod(0o644)
    with pytest.raises(CredentialError, match=r"a\.key: mode 0644 lets group or others read"):
        Identity.from_pki(d, "a")
    (d / "a.key").chmod(0o600)
    with pytest.raises(CredentialError, match=r"certificate .*nobody\.pem: cannot be read"):
        Identity.from_pki(d, "nobody")
    # A key that is not the certificate's.
    pki.identity("b")
    (d / "a.key").write_bytes((d / "b.key").read_bytes())
    with pytest.raises(CredentialError, match=r"a\.key does not match certificate"):
        Identity.from_pki(d, "a")
    # A certificate of another CA in the fleet's folder.
    other = TemporaryPki(fleet="other")
    try:
        other.identity("c")
        for suffix in (".pem", ".key"):
            (d / f"c{suffix}").write_bytes((other.directory / f"c{suffix}").read_bytes())
            (d / f"c{suffix}").chmod(0o600)
        with pytest.raises(CredentialError, match=r"c\.pem is not signed by the fleet CA"):
            Identity.from_pki(d, "c")
    finally:
        other.remove()
    assert tmp_path.exists()


def test_an_expired_certificate_is_refused_naming_when(pki: TemporaryPki) -> None:
    d = pki.directory
    ca_key = serialization.load_pem_private_key((d / "private" / "ca.key").read_bytes(), None)
    ca = x509.load_pem_x509_certificate((d / "ca.pem").read_bytes())
    key = ec.generate_private_key(ec.SECP256R1())
    past = datetime.datetime(2020, 1, 1, tzinfo=datetime.UTC)
    subject = x509.Name(
        [
            x509.NameAttribute(NameOID.ORGANIZATION_NAME, "tls-tests"),
            x509.NameAttribute(NameOID.ORGANIZATIONAL_UNIT_NAME, "agv"),
            x509.NameAttribute(NameOID.COMMON_NAME, "old"),
        ]
    )
    cert = (
        x509.CertificateBuilder()
        .subject_name(subject)
        .issuer_name(ca.subject)
        .public_key(key.public_key())
        .serial_number(x509.random_serial_number())
        .not_valid_before(past)
        .not_valid_after(past + datetime.timedelta(days=30))
        .sign(ca_key, hashes.SHA256())  # type: ignore[arg-type]
    )
    (d / "old.pem").write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    write_private(
        d / "old.key",
        key.private_bytes(
            serialization.Encoding.PEM,
            serialization.PrivateFormat.PKCS8,
            serialization.NoEncryption(),
        ),
    )
    with pytest.raises(CredentialError, match=r"old\.pem expired on 2020-01-31"):
        Identity.from_pki(d, "old")


def test_a_revoked_id_is_not_issued_again(pki: TemporaryPki) -> None:
    pki.identity("lost", role="agv")
    revoke(pki.directory, "lost")
    with pytest.raises(CredentialError, match="a revoked id is not issued again"):
        issue(pki.directory, "lost", role="agv")
    with pytest.raises(CredentialError, match="holds no certificate that is not revoked"):
        revoke(pki.directory, "lost")
