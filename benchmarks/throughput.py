"""Env steps per second on one core: raw random stepping vs TRPO training (updates included).

    python benchmarks/throughput.py [--steps 60000] [--envs InvertedPendulumBulletEnv-v0 HopperBulletEnv-v0]

Prints one row per env; `ratio` = TRPO training throughput / raw stepping.
The simulator is the limit, so everything above it is overhead.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch

from bench import envs
from bench.rl.trpo import TRPOConfig, train


def raw_steps_per_s(env_id: str, steps: int) -> float:
    env = envs.make(env_id, 0)
    rng = np.random.default_rng(0)
    low, high = env.action_space.low, env.action_space.high
    actions = rng.uniform(low, high, size=(steps, len(low))).astype(np.float32)
    start = time.perf_counter()
    for a in actions:
        _, _, term, trunc, _ = env.step(a)
        if term or trunc:
            env.reset()
    elapsed = time.perf_counter() - start
    env.close()
    return steps / elapsed


def trpo_steps_per_s(env_id: str, steps: int, reward_fn=None) -> float:
    cfg = TRPOConfig()
    timings: list[tuple[int, float]] = []
    start = time.perf_counter()
    train(
        lambda s: envs.make(env_id, s),
        steps,
        seed=0,
        cfg=cfg,
        reward_fn=reward_fn,
        callback=lambda n, *_: timings.append((n, time.perf_counter() - start)),
    )
    # Skip the first update: env construction and first-call costs are not throughput.
    (n0, t0), (n1, t1) = timings[0], timings[-1]
    return (n1 - n0) / (t1 - t0)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--steps", type=int, default=60_000)
    parser.add_argument(
        "--envs", nargs="+", default=["InvertedPendulumBulletEnv-v0", "HopperBulletEnv-v0"]
    )
    args = parser.parse_args()
    torch.set_num_threads(1)
    print(f"{'env':32s} {'raw steps/s':>12s} {'TRPO steps/s':>13s} {'ratio':>6s}")
    for env_id in args.envs:
        raw = raw_steps_per_s(env_id, args.steps)
        trpo = trpo_steps_per_s(env_id, args.steps)
        print(f"{env_id:32s} {raw:12,.0f} {trpo:13,.0f} {trpo / raw:6.2f}", flush=True)


if __name__ == "__main__":
    main()
