"""The handshake machine alone: two machines talk bytes to each other, no sockets."""

from __future__ import annotations

import msgpack
import pytest

from objectplaces.transport.handshake import Established, HandshakeMachine, Refused
from objectplaces.transport.mesh_frames import (
    HELLO,
    PeerAddress,
    encode_auth,
    encode_gossip,
    encode_hello,
)

SECRET = b"shared"


def machine(
    node: str,
    *,
    dialing: bool,
    secret: bytes = SECRET,
    now: float = 0.0,
    certified: str | None = None,
    tag: str = "",
) -> HandshakeMachine:
    return HandshakeMachine(
        node_id=node,
        address=f"127.0.0.1:{7000 + ord(node[0])}",
        incarnation=ord(node[0]),
        secret=secret,
        nonce=(node * 16).encode()[:16],
        dialing=dialing,
        now=now,
        timeout=5.0,
        max_frame=4096,
        dialed="127.0.0.1:7000" if dialing else "",
        certified=certified,
        tag=tag,
    )


def converse(dialer: HandshakeMachine, listener: HandshakeMachine) -> int:
    """Carry frames both ways until neither has more to say; returns how many went."""
    sent = 0
    while True:
        moved = False
        for source, target in ((dialer, listener), (listener, dialer)):
            for data in source.data_to_send():
                target.receive(data)
                sent += 1
                moved = True
        if not moved:
            return sent


def test_two_machines_with_the_secret_establish_a_link_in_four_frames() -> None:
    dialer, listener = machine("a", dialing=True), machine("b", dialing=False)
    assert converse(dialer, listener) == 4
    assert dialer.outcome == Established("b", "127.0.0.1:7098", ord("b"), dialer="a")
    assert listener.outcome == Established("a", "127.0.0.1:7097", ord("a"), dialer="a")


def test_a_hello_naming_another_id_than_the_certificate_is_refused() -> None:
    # mallory holds a valid certificate, for "mallory", and says it is "a".
    impostor = machine("a", dialing=True)
    listener = machine("b", dialing=False, certified="mallory")
    converse(impostor, listener)
    assert listener.outcome == Refused(
        1008, "certificate names 'mallory', hello claims 'a'", "refused_identity"
    )
    assert impostor.outcome is None  # it learned nothing: no challenge was sent


def test_a_listener_whose_hello_is_not_its_certificate_is_refused() -> None:
    dialer = machine("a", dialing=True, certified="mallory")
    impostor = machine("b", dialing=False)
    converse(dialer, impostor)
    assert dialer.outcome == Refused(
        1008, "certificate names 'mallory', hello claims 'b'", "refused_identity"
    )


def test_ids_that_match_their_certificates_link() -> None:
    dialer = machine("a", dialing=True, certified="b")
    listener = machine("b", dialing=False, certified="a")
    assert converse(dialer, listener) == 4
    assert isinstance(dialer.outcome, Established)
    assert isinstance(listener.outcome, Established)


def test_a_peer_of_another_fleet_tag_is_refused_naming_both() -> None:
    newcomer = machine("a", dialing=True, tag="layout:1111")
    member = machine("b", dialing=False, tag="layout:2222")
    converse(newcomer, member)
    assert member.outcome == Refused(
        1008, "another fleet: a runs 'layout:1111', b runs 'layout:2222'", "refused_tag"
    )
    # And the other way round: the listener's challenge carries its tag too.
    dialer = machine("a", dialing=True, tag="layout:1111")
    dialer.receive(listener_hello("b", tag="layout:2222"))
    assert dialer.outcome == Refused(
        1008, "another fleet: b runs 'layout:2222', a runs 'layout:1111'", "refused_tag"
    )


def listener_hello(node: str, *, tag: str) -> bytes:
    return encode_hello(
        challenge=True, node=node, address="127.0.0.1:7001", incarnation=1, nonce=b"n" * 16, tag=tag
    )


def test_a_dialer_without_the_secret_is_refused_and_learns_nothing() -> None:
    dialer = machine("a", dialing=True, secret=b"guess")
    listener = machine("b", dialing=False)
    listener.receive(dialer.data_to_send()[0])  # hello
    dialer.receive(listener.data_to_send()[0])  # challenge
    listener.receive(dialer.data_to_send()[0])  # a wrong proof
    assert listener.outcome == Refused(1008, "authentication failed for 'a'", "refused_auth")
    assert listener.data_to_send() == []  # no welcome, no proof of ours
    assert dialer.outcome is None


def test_a_listener_without_the_secret_is_refused_by_the_dialer() -> None:
    dialer = machine("a", dialing=True)
    impostor = machine("b", dialing=False, secret=b"guess")
    impostor.receive(dialer.data_to_send()[0])
    dialer.receive(impostor.data_to_send()[0])
    impostor.receive(dialer.data_to_send()[0])  # the dialer's proof: the impostor refuses
    assert isinstance(impostor.outcome, Refused)
    assert dialer.outcome is None
    dialer.receive(encode_auth(b"\x00" * 32, welcome=True))  # a welcome it made up
    assert dialer.outcome == Refused(1008, "authentication failed", "refused_auth")


def test_the_dialers_proof_cannot_be_replayed_as_the_listeners() -> None:
    dialer, listener = machine("a", dialing=True), machine("b", dialing=False)
    listener.receive(dialer.data_to_send()[0])
    dialer.receive(listener.data_to_send()[0])
    auth = msgpack.unpackb(dialer.data_to_send()[0])
    dialer.receive(encode_auth(auth[1], welcome=True))  # echo the dialer's own proof
    assert isinstance(dialer.outcome, Refused)
    assert dialer.outcome.counter == "refused_auth"


@pytest.mark.parametrize(
    ("data", "code", "reason", "counter"),
    [
        ("a text frame", 1003, "text frames", "refused_malformed"),
        (b"\x93\xc1\xc1", 1002, "malformed handshake", "refused_malformed"),
        (
            msgpack.packb([HELLO, 99, "x", "h:1", 1, b"0" * 16]),
            1008,
            "version 99",
            "refused_version",
        ),
        (encode_auth(b"k" * 32), 1002, "expected a hello", ""),
        (encode_gossip([PeerAddress("x", "h:1", 1)]), 1002, "expected a hello", ""),
        (
            encode_hello(challenge=False, node="b", address="h:1", incarnation=1, nonce=b"n" * 16),
            1008,
            "node id 'b' is this node's",
            "",
        ),
    ],
)
def test_the_listener_refuses_a_bad_first_frame(
    data: bytes | str, code: int, reason: str, counter: str
) -> None:
    listener = machine("b", dialing=False)
    listener.receive(data)
    assert isinstance(listener.outcome, Refused)
    assert (listener.outcome.code, listener.outcome.counter) == (code, counter)
    assert reason in listener.outcome.reason
    assert listener.data_to_send() == []


def test_the_dialer_refuses_anything_but_a_challenge_then_a_welcome() -> None:
    dialer = machine("a", dialing=True)
    dialer.data_to_send()
    dialer.receive(encode_hello(challenge=False, node="b", address="h:1", incarnation=1,
                                nonce=b"n" * 16))  # fmt: skip
    assert dialer.outcome == Refused(1002, "expected a challenge")
    itself = machine("a", dialing=True)
    itself.receive(encode_hello(challenge=True, node="a", address="h:1", incarnation=1,
                                nonce=b"n" * 16))  # fmt: skip
    assert itself.outcome == Refused(1008, "127.0.0.1:7000 is this node itself")
    dialer, listener = machine("a", dialing=True), machine("b", dialing=False)
    listener.receive(dialer.data_to_send()[0])
    dialer.receive(listener.data_to_send()[0])
    dialer.receive(encode_auth(b"k" * 32))  # a dialer's proof, not a welcome
    assert dialer.outcome == Refused(1002, "expected a welcome")


def test_the_handshake_times_out_at_its_deadline_and_later_input_is_ignored() -> None:
    listener = machine("b", dialing=False, now=10.0)
    assert listener.deadline == 15.0
    listener.tick(14.999)
    assert listener.outcome is None
    listener.tick(15.0)
    assert listener.outcome == Refused(1008, "handshake timed out", "refused_timeout")
    listener.receive(machine("a", dialing=True).data_to_send()[0])
    assert listener.data_to_send() == []
    assert isinstance(listener.outcome, Refused)


def test_a_nonce_of_the_wrong_size_is_a_local_error() -> None:
    with pytest.raises(ValueError, match="nonce must be 16 bytes, got 3"):
        HandshakeMachine(
            node_id="a", address="h:1", incarnation=1, secret=SECRET, nonce=b"abc",
            dialing=True, now=0.0, timeout=1.0, max_frame=4096,
        )  # fmt: skip


def test_expiry_refuses_a_handshake_that_had_not_finished() -> None:
    listener = machine("b", dialing=False)
    assert listener.expire() == Refused(1008, "handshake timed out", "refused_timeout")
    assert listener.outcome == listener.expire()


def test_expiry_refuses_even_a_handshake_established_as_time_ran_out() -> None:
    # The shell's timeout can cut the write of the last frame short after the machine
    # reached Established: the peer never got it, so the link must not be used.
    dialer, listener = machine("a", dialing=True), machine("b", dialing=False)
    converse(dialer, listener)
    assert isinstance(listener.outcome, Established)
    assert listener.expire() == Refused(1008, "handshake timed out", "refused_timeout")
