"""Transports: the in-memory simulated network and the WebSocket mesh."""

__all__: list[str] = []
