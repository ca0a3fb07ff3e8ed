"""``objectplaces demo`` argument checks: a token is required off loopback."""

from __future__ import annotations

import argparse

import pytest

from dashboard.cli import build_source, is_loopback, register, run_demo


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers())
    return parser.parse_args(["demo", *argv])


@pytest.mark.parametrize(
    ("host", "expected"),
    [
        ("127.0.0.1", True),
        ("127.5.0.1", True),
        ("::1", True),
        ("localhost", True),
        ("0.0.0.0", False),
        ("192.168.1.4", False),
        ("example.org", False),
    ],
)
def test_loopback_hosts(host: str, expected: bool) -> None:
    assert is_loopback(host) is expected


def test_defaults_match_the_issue(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("OBJECTPLACES_TOKEN", raising=False)
    args = parse()
    assert (args.host, args.port, args.agvs, args.seed, args.open) == (
        "127.0.0.1",
        8000,
        None,  # the demo fleet's default, 12 AGVs
        1,
        False,
    )
    assert args.token is None


def test_non_loopback_without_token_is_refused(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.delenv("OBJECTPLACES_TOKEN", raising=False)
    built: list[argparse.Namespace] = []

    def builder(args: argparse.Namespace):
        built.append(args)
        raise AssertionError("must not build a fleet")

    assert run_demo(parse("--host", "0.0.0.0"), builder=builder) == 2
    assert "--token" in capsys.readouterr().err
    assert built == []


def test_bad_agv_count_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        parse("--agvs", "0")
    assert exit_.value.code == 2
    assert "argument --agvs: expected a whole number >= 1, got '0'" in capsys.readouterr().err


def test_agvs_and_processes_together_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    def builder(args: argparse.Namespace):
        raise AssertionError("must not build a fleet")

    assert run_demo(parse("--agvs", "4", "--processes", "6"), builder=builder) == 2
    err = capsys.readouterr().err
    assert "--agvs 4" in err
    assert "--processes 6" in err
    assert "not both" in err


def test_negative_processes_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit):
        parse("--processes", "-1")
    assert "argument --processes: expected a whole number >= 0, got '-1'" in (
        capsys.readouterr().err
    )


def test_the_default_fleet_has_twelve_agvs() -> None:
    source = build_source(parse("--seed", "2"))
    assert len(source.vehicles()) == 12


@pytest.mark.parametrize("load", ["0", "1.5", "-0.2", "nan"])
def test_a_load_outside_zero_to_one_is_refused(
    load: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit):
        parse("--load", load)
    assert f"argument --load: expected a number in (0, 1], got {load!r}" in (
        capsys.readouterr().err
    )


def test_the_load_reaches_the_fleet() -> None:
    quiet = build_source(parse("--seed", "2", "--load", "0.1"))
    busy = build_source(parse("--seed", "2", "--load", "1"))
    assert quiet.metrics()["tasks_created"] < busy.metrics()["tasks_created"]


def test_the_limit_on_open_tasks_reaches_the_fleet() -> None:
    held = build_source(parse("--seed", "2", "--max-open-tasks", "3"))
    free = build_source(parse("--seed", "2"))
    assert held.desk.max_open == 3  # type: ignore[attr-defined]
    assert free.desk.max_open is None  # type: ignore[attr-defined]
    # The demo's 12 AGVs start with 8 tasks: 5 of them wait at the desk.
    assert held.desk.waiting == 5  # type: ignore[attr-defined]
    assert free.desk.waiting == 0  # type: ignore[attr-defined]


def test_the_automatic_limit_reaches_the_fleet(capsys: pytest.CaptureFixture[str]) -> None:
    auto = build_source(parse("--seed", "2", "--max-open-tasks", "auto"))
    assert auto.desk.admission is not None  # type: ignore[attr-defined]
    with pytest.raises(SystemExit):
        parse("--max-open-tasks", "often")
    assert "a whole number, 'auto', 'crowded' or 'none', got 'often'" in capsys.readouterr().err


def test_a_limit_below_one_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    def builder(args: argparse.Namespace):
        raise AssertionError("must not build a fleet")

    assert run_demo(parse("--max-open-tasks", "0"), builder=builder) == 2
    assert "--max-open-tasks must be at least 1, got 0" in capsys.readouterr().err
