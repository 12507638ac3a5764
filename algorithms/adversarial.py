"""The adversarial imitation loop GAIfO and GAIL share; they differ only in D's inputs.

Each iteration: collect a batch with the current policy, train the
discriminator D (Adam, cross-entropy, expert = 1) on policy vs expert samples,
then take one TRPO step on the reward D gives the batch.

Termination bias: PyBullet tasks end early when the agent falls, so a reward
that is always positive (-log(1 - D), the default) pays for survival whatever
D says, and one that is always negative (log D) pays for ending episodes fast;
compare with the `survival` control before crediting the imitation.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from algorithms.common import deterministic, on_task_device, report_each_update
from bench.registry import Logger, Task
from bench.rl.networks import DeterministicPolicy, RunningNorm, mlp
from bench.rl.rollout import Batch
from bench.rl.trpo import TRPO, TRPOConfig, train

REWARDS: dict[str, Callable[[torch.Tensor], torch.Tensor]] = {
    "-log(1-D)": lambda logit: F.softplus(logit),  # -log(1 - sigmoid(x)) = softplus(x) > 0
    "log D": lambda logit: -F.softplus(-logit),  # log sigmoid(x) < 0
    "log D - log(1-D)": lambda logit: logit,  # the logit itself, either sign
}


@dataclass
class AdversarialConfig(TRPOConfig):
    """TRPO's settings (inherited, two defaults changed) plus the discriminator's."""

    init_log_std: float = -0.5
    """Less action noise than plain TRPO: a noisy policy is told apart from the expert by its noise alone."""

    disc_hidden: tuple[int, ...] = (100, 100)
    """Hidden layer sizes of the discriminator MLP (tanh)."""
    disc_lr: float = 3e-4
    """Adam learning rate of the discriminator."""
    disc_steps: int = 5
    """Discriminator minibatch steps per policy update."""
    disc_minibatch: int = 256
    """Policy samples (and as many expert samples) per discriminator step."""
    grad_penalty: float = 10.0
    """Weight of a gradient penalty on expert/policy interpolates (smooths D); 0 disables it."""
    gp_target: float = 0.0
    """Gradient norm the penalty pulls towards: 0 (zero-centred) or 1 (WGAN-GP style)."""
    reward: str = "-log(1-D)"
    """Policy reward as a function of D = P(expert): "-log(1-D)", "log D" or "log D - log(1-D)"."""

    def __post_init__(self) -> None:
        if self.reward not in REWARDS:
            raise ValueError(
                f"reward must be one of {', '.join(map(repr, REWARDS))}, not {self.reward!r}"
            )
        self.hidden, self.disc_hidden = tuple(self.hidden), tuple(self.disc_hidden)


class Discriminator(nn.Module):
    """Logit of P(expert | features); observations normalized with the policy's statistics."""

    def __init__(
        self, norm: RunningNorm, n_obs: int, extra_dim: int, hidden: tuple[int, ...]
    ) -> None:
        super().__init__()
        self.norm, self.n_obs = norm, n_obs  # n_obs observation blocks come first, then raw extras
        obs_dim = norm.mean.numel()
        self.net = mlp([n_obs * obs_dim + extra_dim, *hidden, 1])

    def normalize(self, x: torch.Tensor) -> torch.Tensor:
        """Observation blocks scaled by the policy's statistics; extras (actions) as they are."""
        d = self.norm.mean.numel()
        parts = [self.norm(x[:, i * d : (i + 1) * d]) for i in range(self.n_obs)]
        return torch.cat([*parts, x[:, self.n_obs * d :]], dim=1)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(self.normalize(x)).squeeze(-1)


def discriminator_step(
    disc: Discriminator,
    opt: torch.optim.Optimizer,
    policy_x: torch.Tensor,
    expert_x: torch.Tensor,
    cfg: AdversarialConfig,
    gen: torch.Generator,
) -> dict[str, float]:
    """`disc_steps` Adam steps of binary cross-entropy, expert labelled 1; returns the last losses."""
    for _ in range(cfg.disc_steps):
        p = disc.normalize(
            policy_x[torch.randint(len(policy_x), (cfg.disc_minibatch,), generator=gen)]
        )
        e = disc.normalize(
            expert_x[torch.randint(len(expert_x), (cfg.disc_minibatch,), generator=gen)]
        )
        logit_p, logit_e = disc.net(p).squeeze(-1), disc.net(e).squeeze(-1)
        bce = F.binary_cross_entropy_with_logits(
            logit_p, torch.zeros_like(logit_p)
        ) + F.binary_cross_entropy_with_logits(logit_e, torch.ones_like(logit_e))
        penalty = torch.zeros(())
        if cfg.grad_penalty > 0:
            # On normalized inputs: raw PyBullet features with tiny variance would make the
            # gradient w.r.t. raw inputs huge and the penalty would swamp the classifier.
            alpha = torch.rand(len(p), 1, generator=gen)
            mix = (alpha * e + (1 - alpha) * p).detach().requires_grad_(True)
            grad = torch.autograd.grad(disc.net(mix).sum(), mix, create_graph=True)[0]
            penalty = (grad.norm(dim=1) - cfg.gp_target).square().mean()
        opt.zero_grad()
        (bce + cfg.grad_penalty * penalty).backward()
        opt.step()
    return {
        "disc_loss": bce.item(),
        "disc_grad_penalty": penalty.item(),
        "disc_acc_policy": (logit_p < 0).float().mean().item(),
        "disc_acc_expert": (logit_e > 0).float().mean().item(),
    }


def train_adversarial(
    task: Task,
    expert_features: np.ndarray,
    features: Callable[[Batch], np.ndarray],
    n_obs: int,
    seed: int,
    budget: int,
    logger: Logger,
    cfg: AdversarialConfig,
) -> DeterministicPolicy:
    """The shared loop. `features(batch)` -> (T*E, F) policy features, laid out like `expert_features`."""
    cfg = on_task_device(cfg, task)
    learner = TRPO(task.obs_dim, task.act_dim, cfg, seed)
    device = learner.device
    extra = expert_features.shape[1] - n_obs * task.obs_dim
    disc = Discriminator(learner.policy.norm, n_obs, extra, cfg.disc_hidden).to(device)
    opt = torch.optim.Adam(disc.net.parameters(), lr=cfg.disc_lr)
    expert_x = torch.as_tensor(expert_features, dtype=torch.float32, device=device)
    gen = torch.Generator().manual_seed(seed + 2)
    reward = REWARDS[cfg.reward]
    stats: dict[str, float] = {}

    def reward_fn(batch: Batch) -> np.ndarray:
        policy_x = torch.as_tensor(features(batch), device=device)
        stats.update(discriminator_step(disc, opt, policy_x, expert_x, cfg, gen))
        with torch.no_grad():
            r = reward(disc(policy_x))
        return r.cpu().numpy().reshape(batch.rewards.shape)

    train(
        task.make_env,
        budget,
        seed,
        reward_fn=reward_fn,
        callback=report_each_update(task, logger, stats),
        learner=learner,
    )
    return deterministic(learner, task)
