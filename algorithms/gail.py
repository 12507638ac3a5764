"""GAIL (Ho & Ermon 2016): adversarial imitation on (s, a). The one algorithm given expert actions."""

from __future__ import annotations

import numpy as np

from algorithms.adversarial import AdversarialConfig, train_adversarial
from bench.registry import Logger, Policy, Task, register
from bench.rl.rollout import Batch
from bench.types import ActionDemos


def state_actions(batch: Batch, low: np.ndarray, high: np.ndarray) -> np.ndarray:
    """(T*E, O + A): [s, a] with a clipped to the action bounds, as the expert's were."""
    return np.concatenate([batch.flat("obs"), np.clip(batch.flat("actions"), low, high)], axis=1)


@register(
    "gail", config=AdversarialConfig, inputs="actions", description="GAIL: discriminator on (s, a)"
)
def train(
    task: Task,
    demos: ActionDemos,
    budget: int,
    seed: int,
    logger: Logger,
    config: AdversarialConfig,
) -> Policy:
    s, a = demos.state_actions()
    features = lambda b: state_actions(b, task.action_low, task.action_high)  # noqa: E731
    return train_adversarial(
        task, np.concatenate([s, a], 1), features, 1, seed, budget, logger, config
    )
