"""The README's middleware example runs as written."""

from __future__ import annotations

import re
from pathlib import Path

README = Path(__file__).resolve().parent.parent / "README.md"


def test_the_simulated_network_example_runs() -> None:
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), re.DOTALL)
    example = next(block for block in blocks if "SimulatedNetwork" in block)
    exec(compile(example, str(README), "exec"), {"__name__": "readme"})
