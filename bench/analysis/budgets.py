"""The same cells at several budgets (`bench budgets`): how far a longer run takes each learner.

Each folder holds one suite's records, each env at the budget that suite gave it (Figure 2's
at 1-2M, the converged reference's at 5-10M). A learner's scores are normalized with its own
folder's random and expert, and set beside each other per env, learner and demonstration
count: the IQM over seeds with its 95% CI, and, where the folder ran the learner's oracle at
that budget, the IQM as a fraction of the oracle's (with its CI) and the worst seed's
fraction (`comparisons.oracle_fractions`, as a report reads them), and, where it ran the
learner's floor, the probability that a run of the learner beats a run of the floor. Their table is
`tables.budgets_table`, their figure `plot.draw_iqm_curves`. Pure functions over tidy
frames; nothing here reads or writes files.
"""

from __future__ import annotations

from collections.abc import Sequence

import pandas as pd

from bench.analysis import comparisons, curves, stats
from bench.analysis.labels import Names, is_reference
from bench.analysis.normalize import demo_free, normalize, reference_returns
from bench.errors import BadInput

COLUMNS = [
    "env_id",
    "algorithm",
    "n_demos",
    "budget",
    "seeds",
    "iqm",
    "lo",
    "hi",
    "of_oracle",
    "of_oracle_lo",
    "of_oracle_hi",
    "worst_of_oracle",
    "over_floor",
    "over_floor_lo",
    "over_floor_hi",
]
"""One row per env, learner, demonstration count and budget (budgets.csv)."""


def side_by_side(
    folders: Sequence[tuple[str, pd.DataFrame]], curves_of: Sequence[pd.DataFrame] | None = None
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Every folder's learner trials (and, given `curves_of`, their learning curves), each
    normalized with its own folder's references, in one frame each: the envs that more than
    one budget holds, at every demonstration count a learner ran them with (a control, taking
    none, beside each). `folders`: (name, `frames.load` of it). Raises BadInput
    where two folders hold one env at one budget (their seeds would mix in one cell)."""
    trials, curve_frames, held = [], [], {}
    for i, (name, df) in enumerate(folders):
        normalized = normalize(df)
        for env_id, budget in normalized[["env_id", "budget"]].drop_duplicates().itertuples(False):
            if (env_id, budget) in held:
                raise BadInput(
                    f"{held[env_id, budget]} and {name} both hold {env_id} at {budget:,} steps:"
                    " give one folder per budget"
                )
            held[env_id, budget] = name
        trials.append(normalized[~is_reference(normalized)])
        if curves_of is not None:
            learned = curves_of[i][~is_reference(curves_of[i])]
            budgets = normalized.drop_duplicates("env_id").set_index("env_id")["budget"]
            learned = normalize(learned, reference_returns(df))
            curve_frames.append(learned.assign(budget=learned["env_id"].map(budgets)))
    # An env held at two budgets shows every count a learner ran it with; the controls (no
    # demonstrations: an oracle screen's too) stand beside each of those counts.
    held_at = pd.concat([df[["env_id", "n_demos", "budget"]] for df in trials])
    budgets_of = held_at.groupby("env_id")["budget"].nunique()
    envs = budgets_of.index[budgets_of > 1]
    if envs.empty:
        raise BadInput("the folders hold no env at two budgets")
    counts = sorted({n for n in held_at["n_demos"] if n > 0})
    ran = held_at[held_at["n_demos"] > 0][["env_id", "n_demos"]]
    alone = [(e, 0) for e in envs if e not in set(ran["env_id"])]  # controls only
    cells = pd.concat([ran, pd.DataFrame(alone, columns=ran.columns)]).drop_duplicates()
    cells = cells[cells["env_id"].isin(envs)]
    joined = pd.concat([_at_counts(df, counts) for df in trials], ignore_index=True)
    joined = joined[joined["status"] == "ok"].merge(cells)
    if curves_of is None:
        return joined, pd.DataFrame()
    curve_frame = pd.concat([_at_counts(c, counts) for c in curve_frames], ignore_index=True)
    return joined, curve_frame.merge(joined[["env_id", "n_demos", "budget"]].drop_duplicates())


def _at_counts(df: pd.DataFrame, counts: list[int]) -> pd.DataFrame:
    """`df` with its demonstration-free rows copied to each of `counts`."""
    free = demo_free(df)
    if not counts or not free.any():
        return df
    return pd.concat([df[~free], *(df[free].assign(n_demos=n) for n in counts)], ignore_index=True)


def statistics(df: pd.DataFrame, reps: int = 2000) -> pd.DataFrame:
    """`COLUMNS` from `side_by_side`'s trials: per env, count and budget, each learner's IQM
    with a 95% CI and, against its controls at the same budget, the fraction of its oracle
    and P(learner > its floor), each with a 95% CI."""
    names = Names.of(df)
    rows = []
    for (env_id, n_demos, budget), cell in df.groupby(["env_id", "n_demos", "budget"]):
        scores = {
            name: runs["normalized"].to_numpy(float)[:, None]
            for name, runs in cell.groupby("algorithm")
        }
        iqm = stats.aggregate_scores(scores, reps=reps)
        iqm = iqm[iqm["metric"] == "iqm"].set_index("algorithm")
        fractions = comparisons.oracle_fractions(scores, names, reps).set_index("algorithm")
        over_floor = stats.improvement_of_pairs(
            scores, comparisons.floor_pairs(scores, names), reps
        )
        over_floor = over_floor.set_index("algorithm")
        for name, runs in scores.items():
            at = iqm.loc[name]
            row = {"env_id": env_id, "algorithm": name, "n_demos": int(n_demos)}
            row |= {"budget": int(budget), "seeds": len(runs)}
            row |= {"iqm": at["estimate"], "lo": at["lo"], "hi": at["hi"]}
            if name in fractions.index:
                of = fractions.loc[name]
                row |= {"of_oracle": of["estimate"], "of_oracle_lo": of["lo"]}
                row |= {"of_oracle_hi": of["hi"], "worst_of_oracle": of["worst"]}
            if name in over_floor.index:
                over = over_floor.loc[name]
                row |= {"over_floor": over["estimate"], "over_floor_lo": over["lo"]}
                row |= {"over_floor_hi": over["hi"]}
            rows.append(row)
    return pd.DataFrame(rows, columns=COLUMNS)


def curve_statistics(curve_frame: pd.DataFrame, reps: int = 2000) -> pd.DataFrame:
    """`curves.iqm_curves` of `side_by_side`'s curves, budget by budget, with a `budget`
    column (what `plot.draw_iqm_curves` draws, budget by budget)."""
    return pd.concat(
        [
            curves.iqm_curves(rows, reps=reps).assign(budget=budget)
            for budget, rows in curve_frame.groupby("budget")
        ],
        ignore_index=True,
    )
