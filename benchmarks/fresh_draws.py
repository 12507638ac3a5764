"""How often `bench compare` says "differs" on a newcomer's run that is a fresh draw.

    bench run suites/quick-draws.yaml
    python benchmarks/fresh_draws.py [results/quick-draws] [--reference results/quick] [--size 5]

The draws folder holds the quick suite's trials on seeds outside the reference's. Its seeds,
in order, are cut into draws of `--size` (5-9, 10-14, ...): each is one newcomer's `make run`,
same code and settings as the reference, other seeds. Each draw is compared with the reference
as `bench compare` compares them (same normalization, same rank test), and the table shows
every row's verdict per draw and the share of draws in which it differs: the rule promises at
most 5% per row.
"""

from __future__ import annotations

import argparse

import pandas as pd

from bench.analysis import agreement, labels, normalize
from bench.harness import frames


def draws_of(trials: pd.DataFrame, size: int) -> list[pd.DataFrame]:
    """The trials cut into runs of `size` consecutive seeds (a trailing short run left out)."""
    seeds = sorted(trials["seed"].unique())
    cuts = [seeds[i : i + size] for i in range(0, len(seeds) - size + 1, size)]
    return [trials[trials["seed"].isin(cut)] for cut in cuts]


def verdicts(draws: list[pd.DataFrame], reference: pd.DataFrame) -> pd.DataFrame:
    """One row per compared cell, one column per draw (its seeds), holding the verdict."""
    columns = {}
    for draw in draws:
        run, ref = normalize.normalized_alike(draw, reference)
        table = agreement.compare(run, ref).set_index(agreement.COMPARE_KEYS)
        seeds = sorted(draw["seed"].unique())
        columns[f"{seeds[0]}-{seeds[-1]}"] = table["verdict"]
    return pd.DataFrame(columns)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("draws", nargs="?", default="results/quick-draws")
    parser.add_argument("--reference", default="results/quick")
    parser.add_argument("--size", type=int, default=5, help="seeds per draw (the reference's)")
    args = parser.parse_args()
    trials, reference = frames.load(args.draws), frames.load(args.reference)
    table = verdicts(draws_of(trials, args.size), reference)
    names = labels.Names.of(trials, reference)
    short = {"agrees": ".", "identical": "=", "differs": "D"}
    print(f"{table.shape[1]} draws of {args.size} seeds against {args.reference}")
    print("(. agrees, = identical, D differs)\n")
    print(f"{'env':36s}{'algorithm':10s}  {' '.join(c.rjust(5) for c in table.columns)}  differs")
    for key, row in table.iterrows():
        env, algorithm = key[0], key[1]
        marks = " ".join(short.get(v, "?").rjust(5) for v in row)
        share = (row.dropna() == "differs").mean()
        print(f"{env:36s}{names.label(algorithm):10s}  {marks}  {share:6.0%}")
    said = table.stack()
    print(f"\nall rows: {(said == 'differs').mean():.1%} of {said.size} verdicts say differs")


if __name__ == "__main__":
    main()
