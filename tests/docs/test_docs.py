"""The documentation: every code block of the docs and the README runs, every command
parses, and every file of examples/ runs as a script (the site itself: test_site.py)."""

from __future__ import annotations

import ast
import asyncio
import json
import os
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from objectplaces.cli import build_parser
from tests.docs.blocks import Block, blocks_of

ROOT = Path(__file__).resolve().parents[2]
PAGES = [*sorted((ROOT / "docs").glob("*.md")), ROOT / "README.md"]
BIN = Path(sys.executable).parent
BLOCK_TIMEOUT = 180.0


def _env() -> dict[str, str]:
    env = dict(os.environ)
    env["PATH"] = f"{BIN}{os.pathsep}{env.get('PATH', '')}"
    env["PYTHONPATH"] = str(ROOT)
    return env


def _exec_python(block: Block, namespace: dict[str, object]) -> None:
    code = compile(
        block.code, str(block.page) + f":{block.line}", "exec", flags=ast.PyCF_ALLOW_TOP_LEVEL_AWAIT
    )
    result = eval(code, namespace)
    if asyncio.iscoroutine(result):  # a block with a top-level await

        async def bounded() -> None:
            async with asyncio.timeout(BLOCK_TIMEOUT):
                await result

        asyncio.run(bounded())


def _command_lines(code: str) -> list[str]:
    """The lines of a shell block, a line continued with a backslash joined to the next."""
    lines: list[str] = []
    pending = ""
    for raw in code.splitlines():
        if raw.rstrip().endswith("\\"):
            pending += raw.rstrip()[:-1] + " "
            continue
        lines.append(pending + raw)
        pending = ""
    if pending:
        lines.append(pending)
    return lines


def _check_command_lines(block: Block) -> None:
    parser = build_parser()
    for raw in _command_lines(block.code):
        line = raw.split(" #", 1)[0].strip()
        if not line.startswith("objectplaces "):
            continue
        argv = shlex.split(line)[1:]
        try:
            parser.parse_args(argv)
        except SystemExit as exc:
            if exc.code:
                raise AssertionError(f"{block.where}: {line!r} does not parse") from None


def run_page(page: Path, folder: Path, monkeypatch: pytest.MonkeyPatch) -> int:
    """Run every block of ``page`` in ``folder``; returns how many ran or were checked."""
    monkeypatch.chdir(folder)
    monkeypatch.setenv("PATH", _env()["PATH"])
    namespace: dict[str, object] = {"__name__": f"docs_{page.stem}"}
    background: list[tuple[Block, subprocess.Popen[str]]] = []
    count = 0
    try:
        for block in blocks_of(page):
            mark, lang = block.mark.split(), block.lang
            if mark[:1] == ["file"]:
                (folder / mark[1]).write_text(block.code)
            elif mark[:1] == ["background"]:
                process = subprocess.Popen(
                    ["bash", "-e", "-c", block.code], cwd=folder, env=_env(), text=True
                )
                background.append((block, process))
            elif mark[:1] == ["run"]:
                argv = ["bash", "-e", "-c", block.code]
                if lang == "python":
                    argv = [sys.executable, "-c", block.code]
                done = subprocess.run(
                    argv,
                    cwd=folder,
                    env=_env(),
                    timeout=BLOCK_TIMEOUT,
                    capture_output=True,
                    text=True,
                )
                assert done.returncode == 0, f"{block.where} failed:\n{done.stdout}{done.stderr}"
            elif lang == "python":
                _exec_python(block, namespace)
            elif lang in ("sh", "bash", "console"):
                _check_command_lines(block)
            elif lang == "json":
                json.loads(block.code)
            else:
                continue
            count += 1
        for block, process in background:
            assert process.wait(timeout=BLOCK_TIMEOUT) == 0, f"{block.where} failed"
    finally:
        for _, process in background:
            if process.poll() is None:
                process.kill()
                process.wait()
    return count


@pytest.mark.parametrize("page", PAGES, ids=lambda p: p.name)
def test_every_block_of_the_page_runs(
    page: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    run_page(page, tmp_path, monkeypatch)


EXAMPLES = sorted((ROOT / "examples").glob("*.py"))


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda p: p.name)
def test_every_example_runs_as_a_script(example: Path, tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, str(example)],
        cwd=tmp_path,
        env=_env(),
        timeout=BLOCK_TIMEOUT,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stdout + done.stderr


def test_the_examples_folder_holds_several_applications() -> None:
    assert len(EXAMPLES) >= 3
