"""Policy and value networks, and the running observation normalizer they share."""

from __future__ import annotations

import copy
import math

import numpy as np
import torch
from torch import nn


class RunningNorm(nn.Module):
    """Running mean/variance of observations; buffers, so they save with the state dict.

    `update` is called by the trainer on each batch; evaluation never calls it,
    so the statistics are frozen as soon as training stops.
    """

    def __init__(self, dim: int, clip: float = 10.0, eps: float = 1e-8) -> None:
        super().__init__()
        self.clip, self.eps = clip, eps
        self.register_buffer("mean", torch.zeros(dim, dtype=torch.float64))
        self.register_buffer("var", torch.ones(dim, dtype=torch.float64))
        self.register_buffer("count", torch.tensor(eps, dtype=torch.float64))

    @torch.no_grad()
    def update(self, x: np.ndarray) -> None:
        """Fold a (B, O) batch into the statistics (parallel Welford)."""
        x = torch.as_tensor(x, dtype=torch.float64, device=self.mean.device).reshape(
            -1, self.mean.numel()
        )
        n = x.shape[0]
        if n == 0:
            return
        b_mean, b_var = x.mean(0), x.var(0, unbiased=False)
        total = self.count + n
        delta = b_mean - self.mean
        self.mean += delta * n / total
        self.var.copy_(
            (self.var * self.count + b_var * n + delta.square() * self.count * n / total) / total
        )
        self.count.fill_(total.item())

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        mean, std = self.mean.to(x.dtype), (self.var + self.eps).sqrt().to(x.dtype)
        return ((x - mean) / std).clamp(-self.clip, self.clip)


def mlp(sizes: list[int], activation: type[nn.Module] = nn.Tanh) -> nn.Sequential:
    layers: list[nn.Module] = []
    for i in range(len(sizes) - 1):
        layers.append(nn.Linear(sizes[i], sizes[i + 1]))
        if i < len(sizes) - 2:
            layers.append(activation())
    return nn.Sequential(*layers)


class GaussianPolicy(nn.Module):
    """Diagonal Gaussian over actions: mean from a tanh MLP, state-independent log std.

    Takes raw observations; normalizes them with its own `norm`.
    """

    def __init__(
        self, obs_dim: int, act_dim: int, hidden: tuple[int, ...] = (64, 64), log_std: float = -0.5
    ):
        super().__init__()
        self.norm = RunningNorm(obs_dim)
        self.mean_net = mlp([obs_dim, *hidden, act_dim])
        self.log_std = nn.Parameter(torch.full((act_dim,), float(log_std)))
        # Small last layer: initial actions near 0 instead of saturating the bounds.
        with torch.no_grad():
            last = self.mean_net[-1]
            last.weight.mul_(0.01)
            last.bias.zero_()

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        """Mean action for raw (B, O) observations."""
        return self.mean_net(self.norm(obs))

    def log_prob(self, mean: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """(B,) log density of `actions` under N(mean, exp(log_std)^2)."""
        z = (actions - mean) * torch.exp(-self.log_std)
        return (
            -0.5 * z.square().sum(-1)
            - self.log_std.sum()
            - 0.5 * math.log(2 * math.pi) * z.shape[-1]
        )


class ValueNet(nn.Module):
    """V(s) from raw observations, normalized with the policy's statistics."""

    def __init__(self, norm: RunningNorm, obs_dim: int, hidden: tuple[int, ...] = (64, 64)):
        super().__init__()
        self.norm = norm  # shared, not copied: one set of statistics per learner
        self.net = mlp([obs_dim, *hidden, 1])

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.net(self.norm(obs)).squeeze(-1)


class DeterministicPolicy:
    """numpy in, numpy out: the mean action, clipped to the action bounds.

    This is what the runner evaluates and what demonstrations are recorded with.
    """

    def __init__(self, policy: GaussianPolicy, low: np.ndarray, high: np.ndarray) -> None:
        self.policy = copy.deepcopy(policy).cpu().eval()  # a snapshot: training goes on without it
        self.low, self.high = np.asarray(low, np.float32), np.asarray(high, np.float32)

    @torch.no_grad()
    def __call__(self, obs: np.ndarray) -> np.ndarray:
        mean = self.policy(torch.as_tensor(np.asarray(obs, np.float32)))
        return np.clip(mean.numpy(), self.low, self.high)
