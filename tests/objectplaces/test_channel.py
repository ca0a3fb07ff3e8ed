"""The reliable channel: in order, exactly once, whatever the network does to frames;
at most a window in flight, a bounded send buffer behind it (docs/protocol.md §4)."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from objectplaces.core import codec
from objectplaces.core.channel import WINDOW, Channel
from objectplaces.core.errors import InvalidValueError, NotPlainDataError
from objectplaces.core.messages import ChannelData, FrameKind


def pair(**kwargs: int) -> tuple[Channel, Channel]:
    sender = Channel(
        outbound_to_participant=True, session=1, epoch=1, rto=0.1, max_tries=5, **kwargs
    )
    receiver = Channel(outbound_to_participant=False, session=1, epoch=1, rto=0.1, max_tries=5)
    return sender, receiver


def frames(data: list[bytes]) -> list[ChannelData]:
    out = []
    for item in data:
        frame = codec.decode(item)
        assert isinstance(frame, ChannelData)
        out.append(frame)
    return out


def send(channel: Channel, payload: object, now: float = 0.0) -> list[ChannelData]:
    assert channel.offer(FrameKind.ROLE, payload)
    return frames(channel.transmit(now))


@given(order=st.permutations(range(12)), dups=st.lists(st.integers(0, 11), max_size=6))
def test_any_arrival_order_delivers_each_frame_once_in_order(
    order: list[int], dups: list[int]
) -> None:
    sender, receiver = pair()
    sent = [frame for i in range(12) for frame in send(sender, i)]
    delivered: list[ChannelData] = []
    last_ack = -1
    for seq in order + dups:
        got, ack = receiver.on_data(sent[seq])
        delivered += got
        assert ack.ack >= last_ack  # cumulative acks never go back
        last_ack = ack.ack
    assert [f.payload for f in delivered] == list(range(12))
    assert sender.on_ack(last_ack)
    assert sender.idle


def test_retransmission_backs_off_then_breaks() -> None:
    sender, _ = pair()
    send(sender, "x")
    assert sender.deadline() == 0.1
    assert sender.due(0.05) == []
    times = []
    now = 0.0
    while not sender.broken:
        now = sender.deadline()  # type: ignore[assignment]
        if sender.due(now):
            times.append(round(now, 3))
    assert times == [0.1, 0.3, 0.7, 1.5]  # doubling gaps, then max_tries reached
    assert sender.broken


def test_ack_of_part_of_the_stream_keeps_the_rest() -> None:
    sender, _ = pair()
    for i in range(3):
        send(sender, i)
    assert sender.on_ack(0)
    assert [f.payload for f in frames(sender.due(1.0))] == [1, 2]
    assert sender.on_ack(2)
    assert sender.idle
    assert sender.on_ack(1)  # a late, older ack changes nothing
    assert sender.idle


def test_an_ack_beyond_anything_sent_is_ignored() -> None:
    sender, _ = pair()
    send(sender, "a")
    send(sender, "b")
    assert not sender.on_ack(5)  # a forgery, or a bug: not taken as is
    assert sender.in_flight == 2
    assert [f.payload for f in frames(sender.due(1.0))] == ["a", "b"]


def test_each_end_acks_the_other_ends_stream() -> None:
    initiator_end, participant_end = pair()
    assert initiator_end.offer(FrameKind.ACTIVATE, None)
    [frame] = frames(initiator_end.transmit(0.0))
    _, ack = participant_end.on_data(frame)
    assert ack.of_participant_stream is False
    assert participant_end.offer(FrameKind.ACTIVATED, None)
    [back] = frames(participant_end.transmit(0.0))
    _, ack = initiator_end.on_data(back)
    assert ack.of_participant_stream is True


def test_at_most_the_window_is_in_flight_and_the_rest_waits() -> None:
    sender, receiver = pair()
    for i in range(WINDOW + 100):
        assert sender.offer(FrameKind.ROLE, i, limited=True)
    first = frames(sender.transmit(0.0))
    assert len(first) == WINDOW
    assert (sender.in_flight, sender.buffered) == (WINDOW, 100)
    assert sender.transmit(0.0) == []  # the window is full
    for frame in first:
        _, ack = receiver.on_data(frame)  # every frame of the window is taken
    assert receiver.expected == WINDOW
    assert sender.on_ack(ack.ack)
    rest = frames(sender.transmit(0.5))
    assert [f.seq for f in rest] == list(range(WINDOW, WINDOW + 100))
    assert sender.deadline() == 0.6  # retries count from each frame's own transmission


def test_a_full_send_buffer_refuses_role_messages_but_never_control_frames() -> None:
    sender, _ = pair(send_buffer=3)
    assert all(sender.offer(FrameKind.ROLE, i, limited=True) for i in range(3))
    assert not sender.offer(FrameKind.ROLE, 3, limited=True)
    assert sender.offer(FrameKind.DEACTIVATE, None)  # never refused
    assert sender.buffered == 4
    sender.transmit(0.0)
    assert sender.offer(FrameKind.ROLE, 4, limited=True)  # room again


def test_a_bad_payload_fails_at_the_offer_and_nothing_is_queued() -> None:
    sender, _ = pair(max_frame=1000)
    with pytest.raises(NotPlainDataError):
        sender.offer(FrameKind.ROLE, {"obj": object()})
    with pytest.raises(InvalidValueError, match="exceeds the frame limit of 1000"):
        sender.offer(FrameKind.ROLE, b"x" * 2000)
    assert sender.idle
    assert sender.next_seq == 0
    send(sender, "fine")
    assert sender.in_flight == 1


def test_deadlines_stay_cheap_with_a_full_window() -> None:
    sender, _ = pair()
    for i in range(WINDOW):
        send(sender, i, now=i * 0.001)
    assert sender.deadline() == pytest.approx(0.1)
    assert sender.on_ack(WINDOW // 2 - 1)
    assert sender.deadline() == pytest.approx(0.1 + (WINDOW // 2) * 0.001)
    assert len(sender.due(10.0)) == WINDOW // 2
