"""The sans-I/O core of ObjectPlaces: inputs in, outputs out; no clock, sockets or randomness."""
