"""Compiled builds: the same source, compiled with mypyc, kept in a cache of its own.

A simulation spends its time in a few dozen modules (docs/sim-speed.md). mypyc compiles
such modules from their annotated source into C extensions that behave as the source
does, only faster. A build is a copy of the project's packages with those extensions
built beside their sources, under the user's cache directory, named by a digest of
every file copied, the list of modules, the Python and the mypyc version: an edit to
any source names a new build, so a stale one is never run, and the source tree itself
never holds an extension that could hide an edit.

A process runs on a build by putting the build first on its path; ``run_on_build``
starts the command line that way.
"""

from __future__ import annotations

import fcntl
import hashlib
import importlib.machinery
import json
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

__all__ = [
    "ACTIVE_ENV",
    "Build",
    "CompiledBuildError",
    "default_cache",
    "ensure_built",
    "find_built",
    "loaded_compiled",
    "run_on_build",
]

ACTIVE_ENV = "OBJECTPLACES_COMPILED"
"""Set to the build's directory in a process started on a build."""

_DONE = "build.json"

# Run in a child process, so setuptools' command machinery stays out of the caller's.
_BUILD_SCRIPT = """
import json, sys
from mypyc.build import mypycify
from setuptools import setup
paths = json.loads(sys.argv[1])
setup(
    name="objectplaces-compiled",
    packages=[],
    py_modules=[],
    ext_modules=mypycify(paths, opt_level="3", multi_file=len(paths) > 1),
    script_args=["build_ext", "--inplace", "--parallel", str(int(sys.argv[2]))],
)
"""


class CompiledBuildError(RuntimeError):
    """A build could not be made (no mypyc, no C compiler, a module it cannot compile)."""


@dataclass(frozen=True)
class Build:
    """What to compile: ``modules`` (dotted names) of ``packages`` found under ``root``."""

    root: Path
    packages: tuple[str, ...]
    modules: tuple[str, ...]

    def files(self) -> Iterator[Path]:
        """Every file a build copies, in a fixed order."""
        for package in self.packages:
            for path in sorted((self.root / package).rglob("*")):
                if path.is_file() and not _skipped(path):
                    yield path

    def digest(self) -> str:
        """A digest of the sources, the modules and the tools: a build's name."""
        h = hashlib.sha256()
        h.update(json.dumps([self.modules, sys.version, _mypyc_version()]).encode())
        for path in self.files():
            h.update(str(path.relative_to(self.root)).encode() + b"\0")
            h.update(path.read_bytes())
        return h.hexdigest()[:16]

    def sources(self) -> list[str]:
        """The compiled modules' source paths, relative to a build's directory."""
        return [module.replace(".", "/") + ".py" for module in self.modules]


def default_cache() -> Path:
    """Where builds are kept: ``$XDG_CACHE_HOME/objectplaces``, else ``~/.cache/...``."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "objectplaces"


def find_built(build: Build, cache: Path | None = None) -> Path | None:
    """The directory of ``build`` if the cache holds it complete, else None (never builds)."""
    target = (cache or default_cache()) / f"compiled-{build.digest()}"
    return target if (target / _DONE).is_file() else None


def ensure_built(
    build: Build,
    cache: Path | None = None,
    *,
    jobs: int = 2,
    report: Callable[[str], None] | None = None,
) -> Path:
    """The directory of ``build``, compiling it first when the cache has none.

    Concurrent callers (test workers, two terminals) build once: the others wait on a
    lock and find it done. Older builds in the cache are removed.

    Args:
        build: what to compile.
        cache: the cache directory; ``default_cache()`` when None.
        jobs: C compiler processes.
        report: told what happens, a line at a time (nothing when None).

    Raises:
        CompiledBuildError: mypyc or the C compiler failed (the message ends with the
            errors they printed), or the cache cannot be written.
    """
    say = report or (lambda _line: None)
    cache = cache or default_cache()
    found = find_built(build, cache)
    if found is not None:
        return found
    target = cache / f"compiled-{build.digest()}"
    try:
        cache.mkdir(parents=True, exist_ok=True)
        with _locked(cache / ".lock"):
            if not (target / _DONE).is_file():
                _build(build, cache, target, jobs, say)
    except OSError as exc:  # an unwritable cache, a full disk
        raise CompiledBuildError(f"cannot write the build cache {cache}: {exc}") from exc
    return target


def _build(build: Build, cache: Path, target: Path, jobs: int, say: Callable[[str], None]) -> None:
    """Compile ``build`` into ``target`` (the cache's lock held); drop older builds."""
    say(
        f"compiling {len(build.modules)} modules with mypyc into {target} "
        "(once for this source; a minute or two)"
    )
    started = time.monotonic()
    work = cache / f".building-{target.name}-{os.getpid()}"
    shutil.rmtree(work, ignore_errors=True)
    try:
        _compile(build, work, jobs, say)
        (work / _DONE).write_text(
            json.dumps({"modules": list(build.modules), "python": sys.version})
        )
        shutil.rmtree(target, ignore_errors=True)
        work.rename(target)
    finally:
        shutil.rmtree(work, ignore_errors=True)
    for old in cache.glob("compiled-*"):
        if old != target:
            shutil.rmtree(old, ignore_errors=True)
    say(f"compiled in {time.monotonic() - started:.0f} s")


def loaded_compiled(modules: Sequence[str]) -> list[str]:
    """Those of ``modules`` that this process imported from compiled extensions."""
    suffixes = tuple(importlib.machinery.EXTENSION_SUFFIXES)
    return [
        name
        for name in modules
        if (m := sys.modules.get(name)) is not None
        and str(getattr(m, "__file__", "")).endswith(suffixes)
    ]


def run_on_build(tree: Path, argv: Sequence[str]) -> int:
    """Run ``objectplaces ARGV`` in a child process on the build at ``tree``.

    Returns:
        The child's exit status.
    """
    env = {**os.environ, ACTIVE_ENV: str(tree)}
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(tree), env.get("PYTHONPATH")) if p)
    # -P: the working directory, perhaps a checkout of the same packages, stays off the
    # path, so the build's modules are the ones imported.
    command = [sys.executable, "-P", "-m", "objectplaces.cli", *argv]
    child = subprocess.Popen(command, env=env)
    try:
        return child.wait()
    except KeyboardInterrupt:  # the child got the same signal; let it finish its report
        return child.wait()


def _compile(build: Build, work: Path, jobs: int, say: Callable[[str], None]) -> None:
    for path in build.files():
        copy = work / path.relative_to(build.root)
        copy.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(path, copy)
    # mypyc type-checks what it compiles; libraries without annotations count as Any.
    (work / "mypy.ini").write_text("[mypy]\nignore_missing_imports = True\n")
    missing = [s for s in build.sources() if not (work / s).is_file()]
    if missing:
        raise CompiledBuildError(f"no such module to compile: {', '.join(missing)}")
    say(f"type-checking {len(build.modules)} modules and translating them to C")
    lines: list[str] = []
    progress = _Progress(say, work)
    with subprocess.Popen(
        [sys.executable, "-c", _BUILD_SCRIPT, json.dumps(build.sources()), str(jobs)],
        cwd=work,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    ) as child:
        assert child.stdout is not None
        for line in child.stdout:
            lines.append(line.rstrip("\n"))
            progress.saw(line)
    returncode = child.returncode
    if returncode != 0:
        # The compiler's command lines run to hundreds of characters: the errors say more.
        said = [line for line in lines if "error:" in line.lower()][-10:] or lines[-10:]
        tail = "\n".join(line if len(line) <= 300 else line[:300] + " ..." for line in said)
        raise CompiledBuildError(f"mypyc build failed (exit {returncode}):\n{tail}")
    shutil.rmtree(work / "build", ignore_errors=True)


class _Progress:
    """Turns the build's output into a progress line every few seconds.

    mypyc prints nothing while it type-checks and writes C; then setuptools prints
    ``running build_ext`` and one compiler command per C file (``... -c FILE.c -o ...``).
    """

    def __init__(self, say: Callable[[str], None], work: Path) -> None:
        self._say = say
        self._work = work
        self._total = 0
        self._done = 0
        self._last_said = time.monotonic()

    def saw(self, line: str) -> None:
        """Take one line of the build's output."""
        if line.startswith("running build_ext"):
            self._total = sum(1 for _ in (self._work / "build").rglob("*.c"))
            self._say(f"type-checked and translated; compiling {self._total} C files")
        elif " -c " in line and ".c -o " in line:
            self._done += 1
            now = time.monotonic()
            if now - self._last_said >= 10.0 or self._done == self._total:
                self._last_said = now
                self._say(f"compiled {self._done} of {self._total} C files")


def _skipped(path: Path) -> bool:
    return "__pycache__" in path.parts or path.name.endswith(
        tuple(importlib.machinery.EXTENSION_SUFFIXES)
    )


def _mypyc_version() -> str:
    try:
        from mypy.version import __version__
    except ImportError:
        return "none"
    return __version__


@contextmanager
def _locked(path: Path) -> Iterator[None]:
    with path.open("a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)
