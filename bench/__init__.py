"""Benchmarks: one script per figure; each updates its section of BENCHMARKS.md."""
