"""Two optimizers side by side: IQM of normalized return [95% CI] and cost per trial, per env.

    python benchmarks/optimizers.py results/offpolicy:gaifo-sac results/pybullet:gaifo --demos 5

Each FOLDER:ALGORITHM is normalized with its own folder's random and expert records and read
at one demo count. Cost is the mean wall time of a trial as recorded (one trial per core, but
not necessarily on a quiet machine: the records say where they ran, not how loaded it was).
"""

from __future__ import annotations

import argparse
import sys

import pandas as pd

from bench.analysis import labels, markdown, normalize, stats
from bench.harness import frames


def scores(folder: str, algorithm: str, n_demos: int) -> pd.DataFrame:
    """One row per ok trial of `algorithm` at `n_demos` in `folder` (at 0 for a control, which
    takes none): env_id, seed, budget, normalized score and wall time."""
    df = normalize.normalize(frames.load(folder))
    at_count = (df["n_demos"] == n_demos) | normalize.demo_free(df)
    mine = df[(df["algorithm"] == algorithm) & (df["status"] == "ok") & at_count]
    if mine.empty:
        print(
            f"{folder}:{algorithm}: no finished trial at {n_demos} demonstrations", file=sys.stderr
        )
        sys.exit(2)
    return mine[["env_id", "seed", "budget", "normalized", "wall_time"]]


def summary(rows: pd.DataFrame, reps: int) -> pd.DataFrame:
    """Per env: IQM [95% CI], seeds, budget and minutes per trial."""
    out = []
    for env_id, g in rows.groupby("env_id"):
        iqm = stats.aggregate_scores({"x": g["normalized"].to_numpy()[:, None]}, reps=reps)
        iqm = iqm[iqm["metric"] == "iqm"].iloc[0]
        out.append(
            {
                "env_id": env_id,
                "score": markdown.interval(iqm["estimate"], iqm["lo"], iqm["hi"]),
                "seeds": len(g),
                "budget": int(g["budget"].max()),
                "minutes": g["wall_time"].mean() / 60,
            }
        )
    return pd.DataFrame(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("sides", nargs="+", metavar="FOLDER:ALGORITHM")
    parser.add_argument("--demos", type=int, default=5)
    parser.add_argument("--reps", type=int, default=2000)
    args = parser.parse_args()
    # Every side is read (and one with no finished trial refused) before any bootstrap runs.
    picked = {}
    for side in args.sides:
        folder, _, algorithm = side.rpartition(":")
        picked[side] = scores(folder, algorithm, args.demos)
    tables = {side: summary(rows, args.reps) for side, rows in picked.items()}
    envs = labels.env_order(set().union(*(set(t["env_id"]) for t in tables.values())))
    rows = [
        [
            labels.env_label(env_id),
            side,
            f"{r.score} ({r.seeds})",
            f"{r.budget:,}",
            f"{r.minutes:.1f}",
        ]
        for env_id in envs
        for side, t in tables.items()
        for r in t[t["env_id"] == env_id].itertuples()
    ]
    header = ["env", "folder:algorithm", "IQM [95% CI] (seeds)", "env steps", "min per trial"]
    print(markdown.table(pd.DataFrame(rows, columns=header), right=header[3:]))
    print(
        f"\n{args.demos} demonstrations (controls: none); each side normalized with its own"
        " folder's references."
    )


if __name__ == "__main__":
    main()
