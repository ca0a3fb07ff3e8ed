"""Run one benchmark function with the code of another checkout, for same-run comparisons.

A figure measured today against one measured last week says more about the machine than
about the change; the same function run with the old and the new code, side by side in
one run, says what the change costs.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

__all__ = ["call_in_tree"]

_CALL = (
    "import dataclasses, importlib, json, sys; "
    "module, name, args = json.loads(sys.argv[1]); "
    "out = getattr(importlib.import_module(module), name)(*args); "
    "out = dataclasses.asdict(out) if dataclasses.is_dataclass(out) else out; "
    "print(json.dumps(out))"
)


def call_in_tree(tree: Path, module: str, function: str, args: list[Any]) -> Any:
    """``module.function(*args)`` imported from checkout ``tree``, in a child process.

    Args:
        tree: a checkout of this project (``git worktree add DIR <commit>``).
        module: dotted module name, e.g. ``"bench.groups"``.
        function: its function to call; a dataclass result comes back as a dict.
        args: JSON-serialisable positional arguments.

    Returns:
        The function's result, decoded from JSON.

    Raises:
        subprocess.CalledProcessError: the child failed (its stderr is attached).
    """
    env = {**os.environ, "PYTHONPATH": str(tree)}
    done = subprocess.run(
        [sys.executable, "-c", _CALL, json.dumps([module, function, args])],
        cwd=tree,
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(done.stdout.strip().splitlines()[-1])
