"""OPOLO (Zhu et al., NeurIPS 2020): off-policy learning from observations.

GAIfO's objective in its dual form, on a TD3 actor-critic that learns from replay:

1. D(s, s') tells the expert's transitions from the agent's (replay), and the critic's reward
   for a minibatch is -log(1 - D) from D as it is now. D takes `disc_steps` Adam steps every
   `train_every` updates (cross-entropy minus a small entropy bonus, gradient penalty
   towards norm 1).
2. The critic minimizes the TD error plus 2 alpha (1 - gamma) E[min Q(s, pi(s))] over replay
   states: the dual form's initial-state term, which keeps Q from overrating the policy's
   own actions where no data says otherwise.
3. The actor maximizes that same term and is pulled towards the expert by an inverse model
   M(s, s') -> a fitted on the agent's replay (its own actions, which it knows): lambda
   E_expert ||M(s, s') - pi(s)||^2, a BCO-like regularizer on demonstrated states.

Settings follow the authors' public code (illidanlab/opolo-code, `td3opolo.py`): TD3 with
[400, 300] networks, batch 100, 10k random steps, Gaussian exploration 0.1, policy delay 2, D
and M 2 x 256 tanh, alpha = lambda = 0.1 (their Hopper runs use 0.01 and lr 1e-4; a suite
entry sets those). Where this differs from that code, on purpose: updates interleave with
collection at one per env step (the code runs bursts of 1,000 every 1,000 steps: the same
ratio), a termination is masked (the code bootstraps across resets), the critic's target has
TD3's smoothing noise off as in the code, and evaluation is deterministic, as for every
algorithm here. No absorbing states: OPOLO's reward -log(1 - D) pays for every step alive,
as the paper's does.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from algorithms.offpolicy import expert_replay, sac_budget, sample_of, train_on_reward
from bench.harness.registry import Logger, Policy, Task, register
from bench.imitation.data import Demos
from bench.imitation.discriminator import (
    DiscriminatorConfig,
    discriminator_log,
    discriminator_step,
)
from bench.rl import flat_adam, sac
from bench.rl.networks import RunningNorm, mlp
from bench.rl.replay import ReplayBatch
from bench.rl.td3 import TD3, TD3Config
from bench.validate import at_least


@dataclass
class OPOLOConfig(TD3Config, DiscriminatorConfig):
    """TD3's settings as the authors run it (shared with OPOLO's controls,
    `algorithms.controls`), D's, and the dual form's and the inverse model's."""

    alpha: float = 0.1
    """Weight of the dual form's initial-state term, 2 alpha (1 - gamma) E[min Q(s, pi(s))]."""
    inverse_weight: float = 0.1
    """lambda: weight of the inverse-model regularizer on the actor."""
    disc_hidden: tuple[int, ...] = (256, 256)
    """Hidden layer sizes of D and of the inverse model M (tanh)."""
    disc_lr: float = 3e-4
    """Adam learning rate of D and M."""
    disc_steps: int = 10
    """D's Adam steps each time it trains."""
    disc_entropy: float = 0.001
    """Weight of the entropy bonus on D's predictions."""
    gp_target: float = 1.0
    """The gradient penalty pulls ||grad D|| towards 1 on expert/agent interpolates."""
    inverse_l2: float = 1e-3
    """Weight decay of the inverse model."""
    inverse_pretrain: int = 2_500
    """M's Adam steps at the first update, on the random steps collected so far."""
    inverse_steps: int = 50
    """M's Adam steps each time it trains."""
    train_every: int = 500
    """Updates between two rounds of D and M training."""

    def __post_init__(self) -> None:
        super().__post_init__()
        at_least(self, 0, "alpha", "inverse_weight", "inverse_l2", "inverse_pretrain")
        at_least(self, 1, "disc_steps", "inverse_steps", "train_every")


def normalized_pair(norm: RunningNorm, batch: ReplayBatch) -> torch.Tensor:
    """(s, s') of a minibatch, each normalized with the expert's statistics: what D and M read."""
    return torch.cat([norm(batch.raw("obs")), norm(batch.raw("next_obs"))], 1)


class StateTransitionD(nn.Module):
    """Logit of P(expert | s, s'), observations normalized with the expert's statistics."""

    def __init__(self, norm: RunningNorm, obs_dim: int, hidden: tuple[int, ...]) -> None:
        super().__init__()
        self.norm = norm
        self.net = mlp([2 * obs_dim, *hidden, 1])

    def inputs(self, batch: ReplayBatch) -> torch.Tensor:
        return normalized_pair(self.norm, batch)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x).squeeze(-1)


class InverseModel(nn.Module):
    """M(s, s') -> a, the action that took s to s', fitted on the agent's own replay."""

    def __init__(self, norm: RunningNorm, obs_dim: int, act_dim: int, hidden) -> None:
        super().__init__()
        self.norm = norm
        self.net = mlp([2 * obs_dim, *hidden, act_dim])

    def forward(self, batch: ReplayBatch) -> torch.Tensor:
        return self.net(normalized_pair(self.norm, batch))


class OPOLO(TD3):
    """TD3 on D's reward with the dual term and the inverse-model regularizer; the loop is
    SAC's (`bench.rl.sac.train`), which calls `explore` (TD3's) and `update`."""

    def __init__(self, task: Task, demos: Demos, cfg: OPOLOConfig, seed: int) -> None:
        # A deterministic actor: SAC's network, read through its mean (`Actor.act`), so the
        # kept policy is the same kind of file.
        obs_dim, act_dim = task.obs_dim, task.act_dim
        super().__init__(obs_dim, act_dim, task.action_low, task.action_high, cfg, seed)
        self.expert = expert_replay(demos, None, act_dim, absorbing=False).to(self.device)
        # D's and M's scale: the expert's states, fixed
        norm = RunningNorm.of(np.concatenate(demos.observations))
        self.disc = StateTransitionD(norm, obs_dim, cfg.disc_hidden).to(self.device)
        self.inverse = InverseModel(norm, obs_dim, act_dim, cfg.disc_hidden).to(self.device)
        self.disc_opt = flat_adam.adam(self.disc.net.parameters(), lr=cfg.disc_lr)
        self.inverse_opt = torch.optim.Adam(
            self.inverse.net.parameters(), lr=cfg.disc_lr, weight_decay=cfg.inverse_l2
        )

    def parts(self) -> dict[str, Any]:
        """Everything that changes as it learns (`bench.rl.resume`), but for counters."""
        mine = ("disc", "inverse", "disc_opt", "inverse_opt")
        return {**super().parts(), **{name: getattr(self, name) for name in mine}}

    # ------------------------------------------------------------ rewards

    @torch.no_grad()
    def reward(self, batch: ReplayBatch) -> torch.Tensor:
        """-log(1 - D(s, s')) from D as it is now, clipped as the authors' code clips it."""
        d = torch.sigmoid(self.disc(self.disc.inputs(batch)))
        return -torch.log((1 - d).clamp(1e-4, 1.0))

    def _expert_batch(self, n: int) -> ReplayBatch:
        return sample_of(self.expert, n, self.gen)

    # ------------------------------------------------------------ D and M

    def train_disc(self) -> None:
        for _ in range(self.cfg.disc_steps):
            p = self.disc.inputs(self.buffer.sample(self.cfg.batch_size, self.device))
            e = self.disc.inputs(self._expert_batch(len(p)))
            parts = discriminator_step(self.disc.net, self.disc_opt, p, e, self.cfg, self.gen)
        self.stats.update(discriminator_log(parts))

    def train_inverse(self, steps: int) -> None:
        for _ in range(steps):
            batch = self.buffer.sample(self.cfg.batch_size, self.device)
            loss = F.mse_loss(self.inverse(batch), batch.actions)
            self.inverse_opt.zero_grad()
            loss.backward()
            self.inverse_opt.step()
        self.stats["inverse_loss"] = loss.item()

    # ------------------------------------------------------------ one update

    def update(self, batch: ReplayBatch, rewards: torch.Tensor) -> dict[str, float]:
        cfg = self.cfg
        if self.updates == 0:
            self.train_inverse(cfg.inverse_pretrain)
        if self.updates % cfg.train_every == 0:
            self.train_disc()
            if self.updates > 0:
                self.train_inverse(cfg.inverse_steps)
        self.updates += 1
        dual = 2 * cfg.alpha * (1 - cfg.gamma)

        with torch.no_grad():
            next_q = torch.min(
                *self.critic_target(batch.next_obs, self.actor_target.act(batch.next_obs))
            )
            target = rewards + cfg.gamma * batch.not_done * next_q
        q1, q2 = self.critic(batch.obs, batch.actions)
        td = 0.5 * ((q1 - target).square() + (q2 - target).square()).mean()
        with torch.no_grad():
            on_policy = self.actor.act(batch.obs)
        initial = torch.min(*self.critic(batch.obs, on_policy)).mean()
        critic_loss = td + dual * initial
        self.critic_opt.zero_grad()
        critic_loss.backward()
        self.critic_opt.step()
        self.stats.update(critic_loss=td.item(), reward_mean=rewards.mean().item())

        if self.updates % cfg.policy_delay == 0:
            expert = self._expert_batch(cfg.batch_size)
            with torch.no_grad():
                inferred = self.inverse(expert)
            with sac.frozen(self.critic_params):
                q = torch.min(*self.critic(batch.obs, self.actor.act(batch.obs))).mean()
            imitation = (self.actor.act(expert.obs) - inferred).square().sum(-1).mean()
            actor_loss = -dual * q + cfg.inverse_weight * imitation
            self.actor_opt.zero_grad()
            actor_loss.backward()
            self.actor_opt.step()
            sac.soft_update(self.targets, self.followed, cfg.tau)
            self.stats.update(actor_q=q.item(), inverse_gap=imitation.item())
        return dict(self.stats)


@register(
    "opolo",
    config=OPOLOConfig,
    inputs="states",
    resumable=True,
    description="OPOLO: off-policy GAIfO on TD3, dual form, inverse-action regularizer",
    min_budget=sac_budget,
    family="td3",
    label="OPOLO",
)
def train(task: Task, demos: Demos, budget: int, seed: int, logger: Logger, config) -> Policy:
    learner = OPOLO(task, demos, config, seed)
    return train_on_reward(task, budget, seed, logger, config, learner.reward, learner)
