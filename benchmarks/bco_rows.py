"""What BCO spends keeping its inverse model's data: every chunk's rows written once into
`TransitionRows`, against concatenating every chunk again before each refit (the old way).

    python benchmarks/bco_rows.py [--obs 105] [--act 8] [--budget 2000000]

Shapes default to Ant-v5's (105-dim states, 8 actions) at its Figure 2 budget, with BCO's
defaults (20k random steps, then chunks of alpha * 20k = 5k, 10% held out). Prints seconds per
trial for each way; the concatenation's total is integrated from a few sizes along the run, so
the script takes about a minute. Run it on quiet cores.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch

from algorithms.bco import BCOConfig
from bench.imitation.inverse_dynamics import TransitionRows


def chunk_sizes(budget: int, cfg: BCOConfig) -> list[int]:
    """Training rows added before each refit: the random phase, then alpha * pre_demo_steps."""
    keep = 1 - cfg.val_fraction
    chunk = round(cfg.alpha * cfg.pre_demo_steps)
    n_chunks = (budget - cfg.pre_demo_steps) // chunk
    return [round(cfg.pre_demo_steps * keep)] + [round(chunk * keep)] * n_chunks


def chunk(rows: int, obs: int, act: int, rng: np.random.Generator) -> tuple[np.ndarray, ...]:
    """(s, a, s') as BCO's policy chunks have them: float32 states, float64 actions."""
    return (
        rng.random((rows, obs), np.float32),
        rng.random((rows, act)),
        rng.random((rows, obs), np.float32),
    )


def seconds_concatenating(first: tuple, later: tuple, refits: int) -> float:
    """Sum over refits of the time to concatenate every chunk so far, measured at five points
    along the run and integrated (the time grows linearly with the rows)."""
    points = np.linspace(1, refits, 5).round().astype(int)
    per_refit = []
    for n in points:
        parts = [first] + [later] * (n - 1)
        start = time.perf_counter()
        tuple(torch.from_numpy(np.concatenate(x)) for x in zip(*parts, strict=True))
        per_refit.append(time.perf_counter() - start)
    return float(np.trapezoid(per_refit, points))


def seconds_growing(first: tuple, later: tuple, refits: int) -> float:
    """Every append of a whole run, and the view read before each refit."""
    rows = TransitionRows()
    start = time.perf_counter()
    for i in range(refits):
        rows.append(*(first if i == 0 else later))
        rows.tensors()
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--obs", type=int, default=105)
    parser.add_argument("--act", type=int, default=8)
    parser.add_argument("--budget", type=int, default=2_000_000)
    args = parser.parse_args()
    sizes = chunk_sizes(args.budget, BCOConfig())
    rng = np.random.default_rng(0)
    first, later = (chunk(n, args.obs, args.act, rng) for n in sizes[:2])
    first = (first[0], first[1].astype(np.float32), first[2])  # random actions: float32
    print(f"{len(sizes)} refits, {sum(sizes):,} training rows of {args.obs}+{args.act}+{args.obs}")
    old = seconds_concatenating(first, later, len(sizes))
    print(f"concatenating before each refit: {old:.0f} s per trial")
    new = seconds_growing(first, later, len(sizes))
    print(f"growing in place:                {new:.1f} s per trial")


if __name__ == "__main__":
    main()
