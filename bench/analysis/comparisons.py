"""Who a report sets against whom, and the statistics of it: pure functions over the tidy
normalized frame (`frames.load` -> `normalize`), each returning a frame. Nothing here writes
or renders; `bench.analysis.report` draws and words what these compute.

- per demonstration count, pooled over envs: mean, median and IQM with CIs, probabilities of
  improvement, a performance profile (`count_statistics`);
- per env at one count: each learner's IQM, its probabilities of improvement, and its IQM as
  a fraction of its optimizer's oracle (`per_env_statistics`);
- per count: how far the learners' states lie from the expert's (`state_match_statistics`).
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from bench.analysis import bootstrap, labels, stats
from bench.analysis.labels import Names, is_reference
from bench.analysis.normalize import EXPERT, RANDOM, demo_free

TARGET = "gaifo"
"""The learner whose probability of improvement over the others a report gives by default: the
benchmark's reference learner, a question the report asks rather than a role. A report on
one's own method names it instead (`bench report --focus NAME`)."""
POOLED = "pooled"
"""env_id of per_env.csv's rows over every env (aggregates.csv's and improvement.csv's numbers)."""
TAUS = 81
"""Score thresholds in a performance profile."""
PER_ENV_COLUMNS = [
    "n_demos",
    "env_id",
    "statistic",
    "algorithm",
    "other",
    "seeds",
    "estimate",
    "lo",
    "hi",
]
STATE_MATCH_COLUMNS = [
    "n_demos",
    "algorithm",
    "runs",
    "iqm",
    "lo",
    "hi",
    "p_closer",
    "p_lo",
    "p_hi",
]


def demo_counts(df: pd.DataFrame) -> list[int]:
    """The demonstration counts the learners ran with; [0] when every learner is demonstration-free."""
    learners = df[~is_reference(df)]
    counts = sorted(int(n) for n in learners["n_demos"].unique() if n > 0)
    return counts or ([0] if len(learners) else [])


def competitors(df: pd.DataFrame, n_demos: int) -> list[str]:
    """Learners with trials at `n_demos`, plus the demonstration-free ones (controls), in plot order."""
    learners = df[~is_reference(df)]
    here = learners["n_demos"] == n_demos
    return labels.algorithm_order(set(learners.loc[here | demo_free(learners), "algorithm"]))


def improvement_pairs(
    names: Collection[str], shown: Names, focus: str = TARGET
) -> list[tuple[str, str]]:
    """The (a, b) whose P(a > b) a report gives: `focus` against every other learner and floor,
    then every other learner against the floor of its own family (did it learn from the
    demonstrations at all?). The ceilings are read as fractions (`oracle_fractions`), not
    rivals."""
    ordered = shown.in_order(n for n in names if shown[n].role != "ceiling")
    pairs = [(focus, other) for other in ordered if other != focus] if focus in names else []
    return pairs + [(a, floor) for a, floor in floor_pairs(names, shown) if a != focus]


def floor_pairs(names: Collection[str], shown: Names) -> list[tuple[str, str]]:
    """(learner, the floor of its own family) for each learner among `names` whose floor is
    among them too, in plot order."""
    pairs = []
    for a in shown.with_role(shown.in_order(names), "learner"):
        floor = control_of(a, "floor", names, shown)
        if floor is not None:
            pairs.append((a, floor))
    return pairs


def control_of(name: str, role: str, names: Collection[str], shown: Names) -> str | None:
    """The control of `role` ("floor" or "ceiling") among `names` that `name` is read against:
    one of its own optimizer family, the one whose label shares its variant suffix
    (gaifo-b1024 -> oracle-b1024) if any, else the family's plain one, else None."""
    me = shown[name]
    if me.family is None:
        return None
    mine = [n for n in names if shown[n].role == role and shown[n].family == me.family]
    suffix = name.removeprefix(me.method)
    for n in mine:
        if suffix and n == f"{shown[n].method}{suffix}":
            return n
    plain = [n for n in mine if n == shown[n].method]
    return plain[0] if plain else None


def between(df: pd.DataFrame, a: str, b: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Two algorithms of one normalized frame, as `agreement.compare` takes two folders' trials:
    `a`'s cells against `b`'s, env by env and count by count (b's rows then named as a's). A
    demonstration-free side (a control) stands beside every count of the other."""
    mine, theirs = df[df["algorithm"] == a], df[df["algorithm"] == b]

    def at_counts(frame: pd.DataFrame, other: pd.DataFrame) -> pd.DataFrame:
        counts = sorted(set(other["n_demos"]) - {0})
        if frame.empty or set(frame["n_demos"]) != {0} or not counts:
            return frame
        return pd.concat([frame.assign(n_demos=n) for n in counts], ignore_index=True)

    mine, theirs = at_counts(mine, theirs), at_counts(theirs, mine)
    return mine.assign(setting=""), theirs.assign(algorithm=a, setting="")


def oracle_fractions(scores: dict[str, np.ndarray], shown: Names, reps: int = 2000) -> pd.DataFrame:
    """Each learner's IQM as a fraction of its ceiling's (`control_of`), with a 95% bootstrap
    CI, and its worst seed as a fraction of the same IQM (a low bar's mean can hide one seed
    that never took off): algorithm, other (the ceiling), estimate, lo, hi, worst. Empty where
    no ceiling of its family ran."""
    rows = []
    for i, name in enumerate(scores):
        ceiling = control_of(name, "ceiling", scores, shown)
        if shown[name].role == "ceiling" or ceiling is None:
            continue
        ratio = stats.iqm_ratio(scores[name], scores[ceiling], reps=reps, seed=i)
        worst = float(np.min(scores[name]) / bootstrap.iqm(np.ravel(scores[ceiling])))
        rows.append({"algorithm": name, "other": ceiling, **ratio, "worst": worst})
    return pd.DataFrame(rows, columns=["algorithm", "other", "estimate", "lo", "hi", "worst"])


@dataclass
class CountStatistics:
    """The pooled statistics at one demonstration count."""

    scores: dict[str, np.ndarray]
    """{learner: (seeds x envs) normalized scores} (stats.score_dict); empty if none."""
    aggregate: pd.DataFrame = field(default_factory=pd.DataFrame)
    """algorithm, metric, estimate, lo, hi, seeds, envs"""
    improvement: pd.DataFrame = field(default_factory=pd.DataFrame)
    """algorithm, other, estimate, lo, hi"""
    profile: pd.DataFrame | None = None
    """stats.performance_profile's frame"""
    left_out: list[str] = field(default_factory=list)
    """What score_dict dropped (envs or seeds some learner lacks), in words."""
    failure: str | None = None
    """Why there are no statistics at all, in words (None: there are)."""


def env_list(env_ids: Collection[str]) -> str:
    """Envs by their short names, in the figure's order: "Walker2D, Ant"."""
    return ", ".join(labels.env_label(e) for e in labels.env_order(env_ids))


def pooled(df: pd.DataFrame, n: int, names: list[str], left_out: list[str]) -> list[str]:
    """The learners whose scores pool over envs at `n` demonstrations: all of them where some
    env has every learner (score_dict then keeps the envs they share), else those run on the
    env set most learners share among the widest (a screen's variants on one env each), the
    others said in `left_out`."""
    rows = df[(df["n_demos"] == n) | (df["n_demos"] == 0)]
    envs_of = {a: frozenset(rows.loc[rows["algorithm"] == a, "env_id"]) for a in names}
    if not names or frozenset.intersection(*envs_of.values()):
        return names
    widest = max(len(e) for e in envs_of.values())
    candidates = {e for e in envs_of.values() if len(e) == widest}
    chosen = max(
        sorted(candidates, key=sorted), key=lambda e: sum(o >= e for o in envs_of.values())
    )
    keep = [a for a in names if envs_of[a] >= chosen]
    for a in names:
        if a not in keep:
            left_out.append(
                f"{a}: left out of the pooled statistics: run on {env_list(envs_of[a])} only,"
                f" not on all of {env_list(chosen)}"
            )
    return keep


def count_statistics(df: pd.DataFrame, n: int, reps: int, focus: str = TARGET) -> CountStatistics:
    """Every learner's pooled aggregates, the probabilities of improvement
    (`improvement_pairs`) and the performance profile at `n` demonstrations."""
    left_out: list[str] = []
    try:
        names = pooled(df, n, competitors(df, n), left_out)
        scores = stats.score_dict(df, n, algorithms=names, left_out=left_out)
    except ValueError as e:
        return CountStatistics({}, left_out=left_out, failure=str(e))
    if not scores:  # every learner's trials failed, or none has a seed on every env
        why = "no learner has a finished trial on every env (see the trials left out)"
        return CountStatistics({}, left_out=left_out, failure=why)
    aggregate = stats.aggregate_scores(scores, reps=reps)
    aggregate = aggregate.assign(
        seeds=[scores[a].shape[0] for a in aggregate["algorithm"]],
        envs=[scores[a].shape[1] for a in aggregate["algorithm"]],
    )
    pairs = improvement_pairs(scores, Names.of(df), focus)
    improvement = stats.improvement_of_pairs(scores, pairs, reps=reps) if pairs else pd.DataFrame()
    everything = np.concatenate([s.ravel() for s in scores.values()])
    taus = np.linspace(min(0.0, everything.min()), max(1.0, everything.max()), TAUS)
    profile = stats.performance_profile(scores, taus, reps=reps)
    return CountStatistics(scores, aggregate, improvement, profile, left_out)


def per_env_statistics(df: pd.DataFrame, n: int, reps: int, focus: str = TARGET) -> pd.DataFrame:
    """Env by env at `n` demonstrations (PER_ENV_COLUMNS): each learner's IQM over every seed
    that env has, its probabilities of improvement on that env alone, and its IQM as a
    fraction of its oracle's, with its worst seed's (statistic "iqm", "p_improvement",
    "of_oracle", "worst_of_oracle": a point, lo and hi empty)."""
    rows = []
    for env_id in labels.env_order(df["env_id"].unique()):
        here = df[df["env_id"] == env_id]
        names = competitors(here, n)
        if not names:
            continue
        scores = stats.score_dict(here, n, algorithms=names, left_out=[])
        iqm = stats.aggregate_scores(scores, reps=reps)
        for r in iqm[iqm["metric"] == "iqm"].itertuples():
            seeds = len(scores[r.algorithm])
            rows.append((n, env_id, "iqm", r.algorithm, "", seeds, r.estimate, r.lo, r.hi))
        shown = Names.of(here)
        pairs = improvement_pairs(scores, shown, focus)
        for r in stats.improvement_of_pairs(scores, pairs, reps=reps).itertuples():
            seeds = min(len(scores[r.algorithm]), len(scores[r.other]))
            rows.append(
                (n, env_id, "p_improvement", r.algorithm, r.other, seeds, r.estimate, r.lo, r.hi)
            )
        for r in oracle_fractions(scores, shown, reps).itertuples():
            seeds = len(scores[r.algorithm])
            rows.append(
                (n, env_id, "of_oracle", r.algorithm, r.other, seeds, r.estimate, r.lo, r.hi)
            )
            rows.append(
                (n, env_id, "worst_of_oracle", r.algorithm, r.other, seeds, r.worst, np.nan, np.nan)
            )
    return pd.DataFrame(rows, columns=PER_ENV_COLUMNS)


def pooled_rows(n: int, aggregate: pd.DataFrame, improvement: pd.DataFrame) -> pd.DataFrame:
    """The pooled statistics at `n` demonstrations as per_env rows (env_id POOLED)."""
    rows = []
    if len(aggregate):
        for r in aggregate[aggregate["metric"] == "iqm"].itertuples():
            rows.append((n, POOLED, "iqm", r.algorithm, "", r.seeds, r.estimate, r.lo, r.hi))
    for r in improvement.itertuples():
        rows.append((n, POOLED, "p_improvement", r.algorithm, r.other, "", r.estimate, r.lo, r.hi))
    return pd.DataFrame(rows, columns=PER_ENV_COLUMNS)


def state_match_statistics(
    df: pd.DataFrame, n: int, reps: int, focus: str = TARGET
) -> pd.DataFrame:
    """How far each learner's (and the references') evaluation states lie from the expert's
    at `n` demonstrations: IQM distance with its CI, and P(`focus` closer) (STATE_MATCH_COLUMNS;
    empty where the records hold no distance: pixels, or records from before)."""
    measured = df.dropna(subset=["state_distance"])
    shown = Names.of(measured)
    names = [
        *competitors(measured, n),
        *shown.with_role(shown, EXPERT),
        *shown.with_role(shown, RANDOM),
    ]
    try:
        distances = stats.score_dict(
            measured, n, algorithms=names, column="state_distance", left_out=[]
        )
    except ValueError:
        return pd.DataFrame(columns=STATE_MATCH_COLUMNS)
    aggregate = stats.aggregate_scores(distances, reps=reps)
    iqm = aggregate[aggregate["metric"] == "iqm"].set_index("algorithm")
    closer = pd.DataFrame()
    if focus in distances and len(distances) > 1:  # closer is better: compare negated distances
        negated = {a: -d for a, d in distances.items()}
        closer = stats.probability_of_improvement(negated, focus, reps=reps).set_index("other")
    rows = []
    for a in shown.in_order(list(distances)):
        d = iqm.loc[a]
        row = {"n_demos": n, "algorithm": a, "runs": "{} × {}".format(*distances[a].shape)}
        row |= {"iqm": d["estimate"], "lo": d["lo"], "hi": d["hi"]}
        if a in closer.index:
            p = closer.loc[a]
            row |= {"p_closer": p["estimate"], "p_lo": p["lo"], "p_hi": p["hi"]}
        rows.append(row)
    return pd.DataFrame(rows, columns=STATE_MATCH_COLUMNS)
