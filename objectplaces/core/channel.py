"""One reliable, ordered session channel between an initiator and a participant.

Each side numbers the frames it sends from 0, keeps them until they are acknowledged,
and retransmits them with exponential backoff. The receiving side delivers frames in
order, buffers a bounded window of early ones, drops duplicates, and acknowledges
cumulatively after every data frame (a lost ack is repaired by the next duplicate).
A channel that exhausts its retransmissions is *broken*: the peer is treated as gone.
"""

from __future__ import annotations

from typing import Any

from objectplaces.core.messages import ChannelAck, ChannelData, FrameKind

__all__ = ["Channel"]

_WINDOW = 256  # early frames kept per channel; beyond that the sender retransmits


class Channel:
    """Both directions of one (session, epoch) channel, seen from one end."""

    __slots__ = (
        "_buffer",
        "_rto",
        "_sent",
        "acked_through",
        "broken",
        "closed",
        "epoch",
        "expected",
        "max_tries",
        "next_seq",
        "outbound_to_participant",
        "session",
    )

    def __init__(
        self,
        *,
        outbound_to_participant: bool,
        session: int,
        epoch: int,
        rto: float,
        max_tries: int,
    ) -> None:
        self.outbound_to_participant = outbound_to_participant
        self.session = session
        self.epoch = epoch
        self._rto = rto
        self.max_tries = max_tries
        self.next_seq = 0
        self.acked_through = -1
        self.expected = 0
        self.broken = False
        #: Set by the owner when it drops the channel: its timer then dies quietly.
        self.closed = False
        # seq -> [frame, next deadline, tries so far]
        self._sent: dict[int, list[Any]] = {}
        self._buffer: dict[int, ChannelData] = {}

    @property
    def idle(self) -> bool:
        """True when every frame sent has been acknowledged."""
        return not self._sent

    def send(self, kind: FrameKind, payload: Any, now: float) -> ChannelData:
        """Number a new frame, remember it for retransmission, and return it."""
        frame = ChannelData(
            self.outbound_to_participant, self.session, self.epoch, self.next_seq, kind, payload
        )
        self._sent[self.next_seq] = [frame, now + self._rto, 1]
        self.next_seq += 1
        return frame

    def on_ack(self, ack: int) -> None:
        """Forget every frame up to ``ack``."""
        if ack <= self.acked_through:
            return
        for seq in range(self.acked_through + 1, min(ack, self.next_seq - 1) + 1):
            self._sent.pop(seq, None)
        self.acked_through = ack

    def on_data(self, frame: ChannelData) -> tuple[list[ChannelData], ChannelAck]:
        """Accept a frame; return the frames now deliverable in order, and the ack to send."""
        deliver: list[ChannelData] = []
        if frame.seq == self.expected:
            deliver.append(frame)
            self.expected += 1
            while (early := self._buffer.pop(self.expected, None)) is not None:
                deliver.append(early)
                self.expected += 1
        elif self.expected < frame.seq < self.expected + _WINDOW:
            self._buffer[frame.seq] = frame
        # The initiator's end acks the participant's stream, and the other way round.
        ack = ChannelAck(self.outbound_to_participant, self.session, self.epoch, self.expected - 1)
        return deliver, ack

    def deadline(self) -> float | None:
        """When the oldest unacknowledged frame is due for retransmission."""
        return min((entry[1] for entry in self._sent.values()), default=None)

    def due(self, now: float) -> list[ChannelData]:
        """Frames to retransmit at ``now``; marks the channel broken when tries run out."""
        frames: list[ChannelData] = []
        for entry in self._sent.values():
            if entry[1] <= now:
                if entry[2] >= self.max_tries:
                    self.broken = True
                    return []
                entry[2] += 1
                entry[1] = now + self._rto * min(2 ** (entry[2] - 1), 16)
                frames.append(entry[0])
        return frames
