"""AIRLfO: adversarial inverse reinforcement learning (Fu et al. 2018) from state transitions.

AIRL's discriminator is D = exp(f) / (exp(f) + pi(a|s)) with f shaped as
f(s, s') = g(s) + gamma h(s') - h(s) (its eq. 4, state-only reward g(s) as in its section 5):
g the reward it recovers, h a potential that absorbs the dynamics' shaping. D's logit is then
f(s, s') - log pi(a|s), and the policy's reward log D - log(1 - D) = f - log pi.

Without the expert's actions, pi(a|s) cannot be evaluated on the expert's side, so the
policy-density term goes: D's logit is f(s, s') alone, trained as GAIfO's (cross-entropy, the
expert labelled 1), and the reward is f(s, s'), the shaped reward (AIRL trains its policy on
the shaped one too; the -log pi it adds is an entropy bonus). That is GAIfO with AIRL's
structured discriminator, and the only departure from AIRL: the rest (TRPO, D's pace and
gradient penalty, absorbing states) is GAIfO's, so the two differ in D's form alone. g and h
are each an MLP of `disc_hidden` (tanh) on the normalized state with its absorbing flag; the
absorbing state is a state like any other, so no done mask multiplies h(s') (AIRL's
implementations need one; absorbing states replace it).
"""

from __future__ import annotations

import torch
from torch import nn

from algorithms.adversarial import AdversarialConfig, train_adversarial
from algorithms.gaifo import state_transition
from bench.harness.learners import one_batch
from bench.harness.registry import Logger, Policy, Task, register
from bench.imitation.data import Demos
from bench.rl.networks import mlp


class ShapedHead(nn.Module):
    """f(s, s') = g(s) + gamma h(s') - h(s), of feature rows (s, s') (`state_transition`)."""

    def __init__(self, in_dim: int, hidden: tuple[int, ...], gamma: float) -> None:
        super().__init__()
        self.state_dim, self.gamma = in_dim // 2, gamma
        self.g = mlp([self.state_dim, *hidden, 1])
        self.h = mlp([self.state_dim, *hidden, 1])

    def forward(self, rows: torch.Tensor) -> torch.Tensor:
        s, s_next = rows[:, : self.state_dim], rows[:, self.state_dim :]
        return self.g(s) + self.gamma * self.h(s_next) - self.h(s)


@register(
    "airlfo",
    config=AdversarialConfig,
    inputs="states",
    resumable=True,
    description="AIRLfO: discriminator f(s, s') = g(s) + gamma h(s') - h(s)",
    pixels=True,
    video_reward=True,
    min_budget=one_batch,
    family="trpo",
    label="AIRLfO",
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
        head=lambda in_dim, hidden: ShapedHead(in_dim, hidden, config.gamma),
    )
