"""`bench compare`: two folders' (or two algorithms') scores, cell by cell.

A cell is one env, algorithm, demonstration count and setting (`COMPARE_KEYS`); in each, the
seeds of one side are set against the seeds of the other: each side's IQM with a 95%
bootstrap CI, the CI of their difference, P(run > ref) (the report's probability of
improvement: one run of this side beats one of the other) with its CI, and a rank test by
permutation whose p gives the verdict (identical, differs or agrees). Pure functions over
normalized frames; the table is `bench.analysis.tables.compare_table`'s.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
import pandas as pd
import scipy.stats

from bench.analysis.bootstrap import iqm
from bench.analysis.stats import improvement_of_pairs
from bench.errors import BadInput


class ComparisonError(BadInput, ValueError):
    """Two results folders that cannot be compared; the message is one line."""


COMPARE_KEYS = ["env_id", "algorithm", "n_demos", "setting"]
"""Cells compared: seeds of one setting (`TrialSpec.setting_id`: budget, settings, evaluation)
against seeds of the same one, never two budgets or two configs row by row."""
COMPARE_COLUMNS = [
    *COMPARE_KEYS,
    *("run_seeds", "run_iqm", "run_lo", "run_hi"),
    *("ref_seeds", "ref_iqm", "ref_lo", "ref_hi"),
    *("diff", "diff_lo", "diff_hi", "better", "better_lo", "better_hi", "p", "verdict"),
]
ALPHA = 0.01
"""A row differs when the permutation test's p is below this. Over fresh draws of both sides
the test says "differs" of at most this share of rows, whatever the seed counts and however
bimodal the scores; against one fixed reference the share a newcomer meets also depends on
the reference's luck (five seeds that all came out low, say), and 1% keeps it under 5% per
row against a pooled reference of 55 seeds, where 5% gave rows up to 10%
(benchmarks/fresh_draws.py). At 5 seeds against 5 only a complete separation is below it."""
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


def reproduced(run: pd.Series, ref: pd.Series) -> bool:
    """Whether every seed of the run (scores indexed by seed) has the score the reference has
    for that seed, to the bit: a rerun of those very trials where the reference was made. The
    reference may hold more seeds than the run."""
    return set(run.index) <= set(ref.index) and np.array_equal(
        run.to_numpy(), ref.loc[run.index].to_numpy()
    )


def verdict_of(run: pd.Series, ref: pd.Series, p: float, alpha: float = ALPHA) -> str:
    """ "identical" where the run reproduces the reference's scores seed for seed
    (`reproduced`), "differs" where p < alpha, else "agrees"."""
    if reproduced(run, ref):
        return "identical"
    return "differs" if p < alpha else "agrees"


def pooled(folders: Sequence[tuple[str, pd.DataFrame]]) -> pd.DataFrame:
    """The trial records of several folders of one suite's trials on other seeds (a reference
    and more draws of it) as one reference, under the first folder's suite name. Raises
    ComparisonError, naming both folders, where two of them hold a record of one seed of one
    cell: the same trial twice would count twice. Each frame holds records."""
    named = [frame.assign(folder=name) for name, frame in folders]
    both = pd.concat(named, ignore_index=True)
    keys = [*COMPARE_KEYS, "seed"]
    twice = both[both.duplicated(keys, keep=False)]
    if len(twice):
        first = twice.iloc[0]
        where = twice[(twice[keys] == first[keys]).all(axis=1)]["folder"]
        raise ComparisonError(
            f"{' and '.join(where)} both hold {first['env_id']} {first['algorithm']} with"
            f" {first['n_demos']} demos, seed {first['seed']}: pool only folders of other seeds"
        )
    return both.drop(columns="folder").assign(suite=named[0]["suite"].iloc[0])


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


def improvement(
    run: np.ndarray, ref: np.ndarray, reps: int = 2000, seed: int = 0
) -> dict[str, float]:
    """P(run > ref): the chance that a run of one sample beats a run of the other, ties
    counting half, with its 95% CI: the report's `stats.improvement_of_pairs` on one task
    (no interval where a side holds one run)."""
    scores = {
        "run": np.asarray(run, dtype=float)[:, None],
        "ref": np.asarray(ref, dtype=float)[:, None],
    }
    found = improvement_of_pairs(scores, [("run", "ref")], reps, seed).iloc[0]
    return {"better": found["estimate"], "better_lo": found["lo"], "better_hi": found["hi"]}


def by_seed(frame: pd.DataFrame) -> dict[tuple, pd.Series]:
    """A normalized frame's scores by seed, per compared cell (COMPARE_KEYS)."""
    return {
        key: cell.set_index("seed")["normalized"].dropna().sort_index()
        for key, cell in frame.groupby(COMPARE_KEYS)
    }


def compare(
    run: pd.DataFrame,
    ref: pd.DataFrame,
    reps: int = 2000,
    seed: int = 0,
    alpha: float = ALPHA,
) -> pd.DataFrame:
    """Per env, algorithm and demo count present in both normalized frames: each one's IQM over
    seeds with a 95% CI, the difference's CI, P(run > ref) with its CI (`improvement`), the
    permutation test's p (`permutation_p`) and a verdict (`verdict_of` at `alpha`). Columns:
    COMPARE_COLUMNS. Raises ComparisonError when no cell is in both."""
    run_cells, ref_cells = by_seed(run), by_seed(ref)
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
        a, b = run_cells[key].to_numpy(), ref_cells[key].to_numpy()
        d = iqm_difference(a, b, reps, seed + i)
        p = permutation_p(a, b, seed + i)
        verdict = verdict_of(run_cells[key], ref_cells[key], p, alpha)
        rows.append(
            {
                **dict(zip(COMPARE_KEYS, key, strict=True)),
                "run_seeds": len(a),
                "ref_seeds": len(b),
                **d,
                **improvement(a, b, reps, seed + i),
                "p": p,
                "verdict": verdict,
            }
        )
    return pd.DataFrame(rows, columns=COMPARE_COLUMNS)
