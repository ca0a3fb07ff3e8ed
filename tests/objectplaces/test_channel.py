"""The reliable channel: in order, exactly once, whatever the network does to frames."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from objectplaces.core.channel import Channel
from objectplaces.core.messages import ChannelData, FrameKind


def pair() -> tuple[Channel, Channel]:
    sender = Channel(outbound_to_participant=True, session=1, epoch=1, rto=0.1, max_tries=5)
    receiver = Channel(outbound_to_participant=False, session=1, epoch=1, rto=0.1, max_tries=5)
    return sender, receiver


@given(order=st.permutations(range(12)), dups=st.lists(st.integers(0, 11), max_size=6))
def test_any_arrival_order_delivers_each_frame_once_in_order(
    order: list[int], dups: list[int]
) -> None:
    sender, receiver = pair()
    frames = [sender.send(FrameKind.ROLE, i, now=0.0) for i in range(12)]
    delivered: list[ChannelData] = []
    last_ack = -1
    for seq in order + dups:
        got, ack = receiver.on_data(frames[seq])
        delivered += got
        assert ack.ack >= last_ack  # cumulative acks never go back
        last_ack = ack.ack
    assert [f.payload for f in delivered] == list(range(12))
    sender.on_ack(last_ack)
    assert sender.idle


def test_retransmission_backs_off_then_breaks() -> None:
    sender, _ = pair()
    sender.send(FrameKind.ROLE, "x", now=0.0)
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
        sender.send(FrameKind.ROLE, i, now=0.0)
    sender.on_ack(0)
    assert [f.payload for f in sender.due(1.0)] == [1, 2]
    sender.on_ack(2)
    assert sender.idle
    sender.on_ack(1)  # a late, older ack changes nothing
    assert sender.idle


def test_each_end_acks_the_other_ends_stream() -> None:
    initiator_end, participant_end = pair()
    frame = initiator_end.send(FrameKind.ACTIVATE, None, now=0.0)
    _, ack = participant_end.on_data(frame)
    assert ack.of_participant_stream is False
    back = participant_end.send(FrameKind.ACTIVATED, None, now=0.0)
    _, ack = initiator_end.on_data(back)
    assert ack.of_participant_stream is True
