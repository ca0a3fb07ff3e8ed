"""Shared output for the benchmark scripts: print a figure, then record it in BENCHMARKS.md.

Each script owns one section of ``BENCHMARKS.md`` delimited by HTML comments, so the
scripts can run in any order and rewrite only what they measured.
"""

from __future__ import annotations

import datetime as _dt
import os
import platform
import re
import sys
from collections.abc import Sequence
from pathlib import Path

__all__ = ["BENCHMARKS_PATH", "GOALS", "machine_summary", "markdown_table", "publish"]

BENCHMARKS_PATH = Path(__file__).resolve().parent.parent / "BENCHMARKS.md"

_HEADER = (
    "# Benchmarks\n\n"
    "Each section below is written by the script it names; rerun the command shown to\n"
    "reproduce it. Every figure is compared with a baseline measured in the same run, on\n"
    "the same machine, so ratios hold even where absolute times drift.\n\n"
    "Each section holds the latest run of its script: what it measures, its goals, the\n"
    "command that reproduces it. Earlier runs live in the repository's history.\n"
)

GOALS: dict[str, str] = {
    "vda5050": "VDA 5050 adds little to a vehicle's reaction: an order or instant action "
    "reaches the vehicle, and its state comes back, within a few milliseconds on one host.",
    "fleet_saturation": "A fleet larger than its floor carries keeps its throughput and never "
    "deadlocks: with the task desk's limit, no wait over 180 s and tasks/h no lower than "
    "with fewer AGVs.",
    "fleet_saturation_generated_100": "The same on a large generated warehouse: 100 AGVs on "
    "`generated:100` with the automatic limit, no wait over 180 s and no violation.",
    "long_run": "Nothing drifts over hours: throughput, waits, memory and tracked objects stay "
    "flat from the first hour to the last, with no collision, lock overlap or deadlock.",
}
"""The goal of each section whose script's body does not state one."""


def machine_summary() -> str:
    """Describe this machine in one line (CPU count, Python, platform)."""
    return (
        f"{os.cpu_count()} CPUs, Python {platform.python_version()}, "
        f"{platform.system()} {platform.machine()}"
    )


def markdown_table(header: Sequence[str], rows: Sequence[Sequence[object]]) -> str:
    """Render rows as a GitHub-flavoured markdown table."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)


def publish(name: str, title: str, body: str, command: str) -> None:
    """Print a benchmark's result and write it into its section of BENCHMARKS.md.

    Args:
        name: the section key, usually the script's stem (``"tuplespace"``).
        title: the section heading.
        body: markdown with the measured figures.
        command: the shell command that reproduces the section.
    """
    stamp = _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    goal = f"Goal: {GOALS[name]}\n\n" if name in GOALS else ""
    section = (
        f"<!-- bench:{name} -->\n## {title}\n\n"
        f"Measured {stamp} on {machine_summary()}.  \n"
        f"Reproduce: `{command}`\n\n{goal}{body.strip()}\n<!-- /bench:{name} -->"
    )
    print(section)
    text = BENCHMARKS_PATH.read_text() if BENCHMARKS_PATH.exists() else _HEADER
    pattern = re.compile(
        rf"<!-- bench:{re.escape(name)} -->.*?<!-- /bench:{re.escape(name)} -->", re.DOTALL
    )
    if pattern.search(text):
        text = pattern.sub(lambda _: section, text)
    else:
        text = text.rstrip("\n") + "\n\n" + section + "\n"
    BENCHMARKS_PATH.write_text(text)
    print(f"\nwrote section {name!r} of {BENCHMARKS_PATH.name}", file=sys.stderr)
