"""Where an algorithm's learning curve has plateaued, per env: the converged budget rule.

    python benchmarks/plateau.py results/mujoco-converged-screen [--algorithm oracle]
        [--level 0.95] [--window 1000000] [--tail 2000000]

The curve is the mean over seeds of the recorded evaluations (5 episodes each), smoothed by
a running mean over `--window` env steps. Its final level is the mean of the seed-mean curve
over the last `--tail` steps. The plateau is the first step where the smoothed curve reaches
`--level` of that final level; the printed budget rounds it to the nearest million. Printed
for 0.90, 0.95 and 0.98 beside it, to show how much the choice of level moves the budget.
"""

from __future__ import annotations

import argparse
import math

import numpy as np
import pandas as pd

from bench.harness import frames


def plateau_step(curve: pd.Series, level: float, window: int, tail: int) -> float:
    """First env step (index of `curve`) where the running mean over `window` steps reaches
    `level` x the mean over the last `tail` steps; NaN where it never does."""
    steps = curve.index.to_numpy()
    spacing = np.median(np.diff(steps))
    points = max(1, round(window / spacing))
    smooth = curve.rolling(points, center=True, min_periods=points).mean()
    final = curve[steps >= steps[-1] - tail].mean()
    reached = smooth[smooth >= level * final]
    return float(reached.index[0]) if len(reached) else math.nan


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results")
    parser.add_argument("--algorithm", default="oracle")
    parser.add_argument("--level", type=float, default=0.95)
    parser.add_argument("--window", type=int, default=1_000_000)
    parser.add_argument("--tail", type=int, default=2_000_000)
    args = parser.parse_args()
    curves = frames.load_curves(args.results)
    curves = curves[curves.algorithm == args.algorithm]
    levels = sorted({0.90, 0.95, 0.98, args.level})
    print(
        f"{'env':18s}{'seeds':>6s}{'final':>8s}" + "".join(f"{f'at {x:.2f}':>10s}" for x in levels)
    )
    for env_id, env in curves.groupby("env_id"):
        seeds = env.seed.nunique()
        steps_per_seed = env.groupby("seed").env_steps.max().min()  # every seed's points only
        mean = env[env.env_steps <= steps_per_seed].groupby("env_steps")["return"].mean()
        final = mean[mean.index >= mean.index[-1] - args.tail].mean()
        at = [plateau_step(mean, level, args.window, args.tail) for level in levels]
        print(f"{env_id:18s}{seeds:6d}{final:8,.0f}" + "".join(f"{s / 1e6:9.1f}M" for s in at))
        budget = round(at[levels.index(args.level)] / 1e6)
        print(f"  -> budget at {args.level:.2f}: {budget}M env steps")


if __name__ == "__main__":
    main()
