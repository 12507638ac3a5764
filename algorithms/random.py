"""Uniformly random actions: the 0 of every normalized score."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bench.harness.registry import Logger, Task, register


@dataclass
class RandomConfig:
    pass


class UniformPolicy:
    def __init__(self, low: np.ndarray, high: np.ndarray, seed: int) -> None:
        self.low, self.high = low, high
        self.rng = np.random.default_rng(seed)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return self.rng.uniform(self.low, self.high, size=(len(obs), len(self.low))).astype(
            np.float32
        )


@register(
    "random",
    config=RandomConfig,
    inputs="none",
    description="uniform random actions (score 0)",
    pixels=True,
    role="random",
    label="Random",
)
def train(
    task: Task, demos: None, budget: int, seed: int, logger: Logger, config: RandomConfig
) -> UniformPolicy:
    return UniformPolicy(task.action_low, task.action_high, seed)
