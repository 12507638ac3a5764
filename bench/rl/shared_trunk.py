"""TRPO from frames: the policy and the value function share one conv trunk.

The natural-gradient step moves the policy's head only, since a trust region of 0.01 nats
spread over every conv weight starves the features of learning; the trunk learns with the
value function instead, as in PPO's Atari networks. Value learning then moves the policy
too, so it pays for that: the value loss carries the KL by which the trunk's step moves the
policy's mean actions (Phasic Policy Gradient's cloning term), and a step that still moves
them past the trust region is backtracked (`hold_trunk`).
"""

from __future__ import annotations

import torch
from torch import nn

from bench.rl.networks import GaussianPolicy, ObsShape, ValueNet, shape_of
from bench.rl.trpo import TRPO, TRPOConfig, value_step

CLONE_WEIGHT = 1.0
"""Weight of the policy-keeping KL in the value loss (Phasic Policy Gradient's
behavioural-cloning weight, beta_clone = 1)."""


def make_trpo(obs_shape: ObsShape, act_dim: int, cfg: TRPOConfig, seed: int) -> TRPO:
    """The TRPO learner for a task's observations: states (O,) or frames (C, H, W)."""
    frames = len(shape_of(obs_shape)) == 3
    return (SharedTrunkTRPO if frames else TRPO)(obs_shape, act_dim, cfg, seed)


def mean_kl(policy: GaussianPolicy, old_mean: torch.Tensor, mean: torch.Tensor) -> torch.Tensor:
    """Mean KL(old || new) between two Gaussians of the same std that differ in their means."""
    return (
        ((mean - old_mean).square() / (2 * torch.exp(2 * policy.log_std.detach()))).sum(-1).mean()
    )


class SharedTrunkTRPO(TRPO):
    """TRPO whose value function reads the policy's trunk, and trains it."""

    def value_net(self, obs_shape: ObsShape) -> ValueNet:
        return ValueNet(self.policy.norm, obs_shape, self.cfg.hidden, self.policy.trunk)

    def value_optimizer(self) -> torch.optim.Optimizer:
        """torch's Adam: the trunk it trains is the policy's, and `hold_trunk` moves it by
        reassigning its parameters, which would cut them from a flat buffer."""
        return torch.optim.Adam(self.value.net.parameters(), lr=self.cfg.vf_lr)

    def state_values(self, obs: torch.Tensor, features: torch.Tensor) -> torch.Tensor:
        return self.value.head(features)  # one trunk pass serves both heads

    def fit_value(
        self, obs: torch.Tensor, features: torch.Tensor, targets: torch.Tensor
    ) -> dict[str, float]:
        """Value regression that also pays the KL by which it moves the policy's mean actions
        (from those after the policy step), then held inside the trust region."""
        policy = self.policy
        with torch.no_grad():
            old_mean = policy.mean_net(features)
        before = nn.utils.parameters_to_vector(policy.trunk.parameters()).detach()

        def loss_of(idx: torch.Tensor) -> torch.Tensor:
            seen = policy.features(obs[idx])  # one trunk pass per minibatch, both heads
            value_loss = (self.value.head(seen) - targets[idx]).square().mean()
            clone = mean_kl(policy, old_mean[idx], policy.mean_net(seen))
            return value_loss + CLONE_WEIGHT * clone

        loss = value_step(self.vf_opt, len(obs), loss_of, self.cfg, self.gen)
        return {"vf_loss": loss, **self.hold_trunk(obs, old_mean, before)}

    @torch.no_grad()
    def hold_trunk(
        self, obs: torch.Tensor, old_mean: torch.Tensor, before: torch.Tensor
    ) -> dict[str, float]:
        """Keep the trunk's value-learning step inside the trust region: if it moved the
        policy's mean actions on `obs` (from `old_mean`) by a KL above max_kl, halve the step
        (TRPO's backtracking) until it does not, or undo it. The cloning term keeps that KL
        small on most updates; this bounds the others (~6% of a pixel InvertedPendulum run's;
        one drift of 4x the trust region was followed by a balanced pendulum falling for good)."""
        trunk = list(self.policy.trunk.parameters())
        after = nn.utils.parameters_to_vector(trunk)
        kl = mean_kl(self.policy, old_mean, self.policy(obs)).item()
        moved = kl
        frac = 1.0
        while kl > self.cfg.max_kl:
            frac /= 2
            if frac < 0.5**self.cfg.line_search_steps:
                frac, kl = 0.0, 0.0
                nn.utils.vector_to_parameters(before, trunk)
                break
            nn.utils.vector_to_parameters(before + frac * (after - before), trunk)
            kl = mean_kl(self.policy, old_mean, self.policy(obs)).item()
        return {"trunk_kl": kl, "trunk_kl_before_hold": moved, "trunk_step_frac": frac}
