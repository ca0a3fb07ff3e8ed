"""The wire codec: round trips, compactness, and clear rejection of bad frames."""

from __future__ import annotations

import contextlib
import math

import msgpack
import pytest
from hypothesis import given
from hypothesis import strategies as st

from objectplaces import DecodeError, LocalProtocolError
from objectplaces.core import codec
from objectplaces.core.errors import InvalidValueError, NotPlainDataError
from objectplaces.core.messages import (
    Beat,
    ChannelAck,
    ChannelData,
    FrameKind,
    Leave,
    PropertyRequest,
    PropertyUpdate,
    Unusable,
)

plain = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(2**63), 2**64 - 1)
    | st.text(max_size=20)
    | st.binary(max_size=20)
    | st.floats(allow_nan=False),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=12,
)


def test_position_update_is_as_small_as_the_papers() -> None:
    update = PropertyUpdate(1234, {"position": (31.234, 17.5), "hull_length": 2.4})
    frame = codec.encode(update)
    assert len(frame) <= 16
    assert codec.decode(frame) == update


def test_compact_update_keeps_other_properties() -> None:
    update = PropertyUpdate(7, {"position": (-3.0, 4.25), "status": "idle"})
    decoded = codec.decode(codec.encode(update))
    assert isinstance(decoded, PropertyUpdate)
    assert dict(decoded.values) == {"position": (-3.0, 4.25), "status": "idle"}


def test_position_is_rounded_to_millimetres_and_normalising_matches_the_wire() -> None:
    value = (1.23456, 9.87654)
    decoded = codec.decode(codec.encode(PropertyUpdate(1, {"position": value})))
    assert isinstance(decoded, PropertyUpdate)
    assert decoded.values["position"] == (1.235, 9.877)
    assert codec.normalise_property("position", value) == decoded.values["position"]
    assert codec.normalise_property("status", value) is value


@pytest.mark.parametrize(
    "message",
    [
        Leave(),
        ChannelData(True, 3, 1, 0, FrameKind.ACTIVATE, ["voter", "Requester"]),
        ChannelData(False, 3, 2, 9, FrameKind.ROLE, {"vote": "allow", "n": [1, 2]}),
        ChannelAck(True, 5, 1, 17),
        ChannelAck(False, 5, 1, 0),
        PropertyUpdate(0, {"a": [1, 2], "b": None}),
        PropertyUpdate(3, {"a": 1}, full=True),
        PropertyUpdate(4, {"position": (1.0, 2.0), "hull_length": 0.5}, full=True),
        PropertyRequest(),
        Beat(0),
        Beat(2**53 - 1),
        Beat(7, 5.0),
        Beat(7, 0.001),
        Beat(7, 86_400.0),
        Beat(7, 0.0),  # the rest ended
    ],
)
def test_round_trip(message: object) -> None:
    assert codec.decode(codec.encode(message)) == message  # type: ignore[arg-type]


@given(
    seq=st.integers(0, 2**40),
    values=st.dictionaries(
        st.text(max_size=10).filter(lambda k: k not in ("position", "hull_length")),
        plain,
        max_size=5,
    ),
)
def test_property_updates_round_trip(seq: int, values: dict[str, object]) -> None:
    decoded = codec.decode(codec.encode(PropertyUpdate(seq, values)))
    assert isinstance(decoded, PropertyUpdate)
    assert decoded.seq == seq
    assert set(decoded.values) == set(values)


@given(x=st.floats(-1e6, 1e6), y=st.floats(-1e6, 1e6), r=st.floats(0, 1e4))
def test_normalised_positions_survive_the_wire_exactly(x: float, y: float, r: float) -> None:
    values = {
        "position": codec.normalise_property("position", (x, y)),
        "hull_length": codec.normalise_property("hull_length", r),
    }
    decoded = codec.decode(codec.encode(PropertyUpdate(1, values)))
    assert isinstance(decoded, PropertyUpdate)
    assert decoded.values == values


@given(st.binary(max_size=64))
def test_random_bytes_decode_or_fail_with_decode_error(data: bytes) -> None:
    with contextlib.suppress(DecodeError):
        codec.decode(data)


@given(
    base=st.sampled_from(
        [
            codec.encode(PropertyUpdate(3, {"position": (1.0, 2.0), "hull_length": 1.0})),
            codec.encode(ChannelData(True, 1, 1, 0, FrameKind.ROLE, {"x": 1})),
            codec.encode(ChannelAck(False, 1, 1, 3)),
            codec.encode(Beat(70_000)),
            codec.encode(Beat(70_000, 5.0)),
        ]
    ),
    index=st.integers(0, 40),
    byte=st.integers(0, 255),
)
def test_mutated_frames_decode_or_fail_with_decode_error(
    base: bytes, index: int, byte: int
) -> None:
    data = bytearray(base)
    data[index % len(data)] = byte
    with contextlib.suppress(DecodeError):
        codec.decode(bytes(data))


@pytest.mark.parametrize(
    ("frame", "reason"),
    [
        (msgpack.packb({"not": "an array"}), "array starting with a type code"),
        (msgpack.packb([99, 1]), "unknown message type 99"),
        (msgpack.packb([1, -1, {}]), "seq must be a non-negative integer"),
        (msgpack.packb([1, 1, {1: 2}]), "string keys"),
        (msgpack.packb([4, 1, 1, 0, 77, None]), "unknown channel frame kind"),
        (msgpack.packb([6, 1, 1]), "ack frame has 3 fields"),
        (msgpack.packb([2, 1, 1.5, 2]), "integer millimetres"),
        (msgpack.packb([11]), "beat frame has 1 fields, expected 2"),
        (msgpack.packb([11, 1, 2, 3]), "beat frame has 4 fields, expected 2 or 3"),
        (msgpack.packb([11, 1, 86_400_001]), "rest interval 86400001 ms"),
        (msgpack.packb([11, -1]), "seq must be a non-negative integer"),
        (msgpack.packb([11, "7"]), "seq must be a non-negative integer"),
        (msgpack.packb([11, True]), "seq must be a non-negative integer"),
        (b"\xc1", "malformed frame"),
        (msgpack.packb([1, 1, {}]) + b"\x00", "malformed frame"),
    ],
)
def test_malformed_frames_are_rejected_with_a_reason(frame: bytes, reason: str) -> None:
    with pytest.raises(DecodeError, match=reason):
        codec.decode(frame)


def test_oversized_frame_is_rejected_before_parsing() -> None:
    with pytest.raises(DecodeError, match="exceeds the limit of 100"):
        codec.decode(b"\x00" * 101, max_size=100)


def test_unserialisable_value_fails_where_it_is_sent() -> None:
    with pytest.raises(LocalProtocolError, match="not serialisable"):
        codec.encode_value({"f": object()})


def test_a_beat_is_a_few_bytes() -> None:
    # The point of a beat: liveness for the price of a frame header and a number.
    assert len(codec.encode(Beat(5))) == 3
    assert len(codec.encode(Beat(70_000))) <= 7
    assert len(codec.encode(Beat(5, 5.0))) == 6  # announcing a rest: the interval in ms
    assert len(codec.encode(Beat(5, 0.0))) == 4  # the rest ended


@pytest.mark.parametrize("rest", [0.0001, -5.0, math.nan, math.inf, 86_400.5])
def test_a_beat_declares_a_rest_it_can_carry_or_none(rest: float) -> None:
    with pytest.raises(InvalidValueError, match="rest interval must be in"):
        codec.encode(Beat(1, rest))


def test_frame_type_peeks_without_decoding() -> None:
    assert codec.frame_type(codec.encode(Leave())) == 3
    assert codec.message_kind(codec.encode(Beat(1))) == "beat"
    assert codec.message_kind(codec.encode(ChannelAck(True, 1, 1, 1))) == "ack"
    assert codec.message_kind(b"") == "malformed"
    with pytest.raises(DecodeError):
        codec.frame_type(b"\xff\xff")


@pytest.mark.parametrize(
    "values",
    [
        {"position": ["x", "y"]},
        {"position": [math.nan, 0.0]},
        {"position": [math.inf, -math.inf]},
        {"position": [None, 1]},
        {"position": [1.0, 2.0, 3.0]},
        {"position": "here"},
        {"hull_length": -1.0},
        {"hull_length": math.nan},
        {"hull_length": "long"},
        {"status": "fine", "hull_length": True},
    ],
)
def test_a_frame_with_an_unusable_well_known_property_is_refused_whole(
    values: dict[str, object],
) -> None:
    # Built by hand: our own encoder never produces these (the local API refuses them).
    refused = codec.decode(msgpack.packb([1, 1, values]))
    assert isinstance(refused, Unusable)
    assert "must be" in refused.reason
    hidden = codec.decode(msgpack.packb([2, 1, 0, 0, None, {"x": 1, **values}]))
    assert isinstance(hidden, Unusable)  # in a compact frame's other properties, too


def test_well_known_properties_from_a_generic_frame_are_rounded_like_ours() -> None:
    decoded = codec.decode(msgpack.packb([1, 4, {"position": [1, 2.00049], "hull_length": 3}]))
    assert decoded == PropertyUpdate(4, {"position": (1.0, 2.0), "hull_length": 3.0})


@pytest.mark.parametrize(
    "frame",
    [
        [1, 2**53, {}],
        [4, 2**60, 1, 0, 4, None],
        [5, 1, 2**64 - 1, 0, 4, None],
        [6, 1, 1, 2**63],
        [11, 2**53],
    ],
)
def test_absurd_counters_are_refused(frame: list[object]) -> None:
    with pytest.raises(DecodeError, match="below 2\\*\\*53"):
        codec.decode(msgpack.packb(frame))


def test_unplain_values_fail_as_type_errors_and_unfit_ones_as_value_errors() -> None:
    with pytest.raises(NotPlainDataError, match=r"value\['f'\] is <object"):
        codec.encode_value({"f": object()})
    with pytest.raises(TypeError):
        codec.encode_value([1, {2}])
    with pytest.raises(InvalidValueError, match="out of the wire's range"):
        codec.encode_value({"big": 2**70})


@given(
    st.lists(
        st.one_of(
            st.recursive(
                st.none() | st.booleans() | st.integers(-(2**63), 2**64 - 1) | st.text(),
                lambda inner: (
                    st.lists(inner, max_size=3)
                    | st.dictionaries(st.text(max_size=3), inner, max_size=3)
                ),
                max_leaves=8,
            ),
            st.just({"bad": object()}),
            st.just([1, 2**70]),
        ),
        min_size=1,
        max_size=6,
    )
)
def test_a_value_encodes_alike_whatever_failed_before_it(values: list[object]) -> None:
    # Packers are reused across calls: one that raised must not carry a byte onward.
    for value in values:
        try:
            expected = msgpack.packb(value, use_bin_type=True)
        except (TypeError, ValueError, OverflowError):
            with pytest.raises((NotPlainDataError, InvalidValueError)):
                codec.encode_value(value)
        else:
            assert codec.encode_value(value) == expected


def test_encodings_nested_in_one_another_do_not_share_a_packer() -> None:
    class Items(dict[str, object]):
        def items(self):
            # Packing this dict encodes another value first, as a thread might.
            inner.append(codec.encode_value(["inner", 1]))
            return super().items()

    inner: list[bytes] = []
    outer = codec.encode_value([Items(a=1), "tail"])
    assert msgpack.unpackb(outer) == [{"a": 1}, "tail"]
    assert [msgpack.unpackb(b) for b in inner] == [["inner", 1]]
