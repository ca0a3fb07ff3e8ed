"""How both session tables put channel frames on the wire (docs/protocol.md §4).

``Channel`` (channel.py) is the pure bookkeeping of one channel: sequence numbers,
what is unacknowledged, what arrived early. This part adds the three things every
owner of a channel needs the same way, so neither the initiator side nor the
participant side repeats them:

* ``send``: number a frame, encode it, queue it, and arm the channel's retransmission
  timer if the channel was idle. One timer per channel, not per frame: a burst of a
  thousand messages costs one heap entry, re-armed at the next due frame each time it
  fires.
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

from objectplaces.core import codec
from objectplaces.core.channel import Channel
from objectplaces.core.config import NodeConfig
from objectplaces.core.messages import ChannelAck, FrameKind
from objectplaces.core.outbox import Outbox
from objectplaces.core.timers import Retransmit, TimerQueue

__all__ = ["Channels"]


class Channels:
    """Opens channels and moves their frames through the outbox.

    Args:
        config: retransmission timeout and limit.
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
        return Channel(
            outbound_to_participant=to_participant,
            session=session,
            epoch=epoch,
            rto=self._config.retransmit_timeout,
            max_tries=self._config.max_retransmissions,
        )

    def send(
        self, target: str, channel: Channel, kind: FrameKind, payload: Any, now: float
    ) -> None:
        """Send one reliable frame to ``target`` on ``channel``."""
        was_idle = channel.idle
        frame = channel.send(kind, payload, now)
        self._outbox.send(target, codec.encode(frame), "channel")
        if was_idle:
            self._timers.push(now + self._config.retransmit_timeout, Retransmit(target, channel))

    def acknowledge(self, target: str, ack: ChannelAck) -> None:
        """Send a cumulative ack to ``target``."""
        self._outbox.send(target, codec.encode(ack), "ack")

    def retransmit(self, target: str, channel: Channel, now: float) -> bool:
        """Resend the frames due at ``now``; return True when the channel just broke."""
        for frame in channel.due(now):
            self._outbox.count("retransmissions")
            self._outbox.send(target, codec.encode(frame), "channel")
        if channel.broken:
            self._outbox.count("channels_broken")
            return True
        deadline = channel.deadline()
        if deadline is not None:
            self._timers.push(deadline, Retransmit(target, channel))
        return False
