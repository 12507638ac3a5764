"""The statistics' frames as markdown tables: a row per algorithm (or pair, or env and
algorithm), cells written by `bench.analysis.markdown`. Pure text over frames computed
elsewhere (`stats`, `comparisons`, `curves`, `agreement`); the prose around them is
`bench.analysis.sections`'.
"""

from __future__ import annotations

from collections.abc import Sequence

import pandas as pd

from bench.analysis import labels
from bench.analysis.agreement import ALPHA
from bench.analysis.comparisons import POOLED
from bench.analysis.labels import Names
from bench.analysis.markdown import demos_title, interval, mean_std, pair_label, steps, table
from bench.analysis.normalize import EXPERT, RANDOM

METRIC_LABELS = {"mean": "mean", "median": "median", "iqm": "IQM"}
"""Each aggregate's column heading, in the order shown."""


def aggregate_table(aggregates: pd.DataFrame, names: Names) -> str:
    """Markdown: a row per algorithm, a column per metric, each `estimate [lo, hi]`.

    `aggregates`: stats.aggregate_scores rows of one demo count, plus seeds and envs columns.
    """
    metrics = [m for m in METRIC_LABELS if m in set(aggregates["metric"])]
    header = ["algorithm", "runs (seeds × envs)"] + [
        f"{METRIC_LABELS[m]} [95% CI]" for m in metrics
    ]
    cells = aggregates.set_index(["algorithm", "metric"])
    rows = []
    for a in names.in_order(aggregates["algorithm"]):
        first = cells.loc[(a, metrics[0])]
        runs = f"{int(first['seeds'])} × {int(first['envs'])}"
        values = [interval(*cells.loc[(a, m), ["estimate", "lo", "hi"]]) for m in metrics]
        rows.append([names.label(a), runs, *values])
    return table(pd.DataFrame(rows, columns=header)) + "\n"


def improvement_table(improvement: pd.DataFrame, names: Names) -> str:
    """Markdown: P(a > b) [95% CI], a row per (algorithm, other) pair of `improvement`."""
    rows = [
        [pair_label(r.algorithm, r.other, names), interval(r.estimate, r.lo, r.hi)]
        for r in improvement.itertuples()
    ]
    return table(pd.DataFrame(rows, columns=["comparison", "P(improvement) [95% CI]"])) + "\n"


def compare_table(
    comparison: pd.DataFrame,
    run: str,
    reference: str,
    names: Names,
    unlike: tuple[int, int] = (0, 0),
    alpha: float = ALPHA,
) -> str:
    """Markdown: per env, algorithm and demo count, IQM [95% CI] of the run and the reference,
    their difference, P(run > ref) and the verdict (agreement.compare at `alpha`); then how
    many rows agree."""
    header = ["env", "algorithm", "demos", f"run ({run})", f"reference ({reference})"]
    header += ["run - ref [95% CI]", "P(run > ref) [95% CI]", "verdict"]
    envs, algorithms = (
        labels.env_order(comparison["env_id"]),
        names.in_order(comparison["algorithm"]),
    )
    ordered = comparison.sort_values(
        ["env_id", "algorithm", "n_demos"],
        key=lambda col: (
            col.map((envs if col.name == "env_id" else algorithms).index)
            if col.name != "n_demos"
            else col
        ),
    )
    rows = [
        [
            labels.env_label(r["env_id"]),
            names.label(r["algorithm"]),
            str(r["n_demos"]),
            interval(r["run_iqm"], r["run_lo"], r["run_hi"]) + f" ({r['run_seeds']})",
            interval(r["ref_iqm"], r["ref_lo"], r["ref_hi"]) + f" ({r['ref_seeds']})",
            interval(r["diff"], r["diff_lo"], r["diff_hi"]),
            interval(r["better"], r["better_lo"], r["better_hi"]),
            "**differs**" if r["verdict"] == "differs" else r["verdict"],
        ]
        for _, r in ordered.iterrows()
    ]
    agree = int((comparison["verdict"] != "differs").sum())
    same = int((comparison["verdict"] == "identical").sum())
    lines = [
        table(pd.DataFrame(rows, columns=header)),
        "",
        f"{agree} of {len(comparison)} rows agree{f' ({same} identical)' if same else ''}. IQM"
        " of normalized returns over seeds (seed count in parentheses), both normalized with the"
        " reference's random and expert returns; a row differs when a rank test by permutation"
        f" gives p < {alpha:g} (of fresh draws of one distribution, {alpha * 100:g}% of rows), and is"
        " identical when each of its seeds scores what the reference's same seed does, to the bit.",
    ]
    if any(unlike):
        lines.append(
            f"\nNot compared: {unlike[0]} cells of the run and {unlike[1]} of the reference have"
            " no like in the other folder (another budget, demonstration count or settings)."
        )
    return "\n".join(lines) + "\n"


def by_count(frame: pd.DataFrame, key: tuple, counts: Sequence[int]) -> list[str]:
    """`estimate [lo, hi]` of `frame` (indexed by `key` and then the demo count) at each of
    `counts`; blank where it has none."""
    return [
        interval(*frame.loc[(*key, n), ["estimate", "lo", "hi"]])
        if (*key, n) in frame.index
        else ""
        for n in counts
    ]


def summary_table(df: pd.DataFrame) -> str:
    """Markdown: normalized mean ± std over seeds, a row per env and algorithm, a column per
    demo count (`df`: the normalized frame, as Figure 2 draws it); then the actions footnote
    where an algorithm is starred."""
    agg = df.groupby(["env_id", "algorithm", "n_demos"])["normalized"].agg(["mean", "std"])
    cells = agg.apply(lambda r: mean_std(r["mean"], r["std"]), axis=1)
    cells = cells.unstack("n_demos", fill_value="")
    demos = sorted(df["n_demos"].unique())
    names = Names.of(df)
    algos = names.order(df["algorithm"].unique()) + [
        *names.with_role(names, RANDOM),
        *names.with_role(names, EXPERT),
    ]
    rows = [
        [labels.env_label(env_id), names.label(a)] + cells.loc[(env_id, a), demos].tolist()
        for env_id in labels.env_order(df["env_id"].unique())
        for a in algos
        if (env_id, a) in cells.index
    ]
    header = ["env", "algorithm"] + [labels.demos_label(n) for n in demos]
    lines = [table(pd.DataFrame(rows, columns=header))]
    if names.starred(algos):
        lines += ["", labels.ACTIONS_FOOTNOTE]
    return "\n".join(lines) + "\n"


def env_table(
    rows: pd.DataFrame, title: str, keys: dict[str, tuple[str, str]], columns: list[str]
) -> str:
    """Markdown: a row per label of `keys` (its algorithm and other), a column per env id of
    `columns`, each cell `estimate [lo, hi]` (and the seed count of an env's IQM)."""
    cells = rows.set_index(["algorithm", "other", "env_id"])
    header = [title, *(e if e == POOLED else labels.env_label(e) for e in columns)]
    body = []
    for label, (a, b) in keys.items():
        values = []
        for env_id in columns:
            if (a, b, env_id) not in cells.index:
                values.append("")
                continue
            r = cells.loc[(a, b, env_id)]
            seeds = f" ({r['seeds']})" if not b and env_id != POOLED else ""
            values.append(interval(r["estimate"], r["lo"], r["hi"]) + seeds)
        body.append([label, *values])
    return table(pd.DataFrame(body, columns=header))


def reach_table(rows: pd.DataFrame, names: Names) -> str:
    """Markdown: `curves.time_to` rows, one per env and learner: the median and worst steps."""
    order = {a: i for i, a in enumerate(names.order(rows["algorithm"].unique()))}
    rows = rows[rows["algorithm"].isin(order)]
    envs = {e: i for i, e in enumerate(labels.env_order(rows["env_id"].unique()))}
    rows = rows.sort_values(["env_id", "algorithm"], key=lambda c: c.map({**envs, **order}))
    body = [
        [
            labels.env_label(r.env_id),
            names.label(r.algorithm),
            steps(r.median),
            steps(r.worst) + (f" ({r.short} of {r.seeds})" if r.short else ""),
        ]
        for r in rows.itertuples()
    ]
    return table(
        pd.DataFrame(body, columns=["Env", "Learner", "median", "worst"]), right=["median", "worst"]
    )


def report_tables(aggregates: pd.DataFrame, improvement: pd.DataFrame, names: Names) -> str:
    """The aggregate and probability-of-improvement tables of a report (`bench report` prints
    them), a heading per demonstration count; labelled by `names` (`labels.Names.of` the
    records)."""
    parts = []
    for n in sorted(set(aggregates["n_demos"]) | set(improvement["n_demos"])):
        parts.append(f"### {demos_title(n)}")
        parts.append(aggregate_table(aggregates[aggregates["n_demos"] == n], names))
        rows = improvement[improvement["n_demos"] == n]
        if len(rows):
            parts.append(improvement_table(rows, names))
    if not parts:
        return "No aggregate statistics: no learning algorithm in these records.\n"
    return "\n\n".join(p.strip() for p in parts) + "\n"


def budgets_table(rows: pd.DataFrame, names: Names) -> str:
    """Markdown: `budgets.statistics` rows, a table per env (its own budgets as columns) with a
    row per demonstration count and learner; per budget, the IQM [CI] (seeds), the fraction
    of the oracle at that budget [CI] (worst seed's fraction) and P(learner > its floor) [CI]."""
    cells = rows.set_index(["env_id", "n_demos", "algorithm", "budget"])
    parts = []
    for env_id in labels.env_order(rows["env_id"].unique()):
        at_env = rows[rows["env_id"] == env_id]
        budgets = sorted(at_env["budget"].unique())
        body = []
        for n_demos in sorted(at_env["n_demos"].unique()):
            for name in names.order(at_env.loc[at_env["n_demos"] == n_demos, "algorithm"]):
                line = [str(n_demos), names.label(name)]
                for budget in budgets:
                    if (env_id, n_demos, name, budget) not in cells.index:
                        line += ["", "", ""]
                        continue
                    r = cells.loc[(env_id, n_demos, name, budget)]
                    line.append(f"{interval(r['iqm'], r['lo'], r['hi'])} ({int(r['seeds'])})")
                    line.append(
                        ""
                        if pd.isna(r["of_oracle"])
                        else f"{interval(r['of_oracle'], r['of_oracle_lo'], r['of_oracle_hi'])}"
                        f" ({r['worst_of_oracle']:.2f})"
                    )
                    line.append(
                        ""
                        if pd.isna(r["over_floor"])
                        else interval(r["over_floor"], r["over_floor_lo"], r["over_floor_hi"])
                    )
                body.append(line)
        heads = [
            h
            for b in budgets
            for h in (steps(b), f"{steps(b)}: of oracle (worst)", f"{steps(b)}: P(> floor)")
        ]
        shown = table(pd.DataFrame(body, columns=["demos", "Learner", *heads]), right=heads)
        parts.append(f"### {labels.env_label(env_id)}\n\n{shown}")
    return "\n\n".join(parts)
