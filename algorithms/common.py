"""What the TRPO-based learners share: where their networks live, the policy the runner
evaluates, and what they report after each update."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from bench.registry import Logger, Task
from bench.rl.networks import DeterministicPolicy
from bench.rl.rollout import Batch
from bench.rl.trpo import TRPO, Callback, TRPOConfig


@dataclass
class ImitationTRPOConfig(TRPOConfig):
    """TRPO as the imitators run it. GAIfO and GAIL extend it and the `survival` control runs it
    as is, so a default changed here changes for the control too: it stays matched."""

    init_log_std: float = 0.0
    """Action noise at the start (log of the Gaussian's std). Measured with absorbing states and
    the signed reward (InvertedPendulum 100k, 10 seeds): at -0.5 two GAIfO seeds of ten and one
    GAIL seed collapsed after reaching the expert; at 0.0 none did. Hopper at 1M agreed."""


def on_task_device(config: TRPOConfig, task: Task) -> TRPOConfig:
    """`config` with networks on the runner's device (cpu unless `bench run --device`)."""
    return dataclasses.replace(config, device=task.device)


def deterministic(learner: TRPO, task: Task) -> DeterministicPolicy:
    """A snapshot of the learner's mean policy, clipped to the task's action bounds."""
    return DeterministicPolicy(learner.policy, task.action_low, task.action_high)


def report_each_update(
    task: Task, logger: Logger, stats: dict[str, float] | None = None
) -> Callback:
    """A TRPO callback: log `stats` (read at each call) and the KL, offer the policy for evaluation."""

    def on_update(steps: int, learner: TRPO, batch: Batch, info: dict[str, float]) -> None:
        logger.log(steps, **(stats or {}), kl=info["kl"])
        logger.checkpoint(steps, deterministic(learner, task))

    return on_update
