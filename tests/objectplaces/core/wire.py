"""A hand-cranked driver for node machines: bytes in, bytes out, virtual time.

No simulator and no event loop: frames move between machines only when a test says
so, instantly (zero delay), and a link can be cut one way. What the machines emit is
kept, so tests can assert the exact frames on the wire.
"""

from __future__ import annotations

from collections import deque
from typing import Any

from objectplaces.core import codec
from objectplaces.core.events import Broadcast, Publish, Send, Subscribe
from objectplaces.core.messages import Message
from objectplaces.core.node import NodeMachine
from objectplaces.runtime.pump import run_callback


class Wire:
    """Connects machines by hand; ``settle()`` moves frames until nothing is left."""

    def __init__(self, *machines: NodeMachine) -> None:
        self.machines = {m.node_id: m for m in machines}
        self.now = 0.0
        self.cut: set[tuple[str, str]] = set()
        self.log: list[tuple[str, str, Message]] = []  # (source, target, decoded frame)
        self.sent_at: list[float] = []  # when each frame of ``log`` went
        self._queue: deque[tuple[str, str, bytes]] = deque()

    def _collect(self, machine: NodeMachine) -> bool:
        outputs = machine.messages_to_send()
        events = machine.events_received()
        for output in outputs:
            match output:
                case Send(target, data, _):
                    self._queue.append((machine.node_id, target, data))
                case Broadcast(data, _) | Publish(_, data, _):
                    for target in self.machines:
                        if target != machine.node_id:
                            self._queue.append((machine.node_id, target, data))
                case Subscribe():
                    pass
        for event in events:
            run_callback(event, machine.node_id)
        return bool(outputs or events)

    def settle(self) -> None:
        """Run callbacks and deliver frames (zero delay) until every machine is quiet."""
        for _ in range(100_000):
            busy = any([self._collect(m) for m in self.machines.values()])
            if not self._queue and not busy:
                return
            while self._queue:
                source, target, data = self._queue.popleft()
                self.log.append((source, target, codec.decode(data)))
                self.sent_at.append(self.now)
                if (source, target) not in self.cut and target in self.machines:
                    self.machines[target].receive(source, data, self.now)
        raise AssertionError("the machines never settled")

    def run_until(self, end: float) -> None:
        """Advance virtual time to ``end``, ticking each machine at its deadlines."""
        self.settle()
        for _ in range(100_000):
            due = [
                (deadline, node)
                for node, m in self.machines.items()
                if (deadline := m.next_deadline()) is not None and deadline <= end
            ]
            if not due:
                self.now = end
                return
            deadline, node = min(due)
            self.now = max(self.now, deadline)
            self.machines[node].tick(self.now)
            self.settle()
        raise AssertionError("timers never ran out")

    def frames(self, source: str, target: str, kind: type[Any]) -> list[Any]:
        """Decoded frames of one type sent from ``source`` to ``target`` so far."""
        return [m for s, t, m in self.log if s == source and t == target and isinstance(m, kind)]
