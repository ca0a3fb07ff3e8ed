"""One reliable, ordered session channel between an initiator and a participant.

The sending side (docs/protocol.md §4):

* **Encoded at the call.** ``offer`` numbers a frame and encodes it at once, so a
  payload that is not plain data (or too large for a frame) fails in the caller's
  ``send``, with nothing queued, instead of at some later retransmission.
* **Flow control.** At most ``WINDOW`` frames are in flight (transmitted, not yet
  acknowledged): exactly what the receiver buffers, so no frame is ever sent that the
  receiver must throw away. The rest wait in a send buffer of at most ``send_buffer``
  role messages (control frames, a handful per channel, are never refused); when it is
  full, ``offer`` says so and the role's ``send`` returns False. A burst therefore
  costs memory, bounded, never a healthy member.
* **Retransmission.** Each frame in flight keeps its own count of transmissions and
  its own deadline, measured from its own last transmission, with exponential backoff
  (capped at 16 x ``rto``). A frame that reaches ``max_tries`` transmissions without an
  acknowledgement marks the channel *broken*: the peer is treated as gone. Waiting in
  the buffer costs a frame no tries. Deadlines live in a heap, so finding the next one
  costs O(log n) however many frames are in flight.
* **Acknowledgements** are cumulative. One beyond anything transmitted is a forgery or
  a bug: ignored (``on_ack`` returns False, the owner counts it).

The receiving side delivers in order, buffers early frames within the window, drops
duplicates, and acknowledges cumulatively after every data frame, duplicates included:
a lost ack is repaired by the next duplicate.
"""

from __future__ import annotations

import heapq
from collections import deque
from typing import Any, Final

from objectplaces.core import codec
from objectplaces.core.errors import InvalidValueError
from objectplaces.core.messages import ChannelAck, ChannelData, FrameKind

__all__ = ["DEFAULT_SEND_BUFFER", "WINDOW", "Channel", "retransmission_span"]

WINDOW: Final = 256
"""Frames in flight per direction; the receiver buffers this many early frames."""
DEFAULT_SEND_BUFFER: Final = 10_000
"""Role messages a channel holds beyond the window before ``send`` returns False."""
_MAX_BACKOFF: Final = 16


def retransmission_span(rto: float, max_tries: int) -> float:
    """Seconds from a frame's first transmission until, never acknowledged, it breaks
    its channel: its ``max_tries`` waits, each twice the one before up to 16 x ``rto``."""
    return rto * sum(min(1 << i, _MAX_BACKOFF) for i in range(max_tries))


class _InFlight:
    """A transmitted frame awaiting its acknowledgement."""

    __slots__ = ("data", "deadline", "tries")

    def __init__(self, data: bytes, deadline: float) -> None:
        self.data = data
        self.deadline = deadline
        self.tries = 1


class Channel:
    """Both directions of one (session, epoch) channel, seen from one end.

    Args:
        outbound_to_participant: this end is the initiator's.
        session: the session number on the initiator's node.
        epoch: the participant's activation count in the session.
        rto: first retransmission timeout, seconds.
        max_tries: transmissions of one frame before the channel counts as broken.
        send_buffer: role messages held beyond the window.
        max_frame: largest encoded frame, bytes.
    """

    __slots__ = (
        "_early",
        "_flight",
        "_heap",
        "_limited",
        "_max_frame",
        "_rto",
        "_send_buffer",
        "_waiting",
        "acked_through",
        "armed_at",
        "broken",
        "closed",
        "epoch",
        "expected",
        "max_tries",
        "next_seq",
        "outbound_to_participant",
        "sent_through",
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
        send_buffer: int = DEFAULT_SEND_BUFFER,
        max_frame: int = codec.DEFAULT_MAX_FRAME,
    ) -> None:
        self.outbound_to_participant = outbound_to_participant
        self.session = session
        self.epoch = epoch
        self._rto = rto
        self.max_tries = max_tries
        self._send_buffer = send_buffer
        self._max_frame = max_frame
        self.next_seq = 0  # the next frame's number
        self.sent_through = -1  # the highest number transmitted
        self.acked_through = -1
        self.broken = False
        #: Set by the owner when it drops the channel: its timer then dies quietly.
        self.closed = False
        #: Deadline of the pending retransmission timer (kept by ``Channels``).
        self.armed_at: float | None = None
        self._waiting: deque[tuple[bytes, bool]] = deque()  # (frame, is a role message)
        self._limited = 0  # role messages in ``_waiting``
        self._flight: dict[int, _InFlight] = {}
        self._heap: list[tuple[float, int]] = []  # (deadline, seq); stale entries skipped
        self.expected = 0
        self._early: dict[int, ChannelData] = {}

    # ------------------------------------------------------------------ sending

    @property
    def idle(self) -> bool:
        """True when everything offered has been acknowledged."""
        return not self._flight and not self._waiting

    @property
    def in_flight(self) -> int:
        """Frames transmitted and not yet acknowledged."""
        return len(self._flight)

    @property
    def buffered(self) -> int:
        """Frames offered and not yet transmitted."""
        return len(self._waiting)

    def offer(self, kind: FrameKind, payload: Any, *, limited: bool = False) -> bool:
        """Number and encode a frame and queue it for transmission.

        Args:
            kind: what the frame carries.
            payload: its content (plain data).
            limited: a role message, refused when the send buffer is full.

        Returns:
            False (nothing queued) when ``limited`` and the send buffer is full.

        Raises:
            NotPlainDataError: the payload is not plain data.
            InvalidValueError: the encoded frame exceeds the frame limit.
        """
        if limited and self._limited >= self._send_buffer:
            return False
        frame = ChannelData(
            self.outbound_to_participant, self.session, self.epoch, self.next_seq, kind, payload
        )
        data = codec.encode(frame)
        if len(data) > self._max_frame:
            raise InvalidValueError(
                f"message of {len(data)} bytes exceeds the frame limit of {self._max_frame}"
            )
        self.next_seq += 1
        self._waiting.append((data, limited))
        self._limited += limited
        return True

    def transmit(self, now: float) -> list[bytes]:
        """Move what the window allows from the buffer into flight; return those frames."""
        out: list[bytes] = []
        waiting, limit = self._waiting, self.acked_through + WINDOW
        deadline = now + self._rto
        while waiting and self.sent_through < limit:
            data, limited = waiting.popleft()
            self._limited -= limited
            self.sent_through += 1
            self._flight[self.sent_through] = _InFlight(data, deadline)
            heapq.heappush(self._heap, (deadline, self.sent_through))
            out.append(data)
        return out

    def on_ack(self, ack: int) -> bool:
        """Forget every frame up to ``ack``; False when ``ack`` is beyond anything sent."""
        if ack > self.sent_through:
            return False
        flight = self._flight
        for seq in range(self.acked_through + 1, ack + 1):
            flight.pop(seq, None)
        self.acked_through = max(self.acked_through, ack)
        if len(self._heap) > 2 * len(flight) + 64:  # acked frames' entries pile up
            self._heap = [(d, s) for d, s in self._heap if self._live(d, s)]
            heapq.heapify(self._heap)
        return True

    def _live(self, deadline: float, seq: int) -> bool:
        entry = self._flight.get(seq)
        return entry is not None and entry.deadline == deadline

    def deadline(self) -> float | None:
        """When the next frame in flight is due for retransmission (None: nothing is)."""
        heap = self._heap
        while heap and not self._live(*heap[0]):
            heapq.heappop(heap)
        return heap[0][0] if heap else None

    def break_span(self) -> float:
        """Seconds from a frame's first transmission until, never acknowledged, it
        breaks the channel (at the current retransmission timeout)."""
        return retransmission_span(self._rto, self.max_tries)

    def due(self, now: float) -> list[bytes]:
        """Frames to retransmit at ``now``; marks the channel broken when one ran out of tries."""
        out: list[bytes] = []
        heap = self._heap
        while (deadline := self.deadline()) is not None and deadline <= now:
            _, seq = heapq.heappop(heap)
            entry = self._flight[seq]
            if entry.tries >= self.max_tries:
                self.broken = True
                return []
            entry.tries += 1
            entry.deadline = now + self._rto * min(2 ** (entry.tries - 1), _MAX_BACKOFF)
            heapq.heappush(heap, (entry.deadline, seq))
            out.append(entry.data)
        return out

    # ------------------------------------------------------------------ receiving

    def on_data(self, frame: ChannelData) -> tuple[list[ChannelData], ChannelAck]:
        """Accept a frame; return the frames now deliverable in order, and the ack to send."""
        deliver: list[ChannelData] = []
        if frame.seq == self.expected:
            deliver.append(frame)
            self.expected += 1
            while (early := self._early.pop(self.expected, None)) is not None:
                deliver.append(early)
                self.expected += 1
        elif self.expected < frame.seq < self.expected + WINDOW:
            self._early[frame.seq] = frame
        # The initiator's end acks the participant's stream, and the other way round.
        ack = ChannelAck(self.outbound_to_participant, self.session, self.epoch, self.expected - 1)
        return deliver, ack
