"""The wire codec: compact binary frames (msgpack arrays with a leading type code).

Every transport, the simulated one included, carries these bytes, so message and byte
counts are real and a message that cannot be serialised fails where it is sent.

Frame layouts (type code first)::

    1  [1, seq, {name: value, ...}]                       property update, any values
    2  [2, seq, x_mm, y_mm(, hull_mm(, {name: value}))]   property update, compact
    3  [3]                                                leave
    8  [8]                                                send me all your properties
    9  like 1                                             property snapshot (all of them)
    10 like 2                                             property snapshot, compact
    11 [11, seq(, rest_ms)]                               beat: alive, latest publication
                                                          (and the rest announced, 0: ended)
    4  [4, session, epoch, seq, kind, payload]            channel data, to participant
    5  [5, session, epoch, seq, kind, payload]            channel data, to initiator
    6  [6, session, epoch, ack]                           ack of the to-participant stream
    7  [7, session, epoch, ack]                           ack of the to-initiator stream

Codes from ``FIRST_TRANSPORT_TYPE`` up belong to transports (hello, gossip ...).

A position update is the hot message: the paper spends 16 bytes on it. Positions and
hull lengths therefore travel as integer millimetres (``position`` as a pair of numbers,
``hull_length`` as a number), which msgpack packs in 1-5 bytes each: a whole update is
about 14 bytes. ``normalise_property`` applies the same rounding to the publisher's own
copy, so every node sees exactly the same value.
"""

from __future__ import annotations

from typing import Any, Final, assert_never

import msgpack

from objectplaces.core.errors import (
    DecodeError,
    InvalidValueError,
    NotPlainDataError,
)
from objectplaces.core.messages import (
    Beat,
    ChannelAck,
    ChannelData,
    FrameKind,
    Leave,
    Message,
    PropertyRequest,
    PropertyUpdate,
    Unusable,
)
from objectplaces.core.values import (
    MAX_COORDINATE,
    POSITION,
    RADIUS,
    check_plain,
    checked_position,
    checked_radius,
    is_finite_number,
)

__all__ = [
    "DEFAULT_MAX_FRAME",
    "FIRST_TRANSPORT_TYPE",
    "MAX_COUNTER",
    "POSITION",
    "RADIUS",
    "decode",
    "encode",
    "encode_value",
    "frame_type",
    "message_kind",
    "normalise_property",
    "unpack_frame",
]

DEFAULT_MAX_FRAME: Final = 1 << 20
FIRST_TRANSPORT_TYPE: Final = 32
MAX_COUNTER: Final = 2**53
"""Sequence, session, epoch and ack numbers are below this (exact as a float, and far
beyond any real run); a larger one is a hostile or broken peer's, refused on decode."""
MAX_REST_MS: Final = 86_400_000
"""The longest beat interval at rest a beat may declare, in milliseconds (a day); a
receiver caps what it grants further still (``NodeConfig.rest_beat_interval``)."""

_PROPS, _COMPACT, _LEAVE, _TO_PART, _TO_INIT, _ACK_PART, _ACK_INIT = 1, 2, 3, 4, 5, 6, 7
_REQUEST, _PROPS_FULL, _COMPACT_FULL, _BEAT = 8, 9, 10, 11
_FULL = {_PROPS: _PROPS_FULL, _COMPACT: _COMPACT_FULL}  # a snapshot's code, by layout
_MM: Final = 1000.0
_MAX_MM: Final = round(MAX_COORDINATE * _MM)
_KIND_NAMES: Final = {
    _PROPS: "property",
    _COMPACT: "property",
    _REQUEST: "property",
    _PROPS_FULL: "property",
    _COMPACT_FULL: "property",
    _BEAT: "beat",
    _LEAVE: "leave",
    _TO_PART: "channel",
    _TO_INIT: "channel",
    _ACK_PART: "ack",
    _ACK_INIT: "ack",
}
_FRAME_KINDS: Final = {k.value: k for k in FrameKind}
# Packers ready for reuse: making one costs twice what packing a frame does. Each call
# takes one off the list and puts it back (a list's pop and append are atomic), so
# callers at once, in threads or nested, never share one.
_PACKERS: Final[list[msgpack.Packer]] = []


def _position_mm(value: object) -> tuple[int, int] | None:
    if isinstance(value, tuple | list) and len(value) == 2 and all(map(is_finite_number, value)):
        return round(value[0] * _MM), round(value[1] * _MM)
    return None


def _radius_mm(value: object) -> int | None:
    return round(value * _MM) if is_finite_number(value) and value >= 0 else None  # type: ignore[operator]


def normalise_property(name: str, value: Any) -> Any:
    """Round a property the way the wire will, so the publisher sees what peers see.

    ``position`` (a pair of finite numbers) becomes a tuple of floats in whole
    millimetres; ``hull_length`` (a finite number >= 0) a float in whole millimetres.
    Every other value is returned unchanged.
    """
    if name == POSITION and (mm := _position_mm(value)) is not None:
        return (mm[0] / _MM, mm[1] / _MM)
    if name == RADIUS and (r := _radius_mm(value)) is not None:
        return r / _MM
    return value


def encode_value(value: Any) -> bytes:
    """Serialise plain data (dict, list, tuple, str, int, float, bool, None, bytes).

    Raises:
        NotPlainDataError: the value holds something that is not plain data.
        InvalidValueError: plain data msgpack cannot carry (nested too deep, an
            integer out of range).
    """
    try:
        packer = _PACKERS.pop()
    except IndexError:
        packer = msgpack.Packer(use_bin_type=True, strict_types=False)
    try:
        return packer.pack(value)  # type: ignore[no-any-return]
    except (TypeError, ValueError, OverflowError) as exc:
        check_plain(value)  # names the offending part, when it can be named
        error = NotPlainDataError if isinstance(exc, TypeError) else InvalidValueError
        raise error(f"not serialisable as plain data: {value!r:.200} ({exc})") from exc
    finally:
        _PACKERS.append(packer)  # a packer empties its buffer after each pack, or error


def _property_frame(update: PropertyUpdate) -> list[Any]:
    values = update.values
    position = _position_mm(values.get(POSITION))
    full = update.full
    if position is None:
        return [_PROPS_FULL if full else _PROPS, update.seq, dict(values)]
    frame: list[Any] = [_COMPACT_FULL if full else _COMPACT, update.seq, position[0], position[1]]
    rest = {k: v for k, v in values.items() if k != POSITION}
    radius = _radius_mm(rest.get(RADIUS)) if RADIUS in rest else None
    if radius is not None:
        del rest[RADIUS]
    if radius is not None or rest:
        frame.append(radius)
    if rest:
        frame.append(rest)
    return frame


def encode(message: Message) -> bytes:
    """Encode one message as a frame.

    Raises:
        LocalProtocolError: a payload or property value is not plain data.
    """
    match message:
        case PropertyUpdate():
            frame = _property_frame(message)
        case ChannelData(to_participant, session, epoch, seq, kind, payload):
            code = _TO_PART if to_participant else _TO_INIT
            frame = [code, session, epoch, seq, int(kind), payload]
        case ChannelAck(of_participant_stream, session, epoch, ack):
            code = _ACK_INIT if of_participant_stream else _ACK_PART
            frame = [code, session, epoch, ack]
        case Beat(seq, rest):
            frame = [_BEAT, seq] if rest is None else [_BEAT, seq, _rest_ms(rest)]
        case Leave():
            frame = [_LEAVE]
        case PropertyRequest():
            frame = [_REQUEST]
        case Unusable():
            raise InvalidValueError(f"a refused frame is never sent: {message!r}")
        case _:
            assert_never(message)
    return encode_value(frame)


def frame_type(data: bytes) -> int:
    """Peek at a frame's type code without decoding the rest.

    Raises:
        DecodeError: the frame does not start with a msgpack array and a small int.
    """
    if len(data) >= 2 and 0x91 <= data[0] <= 0x9F and data[1] < 0x80:
        return data[1]
    raise DecodeError(f"not a frame: starts with {data[:2].hex() or 'nothing'}")


def message_kind(data: bytes) -> str:
    """Name a frame's family for statistics ("property", "channel", "ack", ...)."""
    try:
        return _KIND_NAMES.get(frame_type(data), "transport")
    except DecodeError:
        return "malformed"


def _reject_ext(code: int, data: bytes) -> Any:
    raise DecodeError(f"msgpack extension type {code} is not allowed")


def _rest_ms(rest: float) -> int:
    """A beat interval at rest as the whole milliseconds a beat carries (0: the rest
    ended)."""
    if rest == 0:
        return 0
    ms = round(rest * _MM) if is_finite_number(rest) else 0
    if not 0 < ms <= MAX_REST_MS:
        raise InvalidValueError(
            f"a beat's rest interval must be in [1 ms, 1 day], or 0 (the rest ended), got {rest!r}"
        )
    return ms


def _uint(value: Any, what: str) -> int:
    if isinstance(value, int) and not isinstance(value, bool) and 0 <= value < MAX_COUNTER:
        return value
    raise DecodeError(f"{what} must be a non-negative integer below 2**53, got {value!r:.40}")


def _mm(value: Any, what: str) -> float:
    if isinstance(value, int) and not isinstance(value, bool):
        if abs(value) > _MAX_MM:
            raise InvalidValueError(f"{what} of {value} mm is beyond +-{MAX_COORDINATE:g} m")
        return value / _MM
    raise DecodeError(f"{what} must be integer millimetres, got {value!r}")


def _names(values: Any) -> dict[str, Any]:
    """A peer's property map, its well-known properties checked and rounded like ours.

    Raises:
        DecodeError: not a map with string keys.
        InvalidValueError: a well-known property is unusable (values.py says why).
    """
    if not isinstance(values, dict) or not all(isinstance(k, str) for k in values):
        raise DecodeError(f"property values must be a map with string keys, got {values!r:.80}")
    if POSITION in values:
        values[POSITION] = normalise_property(POSITION, checked_position(values[POSITION]))
    if RADIUS in values:
        values[RADIUS] = normalise_property(RADIUS, checked_radius(values[RADIUS]))
    return values


def _decode_compact(frame: list[Any], full: bool) -> PropertyUpdate:
    if not 4 <= len(frame) <= 6:
        raise DecodeError(f"compact property frame has {len(frame)} fields, expected 4-6")
    values: dict[str, Any] = {}
    if len(frame) == 6:
        values.update(_names(frame[5]))  # a position in here is overridden just below
    values[POSITION] = (_mm(frame[2], "x"), _mm(frame[3], "y"))
    if len(frame) >= 5 and frame[4] is not None:
        values[RADIUS] = _mm(frame[4], "hull length")
    return PropertyUpdate(_uint(frame[1], "seq"), values, full)


def _decode_channel(frame: list[Any]) -> ChannelData:
    if len(frame) != 6:
        raise DecodeError(f"channel frame has {len(frame)} fields, expected 6")
    kind = _FRAME_KINDS.get(frame[4]) if isinstance(frame[4], int) else None
    if kind is None:
        raise DecodeError(f"unknown channel frame kind {frame[4]!r}")
    return ChannelData(
        frame[0] == _TO_PART,
        _uint(frame[1], "session"),
        _uint(frame[2], "epoch"),
        _uint(frame[3], "seq"),
        kind,
        frame[5],
    )


def _decode_ack(frame: list[Any]) -> ChannelAck:
    if len(frame) != 4:
        raise DecodeError(f"ack frame has {len(frame)} fields, expected 4")
    return ChannelAck(
        frame[0] == _ACK_INIT,
        _uint(frame[1], "session"),
        _uint(frame[2], "epoch"),
        _uint(frame[3], "ack"),
    )


def unpack_frame(data: bytes, *, max_size: int = DEFAULT_MAX_FRAME) -> list[Any]:
    """Parse a frame's msgpack array; every decoder (the core's, the mesh's) starts here.

    Raises:
        DecodeError: the frame is oversized, not msgpack, uses an extension type, or is
            not an array starting with an integer type code.
    """
    if len(data) > max_size:
        raise DecodeError(f"frame of {len(data)} bytes exceeds the limit of {max_size}")
    try:
        frame = msgpack.unpackb(data, raw=False, strict_map_key=False, ext_hook=_reject_ext)
    except DecodeError:
        raise
    except Exception as exc:  # msgpack raises several unrelated types on bad input
        raise DecodeError(f"malformed frame: {exc}") from exc
    if not isinstance(frame, list) or not frame or not isinstance(frame[0], int):
        raise DecodeError(f"a frame is an array starting with a type code, got {frame!r:.80}")
    return frame


def decode(data: bytes, *, max_size: int = DEFAULT_MAX_FRAME) -> Message:
    """Decode one frame into a message.

    Returns:
        The message; ``Unusable`` for a well-formed property frame whose position or
        hull length cannot be used (refused whole, but no reason to close a link).

    Raises:
        DecodeError: the frame is oversized, malformed, or of an unknown type.
    """
    frame = unpack_frame(data, max_size=max_size)
    match frame[0]:
        case 1 | 2 | 9 | 10:
            full = frame[0] >= _PROPS_FULL
            try:
                if frame[0] in (_COMPACT, _COMPACT_FULL):
                    return _decode_compact(frame, full)
                if len(frame) != 3:
                    raise DecodeError(f"property frame has {len(frame)} fields, expected 3")
                return PropertyUpdate(_uint(frame[1], "seq"), _names(frame[2]), full)
            except InvalidValueError as exc:
                # Well-formed, but unusable: refused whole, without closing a link.
                return Unusable(str(exc))
        case 3 | 8:
            if len(frame) != 1:
                raise DecodeError(f"frame of type {frame[0]} has {len(frame)} fields, expected 1")
            return Leave() if frame[0] == _LEAVE else PropertyRequest()
        case 11:
            if len(frame) == 2:
                return Beat(_uint(frame[1], "seq"))
            if len(frame) != 3:
                raise DecodeError(f"beat frame has {len(frame)} fields, expected 2 or 3")
            rest = _uint(frame[2], "rest interval")
            if rest > MAX_REST_MS:
                raise DecodeError(f"beat rest interval {rest} ms is not in [0, {MAX_REST_MS}]")
            return Beat(_uint(frame[1], "seq"), rest / _MM)
        case 4 | 5:
            return _decode_channel(frame)
        case 6 | 7:
            return _decode_ack(frame)
        case code:
            raise DecodeError(f"unknown message type {code!r}")
