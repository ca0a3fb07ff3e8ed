"""The asyncio runtime: drives one node machine with the loop's real clock.

Every input (a frame, a timer, an API call) is followed by a drain of the machine, as in
the simulation; the drain runs once per loop iteration (``wake`` coalesces), so updates
made in the same instant leave as one message. The machine's next deadline is kept as
one ``loop.call_at`` timer, moved only when the deadline moves earlier.

asyncio runs a timer that falls due within one tick of its clock
(``BaseEventLoop._clock_resolution``), so on a coarse clock the timer may run a little
before the deadline it was set for. The loop counts that deadline as reached, and so do
we: the machine is ticked at the deadline, the runner's clock never reads earlier than a
deadline already ticked, and the timer is re-armed after every tick whatever the tick
found, so no deadline is ever left without a timer.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable

from objectplaces.core.events import Output
from objectplaces.core.messages import Message
from objectplaces.core.node import NodeMachine
from objectplaces.runtime.pump import Pump

__all__ = ["AsyncioRunner"]


class AsyncioRunner:
    """Feeds one ``NodeMachine`` on the running event loop.

    Args:
        machine: the node's machine.
        transmit: hands one output of the machine to the transport (must not block).
        loop: the event loop (the running one by default).
    """

    def __init__(
        self,
        machine: NodeMachine,
        transmit: Callable[[Output], int],
        *,
        loop: asyncio.AbstractEventLoop | None = None,
    ) -> None:
        self.machine = machine
        self._loop = loop or asyncio.get_running_loop()
        self.pump = Pump(machine, transmit, self._schedule)
        self._wake: asyncio.Handle | None = None
        self._timer: asyncio.TimerHandle | None = None
        self._timer_at: float | None = None
        self._ticked_at = float("-inf")
        self.closed = False

    def now(self) -> float:
        """The loop's clock, in seconds (never earlier than the last deadline ticked)."""
        return max(self._loop.time(), self._ticked_at)

    def wake(self) -> None:
        """Drain the machine soon (once per loop iteration, however often called)."""
        if self._wake is None and not self.closed:
            self._wake = self._loop.call_soon(self._on_wake)

    def deliver(self, source: str, message: Message, size: int) -> None:
        """Hand the machine one decoded frame from ``source`` (``size`` bytes on the wire)."""
        if self.closed:
            return
        self.machine.receive_message(source, message, self.now(), size=size)
        self.wake()

    def peer_restarted(self, peer: str) -> None:
        """``peer`` reconnected as a new run of itself: its old run is gone."""
        if not self.closed:
            self.machine.peer_restarted(peer, self.now())
            self.wake()

    def peer_joined(self, peer: str) -> None:
        """A full-dissemination peer (re)connected: it gets our properties."""
        if not self.closed:
            self.machine.peer_joined(peer, self.now())
            self.wake()

    def send_properties_to(self, peer: str) -> None:
        """A peer subscribed to our cell: it gets our properties."""
        if not self.closed:
            self.machine.send_properties_to(peer, self.now())
            self.wake()

    def drain(self) -> None:
        """Drain the machine now (outputs transmitted, callbacks run)."""
        if not self.closed:
            self.pump.drain()

    def close(self) -> None:
        """Stop driving the machine: cancel the pending drain and timer."""
        self.closed = True
        for handle in (self._wake, self._timer):
            if handle is not None:
                handle.cancel()
        self._wake = self._timer = None
        self._timer_at = None

    def _on_wake(self) -> None:
        self._wake = None
        if not self.closed:
            self.pump.drain()

    def _schedule(self, deadline: float | None) -> None:
        if deadline is None or self.closed:
            return
        if self._timer_at is None or deadline < self._timer_at:
            if self._timer is not None:
                self._timer.cancel()
            self._timer_at = deadline
            self._timer = self._loop.call_at(deadline, self._on_timer)

    def _on_timer(self) -> None:
        due = self._timer_at
        self._timer = None
        self._timer_at = None
        if self.closed:
            return
        if due is not None:
            self._ticked_at = max(self._ticked_at, due)
        self.machine.tick(self.now())
        self.pump.drain()
        # The drain schedules only when it found work; a tick that fired nothing must
        # still leave the machine's next deadline armed.
        self._schedule(self.machine.next_deadline())
