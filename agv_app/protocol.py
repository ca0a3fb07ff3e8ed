"""What every node of the AGV application agrees on, whichever role it plays.

The ``kind`` property tells AGVs from the transport base (group definitions select on
it), and every role counts the messages it sends through one :data:`MessageTally`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from objectplaces.core.codec import encode_value

__all__ = ["AGV_KIND", "BASE_KIND", "OBSERVER_KIND", "MessageTally", "tally_send"]

AGV_KIND = "agv"
"""Value of the ``kind`` property every AGV publishes."""

BASE_KIND = "base"
"""Value of the ``kind`` property of the transport base, the node that runs the task
assignment of every pick station (``agv_app.tasks.desk``)."""

OBSERVER_KIND = "observer"
"""Value of the ``kind`` property of a process fleet's observer: a property to publish,
so its peers hear it even without beats (it initiates the display session)."""

MessageTally = Callable[[str, int], None]
"""Counts one protocol message of a type and its encoded size in bytes."""


def tally_send(tally: MessageTally | None, kind: str, message: Any) -> None:
    """Count ``message`` as one sent message of ``kind`` with its encoded size.

    Args:
        tally: the counter (None: nothing is counted).
        kind: the message type, as the figures name it.
        message: the plain-data message as sent.
    """
    if tally is not None:
        tally(kind, len(encode_value(message)))
