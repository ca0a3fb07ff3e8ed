"""The liveness settings every node of an AGV fleet shares, whatever runs it: the
simulated fleet, the AGV processes and their observer and stations on a real network.

A fleet shares one configuration: a node grants a resting peer no longer a silence than
its own ``rest_beat_interval`` allows, so an observer or a station started without rest
would count every parked AGV failed (docs/protocol.md §2, "A node at rest").
"""

from __future__ import annotations

import argparse
from typing import Any

from objectplaces.arguments import POSITIVE
from objectplaces.core.config import NodeConfig

__all__ = [
    "REPUBLISH_BEATS",
    "REST_BEAT_S",
    "fleet_liveness",
    "liveness_arguments",
    "rest_beat_argument",
]

REPUBLISH_BEATS = 600
"""Heartbeats between two republications of every property, by default (ten minutes at
the 1 s heartbeat): the last resort, since a beat carries the number of the latest
publication and a receiver that is behind asks for a snapshot. A republication goes to
every listener with every property's name; once a minute it was 14 % of what a fleet's
AGVs sent (docs/protocol.md §2)."""

REST_BEAT_S = 5.0
"""Beat interval of an AGV at rest (parked at home, no task), by default."""


def fleet_liveness(
    heartbeat: float, *, republish: float | None, rest_beat: float | None
) -> NodeConfig:
    """The liveness part of every fleet node's ``NodeConfig``.

    Args:
        heartbeat: the beat interval; a peer not heard for three of them has failed.
        republish: seconds between republications of every property. None: no beats,
            every property republished each heartbeat instead.
        rest_beat: beat interval of an AGV at rest (raised to the heartbeat when
            shorter); None: no rest. Ignored without beats.
    """
    if republish is None:
        return NodeConfig(property_interval=heartbeat, failure_timeout=3 * heartbeat)
    return NodeConfig(
        property_interval=republish,
        beat_interval=heartbeat,
        rest_beat_interval=None if rest_beat is None else max(rest_beat, heartbeat),
        failure_timeout=3 * heartbeat,
    )


def liveness_arguments(config: NodeConfig) -> dict[str, Any]:
    """``config``'s liveness settings as keyword arguments of ``start_node`` (either
    transport)."""
    return {
        "property_interval": config.property_interval,
        "beat_interval": config.beat_interval,
        "rest_beat_interval": config.rest_beat_interval,
        "failure_timeout": config.failure_timeout,
    }


def rest_beat_argument(text: str) -> float | None:
    """``--rest-beat``: seconds (> 0), or ``none`` (no rest), for argparse."""
    if text.strip().lower() == "none":
        return None
    try:
        return POSITIVE(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"expected seconds > 0 or 'none', got {text!r}") from None
