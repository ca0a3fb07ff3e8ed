"""``objectplaces demo`` argument checks: tokens, TLS off loopback, the fleet's options.

Every refusal is exit status 2 with a message that names the option or the file.
"""

from __future__ import annotations

import argparse
import os
import stat
import threading
import webbrowser
from pathlib import Path
from typing import Any

import pytest

import dashboard.cli
from dashboard.auth import Tokens, load_token_file
from dashboard.cli import build_source, register, run_demo
from dashboard.listen import Listening
from objectplaces.security import TemporaryPki
from tests.dashboard.conftest import NetworkSource


def parse(*argv: str) -> argparse.Namespace:
    parser = argparse.ArgumentParser()
    register(parser.add_subparsers())
    return parser.parse_args(["demo", *argv])


@pytest.fixture(autouse=True)
def no_token_in_the_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("OBJECTPLACES_TOKEN", raising=False)


def never(args: argparse.Namespace) -> Any:
    raise AssertionError("must not build a fleet")


@pytest.fixture
def served(monkeypatch: pytest.MonkeyPatch) -> list[Listening]:
    """What ``serve`` would have served with (the fleet is the arguments)."""
    seen: list[Listening] = []

    def serve(source: object, *, listening: Listening, open_browser: bool = False) -> None:
        seen.append(listening)

    monkeypatch.setattr(dashboard.cli, "serve", serve)
    return seen


def refusal(capsys: pytest.CaptureFixture[str], *argv: str) -> str:
    """The message ``objectplaces demo argv`` exits 2 with, having built no fleet."""
    assert run_demo(parse(*argv), builder=never) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    return captured.err


def test_defaults_match_the_issue() -> None:
    args = parse()
    assert (args.host, args.port, args.agvs, args.seed, args.open) == (
        "127.0.0.1",
        8000,
        None,  # the demo fleet's default, 12 AGVs
        1,
        False,
    )
    assert (args.token_file, args.tls_cert, args.tls_key, args.pki) == (None, None, None, None)


def test_on_loopback_new_tokens_are_made_at_every_start(served: list[Listening]) -> None:
    assert run_demo(parse(), builder=lambda args: args) == 0
    assert run_demo(parse(), builder=lambda args: args) == 0
    first, second = served
    assert first.tls is None
    assert first.tokens.operator != second.tokens.operator


@pytest.mark.parametrize("host", ["0.0.0.0", "::", "192.168.1.4"])
def test_off_loopback_without_tls_is_refused(host: str, capsys: pytest.CaptureFixture[str]) -> None:
    err = refusal(capsys, "--host", host)
    assert f"--host {host} lets other machines in" in err
    assert "--tls-cert" in err
    assert "--pki" in err


def test_a_token_on_the_command_line_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    err = refusal(capsys, "--token", "T" * 40)
    assert "`ps` shows it" in err
    assert "--token-file" in err


def test_a_token_in_the_environment_is_refused(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setenv("OBJECTPLACES_TOKEN", "T" * 40)
    assert "--token-file" in refusal(capsys)


def test_a_missing_token_file_is_made_private_and_kept(
    tmp_path: Path, served: list[Listening], capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "tokens"
    assert run_demo(parse("--token-file", str(path)), builder=lambda args: args) == 0
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    made = served[0].tokens
    assert load_token_file(path) == (made, False)
    assert run_demo(parse("--token-file", str(path)), builder=lambda args: args) == 0
    assert served[1].tokens == made
    assert served[1].token_file == path
    assert made.operator not in capsys.readouterr().err


def test_a_token_file_others_may_read_is_refused_by_name(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "tokens"
    path.write_text(Tokens.generate().as_text())
    os.chmod(path, 0o644)
    err = refusal(capsys, "--token-file", str(path))
    assert str(path) in err
    assert "0644" in err
    assert "chmod 600" in err


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("", "no viewer and no operator token"),
        (f"operator {'a' * 40}\n", "no viewer token"),
        (f"operator {'a' * 40}\nviewer {'a' * 40}\n", "must differ"),
        (f"operator {'a' * 40}\nviewer short\n", "the viewer token must be 32 to 256"),
        (f"admin {'a' * 40}\n", "line 1: expected 'operator TOKEN'"),
        (f"operator {'a' * 40} extra\n", "line 1"),
        (b"\xff\xfe".decode("latin-1"), "cannot be read"),
    ],
)
def test_a_token_file_that_cannot_be_used_is_refused(
    text: str, expected: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "tokens"
    path.write_bytes(text.encode("latin-1"))
    os.chmod(path, 0o600)
    err = refusal(capsys, "--token-file", str(path))
    assert str(path) in err
    assert expected in err


def test_tls_files_must_come_in_pairs_and_be_usable(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert "go together" in refusal(capsys, "--tls-cert", str(tmp_path / "c.pem"))
    with TemporaryPki(fleet="test") as pki:
        identity = pki.identity("control", role="control")
        other = pki.identity("other", role="control")
        err = refusal(capsys, "--tls-cert", str(identity.cert), "--tls-key", str(other.key))
        assert str(identity.cert) in err
        assert "cannot be used" in err
        err = refusal(capsys, "--pki", str(pki.directory), "--tls-cert", str(identity.cert))
        assert "not both" in err
    missing = tmp_path / "no-such-pki"
    assert str(missing) in refusal(capsys, "--pki", str(missing))


def test_off_loopback_with_the_pkis_certificate_serves_tls(
    served: list[Listening], capsys: pytest.CaptureFixture[str]
) -> None:
    with TemporaryPki(fleet="test") as pki:
        identity = pki.identity("control", role="control")
        argv = ("--host", "0.0.0.0", "--pki", str(pki.directory), "--allowed-host", "floor.lan")
        assert run_demo(parse(*argv), builder=lambda args: args) == 0
    (listening,) = served
    assert listening.tls == (identity.cert, identity.key)
    assert listening.hosts[0] == "floor.lan"


def test_the_login_urls_are_printed_once_and_carry_the_token_in_the_fragment(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    ran: list[dict[str, Any]] = []
    monkeypatch.setattr("uvicorn.run", lambda app, **kwargs: ran.append(kwargs))
    tokens = Tokens.generate()
    listening = Listening(host="::1", port=8123, tokens=tokens, tls=(Path("c"), Path("k")))
    dashboard.cli.serve(NetworkSource(), listening=listening)
    out = capsys.readouterr().out
    assert out.count(f"https://[::1]:8123/login#token={tokens.operator}") == 1
    assert out.count(f"https://[::1]:8123/login#token={tokens.viewer}") == 1
    assert ran == [
        {
            "host": "::1",
            "port": 8123,
            "log_level": "warning",
            "ssl_certfile": Path("c"),
            "ssl_keyfile": Path("k"),
        }
    ]


def test_bad_agv_count_is_refused(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_:
        parse("--agvs", "0")
    assert exit_.value.code == 2
    assert "argument --agvs: expected a whole number >= 1, got '0'" in capsys.readouterr().err


def test_agvs_and_processes_together_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    err = refusal(capsys, "--agvs", "4", "--processes", "6")
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
    assert "--max-open-tasks must be at least 1, got 0" in refusal(capsys, "--max-open-tasks", "0")


def test_open_gives_the_browser_a_private_file_not_the_token(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A browser started with the login URL would show the token in ``ps``."""
    opened: list[tuple[str, int, str]] = []
    called = threading.Event()

    def open_(uri: str) -> bool:
        page = Path(uri.removeprefix("file://"))
        opened.append((uri, stat.S_IMODE(page.stat().st_mode), page.read_text()))
        called.set()
        return True

    def run(app: object, **kwargs: object) -> None:
        assert called.wait(timeout=30), "no browser was opened"

    monkeypatch.setattr(webbrowser, "open", open_)
    monkeypatch.setattr("uvicorn.run", run)
    listening = Listening(host="127.0.0.1", port=8124, tokens=Tokens.generate())
    dashboard.cli.serve(NetworkSource(), listening=listening, open_browser=True)
    ((uri, mode, text),) = opened
    assert listening.tokens.operator not in uri
    assert mode == 0o600
    assert f"http://127.0.0.1:8124/login#token={listening.tokens.operator}" in text
    assert not Path(uri.removeprefix("file://")).exists()  # gone once the server stops
    capsys.readouterr()
