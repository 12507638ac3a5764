"""`bench report`: aggregate statistics and a markdown report, from the records alone.

Per demonstration count, the learners' normalized scores are pooled across envs
and summarized with rliable (mean, median and IQM with 95% stratified-bootstrap
CIs; probability of improvement of GAIfO over each other learner, and of each
learner over the survival control; performance profiles), then the same env by
env, and their learning curves are drawn as IQM over seeds with a 95% CI band. Random and expert are the references (0 and 1), not competitors; learners
that take no demonstrations (e.g. survival) compete at every count as controls.

Written beside `report.md`: figure2, profile_<n>demos and curves_<n>demos as
.png and .pdf, and the numbers of the tables as aggregates.csv, improvement.csv,
per_env.csv and state_match.csv (distance of the learners' states from the expert's, `bench.state_match`).
Nothing here trains or evaluates: it reads records and writes files.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from pathlib import Path
from typing import NamedTuple

import pandas as pd

from bench import comparisons, labels, plot, stats, store
from bench.comparisons import (
    PER_ENV_COLUMNS,
    POOLED,
    STATE_MATCH_COLUMNS,
    TARGET,
    demo_counts,
)
from bench.normalize import (
    EXPERT,
    ORACLE,
    RANDOM,
    REFERENCES,
    demo_free,
    normalize,
    reference_returns,
)

REPORT = "report.md"
AGGREGATES_CSV = "aggregates.csv"
IMPROVEMENT_CSV = "improvement.csv"
STATE_MATCH_CSV = "state_match.csv"
PER_ENV_CSV = "per_env.csv"
AGGREGATE_COLUMNS = ["n_demos", "algorithm", "seeds", "envs", "metric", "estimate", "lo", "hi"]
IMPROVEMENT_COLUMNS = ["n_demos", "algorithm", "other", "estimate", "lo", "hi"]
MAX_LISTED = 20
"""Failed trials named one by one in the header; the rest are counted."""
METRIC_LABELS = {"mean": "mean", "median": "median", "iqm": "IQM"}


# ---------------------------------------------------------------- entry points


class WrittenReport(NamedTuple):
    """A report on disk, and the aggregate tables it holds (so callers need not read them back)."""

    path: Path
    """report.md"""
    aggregates: pd.DataFrame
    """AGGREGATE_COLUMNS, as in aggregates.csv"""
    improvements: pd.DataFrame
    """IMPROVEMENT_COLUMNS, as in improvement.csv"""
    action_users: frozenset[str]
    """Algorithms the records say were given expert actions (marked * in the tables)."""


def write_reports(
    root: str | Path, out_dir: str | Path | None = None, reps: int = 2000
) -> list[WrittenReport]:
    """One report per suite folder under `root` (store.find_result_dirs).

    With several suites, `out_dir` (if given) gets one subfolder per suite, named
    as the suite's folder is under `root`.
    """
    root = Path(root)
    dirs = store.suite_dirs(root)
    if out_dir is None:
        return [write_report(d, reps=reps) for d in dirs]
    if len(dirs) == 1:
        return [write_report(dirs[0], Path(out_dir), reps)]
    return [write_report(d, Path(out_dir) / d.relative_to(root), reps) for d in dirs]


def write_report(results_dir: Path, out_dir: Path | None = None, reps: int = 2000) -> WrittenReport:
    """Write `out_dir`/report.md (default `results_dir`/report) with its figures and CSVs.

    `reps` is the number of bootstrap resamples behind every interval.
    Raises FileNotFoundError when `results_dir` holds no readable trial record,
    and normalize.NormalizationError when an env lacks its random or expert trials.
    """
    results_dir = Path(results_dir)
    out_dir = results_dir / "report" if out_dir is None else Path(out_dir)
    trials = store.load(results_dir)
    if trials.empty:
        raise FileNotFoundError(f"{store.trials_dir(results_dir)}: no readable trial record")
    df = normalize(trials)
    starred = labels.action_users(trials)
    out_dir.mkdir(parents=True, exist_ok=True)

    learners = labels.algorithm_order(df["algorithm"].unique())
    if learners:
        plot.figure2(df, out_dir / "figure2")
        figure_section = (
            "## Normalized return per env\n\n"
            "![Normalized return per env against number of demonstrations](figure2.png)\n\n"
            "Mean ± standard deviation over seeds, as in the figure.\n\n"
            # A line that starts with "* " would be a list item in markdown.
            + plot.summary_table(df).replace(
                labels.ACTIONS_FOOTNOTE, "\\" + labels.ACTIONS_FOOTNOTE
            )
        )
    else:
        figure_section = "No learning algorithm was run: only the random and expert references."

    try:
        curves: pd.DataFrame | str = load_iqm_curves(results_dir, trials, reps)
    except ValueError as e:  # several curves per seed and step: records of more than one run
        curves = str(e)
    per_count = [_demo_section(df, curves, n, out_dir, reps) for n in demo_counts(df)]
    by_env = [
        _per_env_section(df, n, aggregate, improvement, reps, starred)
        for n, (_, aggregate, improvement) in zip(demo_counts(df), per_count, strict=True)
    ]
    matched = [_state_match_section(df, n, reps, starred) for n in demo_counts(df)]
    aggregates = _concat([aggregate for _, aggregate, _ in per_count], AGGREGATE_COLUMNS)
    improvements = _concat([improvement for _, _, improvement in per_count], IMPROVEMENT_COLUMNS)
    aggregates.to_csv(out_dir / AGGREGATES_CSV, index=False)
    improvements.to_csv(out_dir / IMPROVEMENT_CSV, index=False)
    _concat([rows for _, rows in by_env], PER_ENV_COLUMNS).to_csv(
        out_dir / PER_ENV_CSV, index=False
    )
    _concat([rows for _, rows in matched], STATE_MATCH_COLUMNS).to_csv(
        out_dir / STATE_MATCH_CSV, index=False
    )

    sections = [
        _header(df, results_dir),
        _how_to_read(learners, reps, starred),
        _at_a_glance(aggregates, improvements, starred),
        figure_section,
        *(text for text, _, _ in per_count),
        *(text for text, _ in by_env),
        *(text for text, _ in matched),
        _references(df),
        _costs(df),
    ]
    path = out_dir / REPORT
    path.write_text("\n\n".join(s.strip() for s in sections if s) + "\n")
    return WrittenReport(path, aggregates, improvements, starred)


def tables(
    aggregates: pd.DataFrame, improvement: pd.DataFrame, action_users: Collection[str] = ()
) -> str:
    """The aggregate and probability-of-improvement tables of a report, as markdown;
    `action_users` (labels.action_users of the records) are marked with a *."""
    parts = []
    for n in sorted(set(aggregates["n_demos"]) | set(improvement["n_demos"])):
        parts.append(f"### {_demos_title(n)}")
        parts.append(aggregate_table(aggregates[aggregates["n_demos"] == n], action_users))
        rows = improvement[improvement["n_demos"] == n]
        if len(rows):
            parts.append(improvement_table(rows, action_users))
    if not parts:
        return "No aggregate statistics: no learning algorithm in these records.\n"
    return "\n\n".join(p.strip() for p in parts) + "\n"


# ---------------------------------------------------------------- statistics


def load_iqm_curves(results_dir: Path, trials: pd.DataFrame, reps: int = 2000) -> pd.DataFrame:
    """`iqm_curves` of the learners' recorded curves, normalized with `trials`' references."""
    curves = store.load_curves(results_dir)
    curves = curves[~curves["algorithm"].isin(REFERENCES)]
    return stats.iqm_curves(normalize(curves, reference_returns(trials)), reps=reps)


# ---------------------------------------------------------------- markdown


def aggregate_table(aggregates: pd.DataFrame, action_users: Collection[str] = ()) -> str:
    """Markdown: a row per algorithm, a column per metric, each `estimate [lo, hi]`.

    `aggregates`: stats.aggregate_scores rows of one demo count, plus seeds and envs columns.
    """
    metrics = [m for m in METRIC_LABELS if m in set(aggregates["metric"])]
    header = ["algorithm", "runs (seeds × envs)"] + [
        f"{METRIC_LABELS[m]} [95% CI]" for m in metrics
    ]
    lines = [_row(header), "|" + "---|" * len(header)]
    cells = aggregates.set_index(["algorithm", "metric"])
    for a in labels.in_order(aggregates["algorithm"]):
        first = cells.loc[(a, metrics[0])]
        runs = f"{int(first['seeds'])} × {int(first['envs'])}"
        values = [_interval(*cells.loc[(a, m), ["estimate", "lo", "hi"]]) for m in metrics]
        lines.append(_row([labels.algorithm_label(a, action_users), runs, *values]))
    return "\n".join(lines) + "\n"


def improvement_table(improvement: pd.DataFrame, action_users: Collection[str] = ()) -> str:
    """Markdown: P(a > b) [95% CI], a row per (algorithm, other) pair of `improvement`."""
    lines = [_row(["comparison", "P(improvement) [95% CI]"]), "|---|---|"]
    for r in improvement.itertuples():
        lines.append(
            _row(
                [_pair_label(r.algorithm, r.other, action_users), _interval(r.estimate, r.lo, r.hi)]
            )
        )
    return "\n".join(lines) + "\n"


def _pair_label(a: str, b: str, action_users: Collection[str]) -> str:
    return f"{labels.algorithm_label(a, action_users)} > {labels.algorithm_label(b, action_users)}"


def compare_table(
    comparison: pd.DataFrame, run: str, reference: str, action_users: Collection[str] = ()
) -> str:
    """Markdown: per env, algorithm and demo count, IQM [95% CI] of the run and the reference,
    their difference and the verdict (stats.compare); then how many rows agree."""
    header = ["env", "algorithm", "demos", f"run ({run})", f"reference ({reference})"]
    header += ["run - ref [95% CI]", "verdict"]
    lines = [_row(header), "|" + "---|" * len(header)]
    envs, algorithms = (
        labels.env_order(comparison["env_id"]),
        labels.in_order(comparison["algorithm"]),
    )
    ordered = comparison.sort_values(
        ["env_id", "algorithm", "n_demos"],
        key=lambda col: (
            col.map((envs if col.name == "env_id" else algorithms).index)
            if col.name != "n_demos"
            else col
        ),
    )
    for _, r in ordered.iterrows():
        lines.append(
            _row(
                [
                    labels.env_label(r["env_id"]),
                    labels.algorithm_label(r["algorithm"], action_users),
                    r["n_demos"],
                    _interval(r["run_iqm"], r["run_lo"], r["run_hi"]) + f" ({r['run_seeds']})",
                    _interval(r["ref_iqm"], r["ref_lo"], r["ref_hi"]) + f" ({r['ref_seeds']})",
                    _interval(r["diff"], r["diff_lo"], r["diff_hi"]),
                    "**differs**" if r["verdict"] == "differs" else "agrees",
                ]
            )
        )
    agree = int((comparison["verdict"] == "agrees").sum())
    lines += [
        "",
        f"{agree} of {len(comparison)} rows agree. IQM of normalized returns over seeds (seed"
        " count in parentheses), both"
        " normalized with the reference's random and expert returns; a row differs when the 95%"
        " bootstrap CI of the IQM difference excludes 0.",
    ]
    return "\n".join(lines) + "\n"


def _seen(df: pd.DataFrame, env_id: str) -> str:
    """ ", from pixels" where the env's learners observed frames (`observation: pixels`)."""
    seen = df.loc[df["env_id"] == env_id, "observation"]
    return ", from pixels" if (seen == "pixels").any() else ""


def _header(df: pd.DataFrame, results_dir: Path) -> str:
    suites = ", ".join(sorted(map(str, df["suite"].unique())))
    envs = labels.env_order(df["env_id"].unique())
    learners = labels.algorithm_order(df["algorithm"].unique())
    references = [a for a in (RANDOM, EXPERT) if a in set(df["algorithm"])]
    ok = df[df["status"] == "ok"]
    per_cell = ok.groupby(["env_id", "algorithm", "n_demos"]).size()
    seeds = _range_text(per_cell) if len(per_cell) else "0"
    failed = df[df["status"] != "ok"]
    counts = [int(n) for n in sorted(df.loc[df["n_demos"] > 0, "n_demos"].unique())]
    starred = labels.action_users(df)
    label = lambda a: labels.algorithm_label(a, starred)  # noqa: E731
    rows = [
        ("suite", suites),
        ("results", f"`{results_dir}`"),
        ("envs", ", ".join(f"{labels.env_label(e)} (`{e}`{_seen(df, e)})" for e in envs)),
        ("learners", ", ".join(map(label, learners)) or "none"),
        ("references", ", ".join(map(label, references)) or "none"),
        ("demonstrations", ", ".join(map(str, counts)) or "none"),
        ("seeds per cell", f"{seeds} (ok trials per env, algorithm and demo count)"),
        ("trials", f"{len(df)} ({len(failed)} failed)"),
        ("env steps", f"{int(df['env_steps'].sum()):,} of training, summed over trials"),
        ("wall time", f"{_duration(df['wall_time'].sum())} summed over trials"),
    ]
    lines = [f"# ifo-bench report: {suites}", "", "| | |", "|---|---|"]
    lines += [_row(r) for r in rows]
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


def _how_to_read(learners: Sequence[str], reps: int, action_users: Collection[str]) -> str:
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
        "**Probability of improvement** P(GAIfO > X): the chance that a run of GAIfO scores "
        "higher than a run of X on the same env, averaged over envs. 0.5 is a tie; an interval "
        "that excludes 0.5 is a difference the seeds support.",
        "**Performance profile**: for each score τ, the fraction of runs scoring above τ. A "
        "curve that lies above another is better at every level.",
        "**Learning curves**: the IQM over seeds at each evaluation during training, with its "
        "95% CI as a band.",
    ]
    if "survival" in learners:
        items.append(
            "**Survival** is a control: it gets no demonstrations and is rewarded +1 per step "
            "alive, so the same runs appear at every demonstration count. A learner that does "
            "not beat it has not shown that it learned from the demonstrations."
        )
    if ORACLE in learners:
        items.append(
            "**Oracle** is the upper control: the imitators' optimizer with their settings, "
            "trained on the env's own reward, no demonstrations. It is drawn as a line, not a bar. "
            "A learner's IQM as a fraction of the oracle's (per env) says how much of what the "
            "optimizer reaches at this budget the imitation reaches; the gap from the oracle to "
            "the expert is the optimizer's."
        )
    if set(action_users) & set(learners):
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


def _at_a_glance(
    aggregates: pd.DataFrame, improvement: pd.DataFrame, action_users: Collection[str]
) -> str:
    """IQM of every learner, and GAIfO's probability of improvement, across demo counts."""
    if aggregates.empty:
        return ""
    counts = sorted(aggregates["n_demos"].unique())
    columns = [labels.demos_label(n) for n in counts]
    rule = "|" + "---|" * (1 + len(counts))
    lines = ["## At a glance", "", _row(["IQM [95% CI]", *columns]), rule]
    iqm = aggregates[aggregates["metric"] == "iqm"].set_index(["algorithm", "n_demos"])
    for a in labels.in_order(aggregates["algorithm"]):
        cells = [
            _interval(*iqm.loc[(a, n), ["estimate", "lo", "hi"]]) if (a, n) in iqm.index else ""
            for n in counts
        ]
        lines.append(_row([labels.algorithm_label(a, action_users), *cells]))
    if len(improvement):
        pi = improvement.set_index(["algorithm", "other", "n_demos"])
        lines += ["", _row(["P(improvement) [95% CI]", *columns]), rule]
        pairs = dict.fromkeys(zip(improvement["algorithm"], improvement["other"], strict=True))
        for a, b in pairs:
            cells = [
                _interval(*pi.loc[(a, b, n), ["estimate", "lo", "hi"]])
                if (a, b, n) in pi.index
                else ""
                for n in counts
            ]
            lines.append(_row([_pair_label(a, b, action_users), *cells]))
    return "\n".join(lines)


def _references(df: pd.DataFrame) -> str:
    refs = df[(df["status"] == "ok") & df["algorithm"].isin([RANDOM, EXPERT])]
    summary = refs.groupby(["env_id", "algorithm"])["return"].agg(["mean", "std", "size"])
    lines = [
        "## Reference returns",
        "",
        "Raw undiscounted return of the references, mean ± standard deviation over seeds "
        "(each seed's return is itself a mean over evaluation episodes): "
        "the 0 and 1 of every normalized score.",
        "",
        "| env | random | expert |",
        "|---|---|---|",
    ]
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
        lines.append(_row([labels.env_label(env_id), *cells]))
    return "\n".join(lines)


def _costs(df: pd.DataFrame) -> str:
    """Measured cost per trial, to size a bigger run (e.g. on a cluster) before starting it."""
    ok = df[df["status"] == "ok"]
    lines = [
        "## Cost per trial",
        "",
        "Wall time of one trial on one core (training and every evaluation), mean over its "
        "trials; a trial never uses more than one core. Total core-hours of a bigger run = "
        "trials x wall time.",
        "",
        "| env | algorithm | budget (env steps) | trials | wall time per trial | core-hours |",
        "|---|---|---:|---:|---:|---:|",
    ]
    starred = labels.action_users(df)
    for env_id in labels.env_order(ok["env_id"].unique()):
        rows = ok[ok["env_id"] == env_id]
        for algorithm in labels.in_order(rows["algorithm"]):
            cell = rows[rows["algorithm"] == algorithm]
            budget = ", ".join(f"{b:,}" for b in sorted(cell["budget"].unique()))
            lines.append(
                _row(
                    [
                        labels.env_label(env_id),
                        labels.algorithm_label(algorithm, starred),
                        budget,
                        len(cell),
                        _duration(cell["wall_time"].mean()),
                        f"{cell['wall_time'].sum() / 3600:.2f}",
                    ]
                )
            )
    return "\n".join(lines)


def _demo_section(
    df: pd.DataFrame, curves: pd.DataFrame | str, n: int, out_dir: Path, reps: int
) -> tuple[str, pd.DataFrame, pd.DataFrame]:
    """Markdown for one demo count, and its aggregate and improvement rows."""
    title = _demos_title(n)
    parts = [f"## {title}"]
    names = comparisons.competitors(df, n)
    starred = labels.action_users(df)
    counted = comparisons.count_statistics(df, n, reps)
    if counted.failure is not None:
        parts.append(f"No aggregate statistics: {counted.failure}.")
    if counted.left_out:
        parts.append(
            "Left out of the statistics:\n" + "\n".join(f"- {note}" for note in counted.left_out)
        )
    aggregate, improvement = counted.aggregate, counted.improvement
    if counted.scores:
        envs = next(iter(counted.scores.values())).shape[
            1
        ]  # the same for all: score_dict's contract
        pooled = f"Runs of the {envs} envs pooled" if envs > 1 else "Runs of the one env"
        parts += [
            "### Aggregate normalized score",
            f"{pooled}; brackets are 95% bootstrap CIs.",
            aggregate_table(aggregate, starred),
        ]
        parts.append("### Probability of improvement")
        if TARGET not in counted.scores:
            parts.append(
                f"{labels.algorithm_label(TARGET, starred)} has no scores with {title.lower()}."
            )
        if len(improvement):
            parts.append(improvement_table(improvement, starred))
        else:
            parts.append(
                "Nothing to compare: no second learner to set against GAIfO or the control."
            )
        name = f"profile_{n}demos"
        plot.save(
            plot.draw_performance_profile(
                counted.profile, f"Performance profile, {title.lower()}", starred
            ),
            out_dir / name,
        )
        parts += [
            "### Performance profile",
            "Fraction of runs (seeds × envs) scoring above each normalized score τ; band: 95% CI.",
            f"![Performance profile, {title.lower()}]({name}.png)",
        ]

    parts += [
        "### Learning curves",
        _curves_section(curves, names, n, title, out_dir, starred),
    ]
    return (
        "\n\n".join(p.strip() for p in parts),
        aggregate.assign(n_demos=n) if len(aggregate) else aggregate,
        improvement.assign(n_demos=n) if len(improvement) else improvement,
    )


def _per_env_section(
    df: pd.DataFrame,
    n: int,
    pooled_aggregate: pd.DataFrame,
    pooled_improvement: pd.DataFrame,
    reps: int,
    starred: Collection[str],
) -> tuple[str, pd.DataFrame]:
    """Markdown with each learner's IQM and the probabilities of improvement env by env at `n`
    demos, beside their pooled values; and its rows (PER_ENV_COLUMNS).

    Each env keeps every seed it has, where pooling keeps only the seeds every env has, so a
    domain still running is read from all of its finished seeds.
    """
    by_env = comparisons.per_env_statistics(df, n, reps)
    if by_env.empty:
        return "", pd.DataFrame(columns=PER_ENV_COLUMNS)
    envs = list(dict.fromkeys(by_env["env_id"]))
    pooled = comparisons.pooled_rows(n, pooled_aggregate, pooled_improvement)
    frame = pd.concat([by_env, pooled], ignore_index=True) if len(pooled) else by_env

    columns = [*envs, POOLED] if len(envs) > 1 else envs
    iqm = frame[frame["statistic"] == "iqm"]
    improved = frame[frame["statistic"] == "p_improvement"]
    lines = [
        f"## Per env, {_demos_title(n).lower()}",
        "Each env's IQM over its seeds and the probabilities of improvement on that env alone"
        " (every seed an env has; the pooled column keeps the seeds every env has, as above).",
        _env_table(
            iqm,
            "IQM [95% CI] (seeds)",
            {
                labels.algorithm_label(a, starred): (a, "")
                for a in labels.in_order(iqm["algorithm"])
            },
            columns,
        ),
    ]
    if len(improved):
        pairs = dict.fromkeys(zip(improved["algorithm"], improved["other"], strict=True))
        keys = {_pair_label(a, b, starred): (a, b) for a, b in pairs}
        lines.append(_env_table(improved, "P(improvement) [95% CI]", keys, columns))
    fractions = frame[frame["statistic"] == "of_oracle"]
    if len(fractions):
        pairs = dict.fromkeys(zip(fractions["algorithm"], fractions["other"], strict=True))
        keys = {
            f"{labels.algorithm_label(a, starred)} / {labels.algorithm_label(b)}": (a, b)
            for a, b in pairs
        }
        lines.append(_env_table(fractions, "IQM / oracle's IQM [95% CI]", keys, columns))
    return "\n\n".join(lines), frame


def _env_table(
    rows: pd.DataFrame, title: str, keys: dict[str, tuple[str, str]], columns: list[str]
) -> str:
    """Markdown: a row per label of `keys` (its algorithm and other), a column per env id of
    `columns`, each cell `estimate [lo, hi]` (and the seed count of an env's IQM)."""
    cells = rows.set_index(["algorithm", "other", "env_id"])
    header = [title, *(e if e == POOLED else labels.env_label(e) for e in columns)]
    lines = [_row(header), "|" + "---|" * len(header)]
    for label, (a, b) in keys.items():
        values = []
        for env_id in columns:
            if (a, b, env_id) not in cells.index:
                values.append("")
                continue
            r = cells.loc[(a, b, env_id)]
            seeds = f" ({r['seeds']})" if not b and env_id != POOLED else ""
            values.append(_interval(r["estimate"], r["lo"], r["hi"]) + seeds)
        lines.append(_row([label, *values]))
    return "\n".join(lines)


def _state_match_section(
    df: pd.DataFrame, n: int, reps: int, starred: Collection[str]
) -> tuple[str, pd.DataFrame]:
    """Markdown on how far each learner's states lie from the expert's at `n` demos, and its
    rows; nothing where the records hold no distance (pixels, or records from before)."""
    rows = comparisons.state_match_statistics(df, n, reps)
    if rows.empty:
        return "", pd.DataFrame()
    target = labels.algorithm_label(TARGET, starred)
    header = ["algorithm", "runs", "IQM distance [95% CI]", f"P({target} closer) [95% CI]"]
    lines = [_row(header), "|---|---|---|---|"]
    for r in rows.itertuples():
        p_closer = "" if pd.isna(r.p_closer) else _interval(r.p_closer, r.p_lo, r.p_hi)
        lines.append(
            _row(
                [
                    labels.algorithm_label(r.algorithm, starred),
                    r.runs,
                    _interval(r.iqm, r.lo, r.hi),
                    p_closer,
                ]
            )
        )
    text = (
        f"## Distance to the expert's states, {_demos_title(n).lower()}\n\n"
        "How far the states a policy visits in its evaluation episodes lie from the expert's "
        "(bench.state_match: per-dimension 1-Wasserstein distance in units of the expert's "
        "spread, averaged over dimensions; 0 = distributed alike, lower is closer). It sees "
        "imitation where the return cannot: a control that merely survives can score like the "
        f"expert while standing elsewhere. P({target} closer) is the probability that a "
        f"{target} run is closer to the expert than a run of the other.\n\n" + "\n".join(lines)
    )
    return text, rows


def _curves_section(
    curves: pd.DataFrame | str,
    names: list[str],
    n: int,
    title: str,
    out_dir: Path,
    action_users: Collection[str],
) -> str:
    if isinstance(curves, str):
        return f"No learning curves: {curves}."
    frame = curves[curves["algorithm"].isin(names) & ((curves["n_demos"] == n) | demo_free(curves))]
    if frame.empty:
        return f"No learning curves were recorded with {title.lower()}."
    text = ""
    missing = [a for a in names if a not in set(frame["algorithm"])]
    if missing:
        text = (
            "No learning curve recorded for "
            + ", ".join(labels.algorithm_label(a, action_users) for a in missing)
            + ".\n\n"
        )
    name = f"curves_{n}demos"
    figure = plot.draw_iqm_curves(frame, f"Learning curves, {title.lower()}", action_users)
    plot.save(figure, out_dir / name)
    return (
        text + "Normalized return at each evaluation during training: IQM over seeds, "
        "band: 95% CI.\n\n" + f"![Learning curves, {title.lower()}]({name}.png)"
    )


# ---------------------------------------------------------------- helpers


def _concat(frames: list[pd.DataFrame], columns: list[str]) -> pd.DataFrame:
    frames = [f for f in frames if len(f)]
    return (
        pd.concat(frames, ignore_index=True)[columns] if frames else pd.DataFrame(columns=columns)
    )


def _interval(estimate: float, lo: float, hi: float) -> str:
    return f"{estimate:.2f} [{lo:.2f}, {hi:.2f}]"


def _row(cells: Sequence[object]) -> str:
    return "| " + " | ".join(map(str, cells)) + " |"


def _demos_title(n: int) -> str:
    return labels.demos_label(n, "demonstration").capitalize()


def _range_text(values: pd.Series) -> str:
    lo, hi = int(values.min()), int(values.max())
    return str(lo) if lo == hi else f"{lo}–{hi}"


def _duration(seconds: float) -> str:
    if not math.isfinite(seconds) or seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 2 * 3600:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"
