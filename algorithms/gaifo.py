"""GAIfO (Torabi et al. 2018): adversarial imitation from state transitions (s, s') alone."""

from __future__ import annotations

import numpy as np

from algorithms.adversarial import AdversarialConfig, train_adversarial
from bench.registry import Logger, Policy, Task, register
from bench.rl.rollout import Batch
from bench.types import Demos


def transitions(batch: Batch) -> np.ndarray:
    """(T*E, 2*O): [s, s'] with s' the true next observation, final ones included."""
    return np.concatenate([batch.flat("obs"), batch.flat("next_obs")], axis=1)


@register(
    "gaifo",
    config=AdversarialConfig,
    inputs="states",
    description="GAIfO: discriminator on (s, s')",
)
def train(
    task: Task, demos: Demos, budget: int, seed: int, logger: Logger, config: AdversarialConfig
) -> Policy:
    s, s_next = demos.transitions()
    return train_adversarial(
        task, np.concatenate([s, s_next], 1), transitions, 2, seed, budget, logger, config
    )
