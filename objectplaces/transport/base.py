"""What a transport offers the node runtimes, and what it needs from them.

A transport carries the core's outputs: point-to-point ``Send``, ``Broadcast`` to every
peer, and ``Publish`` to the subscribers of grid cells, which it routes from the
``Subscribe`` declarations it sees. Cell keys are ``props/<cx>,<cy>`` with the sender in
the frame's source, the scheme a content router (such as Zenoh) can carry unchanged.

The transport never imports a runtime. Whoever drives a node (the simulation, the
asyncio runner) hands the transport a ``NodeDriver``; the in-memory network also takes a
``Scheduler`` for its virtual time. ``objectplaces.sim`` and ``objectplaces.mesh`` wire
the two together.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, Protocol

from objectplaces.core.events import Output
from objectplaces.core.messages import Message

__all__ = ["Endpoint", "NodeDriver", "RawNodeDriver", "Scheduler", "cell_key"]


def cell_key(cell: tuple[int, int], node: str = "*") -> str:
    """The routing key of properties published in ``cell`` by ``node``."""
    return f"props/{cell[0]},{cell[1]}/{node}"


class Endpoint(Protocol):
    """One node's attachment to a transport."""

    def transmit(self, output: Output) -> int:
        """Carry one output of the node's machine; return how many frames went out."""
        ...


class NodeDriver(Protocol):
    """What a transport needs from whoever drives one node's machine.

    Each call is one input of the machine; the driver feeds it with its own clock and
    drains the machine afterwards. A call may raise (the machine refused or failed on
    the input): the transport then drops that frame, never itself.
    """

    def deliver(self, source: str, message: Message, size: int) -> None:
        """Hand the node one decoded frame from ``source`` (``size`` bytes on the wire)."""
        ...

    def peer_joined(self, peer: str) -> None:
        """A peer that hears everything (re)connected: send it our properties."""
        ...

    def peer_restarted(self, peer: str) -> None:
        """``peer`` came back as a new run of itself: its earlier run is gone."""
        ...

    def send_properties_to(self, peer: str) -> None:
        """``peer`` newly subscribed to the cell we publish in: send it our properties."""
        ...


class RawNodeDriver(NodeDriver, Protocol):
    """A driver that also takes bytes that did not decode (the simulation's nodes), so
    the node's own decoder refuses and counts them."""

    def deliver_raw(self, source: str, data: bytes) -> None:
        """Hand the node one frame from ``source`` that did not decode."""
        ...


class Scheduler(Protocol):
    """A clock and a timer queue (the simulation's virtual-time event loop fits).

    Attributes:
        now: the current time, in seconds.
    """

    now: float

    def call_at(self, when: float, fn: Callable[..., Any], *args: Any) -> None:
        """Run ``fn(*args)`` at time ``when`` (now, if it lies in the past)."""
        ...
