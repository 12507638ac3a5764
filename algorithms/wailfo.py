"""WAILfO: Wasserstein adversarial imitation (Xiao et al. 2019) from state transitions alone.

GAIfO's loop with its classifier swapped for a critic f(s, s'): f minimizes
E_policy[f] - E_expert[f] + lambda (||grad f|| - 1)^2 on interpolates of the two sides (WGAN-GP,
the penalty form of the 1-Lipschitz constraint; lambda = `grad_penalty`, 10 as in WGAN-GP), so
that E_expert[f] - E_policy[f] estimates the Wasserstein-1 distance between the expert's
transitions and the policy's, and the policy's reward is f(s, s') itself (WAIL's reward). What
WAIL takes of (s, a) is taken here of (s, s'), as GAIfO takes GAIL's.

Kept from GAIfO, where the paper leaves the choice open: TRPO and its settings, D's pace
(`disc_steps` critic steps per update, WGAN-GP's n_critic of 5 by default), Adam at D's rate,
and absorbing states, which the critic values like any other input, so a constant shift of f
pays neither for surviving nor for falling.
"""

from __future__ import annotations

from dataclasses import dataclass

from algorithms.adversarial import AdversarialConfig, train_adversarial
from algorithms.gaifo import state_transition
from bench.harness.learners import one_batch
from bench.harness.registry import Logger, Policy, Task, register
from bench.imitation.data import Demos
from bench.imitation.discriminator import wasserstein

CRITIC_VALUE = "log D - log(1-D)"
"""The `reward` that passes D's output through unchanged: for a critic, its value."""


@dataclass
class WAILfOConfig(AdversarialConfig):
    """GAIfO's settings, its D a critic: the gradient penalty pulls towards norm 1."""

    gp_target: float = 1.0
    """Gradient norm the penalty pulls the critic's towards: 1, WGAN-GP's Lipschitz bound."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if self.reward != CRITIC_VALUE:
            raise ValueError(f"WAILfO's reward is its critic's value ({CRITIC_VALUE!r})")
        if self.grad_penalty <= 0:
            raise ValueError("WAILfO's critic needs its gradient penalty (grad_penalty > 0)")
        if self.disc_entropy > 0 or self.disc_pause_above < 1:
            raise ValueError("disc_entropy and disc_pause_above read a classifier's outputs")


@register(
    "wailfo",
    config=WAILfOConfig,
    inputs="states",
    resumable=True,
    description="WAILfO: Wasserstein critic on (s, s'), its value the reward",
    pixels=True,
    video_reward=True,
    min_budget=one_batch,
    family="trpo",
    label="WAILfO",
)
def train(
    task: Task, demos: Demos, budget: int, seed: int, logger: Logger, config: WAILfOConfig
) -> Policy:
    return train_adversarial(
        task=task,
        demos=demos,
        features=state_transition,
        budget=budget,
        seed=seed,
        logger=logger,
        cfg=config,
        objective=wasserstein,
    )
