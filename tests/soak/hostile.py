"""The hostile peer's frames: garbage bytes, malformed frames, and well-formed frames with
hostile values (NaN positions, wrong types, huge sequence numbers, unknown sessions,
acks beyond anything sent).

Frames are built from the wire table in docs/protocol.md with msgpack directly, never
with the core's codec, so the forgeries do not depend on how the core encodes.
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable
from typing import Any

import msgpack

__all__ = ["FORGERIES", "forge"]

# Frame type codes of docs/protocol.md §1.
_PROPS, _COMPACT, _LEAVE, _TO_PART, _TO_INIT, _ACK_PART, _ACK_INIT = 1, 2, 3, 4, 5, 6, 7

_ODD_NUMBERS: list[Any] = [
    -1,
    0,
    2**31,
    2**63 - 1,
    2**64 - 1,
    -(2**63),
    1.5,
    math.nan,
    math.inf,
    -math.inf,
    True,
    None,
    "7",
    b"\x00",
    [],
    {},
]
_ODD_VALUES: list[Any] = [
    *_ODD_NUMBERS,
    "x" * 300,
    [[[[[]]]]],
    {"a": {"b": {"c": [1, 2, 3]}}},
    {1: 2},
    [math.nan, 0.0],
]
_ODD_POSITIONS: list[Any] = [
    [math.nan, 0.0],
    [0.0, math.inf],
    [-math.inf, math.nan],
    [1e308, -1e308],
    ["x", "y"],
    [None, 1],
    [1, 2, 3],
    [1],
    [],
    "here",
    {"x": 1, "y": 2},
    [True, False],
    [2**64 - 1, 0],
]


def _pack(value: Any) -> bytes:
    return bytes(msgpack.packb(value, use_bin_type=True))


def _session(rng: random.Random) -> Any:
    # Small numbers hit live sessions of the honest nodes now and then: that is the point.
    return rng.choice([rng.randint(1, 4), rng.choice(_ODD_NUMBERS)])


def _garbage(rng: random.Random, arena: float) -> bytes:
    return rng.randbytes(rng.randint(0, 48))


def _truncated(rng: random.Random, arena: float) -> bytes:
    whole = _pack([_PROPS, rng.randint(0, 100), {"position": [1.0, 2.0], "team": "t"}])
    return whole[: rng.randint(0, len(whole) - 1)]


def _not_a_frame(rng: random.Random, arena: float) -> bytes:
    return _pack(rng.choice([{}, 5, "frame", None, [], [None], [[1]], {"0": 1}, 2.5]))


def _unknown_type(rng: random.Random, arena: float) -> bytes:
    code = rng.choice([0, 8, 31, 99, 255, -1, "1", 1.0, None])
    return _pack([code, *[rng.choice(_ODD_VALUES) for _ in range(rng.randint(0, 5))]])


def _odd_properties(rng: random.Random, arena: float) -> bytes:
    values: dict[Any, Any] = {}
    for _ in range(rng.randint(1, 3)):
        name = rng.choice(["position", "hull_length", "team", "", 7, None])
        if name == "position":
            values[name] = rng.choice(_ODD_POSITIONS)
        else:
            values[name] = rng.choice(_ODD_VALUES)
    seq = rng.choice([rng.randint(0, 50), *_ODD_NUMBERS])
    return _pack([_PROPS, seq, values])


def _plausible_properties(rng: random.Random, arena: float) -> bytes:
    # A well-formed update with a huge sequence number and a position among the nodes:
    # the hostile peer becomes a candidate for every session around it.
    seq = rng.choice([2**62, 2**63 - 1, rng.randint(0, 10)])
    position = [rng.uniform(0, arena), rng.uniform(0, arena)]
    values = {"position": position, "hull_length": rng.uniform(0.5, 3.0), "team": "red"}
    return _pack([_PROPS, seq, values])


def _odd_compact(rng: random.Random, arena: float) -> bytes:
    fields = [rng.choice([*_ODD_NUMBERS, rng.randint(0, 30_000)]) for _ in range(rng.randint(0, 4))]
    return _pack([_COMPACT, rng.choice([rng.randint(0, 9), *_ODD_NUMBERS]), *fields])


def _odd_leave(rng: random.Random, arena: float) -> bytes:
    return _pack([_LEAVE, *[rng.choice(_ODD_VALUES) for _ in range(rng.randint(0, 2))]])


def _channel_data(rng: random.Random, arena: float) -> bytes:
    code = rng.choice([_TO_PART, _TO_INIT])
    epoch = rng.choice([1, 1, 2, *_ODD_NUMBERS])
    seq = rng.choice([0, 1, 2, 2**63 - 1, 10**9, -1, "0"])
    kind = rng.choice([0, 1, 2, 3, 4, 9, -1, "ROLE", None])
    payload = rng.choice([None, ["probe", "Init"], ["decoy"], *_ODD_VALUES])
    return _pack([code, _session(rng), epoch, seq, kind, payload])


def _channel_short(rng: random.Random, arena: float) -> bytes:
    code = rng.choice([_TO_PART, _TO_INIT, _ACK_PART, _ACK_INIT])
    return _pack([code, *[rng.choice(_ODD_VALUES) for _ in range(rng.randint(0, 3))]])


def _ack_beyond(rng: random.Random, arena: float) -> bytes:
    code = rng.choice([_ACK_PART, _ACK_INIT])
    ack = rng.choice([10**6, 2**31, 2**63 - 1, -2, 1.5, "9", None])
    return _pack([code, _session(rng), rng.choice([1, 2, 0, -1]), ack])


def _oversized(rng: random.Random, arena: float) -> bytes:
    return _pack([_PROPS, 1, {"team": "x" * ((1 << 20) + rng.randint(1, 64))}])


FORGERIES: dict[str, tuple[int, Callable[[random.Random, float], bytes]]] = {
    "garbage": (6, _garbage),
    "truncated": (4, _truncated),
    "not_a_frame": (3, _not_a_frame),
    "unknown_type": (3, _unknown_type),
    "odd_properties": (8, _odd_properties),
    "plausible_properties": (4, _plausible_properties),
    "odd_compact": (4, _odd_compact),
    "odd_leave": (1, _odd_leave),
    "channel_data": (8, _channel_data),
    "channel_short": (3, _channel_short),
    "ack_beyond": (6, _ack_beyond),
    "oversized": (1, _oversized),
}
"""Each kind of forgery: (weight, builder)."""


def forge(rng: random.Random, arena: float) -> tuple[str, bytes]:
    """One hostile frame: its kind and its bytes."""
    names = list(FORGERIES)
    name = rng.choices(names, weights=[FORGERIES[n][0] for n in names])[0]
    return name, FORGERIES[name][1](rng, arena)
