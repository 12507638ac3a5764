"""rliable's stratified bootstrap and its fast estimators, on NumPy alone.

The statistics follow rliable (Agarwal et al., NeurIPS 2021): its metrics module is used as
it is, but its `library` (the bootstrap) is reproduced here, to the bit, rather than
imported. `rliable.library` imports arch, and arch 7.2 calls pandas' private
`deprecate_kwarg` in the form pandas 3 removed (pandas-dev/pandas#61468), so it cannot be
imported under pandas 3 without patching pandas; arch 8 fixed that but dropped the
`random_state` keyword that rliable 1.2 (the latest) still passes, so no released pair of
the two runs under pandas 3. What rliable's bootstrap does is short: resample each task's
runs with replacement, apart from the other tasks' (`stratified_resample`), apply the
statistic each time, and take the 2.5th and 97.5th percentiles of what comes out
(`interval_estimates`, arch's percentile method).

Each bootstrap draws its indices from a `RandomState` seeded with `seed`: the stream that
rliable, which draws from NumPy's global RNG, reads after `np.random.seed(seed)`, so the
intervals are the ones rliable gives, and the global RNG is left alone.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
import scipy.stats

CONFIDENCE = 0.95
"""Coverage of every interval: the 2.5th to the 97.5th percentile of the bootstrap."""

Scores = np.ndarray | tuple[np.ndarray, ...]
"""What a statistic is computed from: one (runs x tasks) array, or several, each with its own
runs (a probability of improvement's two algorithms), resampled independently."""


# rliable's IQM and probability of improvement, computed as they are, without scipy's
# per-call argument handling: inside a bootstrap they run for every resample of every cell
# (~300k calls for a full Figure 2 report), and that handling cost ~20x their arithmetic.
# The same numbers to the bit (tests/test_report.py checks them against rliable's).


def aggregate_iqm(scores: np.ndarray) -> float:
    """rliable's `aggregate_iqm`: scipy's `trim_mean(scores, 0.25, axis=None)`, its very
    partition and mean."""
    flat = np.ravel(scores)
    cut = int(0.25 * flat.size)
    return np.mean(np.partition(flat, (cut, flat.size - cut - 1))[cut : flat.size - cut])


def probability_of_improvement_over(scores_x: np.ndarray, scores_y: np.ndarray) -> float:
    """rliable's `probability_of_improvement`: per task, P(X > Y) + P(X = Y) / 2 over every
    pair of runs (the Mann-Whitney U over m n, which scipy reaches through ranks; both are
    exact sums of halves), 0.5 where the two columns are equal; the mean over tasks.
    `scores_x` (m runs x tasks), `scores_y` (n runs x the same tasks)."""
    per_task = []
    for x, y in zip(scores_x.T, scores_y.T, strict=True):
        if np.array_equal(x, y):
            per_task.append(0.5)
        else:
            greater = np.count_nonzero(x[:, None] > y[None, :])
            ties = np.count_nonzero(x[:, None] == y[None, :])
            per_task.append((greater + 0.5 * ties) / (len(x) * len(y)))
    return np.mean(per_task)


def iqm(scores: np.ndarray, axis: int = -1) -> np.ndarray:
    """Interquartile mean (rliable's aggregate_iqm) along `axis`: the mean of the middle 50%
    of scores."""
    return scipy.stats.trim_mean(scores, proportiontocut=0.25, axis=axis)


def score_distribution(scores: np.ndarray, taus: np.ndarray) -> np.ndarray:
    """rliable's `score_distributions`: for each tau of `taus`, the fraction of all runs x
    tasks of `scores` above it, shape (len(taus),)."""
    return np.array([np.mean(scores > tau) for tau in taus])


# ---------------------------------------------------------------- the bootstrap


def stratified_resample(scores: np.ndarray, rng: np.random.RandomState) -> np.ndarray:
    """`scores` (runs x tasks x ...) with each task's runs drawn anew with replacement, apart
    from the other tasks' (rliable's `StratifiedBootstrap.update_indices`, drawn alike)."""
    runs = rng.choice(len(scores), scores.shape, replace=True)
    strata = np.ogrid[tuple(slice(n) for n in (0, *scores.shape[1:]))][1:]
    return scores[(runs, *strata)]


def interval(
    statistic: Callable[..., np.ndarray | float],
    scores: Scores,
    reps: int,
    rng: np.random.RandomState,
) -> np.ndarray:
    """The 95% percentile-bootstrap interval of `statistic(scores)` (or `statistic(*scores)`
    for a tuple, each array resampled on its own): shape (2, k) for a statistic of k values,
    lower bounds in row 0, upper in row 1 (arch's `conf_int(method="percentile")`)."""
    samples = scores if isinstance(scores, tuple) else (scores,)
    base = statistic(*samples)
    results = np.zeros((reps, 1 if np.isscalar(base) else base.shape[0]))
    for row in results:
        row[:] = statistic(*(stratified_resample(x, rng) for x in samples))
    alpha = (1.0 - CONFIDENCE) / 2
    # one column at a time, as arch does, so the percentiles are its own to the bit
    bounds = [np.percentile(column, [100 * alpha, 100 * (1.0 - alpha)]) for column in results.T]
    lower, upper = (np.array(side) for side in zip(*bounds, strict=True))
    return np.vstack((lower, upper))


def interval_estimates(
    scores: Mapping[str, Scores],
    statistic: Callable[..., np.ndarray | float],
    reps: int,
    seed: int,
) -> tuple[dict[str, np.ndarray | float], dict[str, np.ndarray]]:
    """rliable's `get_interval_estimates`: for each key of `scores`, the statistic's point
    estimate and its 95% interval (`interval`, shape (2, k)), the keys bootstrapped in order
    from one stream seeded with `seed`."""
    rng = np.random.RandomState(seed)
    points, intervals = {}, {}
    for key, sample in scores.items():
        points[key] = statistic(*sample) if isinstance(sample, tuple) else statistic(sample)
        intervals[key] = interval(statistic, sample, reps, rng)
    return points, intervals


def performance_profiles(
    scores: Mapping[str, np.ndarray], taus: Sequence[float], reps: int, seed: int
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """rliable's `create_performance_profile`: per key, the fraction of runs above each tau
    (`score_distribution`, shape (len(taus),)) and its interval (2, len(taus))."""
    taus = np.asarray(taus, dtype=float)
    return interval_estimates(scores, lambda x: score_distribution(x, taus), reps, seed)
