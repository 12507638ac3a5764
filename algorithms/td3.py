"""OPOLO's controls: TD3 with OPOLO's settings (`bench.rl.td3`), no demonstrations, on +1 per
step alive (`survival-td3`, the floor) or on the env's reward (`oracle-td3`, the ceiling), so
OPOLO is read against the optimizer it runs, as GAIfO is against TRPO's controls."""

from __future__ import annotations

from algorithms.offpolicy import sac_budget, train_on_reward
from bench.harness.registry import Logger, Policy, Task, register
from bench.rl.td3 import TD3, TD3Config


def td3_on_reward(task: Task, budget: int, seed: int, logger: Logger, config, reward) -> Policy:
    learner = TD3(task.obs_dim, task.act_dim, task.action_low, task.action_high, config, seed)
    return train_on_reward(task, budget, seed, logger, config, reward, learner)


@register(
    "survival-td3",
    config=TD3Config,
    inputs="none",
    resumable=True,
    description="control: TD3 (OPOLO's settings) on +1 per step alive, no demos",
    min_budget=sac_budget,
    role="floor",
    family="td3",
    label="Survival (TD3)",
)
def train_survival(task: Task, demos: None, budget: int, seed: int, logger: Logger, config):
    # +1 for every real step; a termination is masked (OPOLO's TD3 keeps no absorbing state)
    return td3_on_reward(task, budget, seed, logger, config, lambda b: (~b.obs_absorbing).float())


@register(
    "oracle-td3",
    config=TD3Config,
    inputs="none",
    resumable=True,
    description="control: TD3 (OPOLO's settings) on the env's reward, no demos",
    min_budget=sac_budget,
    role="ceiling",
    family="td3",
    label="Oracle (TD3)",
)
def train_oracle(task: Task, demos: None, budget: int, seed: int, logger: Logger, config):
    return td3_on_reward(task, budget, seed, logger, config, None)
