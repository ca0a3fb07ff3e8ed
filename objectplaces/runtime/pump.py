"""The one loop every runtime shares: drain the machine, transmit, run callbacks.

Runtimes differ only in how they transmit and how they wait for the next deadline; what
happens after an input is the same everywhere, so it lives here once. A drain always
ends by handing the runtime the machine's next deadline, whatever the transport or the
callbacks did, because a deadline without a timer silently stops a node's heartbeats and
retransmissions.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from objectplaces.core.events import Callback, Output, Subscribe
from objectplaces.core.node import NodeMachine

__all__ = ["Pump", "run_callback"]

log = logging.getLogger("objectplaces")


def run_callback(event: Callback, node_id: str) -> None:
    """Run application code; an exception is logged with its session and goes no further."""
    try:
        event.fn(*event.args)
    except Exception:
        log.exception(
            "node %s: %s raised in session %r",
            node_id,
            getattr(event.fn, "__qualname__", event.fn),
            event.session_id or None,
        )


class Pump:
    """Drains one machine after each input until nothing is left to do.

    Args:
        machine: the node machine.
        transmit: hands one output to the transport; returns how many frames it sent.
        schedule: told the machine's next deadline after each drain (None: no timer).
    """

    def __init__(
        self,
        machine: NodeMachine,
        transmit: Callable[[Output], int],
        schedule: Callable[[float | None], None],
    ) -> None:
        self.machine = machine
        self._transmit = transmit
        self._schedule = schedule
        self._draining = False

    @property
    def draining(self) -> bool:
        """True while a drain runs: whatever the machine queues now is drained by it."""
        return self._draining

    def drain(self) -> None:
        """Transmit every pending output and run every pending callback.

        Callbacks may call back into the machine (a role sends in ``in_group``); their
        outputs are drained in the same pass. Re-entrant calls return at once.
        """
        if self._draining or not self.machine.has_work():
            return
        self._draining = True
        machine = self.machine
        try:
            while True:
                outputs = machine.messages_to_send()
                events = machine.events_received()
                if not outputs and not events:
                    break
                for output in outputs:
                    self._transmit_one(output)
                for event in events:
                    run_callback(event, machine.node_id)
        finally:
            self._draining = False
            # Whatever happened above, the machine's next deadline must get a timer, or its
            # retransmissions and heartbeats stop until some other input happens to arrive.
            self._schedule(machine.next_deadline())

    def _transmit_one(self, output: Output) -> None:
        # A transport that fails on one output costs that output only (channels repair it
        # by retransmission), never the rest of the drain: the other outputs, the
        # callbacks already taken from the machine, or the timer.
        try:
            frames = self._transmit(output)
        except Exception:
            log.exception(
                "node %s: transport failed on a %s output",
                self.machine.node_id,
                type(output).__name__,
            )
            return
        if not isinstance(output, Subscribe):
            self.machine.record_sent(output.kind, frames, len(output.data))
