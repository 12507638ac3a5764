"""The controls, one pair per optimizer family, registered by one function (`register_controls`):

- `survival`, the floor: +1 per step alive, no demonstrations. On tasks that end early, what a
  reward that is always positive earns for staying alive, whatever it says about imitation.
- `oracle`, the ceiling: the env's own reward, the one the expert was trained on: what the
  family's optimizer reaches at the budget when it is told the true reward.

Each runs its family's optimizer with exactly the settings the family's learners get (TRPO:
`ImitationTRPOConfig`, and a suite env's `trpo:` settings as they get them; SAC:
`OffPolicyConfig`; TD3: OPOLO's `TD3Config`), through the same path from a reward to that
optimizer, so a learner differs from its controls only in its reward (docs/design/controls.md).
A plugin with an optimizer of its own registers its pair the same way.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any

import numpy as np
import torch

from algorithms.offpolicy import OffPolicyConfig, sac_budget, train_on_reward
from bench.harness.learners import ImitationTRPOConfig, one_batch, trpo_on_reward
from bench.harness.registry import Logger, Policy, Task, register
from bench.rl.replay import ReplayBatch
from bench.rl.rollout import Batch
from bench.rl.td3 import TD3, TD3Config

OnReward = Callable[[Task, int, int, Logger, Any, Any], Policy]
"""on_reward(task, budget, seed, logger, config, reward_fn) -> the trained policy: a family's one
path from a reward (its loop's `reward_fn`; None: the env's own) to its optimizer."""


def register_controls(
    family: str,
    on_reward: OnReward,
    alive: Callable[[Any], Any],
    *,
    names: tuple[str, str],
    labels: tuple[str, str],
    optimizer: str,
    config: type,
    min_budget: Callable[[Any], int],
    pixels: bool = False,
) -> None:
    """Register `family`'s floor and ceiling under `names` (shown as `labels`): `on_reward` on
    `alive` (+1 per step alive, as the family's loop takes a reward) and on the env's reward.
    `optimizer`: how descriptions name it ("TRPO")."""

    def survival(
        task: Task, demos: None, budget: int, seed: int, logger: Logger, cfg: Any
    ) -> Policy:
        return on_reward(task, budget, seed, logger, cfg, alive)

    def oracle(task: Task, demos: None, budget: int, seed: int, logger: Logger, cfg: Any) -> Policy:
        return on_reward(task, budget, seed, logger, cfg, None)

    control = partial(
        register,
        config=config,
        inputs="none",
        resumable=True,
        pixels=pixels,
        min_budget=min_budget,
        family=family,
    )
    paid = f"control: {optimizer} on +1 per step alive, no demos"
    control(names[0], role="floor", label=labels[0], description=paid)(survival)
    told = f"control: {optimizer} on the env's reward, no demos"
    control(names[1], role="ceiling", label=labels[1], description=told)(oracle)


def every_step(batch: Batch) -> np.ndarray:
    """+1 for each of a TRPO batch's (T, E) steps; TRPO values what follows a termination as 0."""
    return np.ones_like(batch.rewards)


def real_steps(batch: ReplayBatch) -> torch.Tensor:
    """+1 for each real step of a replay minibatch (the one into the absorbing state
    included), 0 on the absorbing loop: what staying alive earns where a termination leads
    into it, and +1 per step where it is masked (OPOLO's TD3 keeps no absorbing state)."""
    return (~batch.obs_absorbing).float()


def td3_on_reward(
    task: Task,
    budget: int,
    seed: int,
    logger: Logger,
    config: TD3Config,
    reward_fn: Callable[[ReplayBatch], torch.Tensor] | None,
) -> Policy:
    """OPOLO's optimizer, TD3 with its settings (`bench.rl.td3`), in SAC's loop on `reward_fn`."""
    learner = TD3(task.obs_dim, task.act_dim, task.action_low, task.action_high, config, seed)
    return train_on_reward(task, budget, seed, logger, config, reward_fn, learner)


register_controls(
    "trpo",
    trpo_on_reward,
    every_step,
    names=("survival", "oracle"),
    labels=("Survival", "Oracle"),
    optimizer="TRPO",
    config=ImitationTRPOConfig,
    min_budget=one_batch,
    pixels=True,
)
register_controls(
    "sac",
    train_on_reward,
    real_steps,
    names=("survival-sac", "oracle-sac"),
    labels=("Survival (SAC)", "Oracle (SAC)"),
    optimizer="SAC",
    config=OffPolicyConfig,
    min_budget=sac_budget,
)
register_controls(
    "td3",
    td3_on_reward,
    real_steps,
    names=("survival-td3", "oracle-td3"),
    labels=("Survival (TD3)", "Oracle (TD3)"),
    optimizer="TD3 (OPOLO's settings)",
    config=TD3Config,
    min_budget=sac_budget,
)
