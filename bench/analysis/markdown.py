"""The report's parts as markdown: tables from the statistics' frames (and `bench plot`'s
table of the normalized frame), and the sections that explain them. Pure text: nothing here
computes a statistic (`bench.analysis.comparisons`) or draws (`bench.analysis.plot`). Each table is a frame of
display strings, rendered by `table`."""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from pathlib import Path

import pandas as pd

from bench.analysis import labels
from bench.analysis.comparisons import POOLED, TARGET
from bench.analysis.labels import Names
from bench.analysis.normalize import EXPERT, RANDOM

MAX_LISTED = 20
"""Failed trials named one by one in the header; the rest are counted."""
METRIC_LABELS = {"mean": "mean", "median": "median", "iqm": "IQM"}


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


def pair_label(a: str, b: str, names: Names) -> str:
    return f"{names.label(a)} > {names.label(b)}"


def compare_table(
    comparison: pd.DataFrame,
    run: str,
    reference: str,
    names: Names,
    unlike: tuple[int, int] = (0, 0),
) -> str:
    """Markdown: per env, algorithm and demo count, IQM [95% CI] of the run and the reference,
    their difference and the verdict (stats.compare); then how many rows agree."""
    header = ["env", "algorithm", "demos", f"run ({run})", f"reference ({reference})"]
    header += ["run - ref [95% CI]", "verdict"]
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
        " gives p < 0.05 (under one distribution, 5% of rows at most), and is"
        " identical when both hold the same scores.",
    ]
    if any(unlike):
        lines.append(
            f"\nNot compared: {unlike[0]} cells of the run and {unlike[1]} of the reference have"
            " no like in the other folder (another budget, demonstration count or settings)."
        )
    return "\n".join(lines) + "\n"


def seen(df: pd.DataFrame, env_id: str) -> str:
    """ ", from pixels" where the env's learners observed frames (`observation: pixels`)."""
    seen = df.loc[df["env_id"] == env_id, "observation"]
    return ", from pixels" if (seen == "pixels").any() else ""


def header(df: pd.DataFrame, results_dir: Path) -> str:
    suites = ", ".join(sorted(map(str, df["suite"].unique())))
    envs = labels.env_order(df["env_id"].unique())
    names = Names.of(df)
    learners = names.order(df["algorithm"].unique())
    references = [*names.with_role(names, RANDOM), *names.with_role(names, EXPERT)]
    ok = df[df["status"] == "ok"]
    per_cell = ok.groupby(["env_id", "algorithm", "n_demos"]).size()
    seeds = range_text(per_cell) if len(per_cell) else "0"
    failed = df[df["status"] != "ok"]
    counts = [int(n) for n in sorted(df.loc[df["n_demos"] > 0, "n_demos"].unique())]
    label = names.label
    rows = [
        ("suite", suites),
        ("results", f"`{results_dir}`"),
        ("envs", ", ".join(f"{labels.env_label(e)} (`{e}`{seen(df, e)})" for e in envs)),
        ("learners", ", ".join(map(label, learners)) or "none"),
        ("references", ", ".join(map(label, references)) or "none"),
        ("demonstrations", ", ".join(map(str, counts)) or "none"),
        ("seeds per cell", f"{seeds} (ok trials per env, algorithm and demo count)"),
        ("trials", f"{len(df)} ({len(failed)} failed)"),
        ("env steps", f"{int(df['env_steps'].sum()):,} of training, summed over trials"),
        ("wall time", f"{duration(df['wall_time'].sum())} summed over trials"),
        ("software", "; ".join(sorted(df["software"].unique()))),
    ]
    # A key-value table: blank column names, as the keys say what each row is.
    lines = [f"# ifo-bench report: {suites}", "", table(pd.DataFrame(rows, columns=["", ""]))]
    if len(failed):
        lines += ["", "Failed trials, left out of every statistic:", ""]
        lines += [
            f"- {labels.env_label(r.env_id)}, {label(r.algorithm)}, "
            f"{labels.demos_label(r.n_demos, 'demonstration')}, seed {r.seed}"
            for r in failed.head(MAX_LISTED).itertuples()
        ]
        if len(failed) > MAX_LISTED:
            lines.append(f"- and {len(failed) - MAX_LISTED} more (status in the records)")
    return "\n".join(lines)


def _bold_names(shown: Sequence[str], names: Names) -> str:
    return ", ".join(f"**{names.label(n)}**" for n in shown)


def _is_a(shown: Sequence[str]) -> str:
    return "is a" if len(shown) == 1 else "are each a"


def how_to_read(learners: Sequence[str], reps: int, names: Names, focus: str = TARGET) -> str:
    subject = names.label(focus)
    items = [
        "**Normalized score**: per env, 0 is the mean return of the random policy and 1 that of "
        "the expert that recorded the demonstrations (raw returns in the last section), so envs "
        "can be pooled. Scores below 0 or above 1 are possible.",
        "**Run**: one seed on one env. For each number of demonstrations, the runs of all envs "
        "are pooled into three aggregates: mean, median and IQM.",
        "**IQM** (interquartile mean): the mean of the middle 50% of runs. Less thrown by "
        "outliers than the mean and less noisy than the median: read it first.",
        "**[lo, hi]**: a 95% confidence interval, from a stratified bootstrap over seeds "
        f"({reps} resamples). Few seeds make it wide; with one seed it shrinks to a point, "
        "which means unknown, not certain.",
        f"**Probability of improvement** P({subject} > X): the chance that a run of {subject} scores "
        "higher than a run of X on the same env, averaged over envs. 0.5 is a tie; an interval "
        "that excludes 0.5 is a difference the seeds support.",
        "**Performance profile**: for each score τ, the fraction of runs scoring above τ. A "
        "curve that lies above another is better at every level.",
        "**Learning curves**: the IQM over seeds at each evaluation during training, with its "
        "95% CI as a band.",
    ]
    if floors := names.with_role(learners, "floor"):
        items.append(
            f"{_bold_names(floors, names)} {_is_a(floors)} lower control (the floor): no "
            "demonstrations, trained on a reward that says nothing of the task but to stay in "
            "it (the built-in Survival: +1 per step alive), so the same runs appear at every "
            "demonstration count. A learner that does not beat it has not shown that it "
            "learned from the demonstrations."
        )
    if ceilings := names.with_role(learners, "ceiling"):
        items.append(
            f"{_bold_names(ceilings, names)} {_is_a(ceilings)} upper control (the ceiling): "
            "an optimizer with the imitators' settings, trained on the env's own reward, no "
            "demonstrations. It is drawn as a line, not a bar. A learner's IQM as a fraction of "
            "its own optimizer's ceiling (per env) says how much of what the optimizer reaches "
            "at this budget the imitation reaches, and its worst seed's fraction whether every "
            "seed got there; the gap from the ceiling to the expert is the optimizer's."
        )
    if orphans := [n for n in names.with_role(learners, "learner") if names[n].family is None]:
        items.append(
            f"{_bold_names(orphans, names)} {'has' if len(orphans) == 1 else 'have'} no optimizer"
            " family (`register(..., family=...)`, or a config that extends an optimizer's): no"
            " floor or ceiling to read it against, so it has no P(> floor) and no fraction of an"
            " oracle here."
        )
    if names.starred(learners):
        items.append(
            "**\\*** marks algorithms that see the expert's actions, which imitation from "
            "observation does not."
        )
    return (
        "## How to read this report\n\n"
        + "\n".join(f"- {item}" for item in items)
        + "\n\nStatistics follow Agarwal et al., *Deep Reinforcement Learning at the Edge of "
        "the Statistical Precipice* (NeurIPS 2021), computed with their library, rliable."
    )


def at_a_glance(aggregates: pd.DataFrame, improvement: pd.DataFrame, names: Names) -> str:
    """IQM of every learner, and GAIfO's probability of improvement, across demo counts."""
    if aggregates.empty:
        return ""
    counts = sorted(aggregates["n_demos"].unique())
    columns = [labels.demos_label(n) for n in counts]
    iqm = aggregates[aggregates["metric"] == "iqm"].set_index(["algorithm", "n_demos"])
    rows = [
        [names.label(a), *by_count(iqm, (a,), counts)]
        for a in names.in_order(aggregates["algorithm"])
    ]
    # Each count pools only the envs where every learner has runs: while a suite is partly run,
    # counts can pool different envs, and their columns then do not compare.
    pooled = aggregates.groupby("n_demos")["envs"].max()
    rows.append(["envs pooled", *(str(pooled[n]) for n in counts)])
    lines = ["## At a glance", "", table(pd.DataFrame(rows, columns=["IQM [95% CI]", *columns]))]
    if pooled.nunique() > 1:
        lines += [
            "",
            "Each column pools the envs where every learner has runs with that many"
            " demonstrations (the sections below name the ones left out), and these columns pool"
            " different numbers of them, so read down a column, not across a row.",
        ]
    if len(improvement):
        pi = improvement.set_index(["algorithm", "other", "n_demos"])
        pairs = dict.fromkeys(zip(improvement["algorithm"], improvement["other"], strict=True))
        rows = [[pair_label(a, b, names), *by_count(pi, (a, b), counts)] for a, b in pairs]
        header = ["P(improvement) [95% CI]", *columns]
        lines += ["", table(pd.DataFrame(rows, columns=header))]
    return "\n".join(lines)


def env_by_count(per_env: pd.DataFrame, names: Names, focus: str = TARGET) -> str:
    """Each learner's IQM on each env at every demo count, in one table, and `focus`'s
    probabilities of improvement over the others: a row per learner (or pair), a column per env,
    each cell its values at the counts in order ("-" where it has none): the numbers behind
    Figure 2's bars, read across counts."""
    per_env = per_env[per_env["env_id"] != POOLED]
    iqm = per_env[per_env["statistic"] == "iqm"]
    if iqm.empty:
        return ""
    pairs = per_env[(per_env["statistic"] == "p_improvement") & (per_env["algorithm"] == focus)]
    counts = sorted(iqm["n_demos"].unique())
    envs = labels.env_order(iqm["env_id"].unique())

    def cells(frame: pd.DataFrame) -> list[str]:
        """One row's cells: `frame`'s estimates (one learner's or pair's) per env and count."""
        at = frame.set_index(["env_id", "n_demos"])["estimate"]
        row = []
        for env_id in envs:
            values = [at.get((env_id, n)) for n in counts]
            shown = " / ".join("-" if v is None else f"{v:.2f}" for v in values)
            row.append("" if all(v is None for v in values) else shown)
        return row

    rows = [
        [names.label(a), *cells(iqm[iqm["algorithm"] == a])]
        for a in names.in_order(iqm["algorithm"])
    ]
    rows += [
        [pair_label(focus, other, names), *cells(pairs[pairs["other"] == other])]
        for other in names.in_order(pairs["other"])
    ]
    shown = " / ".join(str(n) for n in counts)
    header = [f"at {shown} demos", *(labels.env_label(e) for e in envs)]
    return "\n".join(
        [
            "## Per env, across demonstration counts",
            "",
            "Each env's IQM over its seeds at each demonstration count, then the probability that"
            f" a {names.label(focus)} run beats a run of each other learner there, as the per-env"
            " sections below"
            ' give them with their CIs; "-" where a count has no runs yet.',
            "",
            table(pd.DataFrame(rows, columns=header)),
        ]
    )


def by_count(frame: pd.DataFrame, key: tuple, counts: Sequence[int]) -> list[str]:
    """`estimate [lo, hi]` of `frame` (indexed by `key` and then the demo count) at each of
    `counts`; blank where it has none."""
    return [
        interval(*frame.loc[(*key, n), ["estimate", "lo", "hi"]])
        if (*key, n) in frame.index
        else ""
        for n in counts
    ]


def references(df: pd.DataFrame) -> str:
    refs = df[(df["status"] == "ok") & df["role"].isin([RANDOM, EXPERT])]
    summary = refs.groupby(["env_id", "role"])["return"].agg(["mean", "std", "size"])
    lines = [
        "## Reference returns",
        "",
        "Raw undiscounted return of the references, mean ± standard deviation over seeds "
        "(each seed's return is itself a mean over evaluation episodes): "
        "the 0 and 1 of every normalized score.",
        "",
    ]
    rows = []
    for env_id in labels.env_order(df["env_id"].unique()):
        cells = []
        for a in (RANDOM, EXPERT):
            if (env_id, a) not in summary.index:
                cells.append("")
                continue
            r = summary.loc[(env_id, a)]
            seeds = f"{int(r['size'])} seed" + ("s" if r["size"] != 1 else "")
            spread = "" if pd.isna(r["std"]) else f" ± {r['std']:.1f}"
            cells.append(f"{r['mean']:.1f}{spread} ({seeds})")
        rows.append([labels.env_label(env_id), *cells])
    lines.append(table(pd.DataFrame(rows, columns=["env", "random", "expert"])))
    return "\n".join(lines)


def costs(df: pd.DataFrame) -> str:
    """Measured cost per trial, to size a bigger run (e.g. on a cluster) before starting it."""
    ok = df[df["status"] == "ok"]
    lines = [
        "## Cost per trial",
        "",
        "Wall time of one trial on one core (training and every evaluation), mean over its "
        "trials; a trial never uses more than one core. Total core-hours of a bigger run = "
        "trials x wall time.",
        "",
    ]
    names = Names.of(df)
    rows = []
    for env_id in labels.env_order(ok["env_id"].unique()):
        trials = ok[ok["env_id"] == env_id]
        for algorithm in names.in_order(trials["algorithm"]):
            cell = trials[trials["algorithm"] == algorithm]
            budget = ", ".join(f"{b:,}" for b in sorted(cell["budget"].unique()))
            rows.append(
                [
                    labels.env_label(env_id),
                    names.label(algorithm),
                    budget,
                    str(len(cell)),
                    duration(cell["wall_time"].mean()),
                    f"{cell['wall_time'].sum() / 3600:.2f}",
                ]
            )
    header = [
        "env",
        "algorithm",
        "budget (env steps)",
        "trials",
        "wall time per trial",
        "core-hours",
    ]
    lines.append(table(pd.DataFrame(rows, columns=header), right=header[2:]))
    return "\n".join(lines)


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
    """Markdown: `stats.time_to` rows, one per env and learner: the median and worst steps."""
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


def steps(n: float) -> str:
    """Env steps, short: 420k, 1.25M; never for inf."""
    if math.isinf(n):
        return "never"
    return f"{n / 1e6:.2f}M" if n >= 1e6 else f"{n / 1e3:.0f}k"


def interval(estimate: float, lo: float, hi: float) -> str:
    """`estimate [lo, hi]`; the estimate alone for a point statistic (no interval)."""
    if pd.isna(lo) and pd.isna(hi):
        return f"{estimate:.2f}"
    return f"{estimate:.2f} [{lo:.2f}, {hi:.2f}]"


def mean_std(mean: float, std: float) -> str:
    return f"{mean:.2f}" if pd.isna(std) else f"{mean:.2f} ± {std:.2f}"


def table(cells: pd.DataFrame, right: Collection[str] = ()) -> str:
    """`cells`, a frame of display strings, as a markdown table; the columns named in `right`
    (numbers) right-aligned, the rest left-aligned."""
    align = ["right" if c in right else "left" for c in cells.columns]
    # No number parsing: the cells are already formatted ("0.010" must not become "0.01").
    return cells.to_markdown(index=False, colalign=align, disable_numparse=True)


def demos_title(n: int) -> str:
    return labels.demos_label(n, "demonstration").capitalize()


def range_text(values: pd.Series) -> str:
    lo, hi = int(values.min()), int(values.max())
    return str(lo) if lo == hi else f"{lo}–{hi}"


def duration(seconds: float) -> str:
    if not math.isfinite(seconds) or seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 2 * 3600:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"
