"""Tests of the WebSocket mesh: real node processes, bad input, the decoders."""
