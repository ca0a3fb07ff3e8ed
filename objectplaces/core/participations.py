"""The participant side: roles this node plays in other nodes' sessions (docs/protocol.md §3).

A participation is created by the first frame of a new channel from an initiator, which
must be its ``ACTIVATE`` (sequence number 0). Any other frame of an unknown channel is
dropped and counted: a peer must not be able to make state appear with stray frames,
and a frame that merely overtook its ``ACTIVATE`` is retransmitted soon enough. A
participation is keyed by (initiator node, session number) and carries the channel's
epoch:

* a frame of an *older* epoch than the current participation is stale: acked (so the
  initiator stops retransmitting it) and dropped;
* a frame of a *newer* epoch means the initiator removed us and activated us again
  while our ``DEACTIVATE`` was still in flight: the old participation ends first, so the
  role hears ``out_group_of`` before a fresh role hears ``in_group_of``.

``ACTIVATE`` runs the registered factory for the role name. No factory (or one that
raises, or returns something that is not a ``Participant``) means ``DECLINED``; the
participation then lives only until the initiator acknowledges that answer, so the
retransmission of ``DECLINED`` is not cut short.

When a participation ends (deactivated, initiator gone, channel broken, node leaving),
its role hears ``out_group_of`` once, its timers are cancelled, and a *tombstone*
remembers the closed (initiator, session, epoch) for ``tombstone_ttl``, and at least as
long as a channel retransmits a frame before it breaks (an older epoch's ``ACTIVATE``,
still retransmitted, must never find it gone and open a role): late frames of
that channel are acknowledged (so the initiator stops retransmitting) and dropped,
instead of being taken for a new activation. Tombstones expire on a timer, so memory
stays bounded however many sessions a long run sees.

Failure detection is local and links can fail one way: this node may take an
initiator for failed while the initiator, hearing us, keeps us as a member. So a role
ended on our own (initiator failed, channel broken) is reported to the initiator with
an out-of-band ``LEFT``, instead of an ack: the initiator drops us as a member (and may
activate us afresh), rather than send into a tombstone that would swallow every message.
The initiator may send nothing more, so ``LEFT`` is retransmitted with backoff until
the initiator acknowledges it, the initiator is gone, or the tombstone expires. It
carries the number after the last frame of our stream, and the initiator acks exactly
that number, so no late ack of the stream is taken for it. Should every repeat be lost,
the initiator's ``PROBE`` (sent to its idle members now and then) finds a channel we
no longer know, and is answered with ``LEFT`` too.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

from objectplaces.core import codec
from objectplaces.core.channel import Channel, retransmission_span
from objectplaces.core.config import NodeConfig, ParticipationInfo
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.ids import InitiatorRef, session_id_for
from objectplaces.core.messages import ChannelAck, ChannelData, FrameKind
from objectplaces.core.plumbing import Plumbing
from objectplaces.core.roles import OutReason, Participant, ParticipantBinding, bind
from objectplaces.core.timers import ExpireTombstone, ParticipationOwner, RepeatLeft

__all__ = ["ParticipantFactory", "ParticipationTable", "tombstone_life"]

log = logging.getLogger("objectplaces")

ParticipantFactory = Callable[[], Participant]
Binder = Callable[[ParticipationOwner, InitiatorRef], ParticipantBinding]
"""Makes the context a freshly activated participant role is bound to."""


def _out_reason(payload: Any) -> OutReason:
    """The reason a ``DEACTIVATE`` carries (``STOPPED`` when it carries none we know)."""
    try:
        return OutReason(payload)
    except (ValueError, TypeError):
        return OutReason.STOPPED


def tombstone_life(config: NodeConfig) -> float:
    """How long a participant remembers a closed channel: ``tombstone_ttl``, and at least
    as long as a channel retransmits a frame, so no frame of it or of an older epoch's
    channel (opened before it) finds the tombstone gone (soak seed 1932)."""
    return max(
        config.tombstone_ttl,
        retransmission_span(config.retransmit_timeout, config.max_retransmissions),
    )


@dataclass(slots=True)
class _Participation:
    owner: ParticipationOwner
    channel: Channel
    ref: InitiatorRef
    since: float
    role: Participant | None = None
    role_name: str = ""
    declining: bool = False  # DECLINED sent; kept until the initiator acks it


@dataclass(slots=True)
class _Tombstone:
    epoch: int
    expires: float
    left_seq: int | None = None  # ended on our own: the number our LEFT carries
    left_wait: float | None = None  # until the next LEFT; None once acked (or moot)


class ParticipationTable:
    """Participant roles of this node, their channels, and tombstones of closed ones.

    Args:
        plumbing: the node's id, tunables (tombstone lifetime), outbox, channels, timers
            (tombstone expiries) and role timers (a role's timers die with it).
        binder: makes the context each activated role is bound to.
    """

    def __init__(self, plumbing: Plumbing, *, binder: Binder) -> None:
        self._node_id = plumbing.node_id
        self._config = plumbing.config
        self._outbox = plumbing.outbox
        self._channels = plumbing.channels
        self._timers = plumbing.timers
        self._role_timers = plumbing.role_timers
        self._binder = binder
        self._factories: dict[str, ParticipantFactory] = {}
        self._parts: dict[tuple[str, int], _Participation] = {}
        self._tombstones: dict[tuple[str, int], _Tombstone] = {}
        self._tomb_life = tombstone_life(self._config)

    # ------------------------------------------------------------------ factories

    def set_factory(self, name: str, factory: ParticipantFactory | None) -> None:
        """Register (or, with None, remove) the factory of participant role ``name``.

        Raises:
            LocalProtocolError: a bad name, or a factory that is not callable.
        """
        if not isinstance(name, str) or not name:
            raise LocalProtocolError(
                f"participant role name must be a non-empty string, got {name!r}"
            )
        if factory is None:
            self._factories.pop(name, None)
        elif not callable(factory):
            raise LocalProtocolError(
                f"participant factory for {name!r} is not callable: {factory!r}"
            )
        else:
            self._factories[name] = factory

    @property
    def factories(self) -> Mapping[str, ParticipantFactory]:
        """Participant role names this node can play, with their factories."""
        return self._factories

    # ------------------------------------------------------------------ frames

    def on_frame(self, source: str, frame: ChannelData, now: float) -> bool:
        """A frame from an initiator to a participant role (to be) on this node; False
        when it belongs to no channel here and opens none (dropped and counted)."""
        key = (source, frame.session)
        tomb = self._tombstones.get(key)
        if tomb is not None and frame.epoch <= tomb.epoch:
            self._outbox.count("dropped_stale")
            if tomb.left_seq is not None and frame.epoch == tomb.epoch:
                # We ended it on our own; the initiator, still talking, must learn it.
                self._tell_left(source, frame.session, tomb.epoch, tomb.left_seq)
            else:  # a closed channel: ack so the initiator stops retransmitting
                ack = ChannelAck(False, frame.session, frame.epoch, frame.seq)
                self._channels.acknowledge(source, ack)
            return True
        if tomb is not None:
            tomb.left_wait = None  # a newer epoch: the initiator has dropped the old one
        part = self._parts.get(key)
        if part is not None and part.owner.epoch != frame.epoch:
            if frame.epoch < part.owner.epoch:
                # Acked like a tombstone's, or the initiator's closing channel of that
                # epoch retransmits until it outlives every tombstone and its ACTIVATE
                # opens a role no session knows (soak seed 2200).
                self._outbox.count("dropped_stale")
                ack = ChannelAck(False, frame.session, frame.epoch, frame.seq)
                self._channels.acknowledge(source, ack)
                return True
            self._end(part, now, why=OutReason.LEFT_GROUP)  # removed, and activated anew
            part = None
        if part is None:
            if frame.seq != 0 or frame.kind is not FrameKind.ACTIVATE:
                # Only an activation opens a participation: a stray frame must not
                # make state appear (a reordered one is retransmitted after the ACTIVATE).
                self._outbox.count("dropped_unknown_session")
                if frame.kind is FrameKind.PROBE:  # it holds us as a member: we are not
                    self._tell_left(source, frame.session, frame.epoch, frame.seq)
                return False
            owner = ParticipationOwner(source, frame.session, frame.epoch)
            channel = self._channels.open(
                to_participant=False, session=frame.session, epoch=frame.epoch
            )
            ref = InitiatorRef(source, session_id_for(source, frame.session))
            part = self._parts[key] = _Participation(owner, channel, ref, now)
        deliver, ack = part.channel.on_data(frame)
        self._channels.acknowledge(source, ack)
        for item in deliver:
            if self._parts.get(key) is not part:
                break  # ended by an earlier frame of this batch (DEACTIVATE)
            self._on_initiator_said(part, item, now)
        return True

    def _on_initiator_said(self, part: _Participation, frame: ChannelData, now: float) -> None:
        match frame.kind:
            case FrameKind.ACTIVATE if part.role is None and not part.declining:
                self._activate(part, frame.payload, now)
            case FrameKind.ROLE if part.role is not None:
                self._outbox.call(part.role.receive, (frame.payload,), part.ref.session_id)
            case FrameKind.DEACTIVATE:
                self._end(part, now, why=_out_reason(frame.payload))
            case FrameKind.PROBE:
                pass  # acknowledged with the stream: we play the role
            case _:
                self._outbox.count("dropped_unexpected_frame")

    def _activate(self, part: _Participation, payload: Any, now: float) -> None:
        name = payload[0] if isinstance(payload, list) and payload else None
        factory = self._factories.get(name) if isinstance(name, str) else None
        role: Participant | None = None
        if factory is not None:
            try:
                role = factory()
                if not isinstance(role, Participant):
                    raise TypeError(f"factory for {name!r} returned {role!r}, not a Participant")
            except Exception:
                log.exception("node %s: participant factory %r failed", self._node_id, name)
                role = None
        initiator = part.owner.initiator
        if role is None:
            part.declining = True
            self._channels.send(initiator, part.channel, FrameKind.DECLINED, None, now)
            return
        part.role = role
        part.role_name = str(name)
        bind(role, self._binder(part.owner, part.ref))
        self._channels.send(initiator, part.channel, FrameKind.ACTIVATED, None, now)
        self._outbox.call(role.in_group_of, (part.ref,), part.ref.session_id)

    def on_ack(self, source: str, ack: ChannelAck, now: float) -> bool:
        """An initiator acknowledged frames of our stream to it; False when it was no
        channel of ours (dropped and counted)."""
        part = self._parts.get((source, ack.session))
        if part is None or part.owner.epoch != ack.epoch:
            tomb = self._tombstones.get((source, ack.session))
            if tomb is not None and tomb.epoch == ack.epoch and tomb.left_seq == ack.ack:
                tomb.left_wait = None  # the initiator has our LEFT
                return True
            self._outbox.count("dropped_stray_ack")
            return False
        self._channels.on_ack(source, part.channel, ack.ack, now)
        if part.declining and part.channel.idle:
            self._end(part, now)
        return True

    # ------------------------------------------------------------------ commands

    def send(self, owner: ParticipationOwner, message: Any, now: float) -> bool:
        """Send a role message to the initiator.

        Returns:
            False, with nothing sent, once the role is inactive or when the channel's
            send buffer is full (docs/protocol.md §4).

        Raises:
            NotPlainDataError, InvalidValueError: ``message`` is not plain data or too
                large (checked even when nothing would be sent).
        """
        part = self._parts.get((owner.initiator, owner.session))
        if part is None or part.owner != owner or part.role is None:
            codec.encode_value(message)
            return False
        channels = self._channels
        return channels.send(
            owner.initiator, part.channel, FrameKind.ROLE, message, now, limited=True
        )

    def _end(
        self,
        part: _Participation,
        now: float,
        *,
        on_our_own: bool = False,
        why: OutReason = OutReason.STOPPED,
    ) -> None:
        """End a participation, for the reason ``why``; ``on_our_own``: without the
        initiator's word (it seemed to have failed, or never acknowledged), so it is
        told, in case it still lives."""
        owner = part.owner
        key = (owner.initiator, owner.session)
        if self._parts.get(key) is part:
            del self._parts[key]
        part.channel.closed = True
        expires = now + self._tomb_life
        tomb = self._tombstones[key] = _Tombstone(owner.epoch, expires)
        self._timers.push(expires, ExpireTombstone(owner.initiator, owner.session))
        # A declining one is told too: its DECLINED may be what was lost, and the
        # initiator would hold it pending for ever (soak seed 1259).
        if on_our_own and (part.role is not None or part.declining):
            tomb.left_seq = part.channel.sent_through + 1
            tomb.left_wait = self._config.retransmit_timeout
            self._tell_left(owner.initiator, owner.session, owner.epoch, tomb.left_seq)
            repeat = RepeatLeft(owner.initiator, owner.session, owner.epoch)
            self._timers.push(now + tomb.left_wait, repeat)
        self._role_timers.cancel(owner)
        role = part.role
        if role is not None:
            part.role = None
            role.out_reason = OutReason.UNREACHABLE if on_our_own else why
            self._outbox.call(role.out_group_of, (part.ref,), part.ref.session_id)

    def _tell_left(self, initiator: str, session: int, epoch: int, seq: int) -> None:
        # Out of band (docs/protocol.md §3): numbered past our stream, so that its ack
        # cannot be mistaken for a late ack of the stream.
        left = ChannelData(False, session, epoch, seq, FrameKind.LEFT, None)
        self._outbox.send(initiator, codec.encode(left), "channel")

    def repeat_left(self, repeat: RepeatLeft, now: float) -> None:
        """Send the ``LEFT`` of that channel again unless it was acknowledged, with the
        channels' backoff (doubling up to 16 times ``retransmit_timeout``)."""
        tomb = self._tombstones.get((repeat.initiator, repeat.session))
        if tomb is None or tomb.epoch != repeat.epoch:
            return  # expired, or superseded by a later channel's (with its own timer)
        if tomb.left_wait is None or tomb.left_seq is None:
            return
        self._tell_left(repeat.initiator, repeat.session, tomb.epoch, tomb.left_seq)
        tomb.left_wait = min(2 * tomb.left_wait, 16 * self._config.retransmit_timeout)
        self._timers.push(now + tomb.left_wait, repeat)

    def initiator_gone(self, node: str, now: float, *, failed: bool) -> None:
        """``node`` failed (``failed``) or left: every role in its sessions ends."""
        for part in [p for p in self._parts.values() if p.owner.initiator == node]:
            self._end(part, now, on_our_own=failed)  # UNREACHABLE, or STOPPED: it left
        if not failed:  # it left on purpose: no one is there to hear a LEFT
            for (initiator, _), tomb in self._tombstones.items():
                if initiator == node:
                    tomb.left_wait = None

    def plays_for(self, initiator: str) -> bool:
        """Whether this node plays a role in a session of ``initiator``."""
        return any(key[0] == initiator for key in self._parts)

    def end_all(self, now: float) -> None:
        """End every participation (this node leaves)."""
        for part in list(self._parts.values()):
            self._end(part, now, why=OutReason.NODE_LEFT)

    def forget_tombstones_of(self, node: str) -> None:
        """``node`` restarted: its new run's sessions reuse numbers and must count."""
        for key in [k for k in self._tombstones if k[0] == node]:
            del self._tombstones[key]

    def expire_tombstone(self, initiator: str, session: int, now: float) -> None:
        """Forget a tombstone whose time is up (a newer one for the same key stays)."""
        key = (initiator, session)
        tomb = self._tombstones.get(key)
        if tomb is not None and tomb.expires <= now:
            del self._tombstones[key]

    # ------------------------------------------------------------------ channels

    def channel_broken(self, target: str, channel: Channel, now: float) -> None:
        """The initiator never acknowledged: the participation ends."""
        part = self._parts.get((target, channel.session))
        if part is not None and part.channel is channel:
            self._end(part, now, on_our_own=True)

    # ------------------------------------------------------------------ introspection

    def infos(self) -> list[ParticipationInfo]:
        """Participant roles active on this node."""
        return [
            ParticipationInfo(p.ref.session_id, p.owner.initiator, p.role_name, p.since)
            for p in self._parts.values()
            if p.role is not None
        ]

    def counts(self) -> dict[str, int]:
        """Sizes of the per-participation structures."""
        return {"participations": len(self._parts), "tombstones": len(self._tombstones)}
