"""Control: TRPO on the env's own reward, no demonstrations: the ceiling at this budget.

`survival` is the floor (paid for staying alive); `oracle` is what the imitators' optimizer
reaches when it is told the true reward. It runs exactly their TRPO settings
(ImitationTRPOConfig, and a suite env's `trpo:` settings as they do), so when an imitator's
bar is low, the gap to this one is the imitation's and the gap from this one to the expert
is the optimizer's at this budget."""

from __future__ import annotations

from bench.harness.learners import ImitationTRPOConfig, one_batch, trpo_on_reward
from bench.harness.registry import Logger, Policy, Task, register


@register(
    "oracle",
    config=ImitationTRPOConfig,
    inputs="none",
    resumable=True,
    description="control: TRPO on the env's reward, no demos",
    pixels=True,
    min_budget=one_batch,
    role="ceiling",
    family="trpo",
    label="Oracle",
)
def train(
    task: Task, demos: None, budget: int, seed: int, logger: Logger, config: ImitationTRPOConfig
) -> Policy:
    # reward_fn=None: the env's reward, what the expert was trained on
    return trpo_on_reward(task, budget, seed, logger, config, reward_fn=None)
