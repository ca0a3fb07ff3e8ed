"""What keeps a node heard: the property heartbeat and the liveness beat (§2).

Two timers say "this node is alive", and one listens for the others:

* ``Republish`` (``property_interval``) sends a snapshot of every property to the
  node's scope. It repairs any lost update, and without beats it is the heartbeat.
* ``SendBeat`` (``beat_interval``) sends a beat of a few bytes when the node has
  published nothing to its scope for a beat interval: any publication proves it alive
  already, so a node that moves sends no beats. The beat carries the number of the
  latest publication; a receiver holding an older one missed something and asks for a
  snapshot, which repairs the loss without republishing everything to everyone. With
  beats, the republication can be rare.
* ``CheckLiveness`` (the failure timeout, three liveness intervals by default) is the
  router's to act on; it is scheduled here with the others.

The beat is due a full interval after the latest publication, not on a fixed phase, so
a live node is never silent for longer than one interval (plus delay): one lost beat
leaves it well inside a timeout of three.
"""

from __future__ import annotations

from objectplaces.core.config import NodeConfig
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.outbox import Outbox
from objectplaces.core.own import OwnProperties
from objectplaces.core.timers import CheckLiveness, Republish, SendBeat, TimerQueue

__all__ = ["Liveness"]


class Liveness:
    """The heartbeat and beat of one node, and when it last published.

    Args:
        config: the node's tunables (the intervals and the failure timeout).
        own: the node's own properties (what a republication or a beat carries).
        outbox: where the frames go.
        timers: the machine's timer queue.
        now: the time at creation.

    Raises:
        LocalProtocolError: an interval or the failure timeout is set and not > 0.
    """

    __slots__ = ("_last_published", "_outbox", "_own", "_timers")

    def __init__(
        self, config: NodeConfig, own: OwnProperties, outbox: Outbox, timers: TimerQueue, now: float
    ) -> None:
        self._own = own
        self._outbox = outbox
        self._timers = timers
        self._last_published = now
        for name in ("property_interval", "beat_interval", "failure_timeout"):
            value = getattr(config, name)
            if value is not None and not value > 0:
                raise LocalProtocolError(f"{name} must be > 0 seconds or None, got {value!r}")
        if config.property_interval is not None:
            timers.push(now + config.property_interval, Republish(config.property_interval))
        if config.beat_interval is not None:
            timers.push(now + config.beat_interval, SendBeat(config.beat_interval))
        timeout = config.effective_failure_timeout
        if timeout is not None:
            timers.push(now + timeout / 3, CheckLiveness(timeout))

    def published(self, now: float) -> None:
        """The node published to its scope at ``now`` (a beat is due an interval later)."""
        self._last_published = now

    def republish(self, action: Republish, now: float) -> None:
        """The heartbeat is due: a snapshot of every property, then again later."""
        output = self._own.republish()
        if output is not None:
            self._outbox.emit(output)
            self._last_published = now
        self._timers.push(now + action.every, action)

    def beat(self, action: SendBeat, now: float) -> None:
        """A beat may be due: send one if the node was silent for the whole interval."""
        due = self._last_published + action.every
        if due > now:
            self._timers.push(due, action)  # it published since: look again then
            return
        if self._own.pending:
            self._last_published = now  # the drain that follows this input publishes
        else:
            output = self._own.beat()
            if output is not None:
                self._outbox.emit(output)
                self._last_published = now
        self._timers.push(now + action.every, action)
