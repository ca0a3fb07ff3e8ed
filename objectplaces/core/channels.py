"""How both session tables put channel frames on the wire (docs/protocol.md §4).

``Channel`` (channel.py) is the pure bookkeeping of one channel: sequence numbers,
what is unacknowledged, what arrived early. This part adds the three things every
owner of a channel needs the same way, so neither the initiator side nor the
participant side repeats them:

* ``send``: number a frame, encode it (a bad payload fails here, nothing queued),
  transmit what the window allows, and arm the channel's retransmission timer. One
  timer per channel, not per frame: a burst of a thousand messages costs one heap
  entry, re-armed at the next due frame each time it fires.
* ``on_ack``: the window moves; frames waiting in the send buffer go out. The last
  ack disarms the timer: with nothing unacknowledged it would only fire to find so.
* ``acknowledge``: acks are cumulative and sent after every data frame, duplicates
  included, because a lost ack is repaired only by the next duplicate.
* ``retransmit``: resend what is due; report a channel whose retries ran out as broken.
  What "broken" means (the peer is gone from that session) is the owner's decision.

An owner that drops a channel marks it ``closed``; its timer then dies quietly (it is
skipped when it fires, and dropped from the queue when it reaches the top), so closing
costs O(1) and needs no search through the heap.
"""

from __future__ import annotations

from typing import Any

from mypy_extensions import mypyc_attr

from objectplaces.core import codec
from objectplaces.core.channel import Channel
from objectplaces.core.config import NodeConfig
from objectplaces.core.messages import ChannelAck, FrameKind
from objectplaces.core.outbox import Outbox
from objectplaces.core.timers import Retransmit, TimerQueue

__all__ = ["Channels"]


@mypyc_attr(allow_interpreted_subclasses=True)
class Channels:
    """Opens channels and moves their frames through the outbox.

    Args:
        config: retransmission timeout and limit, send buffer, frame limit.
        outbox: where frames and counters go.
        timers: where retransmission timers go.
    """

    __slots__ = ("_config", "_outbox", "_timers")

    def __init__(self, config: NodeConfig, outbox: Outbox, timers: TimerQueue) -> None:
        self._config = config
        self._outbox = outbox
        self._timers = timers

    def open(self, *, to_participant: bool, session: int, epoch: int) -> Channel:
        """A new channel; ``to_participant``: this end is the initiator's."""
        config = self._config
        return Channel(
            outbound_to_participant=to_participant,
            session=session,
            epoch=epoch,
            rto=config.retransmit_timeout,
            max_tries=config.max_retransmissions,
            send_buffer=config.send_buffer,
            max_frame=config.max_frame,
        )

    def send(
        self,
        target: str,
        channel: Channel,
        kind: FrameKind,
        payload: Any,
        now: float,
        *,
        limited: bool = False,
    ) -> bool:
        """Send one reliable frame to ``target`` on ``channel`` (now, or when the window
        opens); False when ``limited`` and the channel's send buffer is full.

        Raises:
            NotPlainDataError: the payload is not plain data (nothing is queued).
            InvalidValueError: the frame would exceed the frame limit (nothing is queued).
        """
        if not channel.offer(kind, payload, limited=limited):
            self._outbox.count("send_buffer_full")
            return False
        self._transmit(target, channel, now)
        return True

    def on_ack(self, target: str, channel: Channel, ack: int, now: float) -> None:
        """``target`` acknowledged ``channel``'s frames up to ``ack``: the window moves."""
        if not channel.on_ack(ack):
            self._outbox.count("dropped_ack_beyond_sent")
            return
        if channel.idle:
            # Everything is acknowledged: the armed timer would fire with nothing to
            # resend. Disarmed, it is dead (``timers.is_dead``); the next send arms anew.
            channel.armed_at = None
            return
        self._transmit(target, channel, now)

    def acknowledge(self, target: str, ack: ChannelAck) -> None:
        """Send a cumulative ack to ``target``, unless it acknowledges nothing.

        A frame that arrives ahead of frame 0 leaves nothing delivered in order; an ack of
        -1 would tell the sender nothing, and its intake refuses negative acks (§7).
        """
        if ack.ack < 0:
            return
        self._outbox.send(target, codec.encode(ack), "ack")

    def retransmit(self, target: str, channel: Channel, at: float, now: float) -> bool:
        """The timer armed for ``at`` fired: resend what is due; True when the channel broke."""
        if channel.armed_at != at:
            return False  # superseded by an earlier timer, which re-armed itself
        channel.armed_at = None
        outbox = self._outbox
        for data in channel.due(now):
            outbox.count("retransmissions")
            outbox.send(target, data, "channel")
        if channel.broken:
            outbox.count("channels_broken")
            return True
        self._arm(target, channel)
        return False

    def _transmit(self, target: str, channel: Channel, now: float) -> None:
        outbox = self._outbox
        for data in channel.transmit(now):
            outbox.send(target, data, "channel")
        self._arm(target, channel)

    def _arm(self, target: str, channel: Channel) -> None:
        # One pending timer per channel, at its earliest deadline; a new frame may be
        # due before the backed-off frames already in flight, and then gets its own.
        deadline = channel.deadline()
        if deadline is not None and (channel.armed_at is None or deadline < channel.armed_at):
            channel.armed_at = deadline
            self._timers.push(deadline, Retransmit(target, channel, deadline))
