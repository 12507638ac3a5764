"""What a report finds, computed once from the records before anything is drawn or worded.

Per demonstration count (`AtCount`): the learners' pooled statistics
(`comparisons.count_statistics`), their learning curves there and the env steps each seed
took to reach `REACH`, the same statistics env by env, and how far their states lie from the
expert's. Over every count (`Findings`): those tables stacked, as the CSVs beside report.md
hold them. Pure functions over the tidy normalized frame; `bench.analysis.report` draws,
words and writes what these find.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

from bench.analysis import comparisons
from bench.analysis.comparisons import PER_ENV_COLUMNS, STATE_MATCH_COLUMNS, TARGET, demo_counts
from bench.analysis.curves import iqm_curves, steps_to, time_to
from bench.analysis.labels import Names, is_reference
from bench.analysis.normalize import demo_free, normalize, reference_returns

REACH = 0.8
"""The normalized return whose time to reach the curves' section tabulates."""
AGGREGATE_COLUMNS = ["n_demos", "algorithm", "seeds", "envs", "metric", "estimate", "lo", "hi"]
IMPROVEMENT_COLUMNS = ["n_demos", "algorithm", "other", "estimate", "lo", "hi"]


@dataclass(frozen=True)
class AtCount:
    """What a report finds at one demonstration count."""

    n: int
    """The demonstration count (0 where every learner is demonstration-free)."""
    competing: list[str]
    """The learners set against each other here, demonstration-free controls included, in
    plot order (`comparisons.competitors`)."""
    statistics: comparisons.CountStatistics
    """Pooled over envs: aggregates, probabilities of improvement, the performance profile."""
    curves: pd.DataFrame | str
    """The competing learners' IQM curves here (`curves.iqm_curves` rows), or, where the
    records hold several curves per seed and step, why there are none."""
    seeds: pd.DataFrame
    """The competing learners' normalized curves here, a row per seed and evaluation."""
    reach: pd.DataFrame
    """`curves.time_to` rows here: env steps to `REACH`, median and worst over seeds."""
    per_env: pd.DataFrame
    """PER_ENV_COLUMNS: env by env, then pooled (env_id POOLED); empty where no env has a
    learner here."""
    state_match: pd.DataFrame
    """STATE_MATCH_COLUMNS; empty where the records hold no distance (pixels, older records)."""

    @property
    def aggregate(self) -> pd.DataFrame:
        """The pooled aggregates with their n_demos (AGGREGATE_COLUMNS' columns)."""
        rows = self.statistics.aggregate
        return rows.assign(n_demos=self.n) if len(rows) else rows

    @property
    def improvement(self) -> pd.DataFrame:
        """The pooled probabilities of improvement with their n_demos (IMPROVEMENT_COLUMNS')."""
        rows = self.statistics.improvement
        return rows.assign(n_demos=self.n) if len(rows) else rows


@dataclass(frozen=True)
class Findings:
    """What a report finds over every demonstration count of one suite's records."""

    df: pd.DataFrame
    """The normalized trials (`normalize.normalize`), failed ones included."""
    names: Names
    """How the records name and describe each algorithm."""
    learners: list[str]
    """Every learner and control, in plot order (no references)."""
    counts: list[AtCount]
    """One per demonstration count the learners ran with (`comparisons.demo_counts`)."""
    aggregates: pd.DataFrame
    """AGGREGATE_COLUMNS over every count (aggregates.csv)."""
    improvements: pd.DataFrame
    """IMPROVEMENT_COLUMNS over every count (improvement.csv)."""
    per_env: pd.DataFrame
    """PER_ENV_COLUMNS over every count (per_env.csv)."""
    state_match: pd.DataFrame
    """STATE_MATCH_COLUMNS over every count (state_match.csv)."""


def find(df: pd.DataFrame, curves: pd.DataFrame, reps: int, focus: str = TARGET) -> Findings:
    """Everything a report on `focus` shows, from `df` (normalized trials) and `curves` (the
    records' learning curves, `frames.load_curves`); `reps` bootstrap resamples per interval."""
    names = Names.of(df)
    raw = normalized_curves(curves, df)
    reach = time_to(steps_to(raw, REACH))
    try:
        iqm: pd.DataFrame | str = iqm_curves(raw, reps=reps)
    except ValueError as e:  # several curves per seed and step: records of more than one run
        iqm = str(e)
    counts = [at_count(df, n, iqm, raw, reach, reps, focus) for n in demo_counts(df)]
    return Findings(
        df,
        names,
        names.order(df["algorithm"].unique()),
        counts,
        stack([at.aggregate for at in counts], AGGREGATE_COLUMNS),
        stack([at.improvement for at in counts], IMPROVEMENT_COLUMNS),
        stack([at.per_env for at in counts], PER_ENV_COLUMNS),
        stack([at.state_match for at in counts], STATE_MATCH_COLUMNS),
    )


def at_count(
    df: pd.DataFrame,
    n: int,
    iqm: pd.DataFrame | str,
    raw: pd.DataFrame,
    reach: pd.DataFrame,
    reps: int,
    focus: str = TARGET,
) -> AtCount:
    """What the report finds at `n` demonstrations: `iqm`, `raw` and `reach` (every count's
    IQM curves, normalized curves and steps to REACH) cut to the learners competing there."""
    competing = comparisons.competitors(df, n)
    statistics = comparisons.count_statistics(df, n, reps, focus)
    return AtCount(
        n,
        competing,
        statistics,
        iqm if isinstance(iqm, str) else at_the_count(iqm, competing, n),
        at_the_count(raw, competing, n),
        at_the_count(reach, competing, n),
        per_env(df, n, statistics, reps, focus),
        comparisons.state_match_statistics(df, n, reps, focus),
    )


def per_env(
    df: pd.DataFrame, n: int, pooled: comparisons.CountStatistics, reps: int, focus: str = TARGET
) -> pd.DataFrame:
    """PER_ENV_COLUMNS at `n` demonstrations: each env's statistics (every seed it has,
    where pooling keeps only the seeds every env has, so a domain still running is read from
    all of its finished seeds), then the `pooled` ones beside them; empty where no env has
    a learner."""
    by_env = comparisons.per_env_statistics(df, n, reps, focus)
    if by_env.empty:
        return pd.DataFrame(columns=PER_ENV_COLUMNS)
    rows = comparisons.pooled_rows(n, pooled.aggregate, pooled.improvement)
    return pd.concat([by_env, rows], ignore_index=True) if len(rows) else by_env


def normalized_curves(curves: pd.DataFrame, df: pd.DataFrame) -> pd.DataFrame:
    """The learners' recorded `curves`, normalized with the references of `df` (trials)."""
    return normalize(curves[~is_reference(curves)], reference_returns(df))


def at_the_count(frame: pd.DataFrame, competing: list[str], n: int) -> pd.DataFrame:
    """`frame`'s rows of the `competing` learners at `n` demonstrations, demo-free ones included."""
    return frame[frame["algorithm"].isin(competing) & ((frame["n_demos"] == n) | demo_free(frame))]


def stack(frames: list[pd.DataFrame], columns: list[str]) -> pd.DataFrame:
    """The non-empty `frames` one under another, cut to `columns` (empty with them if none)."""
    frames = [f for f in frames if len(f)]
    return (
        pd.concat(frames, ignore_index=True)[columns] if frames else pd.DataFrame(columns=columns)
    )
