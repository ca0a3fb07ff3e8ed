"""What every part of one node machine shares.

The parts (the two session tables above all) need the same few things: the node's
id and tunables, the outbox their effects go to, the timer queue, the role timers, and
the channels. Handing them over as one frozen bundle keeps each part's constructor about
its own job, and makes plain that these are shared, not owned: the router builds them
once and every part writes into the same outbox and the same queue, which is what keeps
effects in the order they were decided.
"""

from __future__ import annotations

from dataclasses import dataclass

from objectplaces.core.channels import Channels
from objectplaces.core.config import NodeConfig
from objectplaces.core.outbox import Outbox
from objectplaces.core.timers import RoleTimers, TimerQueue

__all__ = ["Plumbing"]


@dataclass(frozen=True, slots=True)
class Plumbing:
    """The node's id and tunables, and the outbox, timers and channels its parts share."""

    node_id: str
    config: NodeConfig
    outbox: Outbox
    timers: TimerQueue
    role_timers: RoleTimers
    channels: Channels

    @classmethod
    def build(cls, node_id: str, config: NodeConfig) -> Plumbing:
        """Fresh plumbing for one node."""
        outbox, timers = Outbox(), TimerQueue()
        return cls(
            node_id, config, outbox, timers, RoleTimers(timers), Channels(config, outbox, timers)
        )
