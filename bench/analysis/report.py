"""`bench report`: aggregate statistics and a markdown report, from the records alone.

Per demonstration count, the learners' normalized scores are pooled across envs
and summarized with rliable (mean, median and IQM with 95% stratified-bootstrap
CIs; probability of improvement of GAIfO over each other learner, and of each
learner over the survival control; performance profiles), then the same env by
env, and their learning curves are drawn as IQM over seeds with a 95% CI band, with
the env steps each took to reach 0.8 normalized (median and worst over seeds). Random and expert are the references (0 and 1), not competitors; learners
that take no demonstrations (e.g. survival) compete at every count as controls.

Written beside `report.md`: figure2, profile_<n>demos, curves_<n>demos and seeds_<n>demos (each
seed's own curve) as
.png and .pdf, and the numbers of the tables as aggregates.csv, improvement.csv,
per_env.csv and state_match.csv (distance of the learners' states from the expert's, `bench.harness.state_match`).
Nothing here trains or evaluates: it reads records and writes files.
"""

from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import pandas as pd

from bench.analysis import comparisons, labels, markdown, plot
from bench.analysis.comparisons import (
    PER_ENV_COLUMNS,
    POOLED,
    STATE_MATCH_COLUMNS,
    TARGET,
    demo_counts,
)
from bench.analysis.curves import iqm_curves, steps_to, time_to
from bench.analysis.labels import Names, is_reference
from bench.analysis.normalize import demo_free, normalize, reference_returns
from bench.harness import store

REPORT = "report.md"
AGGREGATES_CSV = "aggregates.csv"
IMPROVEMENT_CSV = "improvement.csv"
STATE_MATCH_CSV = "state_match.csv"
PER_ENV_CSV = "per_env.csv"
AGGREGATE_COLUMNS = ["n_demos", "algorithm", "seeds", "envs", "metric", "estimate", "lo", "hi"]
IMPROVEMENT_COLUMNS = ["n_demos", "algorithm", "other", "estimate", "lo", "hi"]
REACH = 0.8
"""The normalized return whose time to reach the curves' section tabulates."""


# ---------------------------------------------------------------- entry points


class WrittenReport(NamedTuple):
    """A report on disk, and the aggregate tables it holds (so callers need not read them back)."""

    path: Path
    """report.md"""
    aggregates: pd.DataFrame
    """AGGREGATE_COLUMNS, as in aggregates.csv"""
    improvements: pd.DataFrame
    """IMPROVEMENT_COLUMNS, as in improvement.csv"""
    names: Names
    """How the records name and describe each algorithm (a * for those given expert actions)."""


def write_reports(
    root: str | Path, out_dir: str | Path | None = None, reps: int = 2000, focus: str = TARGET
) -> list[WrittenReport]:
    """One report per suite folder under `root` (store.find_result_dirs), each on `focus`.

    With several suites, `out_dir` (if given) gets one subfolder per suite, named
    as the suite's folder is under `root`.
    """
    root = Path(root)
    dirs = store.suite_dirs(root)
    if out_dir is None:
        return [write_report(d, reps=reps, focus=focus) for d in dirs]
    if len(dirs) == 1:
        return [write_report(dirs[0], Path(out_dir), reps, focus)]
    return [write_report(d, Path(out_dir) / d.relative_to(root), reps, focus) for d in dirs]


def write_report(
    results_dir: Path, out_dir: Path | None = None, reps: int = 2000, focus: str = TARGET
) -> WrittenReport:
    """Write `out_dir`/report.md (default `results_dir`/report) with its figures and CSVs;
    `focus` (an algorithm's name as the records show it) is the learner every comparison is
    about: its probability of improvement over each other learner and over its floor.

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
    names = Names.of(trials)
    out_dir.mkdir(parents=True, exist_ok=True)

    learners = names.order(df["algorithm"].unique())
    if learners:
        plot.figure2(df, out_dir / "figure2")
        figure_section = (
            "## Normalized return per env\n\n"
            "![Normalized return per env against number of demonstrations](figure2.png)\n\n"
            "Mean ± standard deviation over seeds, as in the figure.\n\n"
            # A line that starts with "* " would be a list item in markdown.
            + markdown.summary_table(df).replace(
                labels.ACTIONS_FOOTNOTE, "\\" + labels.ACTIONS_FOOTNOTE
            )
        )
    else:
        figure_section = "No learning algorithm was run: only the random and expert references."

    raw_curves = normalized_curves(results_dir, trials)
    reach = time_to(steps_to(raw_curves, REACH))
    try:
        curves: pd.DataFrame | str = iqm_curves(raw_curves, reps=reps)
    except ValueError as e:  # several curves per seed and step: records of more than one run
        curves = str(e)
    per_count = [
        _demo_section(df, curves, raw_curves, reach, n, out_dir, reps, focus)
        for n in demo_counts(df)
    ]
    by_env = [
        _per_env_section(df, n, aggregate, improvement, reps, names, focus)
        for n, (_, aggregate, improvement) in zip(demo_counts(df), per_count, strict=True)
    ]
    matched = [_state_match_section(df, n, reps, names, focus) for n in demo_counts(df)]
    aggregates = _concat([aggregate for _, aggregate, _ in per_count], AGGREGATE_COLUMNS)
    improvements = _concat([improvement for _, _, improvement in per_count], IMPROVEMENT_COLUMNS)
    aggregates.to_csv(out_dir / AGGREGATES_CSV, index=False)
    improvements.to_csv(out_dir / IMPROVEMENT_CSV, index=False)
    per_env = _concat([rows for _, rows in by_env], PER_ENV_COLUMNS)
    per_env.to_csv(out_dir / PER_ENV_CSV, index=False)
    _concat([rows for _, rows in matched], STATE_MATCH_COLUMNS).to_csv(
        out_dir / STATE_MATCH_CSV, index=False
    )

    sections = [
        markdown.header(df, results_dir),
        markdown.how_to_read(learners, reps, names, focus),
        markdown.at_a_glance(aggregates, improvements, names),
        figure_section,
        markdown.env_by_count(per_env, names, focus),
        *(text for text, _, _ in per_count),
        *(text for text, _ in by_env),
        *(text for text, _ in matched),
        markdown.references(df),
        markdown.costs(df),
    ]
    path = out_dir / REPORT
    path.write_text("\n\n".join(s.strip() for s in sections if s) + "\n")
    return WrittenReport(path, aggregates, improvements, names)


def tables(aggregates: pd.DataFrame, improvement: pd.DataFrame, names: Names) -> str:
    """The aggregate and probability-of-improvement tables of a report, as markdown;
    labelled by `names` (`labels.Names.of` the records)."""
    parts = []
    for n in sorted(set(aggregates["n_demos"]) | set(improvement["n_demos"])):
        parts.append(f"### {markdown.demos_title(n)}")
        parts.append(markdown.aggregate_table(aggregates[aggregates["n_demos"] == n], names))
        rows = improvement[improvement["n_demos"] == n]
        if len(rows):
            parts.append(markdown.improvement_table(rows, names))
    if not parts:
        return "No aggregate statistics: no learning algorithm in these records.\n"
    return "\n\n".join(p.strip() for p in parts) + "\n"


# ---------------------------------------------------------------- statistics


def normalized_curves(results_dir: Path, trials: pd.DataFrame) -> pd.DataFrame:
    """The learners' recorded curves, normalized with `trials`' references."""
    curves = store.load_curves(results_dir)
    return normalize(curves[~is_reference(curves)], reference_returns(trials))


# ---------------------------------------------------------------- markdown


def _demo_section(
    df: pd.DataFrame,
    curves: pd.DataFrame | str,
    raw_curves: pd.DataFrame,
    reach: pd.DataFrame,
    n: int,
    out_dir: Path,
    reps: int,
    focus: str = TARGET,
) -> tuple[str, pd.DataFrame, pd.DataFrame]:
    """Markdown for one demo count, and its aggregate and improvement rows."""
    title = markdown.demos_title(n)
    parts = [f"## {title}"]
    competing = comparisons.competitors(df, n)
    names = Names.of(df)
    counted = comparisons.count_statistics(df, n, reps, focus)
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
            markdown.aggregate_table(aggregate, names),
        ]
        parts.append("### Probability of improvement")
        if focus not in counted.scores:
            parts.append(f"{names.label(focus)} has no scores with {title.lower()}.")
        if len(improvement):
            parts.append(markdown.improvement_table(improvement, names))
        else:
            parts.append(
                f"Nothing to compare: no second learner to set against {names.label(focus)}"
                " or the control."
            )
        name = f"profile_{n}demos"
        plot.save(
            plot.draw_performance_profile(
                counted.profile, names, f"Performance profile, {title.lower()}"
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
        _curves_section(curves, competing, n, title, out_dir, names),
        _seeds_section(raw_curves, competing, n, title, out_dir, names),
        _reach_section(reach, competing, n, names),
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
    names: Names,
    focus: str = TARGET,
) -> tuple[str, pd.DataFrame]:
    """Markdown with each learner's IQM and the probabilities of improvement env by env at `n`
    demos, beside their pooled values; and its rows (PER_ENV_COLUMNS).

    Each env keeps every seed it has, where pooling keeps only the seeds every env has, so a
    domain still running is read from all of its finished seeds.
    """
    by_env = comparisons.per_env_statistics(df, n, reps, focus)
    if by_env.empty:
        return "", pd.DataFrame(columns=PER_ENV_COLUMNS)
    envs = list(dict.fromkeys(by_env["env_id"]))
    pooled = comparisons.pooled_rows(n, pooled_aggregate, pooled_improvement)
    frame = pd.concat([by_env, pooled], ignore_index=True) if len(pooled) else by_env

    columns = [*envs, POOLED] if len(envs) > 1 else envs
    iqm = frame[frame["statistic"] == "iqm"]
    improved = frame[frame["statistic"] == "p_improvement"]
    lines = [
        f"## Per env, {markdown.demos_title(n).lower()}",
        "Each env's IQM over its seeds and the probabilities of improvement on that env alone"
        " (every seed an env has; the pooled column keeps the seeds every env has, as above).",
        markdown.env_table(
            iqm,
            "IQM [95% CI] (seeds)",
            {names.label(a): (a, "") for a in names.in_order(iqm["algorithm"])},
            columns,
        ),
    ]
    if len(improved):
        pairs = dict.fromkeys(zip(improved["algorithm"], improved["other"], strict=True))
        keys = {markdown.pair_label(a, b, names): (a, b) for a, b in pairs}
        lines.append(markdown.env_table(improved, "P(improvement) [95% CI]", keys, columns))
    fractions = frame[frame["statistic"] == "of_oracle"]
    if len(fractions):
        pairs = dict.fromkeys(zip(fractions["algorithm"], fractions["other"], strict=True))
        keys = {f"{names.label(a)} / {names.label(b)}": (a, b) for a, b in pairs}
        lines.append(markdown.env_table(fractions, "IQM / oracle's IQM [95% CI]", keys, columns))
        worst = frame[frame["statistic"] == "worst_of_oracle"]
        lines.append(markdown.env_table(worst, "Worst seed / oracle's IQM", keys, columns))
    return "\n\n".join(lines), frame


def _state_match_section(
    df: pd.DataFrame, n: int, reps: int, names: Names, focus: str = TARGET
) -> tuple[str, pd.DataFrame]:
    """Markdown on how far each learner's states lie from the expert's at `n` demos, and its
    rows; nothing where the records hold no distance (pixels, or records from before)."""
    rows = comparisons.state_match_statistics(df, n, reps, focus)
    if rows.empty:
        return "", pd.DataFrame()
    target = names.label(focus)
    header = ["algorithm", "runs", "IQM distance [95% CI]", f"P({target} closer) [95% CI]"]
    cells = [
        [
            names.label(r.algorithm),
            str(r.runs),
            markdown.interval(r.iqm, r.lo, r.hi),
            "" if pd.isna(r.p_closer) else markdown.interval(r.p_closer, r.p_lo, r.p_hi),
        ]
        for r in rows.itertuples()
    ]
    text = (
        f"## Distance to the expert's states, {markdown.demos_title(n).lower()}\n\n"
        "How far the states a policy visits in its evaluation episodes lie from the expert's "
        "(bench.harness.state_match: per-dimension 1-Wasserstein distance in units of the expert's "
        "spread, averaged over dimensions; 0 = distributed alike, lower is closer). It sees "
        "imitation where the return cannot: a control that merely survives can score like the "
        f"expert while standing elsewhere. P({target} closer) is the probability that a "
        f"{target} run is closer to the expert than a run of the other.\n\n"
        + markdown.table(pd.DataFrame(cells, columns=header))
    )
    return text, rows


def _curves_section(
    curves: pd.DataFrame | str,
    competing: list[str],
    n: int,
    title: str,
    out_dir: Path,
    names: Names,
) -> str:
    if isinstance(curves, str):
        return f"No learning curves: {curves}."
    frame = _at_count(curves, competing, n)
    if frame.empty:
        return f"No learning curves were recorded with {title.lower()}."
    text = ""
    missing = [a for a in competing if a not in set(frame["algorithm"])]
    if missing:
        text = (
            "No learning curve recorded for " + ", ".join(names.label(a) for a in missing) + ".\n\n"
        )
    name = f"curves_{n}demos"
    figure = plot.draw_iqm_curves(frame, f"Learning curves, {title.lower()}", names)
    plot.save(figure, out_dir / name)
    return (
        text + "Normalized return at each evaluation during training: IQM over seeds, "
        "band: 95% CI.\n\n" + f"![Learning curves, {title.lower()}]({name}.png)"
    )


def _seeds_section(
    curves: pd.DataFrame, competing: list[str], n: int, title: str, out_dir: Path, names: Names
) -> str:
    frame = _at_count(curves, competing, n)
    if frame.empty:
        return ""
    name = f"seeds_{n}demos"
    plot.save(plot.draw_seed_curves(frame, f"Each seed, {title.lower()}", names), out_dir / name)
    return f"Each seed's own curve:\n\n![Each seed, {title.lower()}]({name}.png)"


def _reach_section(reach: pd.DataFrame, competing: list[str], n: int, names: Names) -> str:
    rows = _at_count(reach, competing, n)
    if rows.empty:
        return ""
    return (
        f"Env steps to {REACH:g} normalized: the first evaluation at or above it, median and"
        " worst over seeds (never: at none of the evaluations along its curve).\n\n"
        + markdown.reach_table(rows, names)
    )


# ---------------------------------------------------------------- helpers


def _at_count(frame: pd.DataFrame, competing: list[str], n: int) -> pd.DataFrame:
    """`frame`'s rows of the `competing` learners at `n` demonstrations, demo-free ones included."""
    return frame[frame["algorithm"].isin(competing) & ((frame["n_demos"] == n) | demo_free(frame))]


def _concat(frames: list[pd.DataFrame], columns: list[str]) -> pd.DataFrame:
    frames = [f for f in frames if len(f)]
    return (
        pd.concat(frames, ignore_index=True)[columns] if frames else pd.DataFrame(columns=columns)
    )
