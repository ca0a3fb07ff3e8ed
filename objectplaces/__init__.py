"""ObjectPlaces: roles and interaction sessions among mobile nodes."""

from __future__ import annotations

__all__: list[str] = []
