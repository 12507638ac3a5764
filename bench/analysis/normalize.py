"""Normalized return: 0 is the random policy, 1 is the expert, per env.

    normalized = (R - R_random) / (R_expert - R_random)

R_random and R_expert are the mean returns of the ok trials whose role is `random` and
`expert` on that env, taken from the same frame, so a suite's numbers depend only on its own
records.
"""

from __future__ import annotations

import pandas as pd

from bench.errors import BadInput

RANDOM, EXPERT = "random", "expert"
"""The roles of the references that define 0 and 1 (`bench.harness.registry.Role`): the records' `role`
says which trials they are, whatever their algorithms are called."""


def demo_free(df: pd.DataFrame) -> pd.Series:
    """Per row of `df`: does its algorithm take no demonstrations (it has only n_demos=0 rows,
    e.g. random, expert or the survival control)? Such rows belong at every demo count."""
    return df.groupby("algorithm")["n_demos"].transform("max") == 0


class NormalizationError(BadInput, ValueError):
    """An env without a usable random or expert reference; the message is one line."""


def reference_returns(df: pd.DataFrame) -> pd.DataFrame:
    """One row per env of `df`: env_id, random, expert (mean returns; NaN where missing)."""
    ok = df["status"] == "ok" if "status" in df else pd.Series(True, index=df.index)
    refs = df[ok & df["role"].isin([RANDOM, EXPERT])]
    means = refs.groupby(["env_id", "role"])["return"].mean().unstack("role")
    envs = pd.Index(df["env_id"].unique(), name="env_id")
    return (
        means.reindex(index=envs, columns=[RANDOM, EXPERT]).rename_axis(columns=None).reset_index()
    )


def check_one_record_per_seed(df: pd.DataFrame) -> None:
    """Raise NormalizationError if a seed of an (env, algorithm, demos) cell has two records.

    That happens when a suite's settings (a budget, a hyperparameter) changed and it was rerun
    into the same folder: averaging the old trials with the new ones would be wrong.
    """
    keys = ["env_id", "algorithm", "n_demos", "seed"]
    counts = df.groupby(keys).size()
    repeated = counts[counts > 1]
    if len(repeated):
        (env_id, algorithm, n_demos, seed), n = next(iter(repeated.items()))
        cell = df.set_index(keys).index == (env_id, algorithm, n_demos, seed)
        files = (
            ", ".join(f"trials/{t}.json" for t in df.loc[cell, "trial_id"])
            if "trial_id" in df
            else ""
        )
        raise NormalizationError(
            f"{env_id}: {algorithm} with {n_demos} demos, seed {seed}, has "
            f"{n} records of different settings in one results folder "
            f"({len(repeated)} such cells){f': {files}' if files else ''}; move the stale"
            " records out of it"
        )


def check_one_suite(df: pd.DataFrame) -> None:
    """Raise NormalizationError unless the records are one suite's: one suite name, and one
    budget per env. A record of another suite (a link takes the linking suite's name)
    or run at another budget would otherwise be averaged in with the rest."""
    for column, within in (("suite", None), ("budget", "env_id")):
        if column not in df:
            continue
        groups = df.groupby(within) if within else [(None, df)]
        for key, rows in groups:
            counts = rows[column].value_counts()
            if len(counts) > 1:
                odd = rows[rows[column] != counts.index[0]].iloc[0]
                where = f"{key}: " if key is not None else ""
                raise NormalizationError(
                    f"{where}records of {len(counts)} {column}s in one results folder "
                    f"({', '.join(f'{v} x{n}' for v, n in counts.items())}), e.g. trial "
                    f"{odd.get('trial_id', '?')}; a folder holds one suite's trials"
                )


def normalize(df: pd.DataFrame, references: pd.DataFrame | None = None) -> pd.DataFrame:
    """`df` plus a `normalized` column (NaN where `return` is NaN, e.g. failed trials).

    `references` (from `reference_returns`) defaults to those of `df` itself;
    pass the trials' references to normalize a frame of learning curves.
    Raises NormalizationError if an env of `df` lacks a reference, or if its
    expert does no better than random (the scale would be meaningless).
    """
    if references is None:  # trials, not curves: one suite's, one record per cell and seed
        check_one_suite(df)
        check_one_record_per_seed(df)
    refs = reference_returns(df) if references is None else references
    refs = refs.set_index("env_id")
    for env_id in df["env_id"].unique():
        if env_id not in refs.index:
            raise NormalizationError(f"{env_id}: no random or expert trials to normalize against")
        random, expert = refs.loc[env_id, RANDOM], refs.loc[env_id, EXPERT]
        missing = [name for name, value in ((RANDOM, random), (EXPERT, expert)) if pd.isna(value)]
        if missing:
            raise NormalizationError(
                f"{env_id}: no ok trial of {' or '.join(missing)} to normalize against"
                f" (add {' and '.join(missing)} to the suite's algorithms)"
            )
        if expert <= random:
            raise NormalizationError(
                f"{env_id}: expert return {expert:.4g} is not above random {random:.4g}"
            )
    random = df["env_id"].map(refs[RANDOM])
    expert = df["env_id"].map(refs[EXPERT])
    return df.assign(normalized=(df["return"] - random) / (expert - random))


def normalized_alike(run: pd.DataFrame, ref: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Two suites' trials (`bench compare RUN REF`) on their shared envs, both normalized with
    the reference's random and expert returns (the run's where the reference lacks them), so
    both sides share one scale."""
    envs = sorted(set(run["env_id"]) & set(ref["env_id"]))
    if not envs:
        raise NormalizationError("the two folders share no env")
    run, ref = run[run["env_id"].isin(envs)], ref[ref["env_id"].isin(envs)]
    for frame in (run, ref):
        check_one_record_per_seed(frame)
    refs = reference_returns(ref).set_index("env_id")
    refs = refs.combine_first(reference_returns(run).set_index("env_id")).reset_index()
    return normalize(run, refs), normalize(ref, refs)
