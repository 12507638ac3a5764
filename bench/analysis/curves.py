"""Learning-curve statistics from normalized curves (`findings.normalized_curves`: env_id,
algorithm, n_demos, seed, env_steps, normalized, a row per evaluation): the IQM over seeds at
each evaluation with its 95% CI (`iqm_curves`), and the env steps each seed took to reach a
level (`steps_to`, summed up per cell by `time_to`).
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np
import pandas as pd

from bench.analysis.bootstrap import interval_estimates, iqm, over_resamples

CELL = ["env_id", "algorithm", "n_demos"]
TIME_TO_COLUMNS = [*CELL, "seeds", "median", "worst", "short"]


def steps_to(curves: pd.DataFrame, level: float) -> pd.DataFrame:
    """Per seed of every (env, algorithm, demo count) of normalized `curves`: `steps`, the env
    steps of its first evaluation at or above `level`, inf where none is. A curve is evaluated
    every so many steps, so this is as fine as its points are apart."""
    keys = [*CELL, "seed"]
    every = curves.groupby(keys).size().index
    reached = curves[curves["normalized"] >= level].groupby(keys)["env_steps"].min()
    return reached.astype(float).reindex(every, fill_value=np.inf).rename("steps").reset_index()


def time_to(steps: pd.DataFrame) -> pd.DataFrame:
    """`steps_to`'s per-seed steps summed up per cell: TIME_TO_COLUMNS, the median and the
    worst (inf where a seed never got there) over seeds, and how many never got there."""
    grouped = steps.groupby(CELL)["steps"]
    return pd.DataFrame(
        {
            "seeds": grouped.size(),
            "median": grouped.median(),
            "worst": grouped.max(),
            "short": grouped.agg(lambda x: int(np.isinf(x).sum())),
        }
    ).reset_index()[TIME_TO_COLUMNS]


IQM_CURVE_COLUMNS = ["env_id", "algorithm", "n_demos", "env_steps", "iqm", "lo", "hi", "seeds"]


def iqm_curves(curves: pd.DataFrame, reps: int = 2000, seed: int = 0) -> pd.DataFrame:
    """IQM over seeds of the normalized return at each evaluation point, with a 95% CI.

    `curves`: normalized learning curves (env_id, algorithm, n_demos, seed,
    env_steps, normalized). Returns one row per env, algorithm, demo count and
    evaluation point: env_id, algorithm, n_demos, env_steps, iqm, lo, hi, seeds.
    Seeds evaluated at different steps are interpolated onto the steps of all
    of them, within the range they share. Every (env, algorithm, demo count,
    step) is a stratum of rliable's stratified bootstrap, so the band is pointwise.
    """
    # rliable wants one array per run count; cells with as many seeds share one, side by side.
    pooled: dict[int, list[tuple[tuple, pd.DataFrame]]] = defaultdict(list)
    for key, rows in curves.dropna(subset=["normalized"]).groupby(
        ["env_id", "algorithm", "n_demos"]
    ):
        if rows.duplicated(["seed", "env_steps"]).any():
            raise ValueError(
                f"{key[1]} on {key[0]} with {key[2]} demos has several curves per seed;"
                " filter to one suite first"
            )
        table = _on_common_steps(rows.pivot(index="seed", columns="env_steps", values="normalized"))
        if table.size:
            pooled[len(table)].append((key, table))
    out = []
    for n_seeds, cells in sorted(pooled.items()):
        matrix = np.concatenate([t.to_numpy(dtype=float) for _, t in cells], axis=1)
        points, intervals = interval_estimates({"cells": matrix}, _iqm_per_column, reps, seed)
        i = 0
        for (env_id, algo, n), table in cells:
            for step in table.columns:
                lo, hi = intervals["cells"][:, i]
                out.append((env_id, algo, n, step, points["cells"][i], lo, hi, n_seeds))
                i += 1
    return pd.DataFrame(out, columns=IQM_CURVE_COLUMNS)


@over_resamples(lambda stack: iqm(stack, axis=1))
def _iqm_per_column(scores: np.ndarray) -> np.ndarray:
    """IQM of each column of a (runs x cells) array: one bootstrap of every cell at once."""
    return iqm(scores, axis=0)


def _on_common_steps(table: pd.DataFrame) -> pd.DataFrame:
    """A (seeds x env_steps) table without gaps: interpolated inside, cut to the shared range."""
    if table.isna().any(axis=None):
        table = table.T.interpolate(method="index", limit_area="inside").T
    return table.dropna(axis=1)
