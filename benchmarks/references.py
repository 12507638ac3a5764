"""The 0 and 1 of a benchmark script's normalized scores, measured as the runner measures its
references: uniform random actions and the shipped expert, on the same evaluation episodes."""

from __future__ import annotations

import numpy as np

from bench import envs
from bench.demos import experts
from bench.rl.rollout import evaluate


def reference_returns(env_id: str, episodes: int = 5, seed: int = 10_000) -> tuple[float, float]:
    """(random's, the expert's) mean return over `episodes` episodes from `seed` on."""
    rng = np.random.default_rng(0)
    _, act_dim, low, high = envs.spaces(env_id)
    ref_envs = [envs.make(env_id, seed + i) for i in range(episodes)]
    try:
        lo = np.mean(
            evaluate(lambda o: rng.uniform(low, high, (len(o), act_dim)), ref_envs, episodes, seed)
        )
        hi = np.mean(evaluate(experts.load_expert(env_id), ref_envs, episodes, seed))
    finally:
        for env in ref_envs:
            env.close()
    return float(lo), float(hi)
