"""How often `bench compare` says "differs" on a newcomer's run that is a fresh draw.

    bench run suites/quick-draws.yaml
    python benchmarks/fresh_draws.py [results/quick results/quick-draws]
                                     [--size 5] [--resamples 2000] [--alpha 0.01]

`make run` compares a newcomer's 5 seeds with the committed reference pooled from the folders
(the quick suite's 5 seeds and 50 more of it: one CPU, one distribution, 55 seeds a cell). Its
seeds, in order, are cut into disjoint draws of `--size` (0-4, 5-9, ...): each is judged, row
by row, against the pool without it, as `bench compare` judges a row (the exact rank test at
`--alpha`), so each draw is a fresh one against a reference of the other 50 seeds: a
newcomer's `make run`, same code and settings, seeds the reference has not seen. The table
shows every verdict and the share of draws in which a row differs. Eleven draws say little
about a rate of a few percent (one "differs" is 9%), so the same is then done for
`--resamples` draws of `--size` seeds picked at random, each against the rest. The rule
promises at most 5% per row.

The test is on ranks and normalizing is increasing per env, so the scores are normalized once,
with the whole pool's random and expert returns.
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

from bench.analysis import agreement, labels, normalize
from bench.harness import frames


def judged(cells: dict[tuple, pd.Series], seeds, alpha: float) -> pd.Series:
    """`bench compare`'s verdict on each cell, for the draw of these seeds against the cell's
    other seeds (where the cell has them all)."""
    out = {}
    for key, scores in cells.items():
        if set(seeds) <= set(scores.index):
            run, ref = scores.loc[sorted(seeds)], scores.drop(list(seeds))
            p = agreement.permutation_p(run.to_numpy(), ref.to_numpy())
            out[key] = agreement.verdict_of(run, ref, p, alpha)
    return pd.Series(out, dtype=object)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="*", default=["results/quick", "results/quick-draws"])
    parser.add_argument("--size", type=int, default=5, help="seeds per draw (the quick suite's)")
    parser.add_argument("--resamples", type=int, default=2000)
    parser.add_argument("--alpha", type=float, default=agreement.ALPHA)
    args = parser.parse_args()
    trials = agreement.pooled([(f, frames.load(f)) for f in args.folders])
    cells = agreement.by_seed(normalize.normalize(trials))
    seeds = sorted(trials["seed"].unique())
    cuts = [seeds[i : i + args.size] for i in range(0, len(seeds) - args.size + 1, args.size)]
    table = pd.DataFrame({f"{c[0]}-{c[-1]}": judged(cells, c, args.alpha) for c in cuts})
    rng = np.random.default_rng(0)
    picks = [rng.choice(seeds, args.size, replace=False) for _ in range(args.resamples)]
    resampled = pd.DataFrame([judged(cells, p, args.alpha) for p in picks])
    names = labels.Names.of(trials)
    short = {"agrees": ".", "identical": "=", "differs": "D"}
    print(f"{table.shape[1]} disjoint draws of {args.size} seeds, each against the other")
    print(f"{len(seeds) - args.size} seeds of {' + '.join(args.folders)} at p < {args.alpha:g}")
    print(f"(. agrees, D differs); then {args.resamples} draws at random\n")
    cols = " ".join(c.rjust(5) for c in table.columns)
    print(f"{'env':36s}{'algorithm':10s}  {cols}  differs  of {args.resamples}")
    for key, row in table.iterrows():
        marks = " ".join(short.get(v, "?").rjust(5) if isinstance(v, str) else "?" for v in row)
        share = (row.dropna() == "differs").mean()
        again = (resampled[key].dropna() == "differs").mean()
        print(f"{key[0]:36s}{names.label(key[1]):10s}  {marks}  {share:6.0%}  {again:7.1%}")
    for what, frame in (("disjoint draws", table), ("random draws", resampled)):
        verdicts = [v for v in frame.to_numpy().ravel() if isinstance(v, str)]
        share = np.mean([v == "differs" for v in verdicts])
        print(f"all rows, {what}: {share:.1%} of {len(verdicts)} verdicts say differs")


if __name__ == "__main__":
    main()
