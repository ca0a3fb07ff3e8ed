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

**At rest** (``set_at_rest``, with ``rest_beat_interval``) a node beats less often: a
parked vehicle has nothing to say but "still here". The first beats after a
publication, or after the node came to rest, still come at the usual interval, as many
as fit in a failure timeout, and announce the rest interval: a receiver waits for the
node that much longer (``PropertyView``), and one that lost some of them learns the
longer interval from another before its timeout for the usual one runs out, so the
losses a timeout of three intervals survives are survived at rest too. The rarer beats
that follow are plain: a receiver keeps what it granted. A change (a delta) ends the
longer wait at every receiver that hears it, and after any publication the rest is
announced again.
A newcomer given a snapshot (or an asker) takes the node as beating at the usual
interval, so the announcement after a snapshot goes to that peer alone: as many beats
of its own, at the usual interval, and none again for as long (a peer out of scope
that forgets the node and asks at each beat stops asking). A node that leaves rest
without publishing beats at the usual interval again from the next interval on, and
its first beats then (as many as announced the rest) say that its rest ended (0). A
receiver that lost all of them waits the longer while until the node next publishes:
it finds a failure later, never a live node failed.
"""

from __future__ import annotations

import math
from typing import Final

from objectplaces.core import codec
from objectplaces.core.config import NodeConfig
from objectplaces.core.errors import LocalProtocolError
from objectplaces.core.outbox import Outbox
from objectplaces.core.own import OwnProperties
from objectplaces.core.timers import CheckLiveness, Republish, SendBeat, TimerQueue

__all__ = ["Liveness"]

MAX_OWED: Final = 256
"""Peers a node at rest keeps owing their own announcement; beyond them it announces its
rest to all again (a flood of askers costs beats, never memory)."""


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

    __slots__ = (
        "_announce",
        "_announced",
        "_at_rest",
        "_declared",
        "_ending",
        "_last_published",
        "_outbox",
        "_owed",
        "_own",
        "_rest_every",
        "_timers",
    )

    def __init__(
        self, config: NodeConfig, own: OwnProperties, outbox: Outbox, timers: TimerQueue, now: float
    ) -> None:
        self._own = own
        self._outbox = outbox
        self._timers = timers
        self._last_published = now
        for name in (
            "property_interval",
            "beat_interval",
            "rest_beat_interval",
            "failure_timeout",
            "probe_interval",
        ):
            value = getattr(config, name)
            if value is not None and not value > 0:
                raise LocalProtocolError(f"{name} must be > 0 seconds or None, got {value!r}")
        self._rest_every = _rest_every(config)
        self._at_rest = False
        self._announced = 0
        self._declared = False  # a rest was declared to someone since the last publication
        self._ending = 0  # beats still due that say the rest ended
        self._owed: dict[str, int] = {}  # peer -> beats of its own announcement still due
        # Beats at the usual interval that declare the rest before it begins: as many as
        # the failure timeout spans, so the losses it survives are survived at rest too.
        beat, timeout = config.beat_interval, config.effective_failure_timeout
        self._announce = 1 if beat is None or timeout is None else max(1, math.ceil(timeout / beat))
        if config.property_interval is not None:
            timers.push(now + config.property_interval, Republish(config.property_interval))
        if config.beat_interval is not None:
            timers.push(now + config.beat_interval, SendBeat(config.beat_interval))
        timeout = config.effective_failure_timeout
        if timeout is not None:
            timers.push(now + timeout / 3, CheckLiveness(timeout))

    def published(self, now: float, *, snapshot: bool = False) -> None:
        """The node published to its scope at ``now`` (a beat is due an interval later):
        a change, or (``snapshot``) a republication of every property."""
        self._last_published = now
        self._announced = 0
        self._owed.clear()  # the announcement to all that follows reaches them too
        if not snapshot:  # a change ends every grant; a snapshot says nothing of rest
            self._declared = False
            self._ending = 0

    def sent_snapshot(self, peer: str) -> None:
        """``peer`` got a snapshot of this node: it takes the node as beating at the usual
        interval, so a node at rest announces its rest to it again."""
        if not self._at_rest or self._rest_every is None or peer in self._owed:
            return  # owed already: a peer that forgets us and asks again gets no more
        if len(self._owed) < MAX_OWED:
            # Its beats, then as many beats' time before it may be owed them again.
            self._owed[peer] = 2 * self._announce
        else:
            self._announced = 0

    def set_at_rest(self, at_rest: bool) -> None:
        """Whether the node is at rest: it then beats every ``rest_beat_interval``
        (nothing changes without one)."""
        if at_rest != self._at_rest:
            self._at_rest = at_rest
            self._announced = 0
            self._owed.clear()
            self._ending = self._announce if self._declared and not at_rest else 0

    def republish(self, action: Republish, now: float) -> None:
        """The heartbeat is due: a snapshot of every property, then again later."""
        output = self._own.republish()
        if output is not None:
            self._outbox.emit(output)
            self.published(now, snapshot=True)
        self._timers.push(now + action.every, action)

    def beat(self, action: SendBeat, now: float) -> None:
        """A beat may be due: send one if the node was silent for the whole interval."""
        rest = self._rest_every if self._at_rest else None
        if self._owed and rest is not None:
            self._announce_to_owed(rest)
        every = action.every
        if rest is not None and self._announced >= self._announce:
            every = rest
            declare = None  # announced: a plain beat keeps what was granted
        else:
            declare = 0.0 if rest is None and self._ending else rest
        due = self._last_published + every
        if due > now:
            # It published since, or rests: look again then, and at the usual interval
            # at the latest, so that a node leaving rest beats as usual at once.
            self._timers.push(min(due, now + action.every), action)
            return
        if self._own.pending:
            self._last_published = now  # the drain that follows this input publishes
        else:
            output = self._own.beat(declare)
            if output is not None:
                self._outbox.emit(output)
                self._last_published = now
                if rest is not None:
                    self._announced += 1
                    self._declared = True
                elif self._ending:
                    self._ending -= 1
                    self._declared = self._ending > 0
        self._timers.push(now + action.every, action)

    def _announce_to_owed(self, rest: float) -> None:
        """One beat of their own to each peer still owed an announcement of the rest."""
        owed, announce = self._owed, self._announce
        for peer, left in list(owed.items()):
            if left > announce:
                self._outbox.emit(self._own.beat_to(peer, rest))
                self._declared = True
            if left > 1:
                owed[peer] = left - 1
            else:
                del owed[peer]


def _rest_every(config: NodeConfig) -> float | None:
    """The beat interval at rest, checked against the usual one (None: no rest)."""
    rest = config.rest_beat_interval
    if rest is None:
        return None
    if not (math.isfinite(rest) and rest <= codec.MAX_REST_MS / 1000):
        raise LocalProtocolError(f"rest_beat_interval must be at most a day, got {rest!r}")
    if config.beat_interval is None:
        raise LocalProtocolError("rest_beat_interval needs a beat_interval")
    if rest < config.beat_interval:
        raise LocalProtocolError(
            f"rest_beat_interval ({rest!r}) must be at least beat_interval "
            f"({config.beat_interval!r})"
        )
    return None if rest == config.beat_interval else rest  # as usual: nothing to declare
