"""Trust Region Policy Optimization (Schulman et al. 2015), the optimizer every learner shares.

Reads top to bottom: config, advantage estimation, the natural-gradient step
(conjugate gradient on Fisher-vector products, KL-constrained backtracking line
search), value regression, and the training loop. The reward is pluggable: pass
`reward_fn` and it replaces the env reward for every batch, which is how GAIfO,
GAIL and TCN reuse this file unchanged.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from bench.rl.flat_adam import FlatAdam
from bench.rl.networks import ConvTrunk, GaussianPolicy, ObsShape, RunningNorm, ValueNet
from bench.rl.resume import TORCH_RNG, Resumable, Snapshots
from bench.rl.rollout import Batch, RewardFn, Rewards, VecCollector
from bench.validate import Checked, above, at_least, layers


@dataclass
class TRPOConfig(Checked):
    n_envs: int = 8
    """Envs stepped side by side in one process (one batched policy forward per step)."""
    steps_per_env: int = 256
    """Steps collected from each env per update; the batch is n_envs * steps_per_env."""
    gamma: float = 0.99
    """Discount factor."""
    gae_lambda: float = 0.95
    """GAE(lambda) bias/variance trade-off."""
    max_kl: float = 0.01
    """Trust region: mean KL(old || new) allowed per update."""
    cg_iters: int = 10
    """Conjugate-gradient iterations for the natural-gradient direction."""
    cg_damping: float = 0.1
    """Added to the Fisher matrix's diagonal for stability."""
    fisher_subsample: int = 4
    """Fisher-vector products use every k-th sample: same direction, k times cheaper."""
    line_search_steps: int = 10
    """Backtracking halvings before the update is rejected."""
    vf_lr: float = 1e-3
    """Adam learning rate of the value function."""
    vf_epochs: int = 5
    """Passes over the batch for value regression."""
    vf_minibatch: int = 256
    """Value regression minibatch size."""
    scale_rewards: bool = True
    """Divide rewards by a running std of the discounted return, so value targets stay O(1)."""
    hidden: tuple[int, ...] = (64, 64)
    """Hidden layer sizes of policy and value MLPs."""
    init_log_std: float = 0.0
    """Initial log standard deviation of the policy."""

    def __post_init__(self) -> None:
        super().__post_init__()
        layers(self, "hidden")
        counts = ("n_envs", "steps_per_env", "cg_iters", "fisher_subsample", "vf_epochs")
        for name in (*counts, "vf_minibatch"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be >= 1, not {getattr(self, name)}")
        if not (0 < self.gamma <= 1 and 0 <= self.gae_lambda <= 1 and self.max_kl > 0):
            raise ValueError("need 0 < gamma <= 1, 0 <= gae_lambda <= 1 and max_kl > 0")
        at_least(self, 1, "line_search_steps")
        at_least(self, 0, "cg_damping")
        above(self, 0, "vf_lr")

    @property
    def batch_size(self) -> int:
        return self.n_envs * self.steps_per_env


def gae(
    rewards: np.ndarray,
    values: np.ndarray,
    next_values: np.ndarray,
    terminated: np.ndarray,
    truncated: np.ndarray,
    gamma: float,
    lam: float,
    after_termination: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Advantages and value targets, all (T, E).

    `next_values` is V(s') of the true next observation, so a truncated episode
    (time limit or end of batch) bootstraps from it. A terminated one bootstraps
    from `after_termination` (0 if None; an absorbing tail's value, see
    `bench.rl.absorbing`), and the advantage chain stops there either way.
    """
    delta = rewards + gamma * next_values * (1.0 - terminated) - values
    if after_termination is not None:
        delta = delta + gamma * np.where(terminated, after_termination, 0.0)
    ends = terminated | truncated
    adv = np.zeros_like(rewards)
    running = np.zeros(rewards.shape[1], dtype=rewards.dtype)
    for t in reversed(range(rewards.shape[0])):
        running = delta[t] + gamma * lam * (1.0 - ends[t]) * running
        adv[t] = running
    return adv, adv + values


def conjugate_gradient(
    fvp: Callable[[torch.Tensor], torch.Tensor], b: torch.Tensor, iters: int
) -> torch.Tensor:
    """Approximately solve F x = b."""
    x = torch.zeros_like(b)
    r, p = b.clone(), b.clone()
    rr = r @ r
    for _ in range(iters):
        Fp = fvp(p)
        alpha = rr / (p @ Fp + 1e-10)
        x += alpha * p
        r -= alpha * Fp
        rr_new = r @ r
        if rr_new < 1e-10:
            break
        p = r + (rr_new / rr) * p
        rr = rr_new
    return x


def policy_step(
    policy: GaussianPolicy,
    features: torch.Tensor,
    actions: torch.Tensor,
    adv: torch.Tensor,
    cfg: TRPOConfig,
) -> dict[str, float]:
    """One natural-gradient step on the surrogate advantage inside the KL trust region.

    `features`: `policy.features(obs)`, what the mean's MLP reads. The step moves the policy's
    head only (from frames, the conv trunk learns with the value function: see
    `bench.rl.shared_trunk`), so the features stay fixed during it and are computed once.
    """
    params = [p for p in policy.head_parameters() if p.requires_grad]
    with torch.no_grad():
        old_mean = policy.mean_net(features)
        old_log_std = policy.log_std.detach().clone()
        old_logp = policy.log_prob(old_mean, actions)

    def surrogate() -> torch.Tensor:
        new_logp = policy.log_prob(policy.mean_net(features), actions)
        return (torch.exp(new_logp - old_logp) * adv).mean()

    def kl(idx: slice = slice(None)) -> torch.Tensor:
        """Mean KL(old || new) of diagonal Gaussians, analytically."""
        mean = policy.mean_net(features[idx])
        om = old_mean[idx]
        var, old_var = torch.exp(2 * policy.log_std), torch.exp(2 * old_log_std)
        per_dim = policy.log_std - old_log_std + (old_var + (om - mean).square()) / (2 * var) - 0.5
        return per_dim.sum(-1).mean()

    loss = surrogate()
    g = torch.cat([x.reshape(-1) for x in torch.autograd.grad(loss, params)])
    sub = slice(None, None, cfg.fisher_subsample)
    grad_kl = torch.cat(
        [x.reshape(-1) for x in torch.autograd.grad(kl(sub), params, create_graph=True)]
    )

    def fvp(v: torch.Tensor) -> torch.Tensor:
        hv = torch.autograd.grad(grad_kl @ v, params, retain_graph=True)
        return torch.cat([x.reshape(-1) for x in hv]) + cfg.cg_damping * v

    step_dir = conjugate_gradient(fvp, g, cfg.cg_iters)
    shs = 0.5 * (step_dir @ fvp(step_dir))
    full_step = step_dir * torch.sqrt(2 * cfg.max_kl / (2 * shs + 1e-10))
    old = torch.nn.utils.parameters_to_vector(params).detach()
    expected = (g @ full_step).item()
    with torch.no_grad():
        base = loss.item()
        for frac in 0.5 ** np.arange(cfg.line_search_steps):
            torch.nn.utils.vector_to_parameters(old + frac * full_step, params)
            new_kl, improve = kl().item(), surrogate().item() - base
            if np.isfinite(improve) and new_kl <= 1.5 * cfg.max_kl and improve > 0:
                return {
                    "kl": new_kl,
                    "improvement": improve,
                    "expected": expected * frac,
                    "step_frac": float(frac),
                }
        torch.nn.utils.vector_to_parameters(old, params)
    return {"kl": 0.0, "improvement": 0.0, "expected": expected, "step_frac": 0.0}


def value_step(
    opt: torch.optim.Optimizer,
    n: int,
    loss_of: Callable[[torch.Tensor], torch.Tensor],
    cfg: TRPOConfig,
    gen: torch.Generator,
) -> float:
    """Value regression: `cfg.vf_epochs` passes over `n` samples in shuffled minibatches, each
    a step of `opt` on `loss_of(minibatch indices)`. Returns the last minibatch's loss."""
    loss = torch.zeros(())
    for _ in range(cfg.vf_epochs):
        perm = torch.randperm(n, generator=gen)
        for start in range(0, n, cfg.vf_minibatch):
            loss = loss_of(perm[start : start + cfg.vf_minibatch])
            opt.zero_grad()
            loss.backward()
            opt.step()
    return loss.item()


class TRPO:
    """Policy, value function and their optimizer state; `update` consumes one Batch.

    From states. From frames, the policy and the value share a conv trunk, which needs its
    own value step: `bench.rl.shared_trunk.make_trpo` picks the learner for a task's
    observations."""

    def __init__(self, obs_shape: ObsShape, act_dim: int, cfg: TRPOConfig, seed: int) -> None:
        """`obs_shape`: O or (O,), state vectors. From frames (C, H, W), build the learner with
        `bench.rl.shared_trunk.make_trpo`."""
        torch.manual_seed(seed)
        self.cfg = cfg
        self.policy = GaussianPolicy(obs_shape, act_dim, cfg.hidden, cfg.init_log_std)
        self.value = self.value_net(obs_shape)
        self.vf_opt = self.value_optimizer()
        self.gen = torch.Generator().manual_seed(seed + 1)
        self.return_norm = RunningNorm(1)
        self.discounted: np.ndarray | None = None  # running discounted return per env

    def value_net(self, obs_shape: ObsShape) -> ValueNet:
        if isinstance(self.policy.trunk, ConvTrunk):
            raise ValueError("from frames, build the learner with shared_trunk.make_trpo")
        return ValueNet(self.policy.norm, obs_shape, self.cfg.hidden)

    def value_optimizer(self) -> torch.optim.Optimizer:
        """Adam on the value MLP, over one flat buffer (`FlatAdam`: the same values, a fraction
        of the dispatch)."""
        return FlatAdam(self.value.net.parameters(), lr=self.cfg.vf_lr)

    def state_dict(self) -> dict:
        """Everything `update` carries from one batch to the next (tensors and plain numbers
        only, so it loads with torch.load(..., weights_only=True))."""
        return {
            "policy": self.policy.state_dict(),
            "value": self.value.state_dict(),
            "vf_opt": self.vf_opt.state_dict(),
            "gen": self.gen.get_state(),
            "return_norm": self.return_norm.state_dict(),
            "discounted": None if self.discounted is None else torch.from_numpy(self.discounted),
        }

    def load_state_dict(self, state: dict) -> None:
        self.policy.load_state_dict(state["policy"])
        self.value.load_state_dict(state["value"])
        self.vf_opt.load_state_dict(state["vf_opt"])
        self.gen.set_state(state["gen"])
        self.return_norm.load_state_dict(state["return_norm"])
        discounted = state["discounted"]
        self.discounted = None if discounted is None else discounted.numpy().copy()
        # A policy step leaves the head's weights as views into one flat vector
        # (`vector_to_parameters`), and a product with weights at those offsets rounds
        # differently from one with weights of their own: laid out alike, a loaded learner
        # computes the very numbers the saved one would have.
        head = [p for p in self.policy.head_parameters() if p.requires_grad]
        with torch.no_grad():
            torch.nn.utils.vector_to_parameters(torch.nn.utils.parameters_to_vector(head), head)

    def reward_scale(
        self, rewards: np.ndarray, ends: np.ndarray, final: np.ndarray | None = None
    ) -> np.floating:
        """Running std of the discounted return (VecNormalize-style), updated with `rewards`.

        `final` (T, E): value added at an episode's last step (an absorbing tail's), so that
        returns which end in one are scaled to O(1) like any other; 0 where None.
        """
        if self.discounted is None:
            self.discounted = np.zeros(rewards.shape[1])
        seen = np.empty_like(rewards, dtype=np.float64)
        for t in range(len(rewards)):
            self.discounted = self.discounted * self.cfg.gamma + rewards[t]
            if final is not None:
                self.discounted += final[t]
            seen[t] = self.discounted
            self.discounted[ends[t]] = 0.0
        self.return_norm.update(seen.reshape(-1, 1))
        return np.sqrt(self.return_norm.var.item() + 1e-8)

    def update(self, batch: Batch, rewards: np.ndarray | Rewards) -> dict[str, float]:
        """Normalizer, then policy, then value: one TRPO iteration on (T, E) `rewards`."""
        cfg = self.cfg
        self.policy.norm.update(batch.flat("obs"))
        after = None
        if isinstance(rewards, Rewards):
            rewards, after = rewards.per_step, rewards.after_termination
        T, E = rewards.shape
        if cfg.scale_rewards:
            # Tail values are sums of rewards, so they scale with them and count in the scale:
            # a value target of -100 next to rewards of O(1) is more than the value net can fit.
            final = None if after is None else np.where(batch.terminated, self.cfg.gamma * after, 0)
            std = self.reward_scale(rewards, batch.terminated | batch.truncated, final)
            rewards = (rewards / std).astype(np.float32)
            after = None if after is None else (after / std).astype(np.float32)
        obs = torch.from_numpy(batch.flat("obs"))
        next_obs = torch.from_numpy(batch.flat("next_obs"))
        with torch.no_grad():
            features = self.policy.features(obs)
            values = self.state_values(obs, features).numpy().reshape(T, E)
            next_values = self.value(next_obs).numpy().reshape(T, E)
        adv, targets = gae(
            rewards.astype(np.float32),
            values,
            next_values,
            batch.terminated,
            batch.truncated,
            cfg.gamma,
            cfg.gae_lambda,
            after,
        )
        adv_t = torch.from_numpy(adv.reshape(-1))
        adv_t = (adv_t - adv_t.mean()) / (adv_t.std() + 1e-8)
        actions = torch.from_numpy(batch.flat("actions"))
        info = policy_step(self.policy, features, actions, adv_t, cfg)
        info.update(self.fit_value(obs, features, torch.from_numpy(targets.reshape(-1))))
        return info

    def state_values(self, obs: torch.Tensor, features: torch.Tensor) -> torch.Tensor:
        """V(obs); `features` are the policy's of `obs`, for a value that shares them."""
        return self.value(obs)

    def fit_value(
        self, obs: torch.Tensor, features: torch.Tensor, targets: torch.Tensor
    ) -> dict[str, float]:
        """Regress V(obs) on `targets`, after the policy step. `features` are `obs` normalized,
        as the value reads them (the statistics stand still until the next batch): normalized
        once for the batch, not per minibatch, the same numbers."""
        loss_of = lambda idx: (self.value.head(features[idx]) - targets[idx]).square().mean()  # noqa: E731
        return {"vf_loss": value_step(self.vf_opt, len(obs), loss_of, self.cfg, self.gen)}


OnUpdate = Callable[[int, TRPO, Batch, dict[str, float]], None]
"""callback(env_steps_so_far, learner, batch, update_info), after every update."""


def train(
    make_env: Callable[[int], gym.Env],
    budget: int,
    seed: int,
    cfg: TRPOConfig | None = None,
    reward_fn: RewardFn | None = None,
    callback: OnUpdate | None = None,
    learner: TRPO | None = None,
    snapshots: Snapshots | None = None,
    keep: Mapping[str, Any] | None = None,
) -> TRPO:
    """Run TRPO for at most `budget` env steps (whole batches only) and return the learner.

    Pass `learner` to train one built beforehand (e.g. so a discriminator can
    share its observation normalizer); its config then overrides `cfg`.

    With `snapshots`, it saves everything when one is due and, where the trial resumes, starts
    from the last one: the learner, the envs (each episode replayed), the random states, and
    `keep`: what else learns along (a discriminator, its optimizer and generator, a policy
    average), as `bench.rl.resume` saves them. On the same machine it returns the very
    learner a run in one go returns, provided `keep` holds all that changes besides.
    """
    cfg = learner.cfg if learner is not None else cfg or TRPOConfig()
    if budget < cfg.batch_size:
        raise ValueError(
            f"a budget of {budget} env steps is less than one TRPO batch ({cfg.batch_size})"
        )
    torch.set_num_threads(1)
    envs = [make_env(seed * 1000 + i) for i in range(cfg.n_envs)]
    obs_dim = int(np.prod(envs[0].observation_space.shape))
    act_dim = int(np.prod(envs[0].action_space.shape))
    learner = learner or TRPO(obs_dim, act_dim, cfg, seed)
    collector = VecCollector(envs, seed * 1000)
    resume = Resumable(
        snapshots,
        parts={"learner": learner, "keep": keep or {}, "torch_rng": TORCH_RNG},
        replayed={"collector": collector},
    )
    resumed = resume.restore()
    steps = resumed["steps"] if resumed is not None else 0

    def counters() -> dict[str, int]:
        return {"steps": steps}

    try:
        while steps + cfg.batch_size <= budget:
            t0 = time.perf_counter()
            batch = collector.collect(learner.policy, cfg.steps_per_env)
            steps += batch.n_steps
            t1 = time.perf_counter()
            rewards = batch.rewards if reward_fn is None else reward_fn(batch)
            logged = rewards.logged if isinstance(rewards, Rewards) else {}
            info = {**logged, **learner.update(batch, rewards)}
            info.update(collect_s=t1 - t0, update_s=time.perf_counter() - t1)
            if callback is not None:
                callback(steps, learner, batch, info)
            resume.save_if_due(counters, room=steps + cfg.batch_size <= budget)
    finally:
        collector.close()
    return learner
