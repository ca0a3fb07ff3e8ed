"""Drivers that feed the sans-I/O core: a simulated runtime and an asyncio runtime."""

__all__: list[str] = []
