"""TCN reward (Sermanet et al. 2017): imitate by tracking a time-contrastive embedding of the demos.

Adaptation: the original embeds video frames with a CNN, trained multi-view across cameras; here an
MLP embeds state vectors (a small CNN embeds frames, in a suite env with `observation: pixels`),
single-view (positives and negatives come from the same demonstration).

1. Embedding: unit-length MLP features of demonstration states, trained with a triplet loss:
   a positive lies within `pos_window` steps of its anchor, a negative at least `neg_margin` away.
2. Reward: r_t = -a ||e - d||^2 - b sqrt(c + ||e - d||^2) (+ an offset, below), where e embeds the
   agent's s_{t+1} and d is the mean embedding of the demonstrations' states at step t + 1
   (a finished demonstration holds its last state). We compare s_{t+1}, the state the action
   at step t produced, so the reward reaches the action that earned it rather than one step late.
3. The policy: the shared TRPO (bench/rl/trpo.py) on that reward; the embedding stays fixed.

Termination bias: PyBullet tasks end early when the agent falls, and the reward above is always
negative, so ending an episode early pays: on InvertedPendulum (100k steps) the agent learns to
fall at once (return 7; random 21). `nonnegative_reward` (default) shifts every reward up by the
largest penalty possible, so no step pays less than 0 and staying alive pays whatever the
embedding says (pendulum, 10 seeds: 0.84 normalized from 1 demo, 0.92 from 5; `survival`, 1.0).

Weakness: where the expert's states hardly change over time (a balanced pendulum), time contrast
learns noise: under an embedding of one pendulum demo, other expert episodes score below random.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from bench.learners import deterministic, one_batch, report_each_update
from bench.registry import Logger, Policy, Task, register, snapshots_of
from bench.rl.networks import ObsShape, body, normalizer
from bench.rl.rollout import Batch, Rewards
from bench.rl.shared_trunk import make_trpo
from bench.rl.trpo import TRPOConfig
from bench.rl.trpo import train as trpo_train
from bench.types import Demos
from bench.validate import above, at_least


@dataclass
class TCNConfig(TRPOConfig):
    """TRPO's settings (inherited, overridable) plus the embedding's and the reward's."""

    embed_dim: int = 32
    """Size of the embedding."""
    embed_hidden: tuple[int, ...] = (64, 64)
    """Hidden layer sizes of the embedding MLP (tanh)."""
    pos_window: int = 3
    """Positives lie within this many steps of their anchor (and are not the anchor)."""
    neg_margin: int = 15
    """Negatives lie at least this many steps from their anchor."""
    triplet_margin: float = 0.2
    """Hinge margin of the triplet loss, in squared distance between unit-length embeddings."""
    embed_steps: int = 2000
    """Adam minibatch steps of triplet training (before any env step)."""
    embed_lr: float = 1e-3
    """Adam learning rate of the embedding."""
    embed_minibatch: int = 256
    """Triplets per Adam step."""
    reward_alpha: float = 0.5
    """Weight a of the squared embedding distance (alpha in the TCN paper)."""
    reward_beta: float = 0.5
    """Weight b of the Huber-like root term (beta in the TCN paper)."""
    reward_gamma: float = 1e-3
    """c inside the root (gamma in the TCN paper; not TRPO's discount `gamma`)."""
    nonnegative_reward: bool = True
    """Add the largest penalty, a*4 + b*sqrt(c + 4) (unit embeddings: ||e - d||^2 <= 4), so no
    reward is negative and ending early does not pay (see the module docstring)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        self.embed_hidden = tuple(self.embed_hidden)
        if not 1 <= self.pos_window < self.neg_margin:
            raise ValueError("need 1 <= pos_window < neg_margin")
        at_least(self, 1, "embed_dim", "embed_steps", "embed_minibatch")
        at_least(self, 0, "triplet_margin", "reward_alpha", "reward_beta")
        above(self, 0, "embed_lr", "reward_gamma")


class Embedding(nn.Module):
    """Raw (B, O) states -> (B, D) unit-length embeddings; inputs normalized by demo statistics.
    From frames (obs_shape (C, H, W)), a convolutional trunk comes first, as in the TCN paper."""

    def __init__(self, obs_shape: ObsShape, cfg: TCNConfig) -> None:
        super().__init__()
        self.norm = normalizer(obs_shape)
        self.net = body(obs_shape, cfg.embed_hidden, cfg.embed_dim)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return F.normalize(self.net(self.norm(obs)), dim=-1)


def n_negatives(t: np.ndarray, L: np.ndarray, margin: int) -> np.ndarray:
    """How many steps of an episode of L rows lie at least `margin` from step t."""
    return np.maximum(t - margin + 1, 0) + np.maximum(L - t - margin, 0)


def sample_triplets(
    lengths: np.ndarray, n: int, cfg: TCNConfig, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """n (episode, anchor, positive, negative) index arrays; steps index an episode's rows.

    Episodes are drawn in proportion to the anchors they offer (rows with a valid negative).
    """
    m = cfg.neg_margin
    usable = np.array([np.sum(n_negatives(np.arange(L), L, m) > 0) for L in lengths], dtype=float)
    ep = rng.choice(len(lengths), size=n, p=usable / usable.sum())
    L = lengths[ep]
    anchor = rng.integers(0, L)
    while np.any(bad := n_negatives(anchor, L, m) == 0):  # mid-episode anchors of short episodes
        anchor[bad] = rng.integers(0, L[bad])
    offset = rng.integers(1, cfg.pos_window + 1, size=n) * rng.choice([-1, 1], size=n)
    positive = np.clip(anchor + offset, 0, L - 1)
    positive[positive == anchor] = np.clip(anchor - offset, 0, L - 1)[positive == anchor]
    left = np.maximum(anchor - m + 1, 0)  # negatives are 0..left-1, then anchor+m onwards
    k = (rng.random(n) * n_negatives(anchor, L, m)).astype(np.int64)
    negative = np.where(k < left, k, anchor + m + (k - left))
    return ep, anchor, positive, negative


def train_embedding(embed: Embedding, demos: Demos, cfg: TCNConfig, seed: int) -> dict[str, float]:
    """Triplet loss max(0, |a - p|^2 - |a - n|^2 + margin) over demonstration states."""
    embed.norm.update(np.concatenate(demos.observations))
    lengths = np.array([len(o) for o in demos.observations])
    if not np.any(lengths > cfg.neg_margin):
        raise ValueError(f"no demonstration is longer than neg_margin ({cfg.neg_margin} steps)")
    offsets = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    states = torch.from_numpy(np.concatenate(demos.observations))
    opt = torch.optim.Adam(embed.net.parameters(), lr=cfg.embed_lr)
    rng = np.random.default_rng(seed)
    loss, active = torch.zeros(()), torch.zeros(())
    for _ in range(cfg.embed_steps):
        ep, a, p, n = sample_triplets(lengths, cfg.embed_minibatch, cfg, rng)
        e = embed(states[torch.from_numpy(np.concatenate([a, p, n]) + np.tile(offsets[ep], 3))])
        ea, ep_, en = e.chunk(3)
        hinge = (ea - ep_).square().sum(1) - (ea - en).square().sum(1) + cfg.triplet_margin
        loss = hinge.clamp_min(0).mean()
        active = (hinge > 0).float().mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    return {"triplet_loss": loss.item(), "triplet_active": active.item()}


@torch.no_grad()
def demo_targets(embed: Embedding, demos: Demos) -> torch.Tensor:
    """(max_i T_i + 1, D): mean embedding of the demonstrations at each step, last state held."""
    horizon = max(len(o) for o in demos.observations)
    held = [np.concatenate([o, np.repeat(o[-1:], horizon - len(o), 0)]) for o in demos.observations]
    return embed(torch.from_numpy(np.concatenate(held))).reshape(len(held), horizon, -1).mean(0)


@register(
    "tcn",
    config=TCNConfig,
    inputs="states",
    resumable=True,
    description="TCN: TRPO on distance to the demos in a time-contrastive embedding",
    pixels=True,
    video_reward=True,
    min_budget=one_batch,
    family="trpo",
    label="TCN",
)
def train(
    task: Task, demos: Demos, budget: int, seed: int, logger: Logger, config: TCNConfig
) -> Policy:
    cfg = config
    torch.manual_seed(seed)
    embed = Embedding(task.judged_shape, cfg)
    logger.log(0, **train_embedding(embed, demos, cfg, seed))
    targets = demo_targets(embed, demos)
    a, b, c = cfg.reward_alpha, cfg.reward_beta, cfg.reward_gamma
    offset = a * 4.0 + b * np.sqrt(c + 4.0) if cfg.nonnegative_reward else 0.0

    @torch.no_grad()
    def reward_fn(batch: Batch) -> Rewards:
        e = embed(torch.from_numpy(batch.judged("next_obs")))
        t = torch.from_numpy(batch.flat("timesteps") + 1).clamp_max(len(targets) - 1)
        dist2 = (e - targets[t]).square().sum(1)
        r = offset - a * dist2 - b * torch.sqrt(c + dist2)
        per_step = r.numpy().reshape(batch.rewards.shape)
        return Rewards(per_step, logged={"embed_dist2": dist2.mean().item()})

    learner = trpo_train(
        task.make_env,
        budget,
        seed,
        reward_fn=reward_fn,
        callback=report_each_update(task, logger),
        learner=make_trpo(task.obs_shape, task.act_dim, cfg, seed),
        snapshots=snapshots_of(logger),  # the reward, fixed once the embedding is trained
    )
    return deterministic(learner, task)
