"""How often `bench compare` says "differs" between two samples of one distribution.

    python benchmarks/verdict_error.py [results/pybullet results/mujoco] [--splits 126]

Every cell (env, algorithm, demo count) of the committed folders with 10 seeds is split into
two halves of 5 seeds, every way there is (126 distinct splits) or `--splits` of them: both
halves are draws of the same distribution (same code, same settings, seeds apart), as a
newcomer's `make run` and the committed reference are. Each split is judged as `bench
compare` judges a row, by the bootstrap CI of the IQM difference excluding 0 (the old rule)
and by the permutation test at p < `agreement.ALPHA` (`agreement.permutation_p`, the rule
now: 0.01). Prints the share of splits called "differs" over all cells, per folder, and the
worst cells: a rule that holds its level is at or under it in every cell.
"""

from __future__ import annotations

import argparse
import itertools

import numpy as np

from bench.analysis import agreement
from bench.analysis.normalize import normalize
from bench.harness import frames


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="*", default=["results/pybullet", "results/mujoco"])
    parser.add_argument("--splits", type=int, default=126)
    parser.add_argument("--reps", type=int, default=2000, help="bootstrap resamples (old rule)")
    args = parser.parse_args()
    halves = [c for c in itertools.combinations(range(10), 5) if 0 in c][: args.splits]
    print(f"{len(halves)} splits of 10 seeds into 5 against 5 per cell")
    print(f"{'folder':20s}{'cells':>6s}{'old: differs':>14s}{'now: differs':>14s}  worst cell now")
    for folder in args.folders:
        frame = normalize(frames.load(folder))
        old, new, worst = [], [], (0.0, "")
        for key, cell in frame.groupby(["env_id", "algorithm", "n_demos"]):
            scores = cell.sort_values("seed")["normalized"].dropna().to_numpy()
            if len(scores) != 10 or np.ptp(scores) == 0:
                continue  # identical scores: no split can differ (a reference, a solved task)
            old_calls, new_calls = [], []
            for i, half in enumerate(halves):
                a, b = scores[list(half)], np.delete(scores, list(half))
                d = agreement.iqm_difference(a, b, args.reps, i)
                old_calls.append(d["diff_lo"] > 0 or d["diff_hi"] < 0)
                new_calls.append(agreement.permutation_p(a, b, i) < agreement.ALPHA)
            old.append(np.mean(old_calls))
            new.append(np.mean(new_calls))
            worst = max(worst, (new[-1], f"{key[0]} {key[1]} {key[2]} demos"))
        print(
            f"{folder:20s}{len(old):6d}{np.mean(old):14.3f}{np.mean(new):14.3f}"
            f"  {worst[1]} ({worst[0]:.3f}); old rule's worst cell {max(old):.3f}"
        )


if __name__ == "__main__":
    main()
