"""Soft Actor-Critic (Haarnoja et al. 2018), the off-policy optimizer, with absorbing states.

Reads top to bottom: config, the networks, one update, and the training loop; the replay
buffer it learns from is `bench.rl.replay`. As with TRPO (`bench.rl.trpo`) the reward is
pluggable: `reward_fn(batch)` is called on every minibatch the critic learns from, so a learned
reward is always the current one (DAC's recipe, Kostrikov et al. 2019) rather than the one in
force when the step was taken.

Terminations. With `absorbing` (the default), an episode that terminates leads into an
absorbing state that loops on itself for ever, as DAC stores it (`bench.rl.replay`), and
nothing is masked as "done", so the reward of the absorbing state, whatever a learned reward
makes of it, decides what ending an episode is worth (`bench.rl.absorbing` says why).
Truncation (a time limit) is not an end: it bootstraps as usual. With `absorbing: false` a
termination is masked (Q of what follows is 0), the textbook SAC.
"""

from __future__ import annotations

import copy
import math
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field
from typing import Any, Protocol

import gymnasium as gym
import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from bench.rl import flat_adam
from bench.rl.networks import mlp
from bench.rl.replay import ReplayBatch, ReplayBuffer, flagged, transitions_of_step
from bench.rl.resume import TORCH_RNG, Resumable, Snapshots, Stateful
from bench.rl.rollout import Batch, VecCollector
from bench.validate import Checked, layers


@dataclass
class SACConfig(Checked):
    hidden: tuple[int, ...] = (256, 256)
    """Hidden layer sizes of the actor and of each critic (ReLU)."""
    gamma: float = 0.99
    """Discount factor."""
    tau: float = 0.005
    """Polyak step of the target critics towards the critics, per update."""
    lr: float = 3e-4
    """Adam learning rate of actor, critics and temperature."""
    batch_size: int = 256
    """Transitions per update."""
    buffer_size: int = 1_000_000
    """Transitions the replay buffer holds (the oldest go first)."""
    learning_starts: int = 5_000
    """Env steps of uniform random actions before the first update."""
    updates_per_step: float = 1.0
    """Updates per env step (the update-to-data ratio); below 1, an update every few steps."""
    n_envs: int = 1
    """Envs stepped side by side (one batched actor forward per step)."""
    absorbing: bool = True
    """Terminations lead into an absorbing state (DAC); off: they are masked."""
    device: str = "cpu"
    """Where the networks and their updates run: "cpu", or "cuda" ("cuda:1") for a GPU. The
    replay buffer and the envs stay in CPU memory; each minibatch goes over as it is sampled."""

    def __post_init__(self) -> None:
        super().__post_init__()
        layers(self, "hidden")
        try:
            kind = torch.device(self.device).type
        except (RuntimeError, TypeError):
            kind = None
        if kind not in ("cpu", "cuda"):
            raise ValueError(f"device must be cpu or cuda (cuda:N), not {self.device!r}")
        for name in ("batch_size", "buffer_size", "n_envs"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, not {getattr(self, name)}")
        if not (0 < self.gamma < 1 and 0 < self.tau <= 1 and self.lr > 0):
            raise ValueError("need 0 < gamma < 1, 0 < tau <= 1 and lr > 0")
        if self.updates_per_step <= 0 or self.learning_starts < 0:
            raise ValueError("need updates_per_step > 0 and learning_starts >= 0")


# ---------------------------------------------------------------- networks


class Actor(nn.Module):
    """tanh-squashed Gaussian over actions, scaled to the env's bounds."""

    def __init__(self, obs_dim: int, act_dim: int, hidden: tuple[int, ...], low, high) -> None:
        super().__init__()
        self.net = mlp([obs_dim + 1, *hidden, 2 * act_dim], activation=nn.ReLU)
        self.register_buffer("scale", torch.as_tensor((high - low) / 2, dtype=torch.float32))
        self.register_buffer("centre", torch.as_tensor((high + low) / 2, dtype=torch.float32))

    def forward(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        mean, log_std = self.net(obs).chunk(2, dim=-1)
        return mean, log_std.clamp(-5.0, 2.0)

    def sample(self, obs: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Actions and their log densities, reparameterized (gradients flow through)."""
        mean, log_std = self(obs)
        u = mean + log_std.exp() * torch.randn_like(mean)
        squashed = torch.tanh(u)
        log_prob = (
            gaussian_log_prob(u, mean, log_std.exp())
            - torch.log(self.scale * (1 - squashed.square()) + 1e-6)
        ).sum(-1)
        return squashed * self.scale + self.centre, log_prob

    def act(self, obs: torch.Tensor) -> torch.Tensor:
        """The deterministic action: the squashed mean."""
        return torch.tanh(self(obs)[0]) * self.scale + self.centre


def gaussian_log_prob(x: torch.Tensor, mean: torch.Tensor, std: torch.Tensor) -> torch.Tensor:
    """`torch.distributions.Normal(mean, std).log_prob(x)`, its very operations in its order
    (the same numbers to the bit), without building and validating a distribution per call:
    ~5% of a small network's update."""
    return -((x - mean) ** 2) / (2 * std**2) - std.log() - _LOG_SQRT_2PI


_LOG_SQRT_2PI = math.log(math.sqrt(2 * math.pi))


class TwinQ(nn.Module):
    def __init__(self, obs_dim: int, act_dim: int, hidden: tuple[int, ...]) -> None:
        super().__init__()
        self.q1 = mlp([obs_dim + 1 + act_dim, *hidden, 1], activation=nn.ReLU)
        self.q2 = mlp([obs_dim + 1 + act_dim, *hidden, 1], activation=nn.ReLU)

    def forward(self, obs: torch.Tensor, actions: torch.Tensor) -> tuple[torch.Tensor, ...]:
        x = torch.cat([obs, actions], dim=-1)
        return self.q1(x).squeeze(-1), self.q2(x).squeeze(-1)


class DeterministicActor:
    """numpy in, numpy out: what the runner evaluates (observations get their flag, 0)."""

    def __init__(self, actor: Actor) -> None:
        self.actor = copy.deepcopy(actor).to("cpu").eval()  # evaluated and saved on the CPU

    @torch.no_grad()
    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return self.actor.act(torch.from_numpy(flagged(obs))).numpy()

    def state(self) -> dict:
        """Everything needed to rebuild it, as tensors, numbers and lists (weights_only-safe)."""
        layers = [m for m in self.actor.net.modules() if isinstance(m, nn.Linear)]
        return {
            "kind": "sac-actor",
            "obs_dim": layers[0].in_features - 1,
            "act_dim": layers[-1].out_features // 2,
            "hidden": [layer.out_features for layer in layers[:-1]],
            "weights": self.actor.state_dict(),
        }

    @classmethod
    def from_state(cls, state: dict) -> DeterministicActor:
        scale, centre = state["weights"]["scale"], state["weights"]["centre"]
        low, high = (centre - scale).numpy(), (centre + scale).numpy()
        actor = Actor(state["obs_dim"], state["act_dim"], tuple(state["hidden"]), low, high)
        actor.load_state_dict(state["weights"])
        return cls(actor)


# ---------------------------------------------------------------- the learner


@dataclass(frozen=True)
class Logged:
    """Rewards of a minibatch with the diagnostics the reward wants logged (D's accuracy, say):
    the loop logs them with the update's own."""

    rewards: torch.Tensor
    logged: dict[str, float]


SACRewardFn = Callable[[ReplayBatch], "torch.Tensor | Logged"]
"""reward_fn(batch) -> (B,) rewards of a minibatch, e.g. from the current discriminator, or
`Logged` rewards."""


class SAC(Stateful):
    def __init__(self, obs_dim: int, act_dim: int, low, high, cfg: SACConfig, seed: int) -> None:
        torch.manual_seed(seed)  # built on the CPU and then moved: the same weights anywhere
        self.cfg, self.act_dim, self.device = cfg, act_dim, usable_device(cfg.device)
        self.actor = Actor(obs_dim, act_dim, cfg.hidden, low, high).to(self.device)
        self.critic = TwinQ(obs_dim, act_dim, cfg.hidden).to(self.device)
        self.target = TwinQ(obs_dim, act_dim, cfg.hidden).to(self.device)
        self.target.load_state_dict(self.critic.state_dict())
        self.log_alpha = torch.zeros(1, device=self.device, requires_grad=True)
        self.target_entropy = -float(act_dim)
        # over flat buffers (on a GPU foreach): a few kernels per Adam step instead of a loop
        # over tensors, the same numbers to the bit; 20-25% less time per update at 64 x 64
        self.actor_opt = flat_adam.adam(self.actor.parameters(), lr=cfg.lr)
        self.critic_opt = flat_adam.adam(self.critic.parameters(), lr=cfg.lr)
        self.alpha_opt = torch.optim.Adam([self.log_alpha], lr=cfg.lr)
        # Listed once: walking a module's tree for its parameters costs more than the
        # operations on them at these network sizes.
        self.critic_params = list(self.critic.parameters())
        self.target_params = list(self.target.parameters())
        self.buffer = ReplayBuffer(obs_dim, act_dim, cfg.buffer_size, seed)

    def parts(self) -> dict[str, Any]:
        """Everything that changes as it learns (`bench.rl.resume`)."""
        names = ("actor", "critic", "target", "log_alpha", "buffer")
        optimizers = ("actor_opt", "critic_opt", "alpha_opt")
        return {name: getattr(self, name) for name in (*names, *optimizers)}

    def explore(self, obs: torch.Tensor) -> torch.Tensor:
        """Actions to collect with: samples of the squashed Gaussian."""
        return self.actor.sample(obs)[0]

    def update(self, batch: ReplayBatch, rewards: torch.Tensor) -> dict[str, float]:
        """One step of critics, actor and temperature on `batch` with `rewards` (B,)."""
        alpha = self.log_alpha.exp().detach()
        with torch.no_grad():
            next_actions, next_log_prob = self.actor.sample(batch.next_obs)
            q_next = torch.min(*self.target(batch.next_obs, next_actions))
            soft_next = q_next - alpha * next_log_prob
            target = rewards + self.cfg.gamma * batch.not_done * soft_next
        q1, q2 = self.critic(batch.obs, batch.actions)
        critic_loss = F.mse_loss(q1, target) + F.mse_loss(q2, target)
        self.critic_opt.zero_grad()
        critic_loss.backward()
        self.critic_opt.step()

        actions, log_prob = self.actor.sample(batch.obs)
        with frozen(self.critic_params):
            q = torch.min(*self.critic(batch.obs, actions))
        actor_loss = (alpha * log_prob - q).mean()
        self.actor_opt.zero_grad()
        actor_loss.backward()
        self.actor_opt.step()

        alpha_loss = -(self.log_alpha * (log_prob.detach() + self.target_entropy)).mean()
        self.alpha_opt.zero_grad()
        alpha_loss.backward()
        self.alpha_opt.step()

        soft_update(self.target_params, self.critic_params, self.cfg.tau)
        return {
            "critic_loss": critic_loss.item(),
            "actor_loss": actor_loss.item(),
            "alpha": alpha.item(),
            "entropy": -log_prob.mean().item(),
        }


def usable_device(name: str) -> torch.device:
    """torch.device(name), or a one-line error where it cannot run here (no GPU)."""
    device = torch.device(name)
    if device.type == "cuda" and not torch.cuda.is_available():
        raise RuntimeError(f"device {name!r} asked for, but torch sees no GPU on this machine")
    return device


@torch.no_grad()
def soft_update(targets: list[nn.Parameter], sources: list[nn.Parameter], tau: float) -> None:
    """Polyak averaging, targets <- targets + tau (sources - targets): every tensor in one
    foreach call, the same per-tensor lerp as a loop (the same numbers to the bit)."""
    torch._foreach_lerp_(targets, sources, tau)


@contextmanager
def frozen(params: Iterable[nn.Parameter]) -> Iterator[None]:
    """Forward passes inside record no gradients for `params`, a network's weights (the
    actor's loss backpropagates through the critic only to reach the actor): ~10% of a SAC
    update saved, the same numbers to the bit, since the critic's optimizer clears its
    gradients before its own step. Each weight's flag is restored as it was."""
    params = list(params)
    flags = [p.requires_grad for p in params]
    for p in params:
        p.requires_grad_(False)
    try:
        yield
    finally:
        for p, flag in zip(params, flags, strict=True):
            p.requires_grad_(flag)


class OffPolicyLearner(Protocol):
    """What the loop needs of a learner: SAC, or another actor-critic built on its replay
    (OPOLO's TD3, `algorithms.opolo`)."""

    actor: Actor
    buffer: ReplayBuffer
    device: torch.device

    def explore(self, obs: torch.Tensor) -> torch.Tensor: ...

    def update(self, batch: ReplayBatch, rewards: torch.Tensor) -> dict[str, float]: ...

    def state_dict(self) -> dict[str, Any]: ...

    def load_state_dict(self, state: dict[str, Any]) -> None: ...


OnReport = Callable[[int, SAC, dict[str, float]], None]
"""callback(env_steps_so_far, learner, last_update_info and seconds spent collecting and
updating so far), every `report_every` env steps."""


@dataclass
class Progress:
    """The loop's counters, all that a snapshot restarts it from besides the learner."""

    steps: int
    """Env steps taken."""
    next_report: int
    """Env steps at which the callback runs next."""
    owed: float = 0.0
    """Updates owed (`updates_per_step` per env step), paid in whole updates."""
    info: dict[str, float] = field(default_factory=dict)
    """What the last update logged."""
    clock: dict[str, float] = field(default_factory=lambda: {"collect_s": 0.0, "update_s": 0.0})
    """Seconds spent collecting and updating so far."""


def store_step(buffer: ReplayBuffer, step: Batch, absorbing: bool) -> None:
    """One step of every env (`VecCollector.run(act, 1)`: arrays (1, E, ...)) into `buffer`."""
    rows = transitions_of_step(
        step.obs[0],
        step.actions[0],
        step.next_obs[0],
        step.rewards[0],
        step.terminated[0],
        absorbing,
    )
    buffer.add(*rows)


def update_on(
    learner: OffPolicyLearner, batch: ReplayBatch, reward: SACRewardFn
) -> dict[str, float]:
    """One update of `learner` on `batch`, rewarded by `reward`; what to log of it (the
    reward's own diagnostics first, where it gives `Logged` rewards)."""
    rewards = reward(batch)
    if isinstance(rewards, Logged):
        return {**rewards.logged, **learner.update(batch, rewards.rewards)}
    return learner.update(batch, rewards)


def env_reward(batch: ReplayBatch) -> torch.Tensor:
    """The env's own reward (0 into and on the absorbing loop)."""
    return batch.env_rewards


def train(
    make_env: Callable[[int], gym.Env],
    budget: int,
    seed: int,
    cfg: SACConfig,
    reward_fn: SACRewardFn | None = None,
    callback: OnReport | None = None,
    report_every: int | None = None,
    learner: OffPolicyLearner | None = None,
    snapshots: Snapshots | None = None,
) -> SAC:
    """Run SAC (or `learner`, built beforehand) for `budget` env steps and return the learner.
    Without `reward_fn` it learns from the env's reward (0 on the absorbing loop). `callback`
    runs every `report_every` env steps (default: a twentieth of the budget, at most 5,000).
    With `snapshots`, it saves everything when one is due, and where the trial resumes, starts
    from the last one: on the same machine, the very learner an uninterrupted run returns. A
    `reward_fn` that learns (a discriminator) has a `state_dict` and `load_state_dict` too."""
    report_every = report_every or min(5_000, max(1, budget // 20))
    torch.set_num_threads(1)
    collector = VecCollector([make_env(seed * 1000 + i) for i in range(cfg.n_envs)], seed * 1000)
    n_envs, low, high = len(collector.envs), collector.low, collector.high
    learner = learner or SAC(collector.obs.shape[1], len(low), low, high, cfg, seed)
    rng = np.random.default_rng(seed)
    reward = reward_fn or env_reward
    # What learns besides the learner: a reward with a state of its own (D), and the loop.
    extra = {"reward": reward} if hasattr(reward, "state_dict") else {}
    resume = Resumable(
        snapshots,
        parts={"learner": learner, **extra, "rng": rng, "torch_rng": TORCH_RNG},
        replayed={"collector": collector},
    )
    resumed = resume.restore()
    at = Progress(0, report_every) if resumed is None else Progress(**resumed["loop"])

    def act(obs: np.ndarray) -> np.ndarray:
        """Uniform random actions for the first `learning_starts` steps, then the actor's."""
        if at.steps < cfg.learning_starts:
            return rng.uniform(low, high, size=(len(obs), len(low))).astype(np.float32)
        with torch.no_grad():
            return learner.explore(torch.from_numpy(flagged(obs)).to(learner.device)).cpu().numpy()

    try:
        while at.steps + n_envs <= budget:
            t0 = time.perf_counter()
            store_step(learner.buffer, collector.run(act, 1), cfg.absorbing)
            at.steps += n_envs
            t1 = time.perf_counter()
            at.clock["collect_s"] += t1 - t0
            if at.steps >= cfg.learning_starts:
                at.owed += cfg.updates_per_step * n_envs
                while at.owed >= 1:
                    batch = learner.buffer.sample(cfg.batch_size, learner.device)
                    at.info = update_on(learner, batch, reward)
                    at.owed -= 1
            at.clock["update_s"] += time.perf_counter() - t1
            if callback is not None and at.steps >= at.next_report:
                callback(at.steps, learner, {**at.info, **at.clock})
                at.next_report += report_every
            resume.save_if_due(lambda: {"loop": asdict(at)}, room=at.steps + n_envs <= budget)
    finally:
        collector.close()
    return learner
