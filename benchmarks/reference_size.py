"""How many reference seeds keep a newcomer's "differs" near 5% per row, whichever seeds the
committed reference happened to draw.

    python benchmarks/reference_size.py [results/quick results/quick-draws]
        [--sizes 5 10 15 20] [--references 40] [--runs 100] [--alpha 0.01]

The rank test holds its 5% over fresh draws of both sides. A newcomer meets one committed
reference, though, and against an unlucky one (its five seeds all low, say) a fresh run
differs more often. The folders' seeds are pooled per cell (one CPU, one distribution; the
quick suite's and its fresh draws'). For each reference size m: `--references` references of
m seeds drawn from the pool, and against each, `--runs` runs of 5 other seeds, judged as
`bench compare` judges a row. A reference's share of runs that differ is the rate a newcomer
would meet against it; per row, the mean over references (the rule's level), the 90th
percentile and the worst.
"""

from __future__ import annotations

import argparse

import numpy as np
import pandas as pd

from bench.analysis import agreement, labels, normalize
from bench.harness import frames

RUN_SEEDS = 5
"""Seeds of a newcomer's run (the quick suite's)."""


def rates(
    pool: np.ndarray, size: int, references: int, runs: int, seed: int, alpha: float
) -> np.ndarray:
    """Per reference of `size` scores drawn from `pool`: the share of `runs` runs of
    RUN_SEEDS other scores that `bench compare` calls different from it."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(references):
        order = rng.permutation(len(pool))
        ref = pd.Series(pool[order[:size]], index=order[:size])  # scores by seed
        rest = order[size:]
        differs = 0
        for _ in range(runs):
            picked = rng.choice(rest, RUN_SEEDS, replace=False)
            run = pd.Series(pool[picked], index=picked)
            p = agreement.permutation_p(run.to_numpy(), ref.to_numpy())
            differs += agreement.verdict_of(run, ref, p, alpha) == "differs"
        out.append(differs / runs)
    return np.array(out)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folders", nargs="*", default=["results/quick", "results/quick-draws"])
    parser.add_argument("--sizes", type=int, nargs="+", default=[5, 10, 15, 20])
    parser.add_argument("--references", type=int, default=40)
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--alpha", type=float, default=agreement.ALPHA)
    args = parser.parse_args()
    # one distribution: the same trials on other seeds
    trials = agreement.pooled([(f, frames.load(f)) for f in args.folders])
    scored = normalize.normalize(trials)
    names = labels.Names.of(trials)
    print(
        f"{args.references} references per size, {args.runs} runs of {RUN_SEEDS} against each,"
        f" p < {args.alpha:g}"
    )
    print(f"{'env':36s}{'algorithm':10s}{'seeds':>6s}" + "".join(f"{m:>18d}" for m in args.sizes))
    print(" " * 52 + "".join(f"{'mean/p90/worst':>18s}" for _ in args.sizes))
    everywhere: dict[int, list[float]] = {m: [] for m in args.sizes}
    for i, (key, cell) in enumerate(scored.groupby(agreement.COMPARE_KEYS)):
        pool = cell["normalized"].dropna().to_numpy()
        if len(pool) < max(args.sizes) + RUN_SEEDS:
            continue
        shown = []
        for m in args.sizes:
            r = rates(pool, m, args.references, args.runs, seed=i, alpha=args.alpha)
            everywhere[m].extend(r)
            shown.append(f"{r.mean():.1%}/{np.quantile(r, 0.9):.0%}/{r.max():.0%}".rjust(18))
        print(f"{key[0]:36s}{names.label(key[1]):10s}{len(pool):6d}" + "".join(shown))
    print(f"{'all rows':52s}" + "".join(f"{np.mean(everywhere[m]):18.1%}" for m in args.sizes))


if __name__ == "__main__":
    main()
