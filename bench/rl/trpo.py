"""Trust Region Policy Optimization (Schulman et al. 2015), the optimizer every learner shares.

Reads top to bottom: config, advantage estimation, the natural-gradient step
(conjugate gradient on Fisher-vector products, KL-constrained backtracking line
search), value regression, and the training loop. The reward is pluggable: pass
`reward_fn` and it replaces the env reward for every batch, which is how GAIfO,
GAIL and TCN reuse this file unchanged.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import torch
from torch import nn

from bench.rl.networks import ConvTrunk, GaussianPolicy, ObsShape, RunningNorm, ValueNet
from bench.rl.rollout import Batch, RewardFn, Rewards, VecCollector
from bench.validate import above, at_least


@dataclass
class TRPOConfig:
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
        self.hidden = tuple(self.hidden)  # YAML gives lists
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
    obs: torch.Tensor,
    actions: torch.Tensor,
    adv: torch.Tensor,
    cfg: TRPOConfig,
    features: torch.Tensor | None = None,
) -> dict[str, float]:
    """One natural-gradient step on the surrogate advantage inside the KL trust region.

    It moves the policy's head only: from frames, the conv trunk it shares with the value
    function learns from the value loss (as in PPO's Atari networks), since a trust region
    of 0.01 nats spread over every conv weight starves the features of learning. The trunk's
    features are therefore fixed during the step, and computed once (`features`: given
    already, as `policy.features(obs)`).
    """
    params = [p for p in policy.head_parameters() if p.requires_grad]
    with torch.no_grad():
        if features is None:
            features = policy.features(obs)
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


CLONE_WEIGHT = 1.0
"""Weight of the policy-keeping KL in the value loss when the two share a trunk (Phasic Policy
Gradient's behavioural-cloning weight, beta_clone = 1)."""


def mean_kl(policy: GaussianPolicy, old_mean: torch.Tensor, mean: torch.Tensor) -> torch.Tensor:
    """Mean KL(old || new) between two Gaussians of the same std that differ in their means."""
    return (
        ((mean - old_mean).square() / (2 * torch.exp(2 * policy.log_std.detach()))).sum(-1).mean()
    )


def value_step(
    value: ValueNet,
    opt: torch.optim.Optimizer,
    obs: torch.Tensor,
    targets: torch.Tensor,
    cfg: TRPOConfig,
    gen: torch.Generator,
    keep: tuple[GaussianPolicy, torch.Tensor] | None = None,
) -> float:
    """Value regression. With `keep` = (policy, its mean actions on `obs`), for a policy that
    shares the value's trunk: the trunk then also pays the KL by which it would move the policy,
    so value learning does not change the policy outside TRPO's trust region. One trunk pass
    per minibatch feeds both heads."""
    n = obs.shape[0]
    loss = torch.zeros(())
    for _ in range(cfg.vf_epochs):
        perm = torch.randperm(n, generator=gen)
        for start in range(0, n, cfg.vf_minibatch):
            idx = perm[start : start + cfg.vf_minibatch]
            if keep is None:
                loss = (value(obs[idx]) - targets[idx]).square().mean()
            else:
                policy, old_mean = keep
                features = policy.features(obs[idx])
                loss = (value.head(features) - targets[idx]).square().mean()
                clone = mean_kl(policy, old_mean[idx], policy.mean_net(features))
                loss = loss + CLONE_WEIGHT * clone
            opt.zero_grad()
            loss.backward()
            opt.step()
    return loss.item()


class TRPO:
    """Policy, value function and their optimizer state; `update` consumes one Batch."""

    def __init__(
        self, obs_shape: ObsShape, act_dim: int, cfg: TRPOConfig, seed: int, device: str = "cpu"
    ) -> None:
        """`obs_shape`: O for state vectors, (C, H, W) for flat frames (`Task.obs_shape`).
        `device`: where the networks live (rollouts always step on the CPU). Not part of the
        config, so that where a trial ran never changes what it is."""
        torch.manual_seed(seed)
        self.cfg = cfg
        self.device = torch.device(device)
        self.policy = GaussianPolicy(obs_shape, act_dim, cfg.hidden, cfg.init_log_std).to(
            self.device
        )
        trunk = self.policy.trunk if isinstance(self.policy.trunk, ConvTrunk) else None
        self.shared_trunk = trunk is not None
        self.value = ValueNet(self.policy.norm, obs_shape, cfg.hidden, trunk).to(self.device)
        self.vf_opt = torch.optim.Adam(self.value.net.parameters(), lr=cfg.vf_lr)
        self.gen = torch.Generator().manual_seed(seed + 1)
        self.return_norm = RunningNorm(1)
        self.discounted: np.ndarray | None = None  # running discounted return per env

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
        obs = torch.from_numpy(batch.flat("obs")).to(self.device)
        next_obs = torch.from_numpy(batch.flat("next_obs")).to(self.device)
        with torch.no_grad():
            # A shared trunk's features of `obs` serve the values, the policy step and the
            # means to keep: the policy step leaves the trunk as it is.
            features = self.policy.features(obs) if self.shared_trunk else None
            values = self.value(obs) if features is None else self.value.head(features)
            values = values.cpu().numpy().reshape(T, E)
            next_values = self.value(next_obs).cpu().numpy().reshape(T, E)
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
        adv_t = torch.from_numpy(adv.reshape(-1)).to(self.device)
        adv_t = (adv_t - adv_t.mean()) / (adv_t.std() + 1e-8)
        actions = torch.from_numpy(batch.flat("actions")).to(self.device)
        info = policy_step(self.policy, obs, actions, adv_t, cfg, features)
        keep = None
        if features is not None:
            with torch.no_grad():
                keep = (self.policy, self.policy.mean_net(features))
            trunk_before = nn.utils.parameters_to_vector(self.policy.trunk.parameters()).detach()
        info["vf_loss"] = value_step(
            self.value,
            self.vf_opt,
            obs,
            torch.from_numpy(targets.reshape(-1)).to(self.device),
            cfg,
            self.gen,
            keep,
        )
        if keep is not None:
            info.update(self.hold_trunk(obs, keep[1], trunk_before))
        return info

    @torch.no_grad()
    def hold_trunk(
        self, obs: torch.Tensor, old_mean: torch.Tensor, before: torch.Tensor
    ) -> dict[str, float]:
        """Keep the shared trunk's value-learning step inside the trust region: if it moved the
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


Callback = Callable[[int, TRPO, Batch, dict[str, float]], None]
"""callback(env_steps_so_far, learner, batch, update_info), after every update."""


def train(
    make_env: Callable[[int], gym.Env],
    budget: int,
    seed: int,
    cfg: TRPOConfig | None = None,
    reward_fn: RewardFn | None = None,
    callback: Callback | None = None,
    learner: TRPO | None = None,
    device: str = "cpu",
) -> TRPO:
    """Run TRPO for at most `budget` env steps (whole batches only) and return the learner.

    Pass `learner` to train one built beforehand (e.g. so a discriminator can
    share its observation normalizer); its config then overrides `cfg`.
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
    learner = learner or TRPO(obs_dim, act_dim, cfg, seed, device)
    collector = VecCollector(envs, seed * 1000)
    steps = 0
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
    finally:
        collector.close()
    return learner
