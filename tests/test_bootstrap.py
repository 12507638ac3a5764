"""rliable's stratified bootstrap, reproduced on NumPy alone (`bench.analysis.bootstrap`), gives
rliable's numbers to the bit. The expected values below are what rliable 1.2's
`get_interval_estimates` and `create_performance_profile` (on arch 7.2) returned for these
matrices after `np.random.seed(0)`; rliable's library itself no longer imports under pandas 3
(see the module's docstring)."""

from __future__ import annotations

import numpy as np
import pytest
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


@pytest.mark.parametrize("block_elements", [2**20, 9])
@pytest.mark.parametrize(
    "samples",
    [(X,), (X, X[::-1] + 1), (np.arange(24.0).reshape(4, 2, 3),), (X, Y), (X[:1], Y)],
    ids=[
        "one",
        "a pair alike in runs",
        "curves (runs x tasks x points)",
        "a pair unlike",
        "one run",
    ],
)
def test_resamples_drawn_at_once_are_the_ones_drawn_rep_by_rep(
    monkeypatch, samples, block_elements
):
    """rliable draws each rep's run indices with `choice`, sample by sample; the bootstrap
    draws many reps at once where it can (blocks of 9 elements here cross the reps' seams)."""
    monkeypatch.setattr(bootstrap, "BLOCK_ELEMENTS", block_elements)
    reps, rng = 7, np.random.RandomState(3)
    expected = []
    for _ in range(reps):
        expected.append([])
        for x in samples:
            runs = rng.choice(len(x), x.shape, replace=True)
            strata = np.ogrid[tuple(slice(n) for n in (0, *x.shape[1:]))][1:]
            expected[-1].append(x[(runs, *strata)])
    blocks = bootstrap._resample_blocks(samples, reps, np.random.RandomState(3))
    drawn = [rep for stacks in blocks for rep in zip(*stacks, strict=True)]
    assert len(drawn) == reps
    for got, want in zip(drawn, expected, strict=True):
        assert all(np.array_equal(g, w) for g, w in zip(got, want, strict=True))


def test_estimators_over_a_stack_of_resamples_are_theirs_resample_by_resample():
    """What the reports bootstrap, computed a block of resamples at once, is to the bit what
    rliable's estimators give one resample at a time: over run and task counts (odd, even,
    one task), ties between runs and between the pair's columns, scales far apart."""
    rng = np.random.default_rng(0)
    taus = np.linspace(-2.0, 2.0, 11)
    for runs in (1, 2, 3, 5, 8, 10, 13, 25):
        for tasks in (1, 2, 3, 6):
            stack = rng.standard_normal((20, runs, tasks)) * 10.0 ** rng.uniform(-3, 3)
            other = rng.standard_normal((20, runs, tasks)).round(1)
            if runs > 2:
                stack[:, :2] = stack[:, 2:3]  # tied runs
            other[::3] = stack[::3]  # resamples whose columns are alike
            expected = {
                "mean": [metrics.aggregate_mean(x) for x in stack],
                "median": [metrics.aggregate_median(x) for x in stack],
                "iqm": [metrics.aggregate_iqm(x) for x in stack],
                "improvement": [
                    metrics.probability_of_improvement(x, y)
                    for x, y in zip(stack, other, strict=True)
                ],
                # rliable's score distribution (its library's, which does not import here)
                "profile": [[np.mean(x > tau) for tau in taus] for x in stack],
                "iqm per column": [bootstrap.iqm(x, axis=0) for x in stack],  # curves' bands
            }
            got = {
                "mean": bootstrap.aggregate_mean_over(stack),
                "median": bootstrap.aggregate_median_over(stack),
                "iqm": bootstrap.aggregate_iqm_over(stack),
                "improvement": bootstrap.probability_of_improvement_over_resamples(stack, other),
                "profile": bootstrap.score_distribution_over(stack, taus),
                "iqm per column": bootstrap.iqm(stack, axis=1),
            }
            for name, want in expected.items():
                assert np.array_equal(got[name], np.array(want)), (name, runs, tasks)
