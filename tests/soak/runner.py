"""Run seeds of the simulation suite; replay one.

```sh
python -m tests.soak.runner --seeds 1-2000 --jobs 2     # many seeds, with progress
OP_SEED=17 python -m tests.soak.runner --seed 17         # replay one, step by step
```

Each seed builds its scenario (``tests/soak/workload.py``), applies it step by step to
a ``World`` and checks the invariants (``tests/soak/invariants.py``) after every step; a
calm phase waits until membership converged and channels drained, up to a bound derived
from the seed's timings, and fails if the bound passes first. A seed stops at its first
step with a violation. Every failing seed is printed with its replay command, and the
exit status is 1 when any seed failed.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import multiprocessing
import os
import signal
import sys
import time
import traceback
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from types import FrameType
from typing import TYPE_CHECKING

from objectplaces.core.participations import tombstone_life
from tests.soak.invariants import (
    channels_complete,
    convergence_bound,
    deactivated_on_leave,
    forget_deadline,
    judge,
    membership_converged,
    memory_bounded,
    no_exception_escaped,
    nothing_left,
    state_within_bounds,
    stopped_sessions_forgotten,
)
from tests.soak.probes import AppFault
from tests.soak.workload import Settle, Wait, generate
from tests.soak.world import World

if TYPE_CHECKING:
    from rich.progress import Progress

__all__ = ["RunResult", "main", "parse_seeds", "replay_command", "run_seed", "seed_progress"]

SETTLE_STEP = 0.1
"""Virtual seconds between two looks at a settling world."""


@dataclass
class RunResult:
    """The outcome of one seed."""

    seed: int
    violations: list[str] = field(default_factory=list)
    failed_step: str | None = None
    steps: int = 0
    virtual_seconds: float = 0.0
    wall_seconds: float = 0.0
    convergence: list[float] = field(default_factory=list)
    facts: int = 0
    frames: int = 0
    app_faults: int = 0

    @property
    def ok(self) -> bool:
        """No violation."""
        return not self.violations


def replay_command(seed: int) -> str:
    """The command that replays ``seed``."""
    return f"OP_SEED={seed} python -m tests.soak.runner --seed {seed}"


class _EscapeLog(logging.Handler):
    """Collects what the middleware logs with an exception, except the roles' AppFault."""

    def __init__(self, sink: list[str], clock: Callable[[], float]) -> None:
        super().__init__(logging.ERROR)
        self.sink = sink
        self.clock = clock

    def emit(self, record: logging.LogRecord) -> None:
        exc = record.exc_info[1] if record.exc_info else None
        if isinstance(exc, AppFault):
            return
        where = f"t={self.clock():.3f} logged by {record.name}: {record.getMessage()}"
        if exc is not None:
            where += f" ({type(exc).__name__}: {exc})"
        self.sink.append(where)


@contextlib.contextmanager
def _capture(world: World) -> Iterator[None]:
    handler = _EscapeLog(world.escaped, lambda: world.now)
    logger = logging.getLogger("objectplaces")
    logger.addHandler(handler)
    try:
        yield
    finally:
        logger.removeHandler(handler)


def _settle(world: World, result: RunResult, *, final: bool) -> list[str]:
    """Run until the checks of a calm world pass or the bound passes; what failed."""
    if final:
        bound = forget_deadline(world) + tombstone_life(world.config) + 1.0
    else:
        bound = convergence_bound(world)
    start = world.now
    seen = len(world.ledger.facts)
    while True:
        facts = world.ledger.facts
        found = judge(facts[seen:]) + no_exception_escaped(world)
        seen = len(facts)
        if found:
            return found
        if final:
            found = nothing_left(world) + memory_bounded(world)
        else:
            found = membership_converged(world) + channels_complete(world)
            found += memory_bounded(world) + state_within_bounds(world)
        if not found:
            if not final:
                result.convergence.append(round(world.now - start, 3))
            return []
        if world.now - start >= bound:
            return [f"after {bound:.1f}s of calm: {what}" for what in found]
        world.net.run_for(SETTLE_STEP)


def run_seed(
    seed: int, *, phases: int = 3, trace: Callable[[str], None] | None = None
) -> RunResult:
    """Run the scenario of ``seed`` and check every invariant after every step.

    Args:
        seed: the seed.
        phases: chaos phases, each ending in a calm checkpoint.
        trace: called with a line per step (replays print them).
    """
    started = time.perf_counter()
    scenario = generate(seed, phases=phases)
    result = RunResult(seed)
    world = World(scenario)
    seen = 0
    with _capture(world):
        for index, step in enumerate(scenario.steps):
            if trace is not None:
                trace(f"{index:4d} t={world.now:8.3f}  {step!r}")
            try:
                if isinstance(step, Settle):
                    found = _settle(world, result, final=step.final)
                else:
                    world.apply(step)
                    if not isinstance(step, Wait):
                        world.net.run_for(0.0)  # what is due at this instant
                    found = []
            except Exception as exc:
                found = [f"escaped: {type(exc).__name__}: {exc}\n{traceback.format_exc()}"]
            facts = world.ledger.facts
            found += judge(facts[seen:])
            seen = len(facts)
            found += no_exception_escaped(world)
            found += stopped_sessions_forgotten(world) + deactivated_on_leave(world)
            result.steps = index + 1
            if found:
                result.violations = list(dict.fromkeys(found))
                result.failed_step = f"step {index} at t={world.now:.3f}: {step!r}"
                break
    result.virtual_seconds = round(world.now, 3)
    result.wall_seconds = time.perf_counter() - started
    result.facts = len(world.ledger.facts)
    result.frames = world.net.stats().messages
    result.app_faults = world.ledger.app_faults
    return result


def parse_seeds(text: str) -> list[int]:
    """``"1-200"``, ``"7"``, ``"1-5,9,12-13"`` -> the seeds, in order."""
    seeds: list[int] = []
    for part in text.split(","):
        first, dash, last = part.strip().partition("-")
        try:
            low = int(first)
            high = int(last) if dash else low
        except ValueError:
            raise argparse.ArgumentTypeError(f"not a seed range: {part!r}") from None
        if high < low:
            raise argparse.ArgumentTypeError(f"empty seed range: {part!r}")
        seeds.extend(range(low, high + 1))
    return seeds


class _SeedTimeout(Exception):
    pass


def _on_alarm(signum: int, frame: FrameType | None) -> None:
    raise _SeedTimeout


def _run_bounded(seed: int, seconds: int) -> RunResult:
    """``run_seed`` that fails (rather than hangs) past ``seconds`` of wall time."""
    signal.signal(signal.SIGALRM, _on_alarm)
    signal.alarm(seconds)
    try:
        return run_seed(seed)
    except _SeedTimeout:
        return RunResult(seed, [f"the seed ran longer than {seconds}s of wall time"])
    finally:
        signal.alarm(0)


def _worker(job: tuple[int, int]) -> RunResult:
    logging.disable(logging.WARNING - 1)  # workers print nothing but their results
    return _run_bounded(*job)


def _print_failure(result: RunResult, out: Callable[[str], None]) -> None:
    out(f"seed {result.seed} FAILED at {result.failed_step}")
    for line in result.violations[:10]:
        out(f"  {line}")
    if len(result.violations) > 10:
        out(f"  ... and {len(result.violations) - 10} more")
    out(f"  replay: {replay_command(result.seed)}")


def seed_progress() -> Progress:
    """The progress bar of a many-seed run, on stderr: what it says, a bar, seeds done
    of all, time taken."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeElapsedColumn

    columns = (
        "[progress.description]{task.description}",
        BarColumn(),
        MofNCompleteColumn(),
        TimeElapsedColumn(),
    )
    return Progress(*columns, console=Console(stderr=True))


def _run_many(seeds: list[int], jobs: int, seed_timeout: int, budget: float | None) -> int:
    started = time.perf_counter()
    results: list[RunResult] = []
    failed: list[RunResult] = []
    jobs_list = [(seed, seed_timeout) for seed in seeds]
    with (
        seed_progress() as progress,
        multiprocessing.get_context("fork").Pool(jobs, maxtasksperchild=200) as pool,
    ):
        task = progress.add_task("soak: 0 failed", total=len(seeds))
        for result in pool.imap_unordered(_worker, jobs_list):
            results.append(result)
            if not result.ok:
                failed.append(result)
                _print_failure(result, progress.console.print)
            progress.update(task, advance=1, description=f"soak: {len(failed)} failed")
            if budget is not None and time.perf_counter() - started > budget:
                progress.console.print(f"time budget of {budget:.0f}s spent: stopping")
                pool.terminate()
                break
    wall = time.perf_counter() - started
    convergence = sorted(c for r in results for c in r.convergence)
    print(
        f"soak: {len(results)} seeds run ({min(seeds)}-{max(seeds)} asked), "
        f"{len(failed)} failed, {wall:.1f}s wall, "
        f"{sum(r.virtual_seconds for r in results):.0f}s virtual, "
        f"{sum(r.steps for r in results)} steps, {sum(r.frames for r in results)} frames, "
        f"{sum(r.facts for r in results)} facts checked, "
        f"{sum(r.app_faults for r in results)} role faults survived"
    )
    if convergence:
        p99 = convergence[min(len(convergence) - 1, int(0.99 * len(convergence)))]
        print(
            f"convergence after heal: median {convergence[len(convergence) // 2]:.1f}s, "
            f"p99 {p99:.1f}s, max {convergence[-1]:.1f}s over {len(convergence)} checkpoints"
        )
    for result in sorted(failed, key=lambda r: r.seed):
        print(f"FAILED seed {result.seed}: {result.violations[0].splitlines()[0]}")
        print(f"  {replay_command(result.seed)}")
    return 1 if failed else 0


def main(argv: list[str] | None = None) -> int:
    """The command line; returns the exit status."""
    parser = argparse.ArgumentParser(prog="python -m tests.soak.runner", description=__doc__)
    which = parser.add_mutually_exclusive_group()
    which.add_argument("--seed", type=int, help="replay one seed, printing every step")
    which.add_argument("--seeds", type=parse_seeds, help="seeds to run, e.g. 1-2000")
    parser.add_argument("--jobs", type=int, default=1, help="worker processes (default 1)")
    parser.add_argument(
        "--seed-timeout", type=int, default=300, help="wall seconds before a seed counts as hung"
    )
    parser.add_argument(
        "--budget", type=float, default=None, help="stop starting seeds after this many seconds"
    )
    parser.add_argument("--quiet", action="store_true", help="replay without the step trace")
    args = parser.parse_args(argv)
    seed = args.seed
    if seed is None and args.seeds is None:
        replay = os.environ.get("OP_SEED")
        if replay is None:
            parser.error("give --seed N or --seeds A-B (or set OP_SEED)")
        seed = int(replay)
    if seed is not None:
        result = run_seed(seed, trace=None if args.quiet else print)
        print(
            f"seed {seed}: {result.steps} steps, {result.virtual_seconds:.1f}s virtual, "
            f"{result.wall_seconds:.2f}s wall, {result.frames} frames, "
            f"convergence {result.convergence}"
        )
        if result.ok:
            print(f"seed {seed}: ok")
            return 0
        _print_failure(result, print)
        return 1
    return _run_many(args.seeds, max(1, args.jobs), args.seed_timeout, args.budget)


if __name__ == "__main__":
    sys.exit(main())
