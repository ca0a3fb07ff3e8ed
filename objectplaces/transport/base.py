"""What a transport offers the node runtimes.

A transport carries the core's outputs: point-to-point ``Send``, ``Broadcast`` to every
peer, and ``Publish`` to the subscribers of grid cells, which it routes from the
``Subscribe`` declarations it sees. Cell keys are ``props/<cx>,<cy>`` with the sender in
the frame's source, the scheme a content router (such as Zenoh) can carry unchanged.
"""

from __future__ import annotations

from typing import Protocol

from objectplaces.core.events import Output

__all__ = ["Endpoint", "cell_key"]


def cell_key(cell: tuple[int, int], node: str = "*") -> str:
    """The routing key of properties published in ``cell`` by ``node``."""
    return f"props/{cell[0]},{cell[1]}/{node}"


class Endpoint(Protocol):
    """One node's attachment to a transport."""

    def transmit(self, output: Output) -> int:
        """Carry one output of the node's machine; return how many frames went out."""
        ...
