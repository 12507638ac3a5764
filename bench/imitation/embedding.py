"""The time-contrastive embedding of TCN (Sermanet et al. 2017): unit-length features of
demonstration states, trained with a triplet loss so that states close in time lie close
together, and the mean embedding of the demonstrations at each step, the target a TCN reward
tracks."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

from bench.imitation.data import Demos
from bench.rl import flat_adam
from bench.rl.networks import ObsShape, body, normalizer
from bench.validate import Checked, above, at_least, layers


@dataclass
class EmbeddingConfig(Checked):
    """The embedding's settings and its triplet training's."""

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

    def __post_init__(self) -> None:
        super().__post_init__()
        layers(self, "embed_hidden")
        if not 1 <= self.pos_window < self.neg_margin:
            raise ValueError("need 1 <= pos_window < neg_margin")
        at_least(self, 1, "embed_dim", "embed_steps", "embed_minibatch")
        at_least(self, 0, "triplet_margin")
        above(self, 0, "embed_lr")


class Embedding(nn.Module):
    """Raw (B, O) states -> (B, D) unit-length embeddings; inputs normalized by demo statistics.
    From frames (obs_shape (C, H, W)), a convolutional trunk comes first, as in the TCN paper."""

    def __init__(self, obs_shape: ObsShape, cfg: EmbeddingConfig) -> None:
        super().__init__()
        self.norm = normalizer(obs_shape)
        self.net = body(obs_shape, cfg.embed_hidden, cfg.embed_dim)

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return F.normalize(self.net(self.norm(obs)), dim=-1)


def n_negatives(t: np.ndarray, L: np.ndarray, margin: int) -> np.ndarray:
    """How many steps of an episode of L rows lie at least `margin` from step t."""
    return np.maximum(t - margin + 1, 0) + np.maximum(L - t - margin, 0)


def sample_triplets(
    lengths: np.ndarray, n: int, cfg: EmbeddingConfig, rng: np.random.Generator
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


def train_embedding(
    embed: Embedding, demos: Demos, cfg: EmbeddingConfig, seed: int
) -> dict[str, float]:
    """Triplet loss max(0, |a - p|^2 - |a - n|^2 + margin) over demonstration states."""
    embed.norm.update(np.concatenate(demos.observations))
    lengths = np.array([len(o) for o in demos.observations])
    if not np.any(lengths > cfg.neg_margin):
        raise ValueError(f"no demonstration is longer than neg_margin ({cfg.neg_margin} steps)")
    offsets = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    states = torch.from_numpy(np.concatenate(demos.observations))
    opt = flat_adam.adam(embed.net.parameters(), lr=cfg.embed_lr)
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
