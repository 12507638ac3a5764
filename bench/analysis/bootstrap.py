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

from collections.abc import Callable, Iterator, Mapping, Sequence

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
#
# Each estimator the reports bootstrap also has a form `over_resamples`, computed on a stack
# of resamples (reps x runs x tasks) at once: row r of its answer is, to the bit, what the
# estimator gives of resample r (tests/test_bootstrap.py checks it over shapes and ties). Means
# along an axis add in the order the 1-D mean adds, a partition along an axis selects as the
# 1-D partition does, and counts are exact, so the only change is fewer Python calls: a full
# Figure 2 report's ~1M of them.


def over_resamples(batched: Callable[..., np.ndarray]):
    """Marks a statistic as also computable over a stack of resamples (`interval` uses it):
    `batched(*stacks)`, one stack (reps, *sample shape) per sample, gives (reps, k)."""

    def mark(statistic: Callable[..., np.ndarray | float]):
        statistic.over_resamples = batched
        return statistic

    return mark


def aggregate_mean_over(stack: np.ndarray) -> np.ndarray:
    """rliable's `aggregate_mean` of each resample of `stack` (reps x runs x tasks)."""
    return np.mean(np.mean(stack, axis=1), axis=1)


def aggregate_median_over(stack: np.ndarray) -> np.ndarray:
    """rliable's `aggregate_median` of each resample of `stack` (reps x runs x tasks)."""
    return np.median(np.mean(stack, axis=1), axis=1)


def aggregate_iqm_over(stack: np.ndarray) -> np.ndarray:
    """`aggregate_iqm` of each resample of `stack` (reps x runs x tasks)."""
    flat = stack.reshape(len(stack), -1)
    cut = int(0.25 * flat.shape[1])
    middle = np.partition(flat, (cut, flat.shape[1] - cut - 1), axis=1)[
        :, cut : flat.shape[1] - cut
    ]
    return np.mean(middle, axis=1)


@over_resamples(aggregate_iqm_over)
def aggregate_iqm(scores: np.ndarray) -> float:
    """rliable's `aggregate_iqm`: scipy's `trim_mean(scores, 0.25, axis=None)`, its very
    partition and mean."""
    flat = np.ravel(scores)
    cut = int(0.25 * flat.size)
    return np.mean(np.partition(flat, (cut, flat.size - cut - 1))[cut : flat.size - cut])


def probability_of_improvement_over_resamples(xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """`probability_of_improvement_over` of each pair of resamples: `xs` (reps x m runs x
    tasks), `ys` (reps x n runs x tasks); shape (reps,)."""
    greater = np.count_nonzero(xs[:, :, None, :] > ys[:, None, :, :], axis=(1, 2))
    ties = np.count_nonzero(xs[:, :, None, :] == ys[:, None, :, :], axis=(1, 2))
    per_task = (greater + 0.5 * ties) / (xs.shape[1] * ys.shape[1])
    if xs.shape == ys.shape:  # a task's columns alike: 0.5, as np.array_equal finds them
        per_task[np.all(xs == ys, axis=1)] = 0.5
    return np.mean(per_task, axis=1)


@over_resamples(probability_of_improvement_over_resamples)
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
    tasks of `scores` above it, shape (len(taus),). A count over the size is what rliable's
    mean of booleans gives, to the bit: a sum of ones is exact."""
    (fractions,) = score_distribution_over(scores[None], taus)
    return fractions


def score_distribution_over(stack: np.ndarray, taus: np.ndarray) -> np.ndarray:
    """`score_distribution` of each resample of `stack` (reps x runs x tasks): (reps, taus)."""
    flat = stack.reshape(len(stack), -1)
    above = flat[:, None, :] > np.asarray(taus)[None, :, None]
    return np.count_nonzero(above, axis=2) / flat.shape[1]


# ---------------------------------------------------------------- the bootstrap

BLOCK_ELEMENTS = 2**20
"""Run indices drawn at once, at most (8 MiB of them): one block of reps (`_resample_blocks`)."""


def stratified_resample(scores: np.ndarray, rng: np.random.RandomState) -> np.ndarray:
    """`scores` (runs x tasks x ...) with each task's runs drawn anew with replacement, apart
    from the other tasks' (rliable's `StratifiedBootstrap.update_indices`, drawn alike)."""
    ((resampled,),) = _resample_blocks((scores,), 1, rng)
    return resampled[0]


def _strata(scores: np.ndarray) -> list[np.ndarray]:
    """The indices of every axis but the runs', broadcastable against a draw of run indices."""
    return np.ogrid[tuple(slice(n) for n in (0, *scores.shape[1:]))][1:]


def _resample_blocks(
    samples: tuple[np.ndarray, ...], reps: int, rng: np.random.RandomState
) -> Iterator[tuple[np.ndarray, ...]]:
    """The reps' resamples of every sample, a block of reps at a time: per block, one stack
    (block, *sample shape) per sample. Drawn as rliable draws them, rep by rep, each sample in
    turn: `RandomState.choice(runs, shape)`, that is `randint(0, runs, shape)`, which draws
    element by element from the stream, each element by its own bound where the bounds are an
    array. So one draw of (reps, every sample's elements), each bounded by its sample's run
    count, holds what the reps' draws would, in order, at a fraction of the calls."""
    strata = [_strata(x) for x in samples]
    sizes = [x.size for x in samples]
    runs_of = np.concatenate([np.full(x.size, len(x)) for x in samples])
    block = max(1, BLOCK_ELEMENTS // sum(sizes))
    for start in range(0, reps, block):
        drawn = min(block, reps - start)
        runs = rng.randint(0, np.broadcast_to(runs_of, (drawn, runs_of.size)))
        split = np.split(runs, np.cumsum(sizes)[:-1], axis=1)
        yield tuple(
            x[(r.reshape(drawn, *x.shape), *s)]
            for x, r, s in zip(samples, split, strata, strict=True)
        )


def interval(
    statistic: Callable[..., np.ndarray | float],
    scores: Scores,
    reps: int,
    rng: np.random.RandomState,
) -> np.ndarray:
    """The 95% percentile-bootstrap interval of `statistic(scores)` (or `statistic(*scores)`
    for a tuple, each array resampled on its own): shape (2, k) for a statistic of k values,
    lower bounds in row 0, upper in row 1 (arch's `conf_int(method="percentile")`). A
    statistic marked `over_resamples` is computed a block of resamples at a time."""
    samples = scores if isinstance(scores, tuple) else (scores,)
    base = statistic(*samples)
    results = np.zeros((reps, 1 if np.isscalar(base) else base.shape[0]))
    batched = getattr(statistic, "over_resamples", None)
    done = 0
    for stacks in _resample_blocks(samples, reps, rng):
        block = results[done : done + len(stacks[0])]
        if batched is not None:
            block[:] = np.reshape(batched(*stacks), (len(block), -1))
        else:
            for i, row in enumerate(block):
                row[:] = statistic(*(stack[i] for stack in stacks))
        done += len(block)
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

    @over_resamples(lambda stack: score_distribution_over(stack, taus))
    def distribution(scores: np.ndarray) -> np.ndarray:
        return score_distribution(scores, taus)

    return interval_estimates(scores, distribution, reps, seed)
