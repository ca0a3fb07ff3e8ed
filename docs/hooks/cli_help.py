"""mkdocs hook: ``<!-- cli-help: NAME -->`` in a page becomes ``objectplaces NAME --help``,
as the installed command line prints it, so the reference never drifts from the code."""

from __future__ import annotations

import contextlib
import io
import os
import re
from typing import Any

from objectplaces.cli import build_parser

MARKER = re.compile(r"<!-- cli-help: ?([\w-]*) -->")


def _help(name: str) -> str:
    os.environ["COLUMNS"] = "100"  # argparse wraps to the terminal: fix the width
    parser = build_parser()
    out = io.StringIO()
    err = io.StringIO()
    with (
        contextlib.redirect_stdout(out),
        contextlib.redirect_stderr(err),
        contextlib.suppress(SystemExit),
    ):
        parser.parse_args([name, "--help"] if name else ["--help"])
    if not out.getvalue():
        # A command of a missing extra: a page without its options would pass for whole.
        raise RuntimeError(
            f"no help for `objectplaces {name}`: {err.getvalue().strip()} "
            "(build the docs with every extra installed: pip install -e '.[all,docs]')"
        )
    return out.getvalue().rstrip()


def on_page_markdown(markdown: str, **kwargs: Any) -> str:
    """Replace each marker with the help of its command, as a text block."""
    return MARKER.sub(lambda m: f"```text\n{_help(m.group(1))}\n```", markdown)
