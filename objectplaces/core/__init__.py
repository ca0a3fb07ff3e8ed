"""The sans-I/O core of ObjectPlaces: inputs in, outputs out; no clock, sockets or randomness."""

__all__: list[str] = []
