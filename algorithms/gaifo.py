"""GAIfO (Torabi et al. 2018): adversarial imitation from state transitions (s, s') alone."""

from __future__ import annotations

import torch

from algorithms.adversarial import AdversarialConfig, train_adversarial
from bench.harness.learners import one_batch
from bench.harness.registry import Logger, Policy, Task, register
from bench.imitation.data import Demos


def state_transition(s: torch.Tensor, a: torch.Tensor, s_next: torch.Tensor) -> torch.Tensor:
    """D's input (s, s'): what an observer sees, whatever the action was."""
    return torch.cat([s, s_next], dim=1)


@register(
    "gaifo",
    config=AdversarialConfig,
    inputs="states",
    resumable=True,
    description="GAIfO: discriminator on (s, s')",
    pixels=True,
    video_reward=True,
    min_budget=one_batch,
    family="trpo",
    label="GAIfO",
)
def train(
    task: Task, demos: Demos, budget: int, seed: int, logger: Logger, config: AdversarialConfig
) -> Policy:
    return train_adversarial(
        task=task,
        demos=demos,
        features=state_transition,
        budget=budget,
        seed=seed,
        logger=logger,
        cfg=config,
    )
