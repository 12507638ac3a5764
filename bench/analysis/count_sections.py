"""The report's sections at one demonstration count, as markdown: the pooled statistics with
their performance profile and learning curves (`count_section`), the same env by env
(`per_env_section`), and the distance to the expert's states (`state_match_section`). Pure
text over what `bench.analysis.findings` found; the figures it links to are drawn and saved
by `bench.analysis.report` under the names `figure_name` gives.
"""

from __future__ import annotations

import pandas as pd

from bench.analysis import tables
from bench.analysis.comparisons import POOLED
from bench.analysis.findings import REACH, AtCount
from bench.analysis.labels import Names
from bench.analysis.markdown import demos_title, interval, pair_label, table

PROFILE, CURVES, SEEDS = "profile", "curves", "seeds"
"""A count's figures: its performance profile, its IQM learning curves, each seed's curve."""


def figure_name(kind: str, n: int) -> str:
    """The file name (no suffix) of a count's figure of `kind`: "profile_5demos"."""
    return f"{kind}_{n}demos"


def count_section(at: AtCount, names: Names, focus: str) -> str:
    """The pooled statistics at `at.n` demonstrations (aggregates, probabilities of
    improvement, performance profile) and the learning curves there."""
    title = demos_title(at.n)
    counted = at.statistics
    parts = [f"## {title}"]
    if counted.failure is not None:
        parts.append(f"No aggregate statistics: {counted.failure}.")
    if counted.left_out:
        parts.append(
            "Left out of the statistics:\n" + "\n".join(f"- {note}" for note in counted.left_out)
        )
    if counted.scores:
        envs = next(iter(counted.scores.values())).shape[1]  # the same for all: score_dict's
        pooled = f"Runs of the {envs} envs pooled" if envs > 1 else "Runs of the one env"
        parts += [
            "### Aggregate normalized score",
            f"{pooled}; brackets are 95% bootstrap CIs.",
            tables.aggregate_table(counted.aggregate, names),
            "### Probability of improvement",
        ]
        if focus not in counted.scores:
            parts.append(f"{names.label(focus)} has no scores with {title.lower()}.")
        if len(counted.improvement):
            parts.append(tables.improvement_table(counted.improvement, names))
        else:
            parts.append(
                f"Nothing to compare: no second learner to set against {names.label(focus)}"
                " or the control."
            )
        parts += [
            "### Performance profile",
            "Fraction of runs (seeds × envs) scoring above each normalized score τ; band: 95% CI.",
            f"![Performance profile, {title.lower()}]({figure_name(PROFILE, at.n)}.png)",
        ]
    parts += [
        "### Learning curves",
        _curves(at, title, names),
        _seeds(at, title),
        _reach(at, names),
    ]
    return "\n\n".join(p.strip() for p in parts)


def _curves(at: AtCount, title: str, names: Names) -> str:
    """The IQM learning curves' figure, or why there is none."""
    if isinstance(at.curves, str):
        return f"No learning curves: {at.curves}."
    if at.curves.empty:
        return f"No learning curves were recorded with {title.lower()}."
    text = ""
    missing = [a for a in at.competing if a not in set(at.curves["algorithm"])]
    if missing:
        text = (
            "No learning curve recorded for " + ", ".join(names.label(a) for a in missing) + ".\n\n"
        )
    return (
        text + "Normalized return at each evaluation during training: IQM over seeds, "
        "band: 95% CI.\n\n"
        + f"![Learning curves, {title.lower()}]({figure_name(CURVES, at.n)}.png)"
    )


def _seeds(at: AtCount, title: str) -> str:
    """Each seed's curve's figure, where there are curves."""
    if at.seeds.empty:
        return ""
    return (
        f"Each seed's own curve:\n\n![Each seed, {title.lower()}]({figure_name(SEEDS, at.n)}.png)"
    )


def _reach(at: AtCount, names: Names) -> str:
    """How soon each learner got to REACH, where there are curves."""
    if at.reach.empty:
        return ""
    return (
        f"Env steps to {REACH:g} normalized: the first evaluation at or above it, median and"
        " worst over seeds (never: at none of the evaluations along its curve).\n\n"
        + tables.reach_table(at.reach, names)
    )


def per_env_section(at: AtCount, names: Names) -> str:
    """Each learner's IQM and the probabilities of improvement env by env at `at.n`
    demonstrations, beside their pooled values, and the fractions of the oracle; nothing
    where no env has a learner."""
    frame = at.per_env
    if frame.empty:
        return ""
    envs = [e for e in dict.fromkeys(frame["env_id"]) if e != POOLED]
    columns = [*envs, POOLED] if len(envs) > 1 else envs
    iqm = frame[frame["statistic"] == "iqm"]
    improved = frame[frame["statistic"] == "p_improvement"]
    lines = [
        f"## Per env, {demos_title(at.n).lower()}",
        "Each env's IQM over its seeds and the probabilities of improvement on that env alone"
        " (every seed an env has; the pooled column keeps the seeds every env has, as above).",
        tables.env_table(
            iqm,
            "IQM [95% CI] (seeds)",
            {names.label(a): (a, "") for a in names.in_order(iqm["algorithm"])},
            columns,
        ),
    ]
    if len(improved):
        pairs = dict.fromkeys(zip(improved["algorithm"], improved["other"], strict=True))
        keys = {pair_label(a, b, names): (a, b) for a, b in pairs}
        lines.append(tables.env_table(improved, "P(improvement) [95% CI]", keys, columns))
    fractions = frame[frame["statistic"] == "of_oracle"]
    if len(fractions):
        pairs = dict.fromkeys(zip(fractions["algorithm"], fractions["other"], strict=True))
        keys = {f"{names.label(a)} / {names.label(b)}": (a, b) for a, b in pairs}
        lines.append(tables.env_table(fractions, "IQM / oracle's IQM [95% CI]", keys, columns))
        worst = frame[frame["statistic"] == "worst_of_oracle"]
        lines.append(tables.env_table(worst, "Worst seed / oracle's IQM", keys, columns))
    return "\n\n".join(lines)


def state_match_section(at: AtCount, names: Names, focus: str) -> str:
    """How far each learner's states lie from the expert's at `at.n` demonstrations; nothing
    where the records hold no distance (pixels, or records from before)."""
    rows = at.state_match
    if rows.empty:
        return ""
    target = names.label(focus)
    header = ["algorithm", "runs", "IQM distance [95% CI]", f"P({target} closer) [95% CI]"]
    cells = [
        [
            names.label(r.algorithm),
            str(r.runs),
            interval(r.iqm, r.lo, r.hi),
            "" if pd.isna(r.p_closer) else interval(r.p_closer, r.p_lo, r.p_hi),
        ]
        for r in rows.itertuples()
    ]
    return (
        f"## Distance to the expert's states, {demos_title(at.n).lower()}\n\n"
        "How far the states a policy visits in its evaluation episodes lie from the expert's "
        "(bench.harness.state_match: per-dimension 1-Wasserstein distance in units of the expert's "
        "spread, averaged over dimensions; 0 = distributed alike, lower is closer). It sees "
        "imitation where the return cannot: a control that merely survives can score like the "
        f"expert while standing elsewhere. P({target} closer) is the probability that a "
        f"{target} run is closer to the expert than a run of the other.\n\n"
        + table(pd.DataFrame(cells, columns=header))
    )
