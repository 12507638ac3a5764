"""How often `bench compare` says "differs" on a newcomer's run that is a fresh draw.

    bench run suites/quick-draws.yaml
    python benchmarks/fresh_draws.py [results/quick-draws] [--reference results/quick]
                                     [--size 5] [--resamples 2000]

The draws folder holds the quick suite's trials on seeds outside the reference's. Its seeds,
in order, are cut into disjoint draws of `--size` (5-9, 10-14, ...): each is one newcomer's
`make run`, same code and settings as the reference, other seeds. Each draw is judged against
the reference row by row as `bench compare` judges it (both normalized by the reference's
random and expert returns, the exact rank test, "identical" where the scores are the same),
and the table shows every verdict and the share of draws in which a row differs. Ten draws
say little about a 5% rate (one "differs" is 10%), so the same is then done for `--resamples`
draws of `--size` seeds picked at random from all of them: each one a fresh draw, though
they overlap. The rule promises at most 5% per row.
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

from bench.analysis import agreement, labels, normalize
from bench.harness import frames


def judged(draws: dict[tuple, pd.Series], ref: dict[tuple, pd.Series], seeds) -> pd.Series:
    """`bench compare`'s verdict on each cell the reference has, for the draw of these seeds
    (where the cell has them all)."""
    out = {}
    for key, scores in draws.items():
        if key in ref and set(seeds) <= set(scores.index):
            run = scores.loc[sorted(seeds)]
            p = agreement.permutation_p(run.to_numpy(), ref[key].to_numpy())
            out[key] = agreement.verdict_of(run, ref[key], p)
    return pd.Series(out, dtype=object)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("draws", nargs="?", default="results/quick-draws")
    parser.add_argument("--reference", default="results/quick")
    parser.add_argument("--size", type=int, default=5, help="seeds per draw (the reference's)")
    parser.add_argument("--resamples", type=int, default=2000)
    args = parser.parse_args()
    trials, reference = frames.load(args.draws), frames.load(args.reference)
    run_df, ref_df = normalize.normalized_alike(trials, reference)
    draws, ref = agreement.by_seed(run_df), agreement.by_seed(ref_df)
    seeds = sorted(trials["seed"].unique())
    cuts = [seeds[i : i + args.size] for i in range(0, len(seeds) - args.size + 1, args.size)]
    table = pd.DataFrame({f"{c[0]}-{c[-1]}": judged(draws, ref, c) for c in cuts})
    rng = np.random.default_rng(0)
    picks = [rng.choice(seeds, args.size, replace=False) for _ in range(args.resamples)]
    resampled = pd.DataFrame([judged(draws, ref, p) for p in picks])
    names = labels.Names.of(trials, reference)
    short = {"agrees": ".", "identical": "=", "differs": "D"}
    print(f"{table.shape[1]} disjoint draws of {args.size} seeds against {args.reference}")
    print(f"(. agrees, = identical, D differs); then {args.resamples} draws at random\n")
    cols = " ".join(c.rjust(5) for c in table.columns)
    print(f"{'env':36s}{'algorithm':10s}  {cols}  differs  of {args.resamples}")
    for key, row in table.iterrows():
        marks = " ".join(short.get(v, "?") if isinstance(v, str) else "?" for v in row)
        marks = " ".join(m.rjust(5) for m in marks.split())
        share = (row.dropna() == "differs").mean()
        again = (resampled[key].dropna() == "differs").mean() if key in resampled else np.nan
        print(f"{key[0]:36s}{names.label(key[1]):10s}  {marks}  {share:6.0%}  {again:7.1%}")
    for what, frame in (("disjoint draws", table), ("random draws", resampled)):
        verdicts = [v for v in frame.to_numpy().ravel() if isinstance(v, str)]
        share = np.mean([v == "differs" for v in verdicts])
        print(f"all rows, {what}: {share:.1%} of {len(verdicts)} verdicts say differs")


if __name__ == "__main__":
    main()
