"""Samples: exact count, mean and maximum for ever; percentiles over recent values."""

from __future__ import annotations

import pytest

from agv_app.samples import Samples, percentile


def test_mean_and_maximum_are_exact_while_only_recent_values_are_kept() -> None:
    samples = Samples(keep=4)
    for value in [100.0, 1.0, 2.0, 3.0, 4.0]:
        samples.append(value)
    assert len(samples) == samples.count == 5
    assert samples.mean == 22.0
    assert samples.maximum == 100.0
    assert samples.recent() == [1.0, 2.0, 3.0, 4.0]
    assert samples.percentile(100) == 4.0
    assert samples.percentile(50) == 2.5


def test_empty_samples_and_a_bad_keep() -> None:
    samples = Samples()
    assert samples.mean == samples.maximum == samples.percentile(95) == 0.0
    assert percentile([], 50) == 0.0
    with pytest.raises(ValueError, match="keep must be at least 1, got 0"):
        Samples(keep=0)
