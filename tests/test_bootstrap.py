"""rliable's stratified bootstrap, reproduced on NumPy alone (`bench.analysis.bootstrap`), gives
rliable's numbers to the bit. The expected values below are what rliable 1.2's
`get_interval_estimates` and `create_performance_profile` (on arch 7.2) returned for these
matrices after `np.random.seed(0)`; rliable's library itself no longer imports under pandas 3
(see the module's docstring)."""

from __future__ import annotations

import numpy as np
from rliable import metrics

from bench.analysis import bootstrap

X = np.array([[1.0, 5.0], [2.0, 6.0], [3.0, 7.0], [4.0, 8.0]])
"""4 runs x 2 tasks."""
Y = np.array([[0.0, 6.0], [2.5, 5.5], [3.5, 4.0]])
"""3 runs x the same 2 tasks."""


def aggregates(scores: np.ndarray) -> np.ndarray:
    return np.array(
        [
            metrics.aggregate_mean(scores),
            metrics.aggregate_median(scores),
            metrics.aggregate_iqm(scores),
        ]
    )


def test_interval_estimates_are_rliables():
    points, intervals = bootstrap.interval_estimates({"x": X}, aggregates, reps=50, seed=0)
    assert points["x"].tolist() == [4.5, 4.5, 4.5]  # by hand: every aggregate of 1..8
    assert intervals["x"].tolist() == [[3.653125, 3.653125, 3.5], [5.346875, 5.346875, 5.44375]]


def test_independent_samples_are_resampled_apart_as_rliable_does():
    points, intervals = bootstrap.interval_estimates(
        {"k": (X, Y)}, metrics.probability_of_improvement, reps=50, seed=0
    )
    assert points["k"] == 0.6875
    assert intervals["k"].tolist() == [[0.3010416666666667], [0.9812499999999998]]


def test_performance_profiles_are_rliables():
    profiles, intervals = bootstrap.performance_profiles({"x": X}, [2.0, 4.5], reps=50, seed=0)
    # 6 of the 8 runs x tasks score above 2; every resample keeps task 1 below 4.5, task 2 above
    assert profiles["x"].tolist() == [0.75, 0.5]
    assert intervals["x"].tolist() == [[0.5, 0.5], [1.0, 0.5]]


def test_a_resample_draws_runs_within_each_task():
    rng = np.random.RandomState(0)
    for _ in range(20):
        resampled = bootstrap.stratified_resample(X, rng)
        assert resampled.shape == X.shape
        assert set(resampled[:, 0]) <= {1, 2, 3, 4} and set(resampled[:, 1]) <= {5, 6, 7, 8}


def test_the_global_rng_is_left_alone():
    np.random.seed(123)
    expected = np.random.rand()
    np.random.seed(123)
    bootstrap.interval_estimates({"x": X}, aggregates, reps=20, seed=5)
    assert np.random.rand() == expected
