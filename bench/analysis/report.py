"""`bench report`: aggregate statistics and a markdown report, from the records alone.

Per demonstration count, the learners' normalized scores are pooled across envs
and summarized with rliable (mean, median and IQM with 95% stratified-bootstrap
CIs; probability of improvement of GAIfO over each other learner, and of each
learner over the survival control; performance profiles), then the same env by
env, and their learning curves are drawn as IQM over seeds with a 95% CI band, with
the env steps each took to reach 0.8 normalized (median and worst over seeds). Random and
expert are the references (0 and 1), not competitors; learners that take no demonstrations
(e.g. survival) compete at every count as controls.

Written beside `report.md`: figure2, profile_<n>demos, curves_<n>demos and seeds_<n>demos (each
seed's own curve) as .png and .pdf, and the numbers of the tables as aggregates.csv,
improvement.csv, per_env.csv and state_match.csv (distance of the learners' states from the
expert's, `bench.harness.state_match`).

A report is read (`store`), found (`findings.find`: every statistic, computed once), drawn
(`figures`), worded (`text`: `sections` and `count_sections`) and written (`write_report`),
each step apart. Nothing here trains or evaluates.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import NamedTuple

import pandas as pd
from matplotlib.figure import Figure
from tqdm import tqdm

from bench.analysis import count_sections, findings, plot, sections
from bench.analysis.comparisons import TARGET
from bench.analysis.count_sections import CURVES, PROFILE, SEEDS, figure_name
from bench.analysis.findings import Findings
from bench.analysis.labels import Names
from bench.analysis.markdown import demos_title
from bench.analysis.normalize import normalize
from bench.harness import frames, store

REPORT = "report.md"
AGGREGATES_CSV = "aggregates.csv"
IMPROVEMENT_CSV = "improvement.csv"
STATE_MATCH_CSV = "state_match.csv"
PER_ENV_CSV = "per_env.csv"


class WrittenReport(NamedTuple):
    """A report on disk, and the aggregate tables it holds (so callers need not read them back)."""

    path: Path
    """report.md"""
    aggregates: pd.DataFrame
    """findings.AGGREGATE_COLUMNS, as in aggregates.csv"""
    improvements: pd.DataFrame
    """findings.IMPROVEMENT_COLUMNS, as in improvement.csv"""
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
    # what it is doing, on a terminal's line (a large folder's report takes a minute)
    doing = f"report {results_dir}: "
    with tqdm(
        desc=doing + "reading the records", bar_format=STAGE, disable=None, leave=False
    ) as bar:
        at = lambda stage: bar.set_description_str(doing + stage)  # noqa: E731
        trials, curves = frames.load_with_curves(results_dir)
        if trials.empty:
            raise FileNotFoundError(f"{store.trials_dir(results_dir)}: no readable trial record")
        at("statistics")
        found = findings.find(normalize(trials), curves, reps, focus)
        out_dir.mkdir(parents=True, exist_ok=True)
        for name, figure in figures(found):
            at(f"figure {name}")
            plot.save(figure, out_dir / name)
        at("tables")
        for name, frame in csvs(found).items():
            frame.to_csv(out_dir / name, index=False)
        path = out_dir / REPORT
        path.write_text(text(found, results_dir, reps, focus))
    return WrittenReport(path, found.aggregates, found.improvements, found.names)


STAGE = "{desc} [{elapsed}]"
"""The report's progress line: what it is at, and for how long it has run."""


def figures(found: Findings) -> Iterator[tuple[str, Figure]]:
    """Every figure of the report, drawn one at a time, with the name it is saved under
    (no suffix): Figure 2 where a learner ran, then each count's performance profile (where
    it has scores), IQM learning curves and each seed's curves (where it has curves)."""
    names = found.names
    if found.learners:
        yield "figure2", plot.draw_figure2(found.df)
    for at in found.counts:
        shown = demos_title(at.n).lower()
        if at.statistics.scores:
            title = f"Performance profile, {shown}"
            profile = plot.draw_performance_profile(at.statistics.profile, names, title)
            yield figure_name(PROFILE, at.n), profile
        if isinstance(at.curves, pd.DataFrame) and not at.curves.empty:
            curves = plot.draw_iqm_curves(at.curves, f"Learning curves, {shown}", names)
            yield figure_name(CURVES, at.n), curves
        if not at.seeds.empty:
            seeds = plot.draw_seed_curves(at.seeds, f"Each seed, {shown}", names)
            yield figure_name(SEEDS, at.n), seeds


def csvs(found: Findings) -> dict[str, pd.DataFrame]:
    """The report's tables as the CSV files beside it hold them, by file name."""
    return {
        AGGREGATES_CSV: found.aggregates,
        IMPROVEMENT_CSV: found.improvements,
        PER_ENV_CSV: found.per_env,
        STATE_MATCH_CSV: found.state_match,
    }


def text(found: Findings, results_dir: Path, reps: int, focus: str = TARGET) -> str:
    """report.md: the suite's sections, then each count's, each count's per env and each
    count's distance to the expert, then the references and costs."""
    df, names, counts = found.df, found.names, found.counts
    parts = [
        sections.header(df, results_dir),
        sections.how_to_read(found.learners, reps, names, focus),
        sections.at_a_glance(found.aggregates, found.improvements, names),
        sections.figure2(df, found.learners),
        sections.env_by_count(found.per_env, names, focus),
        *(count_sections.count_section(at, names, focus) for at in counts),
        *(count_sections.per_env_section(at, names) for at in counts),
        *(count_sections.state_match_section(at, names, focus) for at in counts),
        sections.references(df),
        sections.costs(df),
    ]
    return "\n\n".join(s.strip() for s in parts if s) + "\n"
