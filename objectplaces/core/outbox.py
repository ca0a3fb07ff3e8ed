"""Where the parts of one node machine put what the driver must do.

The machine is sans-I/O: nothing it decides happens until the driver drains it
(``messages_to_send()``, ``events_received()``). Every part (the view, the session and
participation tables, the channels) writes into this one outbox rather than returning
its effects up the call chain, for the reason websockets' ``Protocol`` appends to one
``data_to_send`` buffer: the order in which effects were decided is the order in which
they leave, across parts, without any part knowing about the others.

Counters live here too: "dropped and counted" is how the machine answers bad network
input (STYLE.md §1), and one table of counters per node is what ``stats()`` shows.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from objectplaces.core.events import Callback, Output, Send

__all__ = ["Outbox"]


class Outbox:
    """Outputs to transmit, callbacks to run, and the node's drop/event counters."""

    __slots__ = ("callbacks", "counters", "outputs", "sent_by_kind")

    def __init__(self) -> None:
        self.outputs: list[Output] = []
        self.callbacks: list[Callback] = []
        self.counters: dict[str, int] = {}
        #: kind -> [frames, bytes] the transport put on the wire (``record_sent``).
        self.sent_by_kind: dict[str, list[int]] = {}

    def emit(self, output: Output | None) -> None:
        """Queue one output (a frame to send, broadcast or publish, or a subscription);
        None, what a part returns when it has nothing to say, is ignored."""
        if output is not None:
            self.outputs.append(output)

    def send(self, target: str, data: bytes, kind: str) -> None:
        """Queue one encoded frame for one node."""
        self.outputs.append(Send(target, data, kind))

    def call(
        self, fn: Callable[..., Any], args: tuple[Any, ...] = (), session_id: str = ""
    ) -> None:
        """Queue a call of application code (a role method, a timer, an observer)."""
        self.callbacks.append(Callback(fn, args, session_id))

    def count(self, name: str, by: int = 1) -> None:
        """Add ``by`` to counter ``name``."""
        self.counters[name] = self.counters.get(name, 0) + by

    def record_sent(self, kind: str, frames: int, size: int) -> None:
        """Count ``frames`` frames of ``size`` bytes each that the transport sent."""
        tally = self.sent_by_kind.setdefault(kind, [0, 0])
        tally[0] += frames
        tally[1] += frames * size

    def take_outputs(self) -> list[Output]:
        """Hand over the queued outputs, oldest first."""
        out, self.outputs = self.outputs, []
        return out

    def take_callbacks(self) -> list[Callback]:
        """Hand over the queued callbacks, oldest first."""
        out, self.callbacks = self.callbacks, []
        return out
