"""What the node machine asks its driver to do: transmit frames and run callbacks.

The outputs and callbacks are values, immutable by convention: nobody assigns to their
fields. They are not frozen dataclasses because a node makes several for every frame,
and a frozen one sets each field through ``object.__setattr__``, three times the cost of
a plain slotted one; they keep a frozen value's equality and hash.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, TypeAlias

__all__ = ["Broadcast", "Callback", "Output", "Publish", "Send", "Subscribe", "TimerHandle"]


@dataclass(slots=True, unsafe_hash=True)
class Send:
    """Deliver ``data`` to one node."""

    target: str
    data: bytes
    kind: str


@dataclass(slots=True, unsafe_hash=True)
class Broadcast:
    """Deliver ``data`` to every node the transport knows."""

    data: bytes
    kind: str


@dataclass(slots=True, unsafe_hash=True)
class Publish:
    """Deliver ``data`` to every node subscribed to any of ``cells`` (scoped dissemination).

    The first ``home`` cells are the ones the publisher publishes in now (its own cell,
    or every cell of its footprint, ``NodeConfig.footprint_margin``); the rest are cells
    it just left: their subscribers must learn that it is gone, or they keep a stale
    position forever. A subscriber of several of the cells hears the frame once where
    the transport can tell (a router); a receiver takes a repeated frame as a no-op.

    ``snapshot``, when given, is the same publication as a snapshot (same sequence
    number, every property): the home grew, and a node that did not hear the
    publisher's last home may never have heard of it. Those nodes get ``snapshot``
    instead of ``data`` (where the transport can tell; else a cell of the new home
    gets ``snapshot`` and the others ``data``), the ones that did hear it the delta.
    """

    cells: tuple[tuple[int, int], ...]
    data: bytes
    kind: str
    home: int = 1
    snapshot: bytes | None = None


@dataclass(slots=True, unsafe_hash=True)
class Subscribe:
    """From now on deliver to this node what is published in ``cells`` (None: everything)."""

    cells: frozenset[tuple[int, int]] | None


Output: TypeAlias = Send | Broadcast | Publish | Subscribe


@dataclass(slots=True, unsafe_hash=True)
class Callback:
    """Run application code: a role method, a timer, or an observer.

    Attributes:
        fn: what to call.
        args: its arguments.
        session_id: the session it belongs to, for the log if it raises ("" for none).
    """

    fn: Callable[..., Any]
    args: tuple[Any, ...]
    session_id: str = ""


@dataclass(eq=False, slots=True)
class TimerHandle:
    """A callback scheduled with ``call_later``; ``cancel()`` stops it from running."""

    deadline: float
    fn: Callable[[], Any]
    owner: Any = None
    cancelled: bool = field(default=False)

    def cancel(self) -> None:
        """Stop the callback from running (no effect once it ran)."""
        self.cancelled = True
