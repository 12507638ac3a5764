"""TD3 (Fujimoto et al. 2018), the optimizer under OPOLO, as OPOLO's authors run it.

A deterministic actor with Gaussian exploration noise, twin critics whose smaller estimate is
the target, and a delayed actor (and target) update. The loop is SAC's (`bench.rl.sac.train`),
which calls `explore` and `update`; settings are the OPOLO code's (`TD3Config`), so OPOLO's
controls run the very optimizer OPOLO does, on the env's reward or on one for staying alive.
As in that code, the critic's target has no smoothing noise.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

import torch

from bench.rl import flat_adam, replay, sac
from bench.rl.resume import Stateful
from bench.validate import at_least


@dataclass
class TD3Config(sac.SACConfig):
    """SAC's loop settings with TD3's defaults as the OPOLO code sets them."""

    hidden: tuple[int, ...] = (400, 300)
    batch_size: int = 100
    learning_starts: int = 10_000
    absorbing: bool = False
    exploration_noise: float = 0.1
    """Std of the Gaussian added to the actor's action while collecting, as a fraction of
    half the action range."""
    policy_delay: int = 2
    """Critic updates per actor (and target) update."""

    def __post_init__(self) -> None:
        super().__post_init__()
        at_least(self, 0, "exploration_noise")
        at_least(self, 1, "policy_delay")


class TD3(Stateful):
    """The actor, twin critics, their targets and optimizers, and the replay buffer."""

    def __init__(self, obs_dim: int, act_dim: int, low, high, cfg: TD3Config, seed: int) -> None:
        torch.manual_seed(seed)  # built on the CPU and then moved: the same weights anywhere
        self.cfg, self.device = cfg, sac.usable_device(cfg.device)
        self.actor = sac.Actor(obs_dim, act_dim, cfg.hidden, low, high).to(self.device)
        self.critic = sac.TwinQ(obs_dim, act_dim, cfg.hidden).to(self.device)
        self.actor_target = copy.deepcopy(self.actor)
        self.critic_target = copy.deepcopy(self.critic)
        self.actor_opt = flat_adam.adam(self.actor.parameters(), lr=cfg.lr)
        self.critic_opt = flat_adam.adam(self.critic.parameters(), lr=cfg.lr)
        self.buffer = replay.ReplayBuffer(obs_dim, act_dim, cfg.buffer_size, seed)
        self.critic_params = list(self.critic.parameters())
        self.targets = [*self.actor_target.parameters(), *self.critic_target.parameters()]
        self.followed = [*self.actor.parameters(), *self.critic_params]
        self.gen = torch.Generator().manual_seed(seed + 3)
        self.updates = 0
        self.stats: dict[str, float] = {}

    def parts(self) -> dict[str, Any]:
        networks = ("actor", "critic", "actor_target", "critic_target")
        return {
            n: getattr(self, n) for n in (*networks, "actor_opt", "critic_opt", "buffer", "gen")
        }

    def state_dict(self) -> dict[str, Any]:
        return {**super().state_dict(), "updates": self.updates, "stats": self.stats}

    def load_state_dict(self, state: dict[str, Any]) -> None:
        super().load_state_dict(state)
        self.updates, self.stats = state["updates"], dict(state["stats"])

    def explore(self, obs: torch.Tensor) -> torch.Tensor:
        action = self.actor.act(obs)
        noise = torch.randn(action.shape, generator=self.gen).to(self.device)
        noise = noise * self.cfg.exploration_noise
        low, high = self.actor.centre - self.actor.scale, self.actor.centre + self.actor.scale
        return torch.maximum(torch.minimum(action + noise * self.actor.scale, high), low)

    def update(self, batch: replay.ReplayBatch, rewards: torch.Tensor) -> dict[str, float]:
        cfg = self.cfg
        self.updates += 1
        with torch.no_grad():
            next_q = torch.min(
                *self.critic_target(batch.next_obs, self.actor_target.act(batch.next_obs))
            )
            target = rewards + cfg.gamma * batch.not_done * next_q
        q1, q2 = self.critic(batch.obs, batch.actions)
        td = 0.5 * ((q1 - target).square() + (q2 - target).square()).mean()
        self.critic_opt.zero_grad()
        td.backward()
        self.critic_opt.step()
        self.stats.update(critic_loss=td.item(), reward_mean=rewards.mean().item())
        if self.updates % cfg.policy_delay == 0:
            with sac.frozen(self.critic_params):
                q = torch.min(*self.critic(batch.obs, self.actor.act(batch.obs))).mean()
            self.actor_opt.zero_grad()
            (-q).backward()
            self.actor_opt.step()
            sac.soft_update(self.targets, self.followed, cfg.tau)
            self.stats["actor_q"] = q.item()
        return dict(self.stats)
