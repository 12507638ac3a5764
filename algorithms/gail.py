"""GAIL (Ho & Ermon 2016): adversarial imitation on (s, a). The one algorithm given expert actions."""

from __future__ import annotations

import torch

from algorithms.adversarial import AdversarialConfig, train_adversarial
from bench.harness.learners import one_batch
from bench.harness.registry import Logger, Policy, Task, register
from bench.imitation.data import ActionDemos


def state_action(s: torch.Tensor, a: torch.Tensor, s_next: torch.Tensor) -> torch.Tensor:
    """D's input (s, a); actions clipped to the bounds, as the expert's were."""
    return torch.cat([s, a], dim=1)


@register(
    "gail",
    config=AdversarialConfig,
    inputs="actions",
    resumable=True,
    description="GAIL: discriminator on (s, a)",
    pixels=True,
    video_reward=True,
    min_budget=one_batch,
    family="trpo",
    label="GAIL",
)
def train(
    task: Task,
    demos: ActionDemos,
    budget: int,
    seed: int,
    logger: Logger,
    config: AdversarialConfig,
) -> Policy:
    return train_adversarial(
        task=task,
        demos=demos.demos,
        expert_actions=demos.actions,
        features=state_action,
        budget=budget,
        seed=seed,
        logger=logger,
        cfg=config,
    )
