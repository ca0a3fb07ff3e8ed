"""What an AGV process says: one JSON object per line on stdout, and the name it signs
its errors on stderr with (:mod:`agv_app.fleet.agv_process`).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any

__all__ = ["emit", "who"]


def emit(event: str, **fields: Any) -> None:
    """Print one event as a JSON line on stdout."""
    record = {"event": event, "t": time.monotonic(), **fields}
    sys.stdout.write(json.dumps(record, default=repr) + "\n")
    sys.stdout.flush()


def who(args: argparse.Namespace) -> str:
    """The name an AGV process signs its errors on stderr with."""
    return f"objectplaces agv {args.id}"
