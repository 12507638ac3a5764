"""Aggregate statistics from the tidy normalized frame, with rliable's estimators.

rliable's contract is `dict[algorithm] -> array(runs x tasks)`; here runs are seeds and tasks
are envs, at one demonstration count. `score_dict` builds it; the rest turn the bootstrap's
answers (`bench.analysis.bootstrap`) into tidy frames. Intervals are 95% stratified-bootstrap
CIs (percentile method). Learning curves are `bench.analysis.curves`'s, and two folders
compared `bench.analysis.agreement`'s.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable, Sequence

import numpy as np
import pandas as pd
from rliable import metrics  # numpy and scipy only; rliable's bootstrap is bench.analysis.bootstrap

from bench.analysis.bootstrap import (
    aggregate_iqm,
    aggregate_iqm_over,
    aggregate_mean_over,
    aggregate_median_over,
    interval_estimates,
    iqm,
    over_resamples,
    performance_profiles,
    probability_of_improvement_over,
)
from bench.analysis.labels import is_reference
from bench.analysis.normalize import demo_free

METRICS: dict[str, Callable[[np.ndarray], float]] = {
    "mean": metrics.aggregate_mean,
    "median": metrics.aggregate_median,
    "iqm": aggregate_iqm,
}
"""The aggregates of every score table, in the order the report's columns show them."""

METRICS_OVER: dict[str, Callable[[np.ndarray], np.ndarray]] = {
    "mean": aggregate_mean_over,
    "median": aggregate_median_over,
    "iqm": aggregate_iqm_over,
}
"""`METRICS` of each resample of a stack (reps x runs x tasks) at once, to the bit."""


def score_dict(
    df: pd.DataFrame,
    n_demos: int,
    algorithms: Sequence[str] | None = None,
    column: str = "normalized",
    left_out: list[str] | None = None,
) -> dict[str, np.ndarray]:
    """{algorithm: (seeds x envs) array of `column`} for the trials with `n_demos` demos.

    Learners that take no demonstrations (only n_demos=0 rows, e.g. survival)
    are included at any `n_demos`; random and expert only when named in
    `algorithms` (or when n_demos=0). Every algorithm gets the same envs, in sorted order (envs some algorithm
    lacks are dropped), and for each algorithm only the seeds that have a
    score on every env (failed or missing runs drop the seed). Each drop is
    said in words: appended to `left_out` when given, else with warnings.warn.
    Algorithms come in sorted order unless given.
    """

    def drop(message: str) -> None:
        if left_out is None:
            warnings.warn(message, stacklevel=3)
        else:
            left_out.append(message)

    # Algorithms that take no demonstrations (n_demos=0 only) compete at every count;
    # random and expert are left out, being 0 and 1 by construction.
    free = demo_free(df)
    at_count = df["n_demos"] == n_demos
    if algorithms is None:
        frame = df[at_count | (free & ~is_reference(df))]
    else:
        frame = df[df["algorithm"].isin(algorithms) & (at_count | free)]
    if frame.empty:
        have = ", ".join(map(str, sorted(df["n_demos"].unique())))
        raise ValueError(f"no scores with n_demos={n_demos} (have: {have or 'none'})")
    names = list(algorithms) if algorithms is not None else sorted(frame["algorithm"].unique())

    envs_of = {a: set(frame.loc[frame["algorithm"] == a, "env_id"]) for a in names}
    absent = [a for a, own in envs_of.items() if not own]
    if absent:
        raise ValueError(f"no scores with n_demos={n_demos} for {', '.join(absent)}")
    envs = sorted(set.intersection(*envs_of.values()))
    if not envs:
        raise ValueError(f"no env has scores of every algorithm with n_demos={n_demos}")
    for name, own in envs_of.items():
        if own - set(envs):
            drop(f"{name}: dropped env(s) {sorted(own - set(envs))} that other algorithms lack")

    scores = {}
    for name in names:
        rows = frame[frame["algorithm"] == name]
        if rows.duplicated(["seed", "env_id"]).any():
            raise ValueError(f"{name}: several trials per seed and env; filter to one suite first")
        table = rows.pivot(index="seed", columns="env_id", values=column).reindex(columns=envs)
        complete = table.dropna()
        dropped = sorted(set(table.index) - set(complete.index))
        if dropped:
            drop(
                f"{name}: dropped seed(s) {dropped} without a score on every env"
                f" (failed or not run); {len(complete)} left"
            )
        if len(complete):
            scores[name] = complete.sort_index().to_numpy(dtype=float)
    return scores


AGGREGATE_COLUMNS = ["algorithm", "metric", "estimate", "lo", "hi"]


def aggregate_scores(
    scores: dict[str, np.ndarray], reps: int = 2000, seed: int = 0
) -> pd.DataFrame:
    """Mean, median and IQM per algorithm with 95% CIs: algorithm, metric, estimate, lo, hi."""

    @over_resamples(lambda stack: np.stack([METRICS_OVER[m](stack) for m in METRICS], axis=1))
    def aggregate(x: np.ndarray) -> np.ndarray:
        return np.array([f(x) for f in METRICS.values()])

    points, intervals = interval_estimates(scores, aggregate, reps, seed)
    return pd.DataFrame(
        [
            {
                "algorithm": name,
                "metric": metric,
                "estimate": float(points[name][i]),
                "lo": _bound(intervals[name][0, i], scores[name]),
                "hi": _bound(intervals[name][1, i], scores[name]),
            }
            for name in scores
            for i, metric in enumerate(METRICS)
        ],
        columns=AGGREGATE_COLUMNS,  # where no learner has a score: no row, the columns still
    )


def _bound(value: float, *samples: np.ndarray) -> float:
    """A bootstrap bound, or NaN (no interval) where a sample holds one run: resampling one
    seed gives that seed back every time, an interval of zero width that claims certainty."""
    return float(value) if all(len(x) > 1 for x in samples) else float("nan")


def probability_of_improvement(
    scores: dict[str, np.ndarray], target: str = "gaifo", reps: int = 2000, seed: int = 0
) -> pd.DataFrame:
    """P(target > other), averaged over envs, for each other algorithm: algorithm, other, estimate, lo, hi."""
    if target not in scores:
        raise ValueError(f"{target!r} not among the algorithms ({', '.join(scores)})")
    pairs = [(target, other) for other in scores if other != target]
    return improvement_of_pairs(scores, pairs, reps, seed)


IMPROVEMENT_COLUMNS = ["algorithm", "other", "estimate", "lo", "hi"]


def improvement_of_pairs(
    scores: dict[str, np.ndarray],
    pairs: Sequence[tuple[str, str]],
    reps: int = 2000,
    seed: int = 0,
) -> pd.DataFrame:
    """P(a > b), averaged over envs, for each (a, b) in `pairs`: algorithm (a), other (b),
    estimate, lo, hi."""
    unknown = sorted({name for pair in pairs for name in pair} - set(scores))
    if unknown:
        raise ValueError(
            f"{', '.join(map(repr, unknown))} not among the algorithms ({', '.join(scores)})"
        )
    if not pairs:
        return pd.DataFrame(columns=IMPROVEMENT_COLUMNS)
    keyed = {f"{a} > {b}": (scores[a], scores[b]) for a, b in pairs}
    points, intervals = interval_estimates(keyed, probability_of_improvement_over, reps, seed)
    return pd.DataFrame(
        [
            {
                "algorithm": a,
                "other": b,
                "estimate": float(np.squeeze(points[key])),
                "lo": _bound(np.squeeze(intervals[key][0]), scores[a], scores[b]),
                "hi": _bound(np.squeeze(intervals[key][1]), scores[a], scores[b]),
            }
            for key, (a, b) in zip(keyed, pairs, strict=True)
        ],
        columns=IMPROVEMENT_COLUMNS,
    )


def performance_profile(
    scores: dict[str, np.ndarray], taus: Sequence[float], reps: int = 2000, seed: int = 0
) -> pd.DataFrame:
    """Fraction of runs (all seeds x envs) scoring above each tau: algorithm, tau, fraction, lo, hi."""
    taus = np.asarray(taus, dtype=float)
    profiles, intervals = performance_profiles(scores, taus, reps, seed)
    return pd.DataFrame(
        [
            {
                "algorithm": name,
                "tau": float(tau),
                "fraction": float(profiles[name][i]),
                "lo": float(intervals[name][0, i]),
                "hi": float(intervals[name][1, i]),
            }
            for name in scores
            for i, tau in enumerate(taus)
        ]
    )


def iqm_ratio(
    scores: np.ndarray, ceiling: np.ndarray, reps: int = 2000, seed: int = 0
) -> dict[str, float]:
    """IQM(scores) / IQM(ceiling), e.g. a learner's as a fraction of the oracle's, with a 95%
    percentile-bootstrap CI: two independent samples of seeds, each resampled on its own."""
    rng = np.random.default_rng(seed)
    scores, ceiling = np.ravel(scores).astype(float), np.ravel(ceiling).astype(float)
    boot = iqm(scores[rng.integers(len(scores), size=(reps, len(scores)))])
    boot_ceiling = iqm(ceiling[rng.integers(len(ceiling), size=(reps, len(ceiling)))])
    with np.errstate(divide="ignore", invalid="ignore"):
        lo, hi = np.nanpercentile(boot / boot_ceiling, [2.5, 97.5])
    return {"estimate": float(iqm(scores) / iqm(ceiling)), "lo": float(lo), "hi": float(hi)}
