"""Compiled builds (objectplaces.compiled): built once per source, run, never stale."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import threading
from pathlib import Path

import pytest

import objectplaces
from objectplaces.compiled import (
    ACTIVE_ENV,
    Build,
    CompiledBuildError,
    ensure_built,
    find_built,
)

pytestmark = [
    pytest.mark.source_only("builds from the source tree it runs in"),
    # Each test builds a one-module package: seconds on a quiet machine, a minute or more
    # on a loaded one; the bound only catches a hang.
    pytest.mark.timeout(900),
]

_FAST = """
class Counter:
    def __init__(self) -> None:
        self.n = 0

    def add(self, k: int) -> int:
        self.n += k
        return self.n


def total(values: list[int]) -> int:
    c = Counter()
    for v in values:
        c.add(v)
    return c.n
"""


def _package(root: Path, body: str = _FAST) -> Build:
    (root / "tinyp").mkdir(parents=True, exist_ok=True)
    (root / "tinyp" / "__init__.py").write_text("")
    (root / "tinyp" / "fast.py").write_text(body)
    (root / "tinyp" / "data.txt").write_text("shipped beside the code\n")
    return Build(root, ("tinyp",), ("tinyp.fast",))


def _run_on(tree: Path, code: str) -> str:
    root = Path(objectplaces.__file__).resolve().parent.parent
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(tree), str(root)])}
    done = subprocess.run(
        [sys.executable, "-P", "-c", code],
        env=env,
        cwd=tree,
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    )
    return done.stdout.strip()


def test_a_build_runs_the_module_compiled_with_the_same_results(tmp_path: Path) -> None:
    build = _package(tmp_path / "src")
    lines: list[str] = []
    assert find_built(build, tmp_path / "cache") is None
    tree = ensure_built(build, tmp_path / "cache", report=lines.append)
    assert find_built(build, tmp_path / "cache") == tree
    assert tree.name == f"compiled-{build.digest()}"
    assert lines[0].startswith("compiling 1 modules with mypyc")
    assert lines[1] == "type-checking 1 modules and translating them to C"
    assert any(re.fullmatch(r"compiled (\d+) of \1 C files", line) for line in lines)
    assert lines[-1].startswith("compiled in ")
    out = _run_on(
        tree,
        "import tinyp.fast as f\n"
        "from objectplaces.compiled import loaded_compiled\n"
        "print(f.total([1, 2, 39]), loaded_compiled(['tinyp.fast', 'tinyp']))",
    )
    assert out == "42 ['tinyp.fast']"
    assert (tree / "tinyp" / "data.txt").read_text() == "shipped beside the code\n"
    assert not list((tmp_path / "src").rglob("*.so")), "the source tree stays pure"


def test_a_second_call_finds_the_build_and_an_edit_names_a_new_one(tmp_path: Path) -> None:
    src, cache = tmp_path / "src", tmp_path / "cache"
    build = _package(src)
    first = ensure_built(build, cache)
    lines: list[str] = []
    assert ensure_built(build, cache, report=lines.append) == first
    assert lines == []  # nothing built
    edited = _package(src, _FAST + "\nANSWER = 42\n")
    second = ensure_built(edited, cache)
    assert second != first
    assert not first.exists(), "the older build is removed"
    assert _run_on(second, "import tinyp.fast as f; print(f.ANSWER)") == "42"


def test_callers_at_once_build_once(tmp_path: Path) -> None:
    build = _package(tmp_path / "src")
    lines: list[str] = []
    trees: list[Path] = []

    def call() -> None:
        trees.append(ensure_built(build, tmp_path / "cache", report=lines.append))

    callers = [threading.Thread(target=call) for _ in range(3)]
    for c in callers:
        c.start()
    for c in callers:
        c.join(timeout=300)
    assert len(trees) == 3
    assert len(set(trees)) == 1
    assert sum(line.startswith("compiling") for line in lines) == 1


def test_a_module_mypyc_refuses_fails_with_its_message(tmp_path: Path) -> None:
    build = _package(tmp_path / "src", "def f() -> int:\n    return 'not an int'\n")
    with pytest.raises(CompiledBuildError, match="Incompatible return value type"):
        ensure_built(build, tmp_path / "cache")
    assert not list((tmp_path / "cache").glob("compiled-*")), "no half-made build is kept"


def test_a_module_that_is_not_there_is_named(tmp_path: Path) -> None:
    build = _package(tmp_path / "src")
    missing = Build(build.root, build.packages, ("tinyp.fast", "tinyp.slow"))
    with pytest.raises(CompiledBuildError, match=r"no such module to compile: tinyp/slow\.py"):
        ensure_built(missing, tmp_path / "cache")


def test_the_cache_follows_xdg_cache_home(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from objectplaces.compiled import default_cache

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert default_cache() == tmp_path / "objectplaces"
    monkeypatch.delenv("XDG_CACHE_HOME")
    assert default_cache() == Path.home() / ".cache" / "objectplaces"
    assert ACTIVE_ENV == "OBJECTPLACES_COMPILED"


def test_a_cache_that_cannot_be_written_is_named(tmp_path: Path) -> None:
    build = _package(tmp_path / "src")
    blocked = tmp_path / "a-file"
    blocked.write_text("not a directory")
    with pytest.raises(CompiledBuildError, match=r"cannot write the build cache .*a-file"):
        ensure_built(build, blocked / "cache")
