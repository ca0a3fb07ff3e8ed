"""A small JSON document in one file, replaced atomically: what a vehicle keeps across a
restart of its process (the simulated driver's pose, the task the process held).

A write goes to a temporary file in the same directory, which then replaces the old one
(``os.replace``), so a reader finds the old document or the new one, never a torn one.
``durable=True`` also syncs the file and its directory to the disk, for what must
survive a power cut; without it a crash of the process loses nothing, a power cut may
lose the last writes.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

from agv_app.geometry import Pose

__all__ = ["StateFile", "StateFileError", "pose_from_json", "pose_to_json"]


class StateFileError(ValueError):
    """A state file exists but does not hold what it should."""


class StateFile:
    """One JSON document at ``path``.

    Args:
        path: the file; its directory must exist.
    """

    __slots__ = ("path",)

    def __init__(self, path: Path) -> None:
        self.path = path

    def read(self) -> Any:
        """The document, or None when there is no file.

        Raises:
            StateFileError: the file is not JSON.
        """
        try:
            text = self.path.read_text(encoding="utf-8")
        except FileNotFoundError:
            return None
        try:
            return json.loads(text)
        except json.JSONDecodeError as exc:
            raise StateFileError(f"{self.path}: not JSON ({exc})") from None

    def write(self, document: Any, *, durable: bool = False) -> None:
        """Replace the document (see the module docstring for ``durable``)."""
        data = json.dumps(document, separators=(",", ":")).encode()
        tmp = self.path.with_name(f".{self.path.name}.tmp")
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600)
        try:
            os.write(fd, data)
            if durable:
                os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(tmp, self.path)
        if durable:
            dir_fd = os.open(self.path.parent, os.O_RDONLY)
            try:
                os.fsync(dir_fd)
            finally:
                os.close(dir_fd)


def pose_to_json(pose: Pose) -> dict[str, float]:
    """A pose as a JSON object."""
    return {"x": pose.x, "y": pose.y, "heading_rad": pose.heading_rad}


def pose_from_json(document: Any, *, where: str = "pose") -> Pose:
    """The pose a JSON object holds.

    Raises:
        StateFileError: not an object with finite ``x``, ``y`` and ``heading_rad``.
    """
    if not isinstance(document, dict):
        raise StateFileError(f"{where}: expected an object, got {document!r}")
    values = []
    for key in ("x", "y", "heading_rad"):
        value = document.get(key)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise StateFileError(f"{where}: {key} must be a number, got {value!r}")
        if not math.isfinite(value):
            raise StateFileError(f"{where}: {key} must be finite, got {value!r}")
        values.append(float(value))
    return Pose(values[0], values[1], values[2])
