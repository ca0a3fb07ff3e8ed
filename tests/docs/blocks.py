"""The code blocks of a markdown page, and how the suite runs each.

A block runs by its language, unless an HTML comment on the line before it says
otherwise (``<!-- test: MARK -->``, invisible on the rendered page):

=====================  ===============================================================
block                  what the suite does
=====================  ===============================================================
```python              run in the page's namespace, in order, in the page's own
                       temporary folder; a block with a top-level ``await`` runs in an
                       event loop (bounded in time)
file NAME              written to NAME in that folder (a script a later block runs)
run                    a ``sh`` block run by bash there (or a ``python`` block run as a
                       script in a process of its own), bounded in time; must exit 0
background             a ``sh`` block started there; it must exit 0 by the page's end
```sh (no mark)        not run (installs, long commands): every ``objectplaces`` command
                       in it must parse with the command line's own parser
```json                must parse as JSON
anything else          text: not run
=====================  ===============================================================
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Block", "blocks_of"]

_FENCE = re.compile(
    r"(?:^<!-- test: (?P<mark>[^>]*?) -->\n)?"
    r"^(?P<indent>[ ]*)```(?P<lang>[\w-]*)[^\n]*\n(?P<code>.*?)^(?P=indent)```[ ]*$",
    re.MULTILINE | re.DOTALL,
)


@dataclass(frozen=True)
class Block:
    """One fenced block of a page."""

    page: Path
    line: int
    lang: str
    code: str
    mark: str = ""

    @property
    def where(self) -> str:
        """``page:line``, for messages and tracebacks."""
        return f"{self.page.name}:{self.line}"


def blocks_of(page: Path) -> list[Block]:
    """Every fenced block of ``page``, in order."""
    text = page.read_text()
    found = []
    for match in _FENCE.finditer(text):
        indent = match.group("indent")
        code = "\n".join(line.removeprefix(indent) for line in match.group("code").splitlines())
        line = text.count("\n", 0, match.start("lang")) + 1
        found.append(Block(page, line, match.group("lang"), code + "\n", match.group("mark") or ""))
    return found
