"""Policy and value networks, and the observation normalizer they share.

Observations are vectors (O,), or flat frames whose image shape (C, H, W) is given: then
the normalizer scales pixels to [0, 1] and every network starts with a small convolutional
trunk (`body`)."""

from __future__ import annotations

import copy
import math
from collections.abc import Callable

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

    @classmethod
    def of(cls, states: np.ndarray) -> RunningNorm:
        """A norm at the statistics of (N, O) `states`, e.g. an expert's; fixed, as nothing
        calls its `update` after."""
        norm = cls(states.shape[1])
        norm.update(states)
        return norm

    @torch.no_grad()
    def update(self, x: np.ndarray) -> None:
        """Fold a (B, O) batch into the statistics (parallel Welford)."""
        x = torch.as_tensor(x, dtype=torch.float64).reshape(-1, self.mean.numel())
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


class PixelScale(nn.Module):
    """Frames' normalizer: flat uint8 (B, C*H*W) -> (B, C, H, W) floats in [0, 1]. Fixed: pixels
    have known bounds, and statistics of a mostly still background would amplify noise."""

    def __init__(self, shape: tuple[int, int, int]) -> None:
        super().__init__()
        self.shape = tuple(shape)

    def update(self, x: np.ndarray) -> None:
        """Nothing to learn (RunningNorm's interface)."""

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x.to(torch.float32).reshape(-1, *self.shape) / 255.0


ObsShape = int | tuple[int, ...]
"""O for vectors, (C, H, W) for frames."""


def shape_of(obs_shape: ObsShape) -> tuple[int, ...]:
    """(O,) for an int O, else the shape as a tuple."""
    return (obs_shape,) if isinstance(obs_shape, int) else tuple(obs_shape)


def normalizer(obs_shape: ObsShape) -> RunningNorm | PixelScale:
    """RunningNorm for vectors, PixelScale for frames."""
    shape = shape_of(obs_shape)
    return RunningNorm(shape[0]) if len(shape) == 1 else PixelScale(shape)


def observation(o: np.ndarray) -> np.ndarray:
    """What networks and policies are given: float32 state vectors, or uint8 flat frames as they
    are (a quarter of float32's memory; PixelScale scales them)."""
    o = np.asarray(o)
    return o if o.dtype == np.uint8 else o.astype(np.float32, copy=False)


def mlp(sizes: list[int], activation: type[nn.Module] = nn.Tanh) -> nn.Sequential:
    layers: list[nn.Module] = []
    for i in range(len(sizes) - 1):
        layers.append(nn.Linear(sizes[i], sizes[i + 1]))
        if i < len(sizes) - 2:
            layers.append(activation())
    return nn.Sequential(*layers)


def orthogonal_init(net: nn.Module, last_gain: float) -> None:
    """Orthogonal weights and zero biases: gain sqrt(2) on every layer but the last, `last_gain`
    on the last (OpenAI Baselines' and Stable-Baselines3's initialization for TRPO and PPO)."""
    layers = [m for m in net.modules() if isinstance(m, nn.Linear | nn.Conv2d)]
    for i, layer in enumerate(layers):
        gain = last_gain if i == len(layers) - 1 else math.sqrt(2)
        nn.init.orthogonal_(layer.weight, gain)
        nn.init.zeros_(layer.bias)


class ConvTrunk(nn.Module):
    """(B, C, H, W) images in [0, 1] -> (B, F) features: the first two layers of the DQN
    encoder (8x8 stride 4, 4x4 stride 2, ReLU) at half its width, small enough for CPUs."""

    def __init__(self, shape: tuple[int, int, int]) -> None:
        super().__init__()
        channels = shape[0]
        self.net = nn.Sequential(
            nn.Conv2d(channels, 16, 8, stride=4),
            nn.ReLU(),
            nn.Conv2d(16, 32, 4, stride=2),
            nn.ReLU(),
            nn.Flatten(),
        )
        with torch.no_grad():
            self.out_dim = int(self.net(torch.zeros(1, *shape)).shape[1])

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.net(x)


def body(
    obs_shape: ObsShape, hidden: tuple[int, ...], out_dim: int, trunk: ConvTrunk | None = None
) -> nn.Sequential:
    """A tanh MLP on normalized observations; for frames, a ConvTrunk in front of it (`trunk`,
    to share one that exists, else a new one)."""
    shape = shape_of(obs_shape)
    if len(shape) == 1:
        return mlp([shape[0], *hidden, out_dim])
    trunk = trunk or ConvTrunk(shape)
    return nn.Sequential(trunk, mlp([trunk.out_dim, *hidden, out_dim]))


class GaussianPolicy(nn.Module):
    """Diagonal Gaussian over actions: mean from a tanh MLP, state-independent log std.

    Takes raw observations (vectors, or flat frames given their (C, H, W) shape) and
    normalizes them with its own `norm`. From frames, a ConvTrunk (`trunk`) turns them into
    features first; for vectors `trunk` is the identity.
    """

    def __init__(
        self,
        obs_shape: ObsShape,
        act_dim: int,
        hidden: tuple[int, ...] = (64, 64),
        log_std: float = -0.5,
    ):
        super().__init__()
        shape = shape_of(obs_shape)
        self.norm = normalizer(obs_shape)
        self.trunk: nn.Module = ConvTrunk(shape) if len(shape) == 3 else nn.Identity()
        features = self.trunk.out_dim if len(shape) == 3 else shape[0]
        self.mean_net = mlp([features, *hidden, act_dim])
        self.log_std = nn.Parameter(torch.full((act_dim,), float(log_std)))
        # Small last layer: initial actions near 0 instead of saturating the bounds.
        with torch.no_grad():
            last = [m for m in self.mean_net.modules() if isinstance(m, nn.Linear)][-1]
            last.weight.mul_(0.01)
            last.bias.zero_()

    def features(self, obs: torch.Tensor) -> torch.Tensor:
        """What the mean's MLP reads: normalized states, or the trunk's features of frames."""
        return self.trunk(self.norm(obs))

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        """Mean action for raw (B, O) observations."""
        return self.mean_net(self.features(obs))

    def frozen_mean(self) -> Callable[[torch.Tensor], torch.Tensor]:
        """`forward` as it stands now, for many calls while nothing changes the policy (a
        batch's collection): the normalizer's statistics converted once, the layers called
        without nn.Module's dispatch. The same operations, so the same values to the bit; where
        the policy is not the plain MLP on a RunningNorm (a subclass, frames), `forward`."""
        layers = list(self.mean_net)
        plain = (
            type(self) is GaussianPolicy
            and type(self.norm) is RunningNorm
            and type(self.trunk) is nn.Identity
            and all(type(m) in (nn.Linear, nn.Tanh) for m in layers)
        )
        if not plain:
            return self.forward
        norm = self.norm
        mean, std = norm.mean.to(torch.float32), (norm.var + norm.eps).sqrt().to(torch.float32)
        steps = [(m.weight, m.bias) if type(m) is nn.Linear else None for m in layers]

        def mean_action(obs: torch.Tensor) -> torch.Tensor:
            if obs.dtype != torch.float32:
                return self.forward(obs)
            x = ((obs - mean) / std).clamp(-norm.clip, norm.clip)
            for step in steps:
                x = torch.tanh(x) if step is None else nn.functional.linear(x, *step)
            return x

        return mean_action

    def head_parameters(self) -> list[nn.Parameter]:
        """The parameters after the trunk (log std and the mean's MLP), in `parameters()` order:
        what TRPO's natural-gradient step moves (the trunk learns with the value function)."""
        trunk = {id(p) for p in self.trunk.parameters()}
        return [p for p in self.parameters() if id(p) not in trunk]

    def log_prob(self, mean: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """(B,) log density of `actions` under N(mean, exp(log_std)^2)."""
        z = (actions - mean) * torch.exp(-self.log_std)
        return (
            -0.5 * z.square().sum(-1)
            - self.log_std.sum()
            - 0.5 * math.log(2 * math.pi) * z.shape[-1]
        )


class ValueNet(nn.Module):
    """V(s) from raw observations, normalized with the policy's statistics. Given the policy's
    `trunk` (frames), it reads the same features and trains that trunk with its own loss."""

    def __init__(
        self,
        norm: RunningNorm | PixelScale,
        obs_shape: ObsShape,
        hidden: tuple[int, ...] = (64, 64),
        trunk: ConvTrunk | None = None,
    ):
        super().__init__()
        self.norm = norm  # shared, not copied: one set of statistics per learner
        self.net = body(obs_shape, hidden, 1, trunk)
        self.frames = len(shape_of(obs_shape)) == 3

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return self.net(self.norm(obs)).squeeze(-1)

    def head(self, features: torch.Tensor) -> torch.Tensor:
        """V from features the trunk already computed (frames; for vectors, the normalized
        states): with a shared trunk, one trunk pass serves the policy and the value."""
        return (self.net[1] if self.frames else self.net)(features).squeeze(-1)


class DeterministicPolicy:
    """numpy in, numpy out: the mean action, clipped to the action bounds.

    This is what the runner evaluates and what demonstrations are recorded with.
    """

    def __init__(self, policy: GaussianPolicy, low: np.ndarray, high: np.ndarray) -> None:
        self.policy = copy.deepcopy(policy).eval()  # a snapshot: training goes on without it
        self.low, self.high = np.asarray(low, np.float32), np.asarray(high, np.float32)

    @torch.no_grad()
    def __call__(self, obs: np.ndarray) -> np.ndarray:
        mean = self.policy(torch.as_tensor(observation(obs)))
        return np.clip(mean.numpy(), self.low, self.high)

    def state(self) -> dict:
        """Everything needed to rebuild it, as tensors, numbers and lists (weights_only-safe)."""
        norm = self.policy.norm
        obs_shape = list(norm.shape) if isinstance(norm, PixelScale) else [norm.mean.numel()]
        layers = [m for m in self.policy.mean_net.modules() if isinstance(m, nn.Linear)]
        return {
            "kind": "gaussian-mean",
            "obs_shape": obs_shape,
            "act_dim": layers[-1].out_features,
            "hidden": [layer.out_features for layer in layers[:-1]],
            "low": torch.from_numpy(self.low),
            "high": torch.from_numpy(self.high),
            "weights": self.policy.state_dict(),
        }

    @classmethod
    def from_state(cls, state: dict) -> DeterministicPolicy:
        shape = state["obs_shape"]
        policy = GaussianPolicy(
            shape[0] if len(shape) == 1 else tuple(shape), state["act_dim"], tuple(state["hidden"])
        )
        policy.load_state_dict(state["weights"])
        return cls(policy, state["low"].numpy(), state["high"].numpy())
