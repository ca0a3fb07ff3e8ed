"""The deterministic randomized simulation suite: seeded workloads, invariants, a runner."""
