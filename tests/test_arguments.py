"""Number options of every command line: a bad value stops the parse with exit status 2
and a message naming the option, never a traceback or a run that cannot end
(objectplaces/arguments.py)."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given
from hypothesis import strategies as st

from agv_app.fleet import agv_process
from objectplaces.arguments import (
    POSITIVE,
    NumberArgument,
    group_argument,
    number,
    property_argument,
    whole,
)
from objectplaces.cli import build_parser
from objectplaces.security import CredentialError, credentials_from_args

# What each parser needs besides the option under test.
REQUIRED = {
    "node": ["--id", "n1"],
    "agv_process": ["--id", "agv-01", "--pki", "pki", "--home", "P0350n"],
    "agv": ["--id", "agv-01", "--pki", "pki", "--home", "P0350n"],
    "control": ["--connect", "127.0.0.1:9"],
}
# Options that take any whole number.
ANY_NUMBER = {"--seed"}


def _parsers() -> dict[str, argparse.ArgumentParser]:
    """Every command line: each ``objectplaces`` subcommand, and the AGV process."""
    parsers = {"agv_process": agv_process.build_parser()}
    for action in build_parser()._actions:
        if isinstance(action, argparse._SubParsersAction):
            parsers.update(action.choices)
    return parsers


def _options() -> list[tuple[str, str, NumberArgument, Any]]:
    """``(command, option, type, default)`` of every number option."""
    return [
        (command, action.option_strings[-1], action.type, action.default)
        for command, parser in _parsers().items()
        for action in parser._actions
        if isinstance(action.type, NumberArgument)
    ]


OPTIONS = _options()


def _argv(command: str, option: str, value: str) -> list[str]:
    return [*REQUIRED.get(command, []), f"{option}={value}"]


def _outside(kind: NumberArgument) -> list[str]:
    """Values just outside the bounds of ``kind``."""
    out = []
    if kind.above is not None:
        out.append(repr(kind.above))
    if kind.at_least is not None:
        out.append(str(int(kind.at_least) - 1) if kind.whole else repr(kind.at_least - 1e-9))
    if kind.below is not None:
        out.append(repr(kind.below))
    if kind.at_most is not None:
        out.append(str(int(kind.at_most) + 1) if kind.whole else repr(kind.at_most + 1e-9))
    return out


def test_the_command_lines_have_their_number_options_checked() -> None:
    found = {(command, option) for command, option, _, _ in OPTIONS}
    assert {
        ("sim", "--agvs"),
        ("sim", "--minutes"),
        ("sim", "--delay"),
        ("sim", "--loss"),
        ("sim", "--load"),
        ("demo", "--port"),
        ("demo", "--load"),
        ("node", "--lease"),
        ("node", "--max-frame"),
        ("router", "--run-seconds"),
        ("agv_process", "--dt"),
        ("agv_process", "--poll-interval"),
    } <= found


def test_no_option_takes_an_unchecked_number() -> None:
    for command, parser in _parsers().items():
        for action in parser._actions:
            if action.type in (float, int):
                assert action.option_strings[-1] in ANY_NUMBER, (command, action.option_strings)


@pytest.mark.parametrize(("command", "option", "kind", "default"), OPTIONS)
def test_every_default_is_in_range(
    command: str, option: str, kind: NumberArgument, default: Any
) -> None:
    if default is not None:
        assert kind.admits(default), (command, option, default)


@pytest.mark.parametrize(("command", "option", "kind", "default"), OPTIONS)
def test_a_bad_value_stops_the_parse_and_names_the_option(
    command: str,
    option: str,
    kind: NumberArgument,
    default: Any,
    capsys: pytest.CaptureFixture[str],
) -> None:
    parser = _parsers()[command]
    for bad in ["nan", "inf", "-inf", "1e999", "", "ten", "0x10", *_outside(kind)]:
        with pytest.raises(SystemExit) as exit_:
            parser.parse_args(_argv(command, option, bad))
        assert exit_.value.code == 2, (option, bad)
        err = capsys.readouterr().err
        assert f"argument {option}: expected {kind}, got {bad!r}" in err, err


@pytest.mark.parametrize(("command", "option", "kind", "default"), OPTIONS)
def test_a_value_in_range_is_taken(
    command: str, option: str, kind: NumberArgument, default: Any
) -> None:
    candidates = [default, kind.at_least, None if kind.above is None else kind.above + 1, 1]
    inside = next(v for v in candidates if v is not None and kind.admits(v))
    parsed = _parsers()[command].parse_args(_argv(command, option, str(inside)))
    assert getattr(parsed, option.lstrip("-").replace("-", "_")) == inside


@pytest.mark.parametrize(
    ("kind", "said"),
    [
        (POSITIVE, "a number > 0"),
        (number(at_least=0), "a number >= 0"),
        (number(at_least=0, below=1), "a number in [0, 1)"),
        (number(above=0, at_most=1), "a number in (0, 1]"),
        (number(below=5), "a number < 5"),
        (number(), "a number"),
        (whole(at_least=1), "a whole number >= 1"),
        (whole(at_least=0, at_most=65535), "a whole number in [0, 65535]"),
    ],
)
def test_the_range_is_said_as_it_is_checked(kind: NumberArgument, said: str) -> None:
    assert str(kind) == said


def test_a_whole_number_is_an_int_and_a_fraction_is_refused() -> None:
    kind = whole(at_least=1)
    assert kind("12") == 12
    assert type(kind("12")) is int
    assert kind(" 7 ") == 7
    with pytest.raises(argparse.ArgumentTypeError, match="expected a whole number >= 1"):
        kind("3.0")
    assert kind("9" * 400) == int("9" * 400)  # no float conversion: no overflow


_BOUND = st.one_of(st.none(), st.floats(-1e6, 1e6))


@given(
    text=st.one_of(
        st.text(max_size=30),
        st.floats(allow_nan=True, allow_infinity=True).map(repr),
        st.integers().map(str),
    ),
    above=_BOUND,
    at_most=_BOUND,
    whole_number=st.booleans(),
)
def test_any_text_gives_a_number_in_range_or_a_clear_refusal(
    text: str, above: float | None, at_most: float | None, whole_number: bool
) -> None:
    kind = NumberArgument(above=above, at_most=at_most, whole=whole_number)
    refusal = None
    try:
        value = kind(text)
    except argparse.ArgumentTypeError as exc:
        refusal = str(exc)
    if refusal is not None:
        assert refusal == f"expected {kind}, got {text!r}"
        return
    assert isinstance(value, int) if whole_number else isinstance(value, float)
    assert isinstance(value, int) or math.isfinite(value)
    assert above is None or value > above
    assert at_most is None or value <= at_most


@pytest.mark.parametrize(
    ("spec", "members"),
    [("within:2.5", {"near"}), ("within:", {"near"}), ("circles", {"near"})],
)
def test_a_group_option_names_a_group(spec: str, members: set[str]) -> None:
    definition = group_argument(spec)
    own = {"position": (0.0, 0.0), "hull_length": 1.0}
    near = {"position": (1.0, 0.0), "hull_length": 1.0}
    far = {"position": (50.0, 0.0), "hull_length": 1.0}
    chosen = {name for name, props in (("near", near), ("far", far)) if definition(own, props)}
    assert chosen == members


@pytest.mark.parametrize("spec", ["within:nan", "within:-1", "within:inf", "within:x", "circles:3"])
def test_a_bad_group_option_is_refused_with_what_it_takes(spec: str) -> None:
    with pytest.raises(argparse.ArgumentTypeError) as refused:
        group_argument(spec)
    assert str(refused.value) == (
        f"expected within:D (D a distance >= 0, m) or circles, got {spec!r}"
    )


def test_a_property_option_is_a_name_and_a_json_value() -> None:
    assert property_argument("position=[1, 2]") == ("position", (1, 2))
    assert property_argument("kind=agv") == ("kind", "agv")  # not JSON: text
    assert property_argument('tags={"a": [1]}') == ("tags", {"a": [1]})
    for bad in ("position", "=3"):
        with pytest.raises(argparse.ArgumentTypeError, match="property must be NAME=JSON"):
            property_argument(bad)


def test_a_secret_file_that_cannot_be_read_stops_the_node_with_a_line(tmp_path: Path) -> None:
    args = argparse.Namespace(pki=None, insecure=True, secret_file=tmp_path / "missing")
    with pytest.raises(CredentialError, match=r"secret file .*missing: cannot be read"):
        credentials_from_args(args, "n1")
