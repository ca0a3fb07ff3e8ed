"""The channel's retransmission timer is disarmed by the last ack, and whatever the
order of sends, acks and ticks, it resends exactly what the always-armed timer did."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from objectplaces.core.channel import Channel
from objectplaces.core.channels import Channels
from objectplaces.core.config import NodeConfig
from objectplaces.core.events import Send
from objectplaces.core.messages import FrameKind
from objectplaces.core.outbox import Outbox
from objectplaces.core.timers import Retransmit, TimerQueue, is_dead

RTO = NodeConfig().retransmit_timeout


class AlwaysArmed(Channels):
    """The plain path: an ack only moves the window; the timer fires when it is due."""

    def on_ack(self, target: str, channel: Channel, ack: int, now: float) -> None:
        if channel.on_ack(ack):
            self._transmit(target, channel, now)


def setup(kind: type[Channels]) -> tuple[Channels, Channel, Outbox, TimerQueue]:
    outbox, timers = Outbox(), TimerQueue()
    channels = kind(NodeConfig(), outbox, timers)
    return channels, channels.open(to_participant=True, session=1, epoch=0), outbox, timers


def tick(channels: Channels, timers: TimerQueue, now: float) -> int:
    """Fire what is due at ``now`` as the machine does; how many live timers fired."""
    fired = 0
    while (action := timers.pop_due(now)) is not None:
        assert isinstance(action, Retransmit)
        fired += not is_dead(action)
        channels.retransmit(action.target, action.channel, action.at, now)
    return fired


def test_the_last_ack_disarms_the_timer_and_the_next_send_arms_it() -> None:
    channels, channel, outbox, timers = setup(Channels)
    channels.send("p", channel, FrameKind.ROLE, "a", now=0.0)
    channels.send("p", channel, FrameKind.ROLE, "b", now=0.0)
    assert timers.next_deadline() == RTO
    channels.on_ack("p", channel, 0, now=0.01)
    assert timers.next_deadline() == RTO  # frame 1 still unacknowledged
    channels.on_ack("p", channel, 1, now=0.02)
    assert timers.next_deadline() is None
    assert tick(channels, timers, 1.0) == 0
    channels.send("p", channel, FrameKind.ROLE, "c", now=1.0)
    assert timers.next_deadline() == 1.0 + RTO
    outbox.take_outputs()
    assert tick(channels, timers, 1.0 + RTO) == 1
    [resent] = outbox.take_outputs()
    assert isinstance(resent, Send)
    assert resent.kind == "channel"


Step = tuple[str, int]


@given(
    st.lists(
        st.tuples(st.sampled_from(["send", "ack", "wait"]), st.integers(0, 6)),
        max_size=40,
    )
)
def test_the_same_frames_go_out_at_the_same_times_as_with_the_timer_always_armed(
    steps: list[Step],
) -> None:
    runs = []
    for kind in (Channels, AlwaysArmed):
        channels, channel, outbox, timers = setup(kind)
        now, sent, fired = 0.0, [], 0
        for what, n in steps:
            if what == "send":
                channels.send("p", channel, FrameKind.ROLE, n, now)
            elif what == "ack":
                # Cumulative: some prefix of what is in flight (n beyond it: the whole).
                ack = min(channel.acked_through + n, channel.sent_through)
                if ack >= 0:
                    channels.on_ack("p", channel, ack, now)
            else:
                now += n * RTO / 3
            fired += tick(channels, timers, now)
            sent += [(now, out.data) for out in outbox.take_outputs() if isinstance(out, Send)]
        runs.append((sent, channel.broken, fired))
    (sent, broken, fired), (plain_sent, plain_broken, plain_fired) = runs
    assert sent == plain_sent
    assert broken == plain_broken
    assert fired <= plain_fired
