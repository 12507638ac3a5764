"""Control: TRPO on +1 per step, no demonstrations. On tasks that end early this is what a
positive imitation reward earns for staying alive alone."""

from __future__ import annotations

import dataclasses

import numpy as np

from bench.registry import Logger, Policy, Task, register
from bench.rl.networks import DeterministicPolicy
from bench.rl.trpo import TRPOConfig
from bench.rl.trpo import train as trpo_train


@register(
    "survival",
    config=TRPOConfig,
    inputs="none",
    description="control: TRPO on +1 per step, no demos",
)
def train(
    task: Task, demos: None, budget: int, seed: int, logger: Logger, config: TRPOConfig
) -> Policy:
    def on_update(steps, learner, batch, info):
        logger.checkpoint(
            steps, DeterministicPolicy(learner.policy, task.action_low, task.action_high)
        )

    config = dataclasses.replace(
        config, device=task.device
    )  # the runner decides where networks live
    learner = trpo_train(
        task.make_env, budget, seed, config, lambda b: np.ones_like(b.rewards), on_update
    )
    return DeterministicPolicy(learner.policy, task.action_low, task.action_high)
