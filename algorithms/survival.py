"""Control: TRPO on +1 per step, no demonstrations. On tasks that end early this is what a
positive imitation reward earns for staying alive alone. It runs the imitators' TRPO settings
(ImitationTRPOConfig), so it differs from GAIfO and GAIL only in its reward."""

from __future__ import annotations

import numpy as np

from bench.harness.learners import ImitationTRPOConfig, one_batch, trpo_on_reward
from bench.harness.registry import Logger, Policy, Task, register


@register(
    "survival",
    config=ImitationTRPOConfig,
    inputs="none",
    resumable=True,
    description="control: TRPO on +1 per step, no demos",
    pixels=True,
    min_budget=one_batch,
    role="floor",
    family="trpo",
    label="Survival",
)
def train(
    task: Task, demos: None, budget: int, seed: int, logger: Logger, config: ImitationTRPOConfig
) -> Policy:
    reward = lambda b: np.ones_like(b.rewards)  # noqa: E731
    return trpo_on_reward(task, budget, seed, logger, config, reward)
