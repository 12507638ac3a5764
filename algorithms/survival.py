"""Control: TRPO on +1 per step, no demonstrations. On tasks that end early this is what a
positive imitation reward earns for staying alive alone. It runs the imitators' TRPO settings
(ImitationTRPOConfig), so it differs from GAIfO and GAIL only in its reward."""

from __future__ import annotations

import numpy as np

from algorithms.common import (
    ImitationTRPOConfig,
    PolicyAverage,
    one_batch,
    report_each_update,
)
from bench.registry import Logger, Policy, Task, register
from bench.rl.trpo import TRPO
from bench.rl.trpo import train as trpo_train


@register(
    "survival",
    config=ImitationTRPOConfig,
    inputs="none",
    description="control: TRPO on +1 per step, no demos",
    pixels=True,
    min_budget=one_batch,
)
def train(
    task: Task, demos: None, budget: int, seed: int, logger: Logger, config: ImitationTRPOConfig
) -> Policy:
    average = PolicyAverage(config.policy_average)
    learner = trpo_train(
        task.make_env,
        budget,
        seed,
        reward_fn=lambda batch: np.ones_like(batch.rewards),
        callback=report_each_update(task, logger, average=average),
        learner=TRPO(task.obs_shape, task.act_dim, config, seed, task.device),
    )
    return average.policy(learner, task)
