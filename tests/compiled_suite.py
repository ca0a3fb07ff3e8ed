"""Run the tests of the compiled packages again, on the compiled build.

```sh
python -m tests.compiled_suite              # build if needed, then the tests, 2 workers
python -m tests.compiled_suite --no-slow    # without the long fleet scenarios (make test)
python -m tests.compiled_suite -k voter -x  # other arguments go to pytest
```

The build (``agv_app.fleet.compiled``, docs/sim-speed.md "A compiled build") is made
when the cache has none for this source, then pytest runs the tests of tuplespace,
objectplaces and agv_app with the build first on the path; the session refuses to
start unless every compiled module came from the build. Tests marked ``source_only``
stay out: they replace a function of a compiled module (compiled callers keep calling
the original) or check how an argument of the wrong type is refused (a compiled module
refuses it first, with a TypeError of its own), and tests marked ``processes``: only
``sim --compiled`` runs on the build, never an AGV or node process, so a process on
the build would test what no command runs. ``--no-slow`` leaves out the tests
marked ``slow`` as well: ``make test`` runs them on the source, and the fleet's figures
from both builds are compared in the suite itself (tests/agv_app/fleet/test_compiled.py).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

from agv_app.fleet.compiled import sim_build
from objectplaces.compiled import ACTIVE_ENV, CompiledBuildError, ensure_built

ROOT = Path(__file__).resolve().parent.parent
SUITES = ("tests/tuplespace", "tests/objectplaces", "tests/agv_app")
"""The tests of the packages the build compiles modules of."""


def main(argv: list[str] | None = None) -> int:
    """Build, then run the suites on the build; pytest's exit status."""
    extra = list(sys.argv[1:] if argv is None else argv)
    chosen = "not source_only and not processes"
    if "--no-slow" in extra:
        extra.remove("--no-slow")
        chosen += " and not slow"
    try:
        tree = ensure_built(sim_build(), report=lambda line: print(line, flush=True))
    except CompiledBuildError as exc:
        print(f"tests.compiled_suite: {exc}", file=sys.stderr)
        return 1
    env = {**os.environ, ACTIVE_ENV: str(tree)}
    env["PYTHONPATH"] = os.pathsep.join([str(tree), str(ROOT)])
    command = [
        sys.executable,
        "-P",  # the checkout's own packages must not come first
        "-m",
        "pytest",
        "-p",
        "no:cacheprovider",
        "--import-mode=importlib",
        "-m",
        chosen,
        "-n",
        "2",
        "--dist",
        "worksteal",
        *SUITES,
        *extra,
    ]
    print(f"tests on the compiled build {tree}", flush=True)
    return subprocess.call(command, env=env, cwd=ROOT)


if __name__ == "__main__":
    sys.exit(main())
