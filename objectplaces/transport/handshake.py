"""The mesh handshake as a machine: versioned hello, HMAC challenge/response (sans-I/O).

A link starts with four frames (layouts in ``mesh_frames``)::

    dialer                                  listener
      hello(version, node, address, incarnation, nonce_d)  ->
                        <-  challenge(version, node, address, incarnation, nonce_l)
      auth(mac_d)                                          ->
                        <-  welcome(mac_l)

Each side proves the shared secret with an HMAC over both ids and both nonces,
labelled by direction (``mesh_frames.handshake_macs``): neither proof can be replayed
as the other, and the secret never travels. The listener checks the dialer's proof
before it proves anything itself, so a dialer without the secret learns nothing.

The machine only reads and writes bytes: ``receive`` takes each message the shell
reads, ``data_to_send`` gives what the shell must write, and ``outcome`` says when the
handshake is over: ``Established`` or ``Refused`` (with the close code, the reason and
the counter the transport bumps). Randomness (the nonce) and time come in from the
shell; ``tick(now)`` past ``deadline`` refuses with a timeout.
"""

from __future__ import annotations

import hmac
from dataclasses import dataclass

from objectplaces.core.errors import DecodeError
from objectplaces.transport.mesh_frames import (
    NONCE_SIZE,
    Auth,
    Hello,
    TransportFrame,
    VersionMismatch,
    decode_transport,
    encode_auth,
    encode_hello,
    handshake_macs,
)
from objectplaces.transport.policing import CloseCode

__all__ = ["Established", "HandshakeMachine", "Refused"]


@dataclass(frozen=True, slots=True)
class Established:
    """The handshake succeeded: who the peer is, where it listens, which run of it.

    Attributes:
        dialer: the id of the side that dialed (arbitrates duplicate links).
    """

    peer: str
    address: str
    incarnation: int
    dialer: str


@dataclass(frozen=True, slots=True)
class Refused:
    """The handshake failed: close the connection with ``code`` and ``reason``.

    Attributes:
        counter: the transport counter this refusal bumps ("" for none).
    """

    code: int
    reason: str
    counter: str = ""


class HandshakeMachine:
    """One side of one link's handshake.

    Args:
        node_id: this node's id.
        address: where this node listens (told to the peer).
        incarnation: this run of the node.
        secret: the mesh's shared secret.
        nonce: ``NONCE_SIZE`` fresh random bytes.
        dialing: True on the side that dialed, False on the listener.
        now: the time the connection opened.
        timeout: time allowed for the whole handshake.
        max_frame: largest handshake frame accepted, in bytes.
        dialed: the address dialed (dialer only; names it in refusals).
        certified: the id the peer's TLS certificate names (None on a plain link): a
            hello naming another id is refused, whatever it proves.
        tag: what every member of the fleet shares (``Hello.tag``): a peer with another
            tag is refused, the reason naming both.
    """

    def __init__(
        self,
        *,
        node_id: str,
        address: str,
        incarnation: int,
        secret: bytes,
        nonce: bytes,
        dialing: bool,
        now: float,
        timeout: float,
        max_frame: int,
        dialed: str = "",
        certified: str | None = None,
        tag: str = "",
    ) -> None:
        if len(nonce) != NONCE_SIZE:
            raise ValueError(f"nonce must be {NONCE_SIZE} bytes, got {len(nonce)}")
        self.node_id = node_id
        self.dialing = dialing
        self.deadline = now + timeout
        self.outcome: Established | Refused | None = None
        self._address = address
        self._incarnation = incarnation
        self._secret = secret
        self._nonce = nonce
        self._max_frame = max_frame
        self._dialed = dialed
        self._certified = certified
        self._tag = tag
        self._peer: Hello | None = None
        self._expected_mac = b""
        self._outbox: list[bytes] = []
        if dialing:
            self._outbox.append(self._hello(challenge=False))

    def data_to_send(self) -> list[bytes]:
        """Take the frames to write, in order."""
        out, self._outbox = self._outbox, []
        return out

    def receive(self, data: str | bytes) -> None:
        """Take one message from the peer (ignored once there is an ``outcome``)."""
        if self.outcome is not None:
            return
        frame = self._decode(data)
        if frame is None:
            return
        if self.dialing:
            self._dialer_step(frame)
        else:
            self._listener_step(frame)

    def tick(self, now: float) -> None:
        """Let time pass: past ``deadline`` without an outcome, the handshake times out."""
        if self.outcome is None and now >= self.deadline:
            self._refuse(CloseCode.POLICY_VIOLATION, "handshake timed out", "refused_timeout")

    def expire(self) -> Refused:
        """The shell's time for the handshake ran out: the handshake is refused.

        Also when it had just reached ``Established``: the timeout may have cut the
        write of its last frame short, so the peer cannot count on the link. The peer
        dials again.
        """
        if not isinstance(self.outcome, Refused):
            self._refuse(CloseCode.POLICY_VIOLATION, "handshake timed out", "refused_timeout")
        assert isinstance(self.outcome, Refused)
        return self.outcome

    # ------------------------------------------------------------------ steps

    def _dialer_step(self, frame: TransportFrame) -> None:
        peer = self._peer
        if peer is None:
            if not isinstance(frame, Hello) or not frame.challenge:
                self._refuse(CloseCode.PROTOCOL_ERROR, "expected a challenge")
            elif frame.node == self.node_id:
                self._refuse(CloseCode.POLICY_VIOLATION, f"{self._dialed} is this node itself")
            elif not self._as_certified(frame.node) or not self._same_tag(frame):
                pass
            else:
                self._peer = frame
                ours, theirs = handshake_macs(
                    self._secret, self.node_id, frame.node, self._nonce, frame.nonce
                )
                self._expected_mac = theirs
                self._outbox.append(encode_auth(ours))
        elif not isinstance(frame, Auth) or not frame.welcome:
            self._refuse(CloseCode.PROTOCOL_ERROR, "expected a welcome")
        elif not hmac.compare_digest(frame.mac, self._expected_mac):
            self._refuse(CloseCode.POLICY_VIOLATION, "authentication failed", "refused_auth")
        else:
            self.outcome = Established(peer.node, peer.address, peer.incarnation, self.node_id)

    def _listener_step(self, frame: TransportFrame) -> None:
        peer = self._peer
        if peer is None:
            if not isinstance(frame, Hello) or frame.challenge:
                self._refuse(CloseCode.PROTOCOL_ERROR, "expected a hello")
            elif frame.node == self.node_id:
                self._refuse(CloseCode.POLICY_VIOLATION, f"node id {frame.node!r} is this node's")
            elif not self._as_certified(frame.node) or not self._same_tag(frame):
                pass
            else:
                self._peer = frame
                self._outbox.append(self._hello(challenge=True))
            return
        theirs, ours = handshake_macs(
            self._secret, peer.node, self.node_id, peer.nonce, self._nonce
        )
        if (
            not isinstance(frame, Auth)
            or frame.welcome
            or not hmac.compare_digest(frame.mac, theirs)
        ):
            self._refuse(
                CloseCode.POLICY_VIOLATION,
                f"authentication failed for {peer.node!r}",
                "refused_auth",
            )
            return
        self._outbox.append(encode_auth(ours, welcome=True))
        self.outcome = Established(peer.node, peer.address, peer.incarnation, peer.node)

    # ------------------------------------------------------------------ helpers

    def _as_certified(self, claimed: str) -> bool:
        """Whether the id a hello claims is the one the peer's certificate names (refuses
        the handshake if not)."""
        if self._certified is None or claimed == self._certified:
            return True
        self._refuse(
            CloseCode.POLICY_VIOLATION,
            f"certificate names {self._certified!r}, hello claims {claimed!r}",
            "refused_identity",
        )
        return False

    def _same_tag(self, hello: Hello) -> bool:
        """Whether the peer's fleet tag is ours (refuses the handshake if not)."""
        if hello.tag == self._tag:
            return True
        self._refuse(
            CloseCode.POLICY_VIOLATION,
            f"another fleet: {hello.node} runs {hello.tag!r}, {self.node_id} runs {self._tag!r}",
            "refused_tag",
        )
        return False

    def _hello(self, *, challenge: bool) -> bytes:
        return encode_hello(
            challenge=challenge,
            node=self.node_id,
            address=self._address,
            incarnation=self._incarnation,
            nonce=self._nonce,
            tag=self._tag,
        )

    def _decode(self, data: str | bytes) -> TransportFrame | None:
        if not isinstance(data, bytes):
            self._refuse(
                CloseCode.UNSUPPORTED_DATA, "text frames are not accepted", "refused_malformed"
            )
            return None
        try:
            frame = decode_transport(data, max_size=self._max_frame)
        except VersionMismatch as exc:
            self._refuse(CloseCode.POLICY_VIOLATION, str(exc), "refused_version")
            return None
        except DecodeError as exc:
            self._refuse(
                CloseCode.PROTOCOL_ERROR, f"malformed handshake: {exc}", "refused_malformed"
            )
            return None
        return frame

    def _refuse(self, code: int, reason: str, counter: str = "") -> None:
        self.outcome = Refused(code, reason, counter)
