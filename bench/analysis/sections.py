"""The report's sections over a whole suite, as markdown: its header, how to read it, the
numbers at a glance, Figure 2 with its table, each env across demonstration counts, the
reference returns and the cost per trial. Pure text over the tidy frame and the statistics'
frames (`bench.analysis.findings`); the sections at one demonstration count are
`bench.analysis.count_sections`'.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import pandas as pd

from bench.analysis import labels
from bench.analysis.comparisons import POOLED, TARGET
from bench.analysis.labels import Names
from bench.analysis.markdown import duration, pair_label, range_text, table
from bench.analysis.normalize import EXPERT, RANDOM
from bench.analysis.tables import by_count, summary_table

MAX_LISTED = 20
"""Failed trials named one by one in the header; the rest are counted."""


def _code(text: str) -> str:
    """`text` fit for inline code: a backquote in it would end the span."""
    return text.replace("`", "'")


def seen(df: pd.DataFrame, env_id: str) -> str:
    """ ", from pixels" where the env's learners observed frames (`observation: pixels`)."""
    seen = df.loc[df["env_id"] == env_id, "observation"]
    return ", from pixels" if (seen == "pixels").any() else ""


def header(df: pd.DataFrame, results_dir: Path) -> str:
    """The title and a key-value table of what the records hold (suite, envs, learners,
    references, counts, seeds, trials, steps, time, software); then the failed trials."""
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
            + (f": `{_code(r.failure)}`" if isinstance(r.failure, str) else "")
            for r in failed.head(MAX_LISTED).itertuples()
        ]
        if len(failed) > MAX_LISTED:
            lines.append(f"- and {len(failed) - MAX_LISTED} more (status in the records)")
    return "\n".join(lines)


def _bold_names(shown: Sequence[str], names: Names) -> str:
    return ", ".join(f"**{names.label(n)}**" for n in shown)


def _is_a(shown: Sequence[str], noun: str) -> str:
    """ "is a lower", "is an upper", "are each an upper": `noun` after its verb and article."""
    article = "an" if noun[0] in "aeiou" else "a"
    return f"{'is' if len(shown) == 1 else 'are each'} {article} {noun}"


def how_to_read(learners: Sequence[str], reps: int, names: Names, focus: str = TARGET) -> str:
    """What each statistic means, and what the controls among `learners` are for."""
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
            f"{_bold_names(floors, names)} {_is_a(floors, 'lower')} control (the floor): no "
            "demonstrations, trained on a reward that says nothing of the task but to stay in "
            "it (the built-in Survival: +1 per step alive), so the same runs appear at every "
            "demonstration count. A learner that does not beat it has not shown that it "
            "learned from the demonstrations."
        )
    if ceilings := names.with_role(learners, "ceiling"):
        items.append(
            f"{_bold_names(ceilings, names)} {_is_a(ceilings, 'upper')} control (the ceiling): "
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


def figure2(df: pd.DataFrame, learners: Sequence[str]) -> str:
    """Figure 2 (figure2.png, beside the report) and the table of its means and standard
    deviations; a line saying there is none where no learner ran."""
    if not learners:
        return "No learning algorithm was run: only the random and expert references."
    return (
        "## Normalized return per env\n\n"
        "![Normalized return per env against number of demonstrations](figure2.png)\n\n"
        "Mean ± standard deviation over seeds, as in the figure.\n\n"
        # A line that starts with "* " would be a list item in markdown.
        + summary_table(df).replace(labels.ACTIONS_FOOTNOTE, "\\" + labels.ACTIONS_FOOTNOTE)
    )


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


def references(df: pd.DataFrame) -> str:
    """The random and expert returns per env that define 0 and 1: mean ± std over seeds."""
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
    # CPU seconds, where records measured them: what a trial cost whatever shared its core
    cpu = "cpu_time" in ok and ok["cpu_time"].notna().any()
    if cpu:
        lines[-1:-1] = [
            "",
            "CPU time is what the trial's own process took: below its wall time by what shared",
            "its core (a dash where its records are older than the measure).",
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
                    *([_cpu_per_trial(cell["cpu_time"])] if cpu else []),
                ]
            )
    header = [
        "env",
        "algorithm",
        "budget (env steps)",
        "trials",
        "wall time per trial",
        "core-hours",
        *(["CPU time per trial"] if cpu else []),
    ]
    lines.append(table(pd.DataFrame(rows, columns=header), right=header[2:]))
    return "\n".join(lines)


def _cpu_per_trial(seconds: pd.Series) -> str:
    """Mean CPU time of the trials that measured it, or a dash where none did."""
    measured = seconds.dropna()
    return duration(measured.mean()) if len(measured) else "-"
