"""Aggregate statistics with rliable, from the tidy normalized frame.

rliable's contract is `dict[algorithm] -> array(runs x tasks)`; here runs are
seeds and tasks are envs, at one demonstration count. `score_dict` builds it;
the rest are thin wrappers that turn rliable's answers into tidy frames.
Intervals are 95% stratified-bootstrap CIs (percentile method).
"""

from __future__ import annotations

import contextlib
import inspect
import itertools
import math
import warnings
from collections import defaultdict
from collections.abc import Callable, Iterator, Sequence
from types import ModuleType

import numpy as np
import pandas as pd
import scipy.stats

from bench.analysis.labels import is_reference
from bench.analysis.normalize import demo_free
from bench.errors import BadInput


def _import_rliable() -> tuple[ModuleType, ModuleType]:
    """Import rliable, bridging arch <= 7.2 to pandas >= 3.

    rliable imports arch.bootstrap; arch 7.2 decorates a method at import time
    with pandas' private `deprecate_kwarg(old, new)`, which pandas 3 changed to
    `deprecate_kwarg(klass, old, new)` (pandas-dev/pandas#61468; the same break
    as statsmodels/statsmodels#9614), so the import fails with "missing 1
    required positional argument: 'new_arg_name'". For the import only, accept
    the old call form; nothing else changes, and with a fixed arch this is a no-op.
    """
    import pandas.util._decorators as decorators

    original = decorators.deprecate_kwarg
    needs_bridge = "klass" in inspect.signature(original).parameters

    def old_form(*args, **kwargs):
        if args and isinstance(args[0], str):
            return original(FutureWarning, *args, **kwargs)
        return original(*args, **kwargs)

    if needs_bridge:
        decorators.deprecate_kwarg = old_form
    try:
        from rliable import library, metrics
    finally:
        decorators.deprecate_kwarg = original
    return library, metrics


rly, metrics = _import_rliable()


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
    exact sums of halves), 0.5 where the two columns are equal; the mean over tasks."""
    per_task = []
    for x, y in zip(scores_x.T, scores_y.T, strict=True):
        if np.array_equal(x, y):
            per_task.append(0.5)
        else:
            greater = np.count_nonzero(x[:, None] > y[None, :])
            ties = np.count_nonzero(x[:, None] == y[None, :])
            per_task.append((greater + 0.5 * ties) / (len(x) * len(y)))
    return np.mean(per_task)


METRICS: dict[str, Callable[[np.ndarray], float]] = {
    "mean": metrics.aggregate_mean,
    "median": metrics.aggregate_median,
    "iqm": aggregate_iqm,
}


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


def aggregate_scores(
    scores: dict[str, np.ndarray], reps: int = 2000, seed: int = 0
) -> pd.DataFrame:
    """Mean, median and IQM per algorithm with 95% CIs: algorithm, metric, estimate, lo, hi."""

    def aggregate(x: np.ndarray) -> np.ndarray:
        return np.array([f(x) for f in METRICS.values()])

    with _seeded(seed):
        points, intervals = rly.get_interval_estimates(scores, aggregate, reps=reps)
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
        ]
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
    with _seeded(seed):
        points, intervals = rly.get_interval_estimates(
            keyed, probability_of_improvement_over, reps=reps
        )
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
    with _seeded(seed):
        profiles, intervals = rly.create_performance_profile(scores, taus, reps=reps)
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


@contextlib.contextmanager
def _seeded(seed: int) -> Iterator[None]:
    """Seed the global NumPy RNG for the block, then put it back.

    rliable 1.2's bootstraps draw their resampling indices with np.random.choice
    (library.py, update_indices), not with their random_state, so the global
    RNG is what fixes the intervals. (arch also deprecates random_state, so we
    do not pass one.)
    """
    saved = np.random.get_state()
    np.random.seed(seed)
    try:
        yield
    finally:
        np.random.set_state(saved)


class ComparisonError(BadInput, ValueError):
    """Two results folders that cannot be compared; the message is one line."""


COMPARE_KEYS = ["env_id", "algorithm", "n_demos", "setting"]
"""Cells compared: seeds of one setting (`TrialSpec.setting_id`: budget, settings, evaluation)
against seeds of the same one, never two budgets or two configs row by row."""
COMPARE_COLUMNS = [
    *COMPARE_KEYS,
    *("run_seeds", "run_iqm", "run_lo", "run_hi"),
    *("ref_seeds", "ref_iqm", "ref_lo", "ref_hi"),
    *("diff", "diff_lo", "diff_hi", "p", "verdict"),
]
ALPHA = 0.05
"""A row differs when the permutation test's p is below this: under the same distribution,
at most this share of rows differ, whatever the seed counts and however bimodal the scores."""
EXACT_SPLITS = 20_000
"""Up to this many ways to split the pooled seeds, the test tries every one (5 against 5:
252); beyond, this many random ones (seeded)."""


def unlike(run: pd.DataFrame, ref: pd.DataFrame) -> tuple[int, int]:
    """How many cells (`COMPARE_KEYS`) of the run and of the reference have no like in the
    other: another budget, demonstration count or settings."""
    a = set(run.groupby(COMPARE_KEYS).groups)
    b = set(ref.groupby(COMPARE_KEYS).groups)
    return len(a - b), len(b - a)


def _why_unlike(run: pd.DataFrame, ref: pd.DataFrame) -> str:
    """ ": budgets 2048 (run) and 4096 (reference)", where the folders' budgets differ."""
    budgets = [sorted(set(frame["budget"])) for frame in (run, ref)]
    if budgets[0] == budgets[1]:
        return " (their settings differ)"
    return f": budgets {budgets[0]} (run) and {budgets[1]} (reference)"


def permutation_p(run: np.ndarray, ref: np.ndarray, seed: int = 0) -> float:
    """Two-sided p of a rank test of run against ref (Mann-Whitney's, by permutation): the
    share of the ways to split the pooled scores into samples of these sizes whose mean ranks
    lie at least as far apart (every split up to EXACT_SPLITS, else that many random ones);
    ties share their rank. Exact at the seed counts a benchmark has, where a bootstrap CI of
    the IQM difference is too narrow; and on ranks, since an IQM of 5 seeds (the mean of the
    middle 3) ties across most splits of bimodal scores and would leave the test no power."""
    run, ref = np.asarray(run, dtype=float), np.asarray(ref, dtype=float)
    ranks, n = scipy.stats.rankdata(np.concatenate([run, ref])), len(run)
    if math.comb(len(ranks), n) <= EXACT_SPLITS:
        picks = np.array(list(itertools.combinations(range(len(ranks)), n)))
    else:
        rng = np.random.default_rng(seed)
        picks = np.argsort(rng.random((EXACT_SPLITS, len(ranks))), axis=1)[:, :n]
    first = ranks[picks].sum(axis=1)
    # mean rank of one side minus the other's, from the first side's rank sum
    total, m = ranks.sum(), len(ranks) - n
    split = np.abs(first / n - (total - first) / m)
    observed = abs(ranks[:n].mean() - ranks[n:].mean())
    return float(np.mean(split >= observed - 1e-9))


def verdict_of(run: np.ndarray, ref: np.ndarray, p: float) -> str:
    """ "identical" where both samples hold the same scores (a rerun computed to the bit),
    "differs" where p < ALPHA, else "agrees"."""
    if len(run) == len(ref) and np.array_equal(np.sort(run), np.sort(ref)):
        return "identical"
    return "differs" if p < ALPHA else "agrees"


def iqm(scores: np.ndarray, axis: int = -1) -> np.ndarray:
    """Interquartile mean (rliable's aggregate_iqm): the mean of the middle 50% of scores."""
    return scipy.stats.trim_mean(scores, proportiontocut=0.25, axis=axis)


def iqm_difference(
    run: np.ndarray, ref: np.ndarray, reps: int = 2000, seed: int = 0
) -> dict[str, float]:
    """IQMs of two independent samples of scores with 95% percentile-bootstrap CIs, and of
    their difference run - ref (each sample resampled on its own, `reps` times)."""
    rng = np.random.default_rng(seed)
    run, ref = np.asarray(run, dtype=float), np.asarray(ref, dtype=float)
    boot_run = iqm(run[rng.integers(len(run), size=(reps, len(run)))])
    boot_ref = iqm(ref[rng.integers(len(ref), size=(reps, len(ref)))])
    ci = lambda boot: np.percentile(boot, [2.5, 97.5])  # noqa: E731
    (run_lo, run_hi), (ref_lo, ref_hi) = ci(boot_run), ci(boot_ref)
    diff_lo, diff_hi = ci(boot_run - boot_ref)
    return {
        "run_iqm": float(iqm(run)),
        "run_lo": float(run_lo),
        "run_hi": float(run_hi),
        "ref_iqm": float(iqm(ref)),
        "ref_lo": float(ref_lo),
        "ref_hi": float(ref_hi),
        "diff": float(iqm(run) - iqm(ref)),
        "diff_lo": float(diff_lo),
        "diff_hi": float(diff_hi),
    }


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


def compare(run: pd.DataFrame, ref: pd.DataFrame, reps: int = 2000, seed: int = 0) -> pd.DataFrame:
    """Per env, algorithm and demo count present in both normalized frames: each one's IQM over
    seeds with a 95% CI, the difference's CI, the permutation test's p (`permutation_p`) and
    a verdict (`verdict_of`). Columns: COMPARE_COLUMNS. Raises ComparisonError when no cell is
    in both."""
    run_cells = {k: g["normalized"].dropna().to_numpy() for k, g in run.groupby(COMPARE_KEYS)}
    ref_cells = {k: g["normalized"].dropna().to_numpy() for k, g in ref.groupby(COMPARE_KEYS)}
    shared = [
        k for k in sorted(run_cells) if k in ref_cells and len(run_cells[k]) and len(ref_cells[k])
    ]
    if not shared:
        raise ComparisonError(
            "the two folders share no (env, algorithm, demo count) run with the same settings"
            f" with scores{_why_unlike(run, ref)}"
        )
    rows = []
    for i, key in enumerate(shared):
        a, b = run_cells[key], ref_cells[key]
        d = iqm_difference(a, b, reps, seed + i)
        p = permutation_p(a, b, seed + i)
        verdict = verdict_of(a, b, p)
        rows.append(
            {
                **dict(zip(COMPARE_KEYS, key, strict=True)),
                "run_seeds": len(a),
                "ref_seeds": len(b),
                **d,
                "p": p,
                "verdict": verdict,
            }
        )
    return pd.DataFrame(rows, columns=COMPARE_COLUMNS)


# ---------------------------------------------------------------- learning curves

CELL = ["env_id", "algorithm", "n_demos"]
TIME_TO_COLUMNS = [*CELL, "seeds", "median", "worst", "short"]


def steps_to(curves: pd.DataFrame, level: float) -> pd.DataFrame:
    """Per seed of every (env, algorithm, demo count) of normalized `curves`: `steps`, the env
    steps of its first evaluation at or above `level`, inf where none is. A curve is evaluated
    every so many steps, so this is as fine as its points are apart."""
    keys = [*CELL, "seed"]
    every = curves.groupby(keys).size().index
    reached = curves[curves["normalized"] >= level].groupby(keys)["env_steps"].min()
    return reached.astype(float).reindex(every, fill_value=np.inf).rename("steps").reset_index()


def time_to(steps: pd.DataFrame) -> pd.DataFrame:
    """`steps_to`'s per-seed steps summed up per cell: TIME_TO_COLUMNS, the median and the
    worst (inf where a seed never got there) over seeds, and how many never got there."""
    grouped = steps.groupby(CELL)["steps"]
    return pd.DataFrame(
        {
            "seeds": grouped.size(),
            "median": grouped.median(),
            "worst": grouped.max(),
            "short": grouped.agg(lambda x: int(np.isinf(x).sum())),
        }
    ).reset_index()[TIME_TO_COLUMNS]


IQM_CURVE_COLUMNS = ["env_id", "algorithm", "n_demos", "env_steps", "iqm", "lo", "hi", "seeds"]


def iqm_curves(curves: pd.DataFrame, reps: int = 2000, seed: int = 0) -> pd.DataFrame:
    """IQM over seeds of the normalized return at each evaluation point, with a 95% CI.

    `curves`: normalized learning curves (env_id, algorithm, n_demos, seed,
    env_steps, normalized). Returns one row per env, algorithm, demo count and
    evaluation point: env_id, algorithm, n_demos, env_steps, iqm, lo, hi, seeds.
    Seeds evaluated at different steps are interpolated onto the steps of all
    of them, within the range they share. Every (env, algorithm, demo count,
    step) is a stratum of rliable's stratified bootstrap, so the band is pointwise.
    """
    # rliable wants one array per run count; cells with as many seeds share one, side by side.
    pooled: dict[int, list[tuple[tuple, pd.DataFrame]]] = defaultdict(list)
    for key, rows in curves.dropna(subset=["normalized"]).groupby(
        ["env_id", "algorithm", "n_demos"]
    ):
        if rows.duplicated(["seed", "env_steps"]).any():
            raise ValueError(
                f"{key[1]} on {key[0]} with {key[2]} demos has several curves per seed;"
                " filter to one suite first"
            )
        table = _on_common_steps(rows.pivot(index="seed", columns="env_steps", values="normalized"))
        if table.size:
            pooled[len(table)].append((key, table))
    out = []
    for n_seeds, cells in sorted(pooled.items()):
        matrix = np.concatenate([t.to_numpy(dtype=float) for _, t in cells], axis=1)
        with _seeded(seed):
            points, intervals = rly.get_interval_estimates(
                {"cells": matrix}, _iqm_per_column, reps=reps
            )
        i = 0
        for (env_id, algo, n), table in cells:
            for step in table.columns:
                lo, hi = intervals["cells"][:, i]
                out.append((env_id, algo, n, step, points["cells"][i], lo, hi, n_seeds))
                i += 1
    return pd.DataFrame(out, columns=IQM_CURVE_COLUMNS)


def _iqm_per_column(scores: np.ndarray) -> np.ndarray:
    """IQM of each column of a (runs x cells) array: one bootstrap of every cell at once."""
    return iqm(scores, axis=0)


def _on_common_steps(table: pd.DataFrame) -> pd.DataFrame:
    """A (seeds x env_steps) table without gaps: interpolated inside, cut to the shared range."""
    if table.isna().any(axis=None):
        table = table.T.interpolate(method="index", limit_area="inside").T
    return table.dropna(axis=1)
