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
3. The policy: the imitators' TRPO (`trpo_on_reward`) on that reward; the embedding stays fixed.

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

from bench.fields import added_later
from bench.harness.learners import ImitationTRPOConfig, one_batch, trpo_on_reward
from bench.harness.registry import Logger, Policy, Task, register
from bench.imitation.data import Demos
from bench.imitation.embedding import Embedding, EmbeddingConfig, demo_targets, train_embedding
from bench.rl.rollout import Batch, Rewards
from bench.validate import above, at_least


@dataclass
class TCNConfig(ImitationTRPOConfig, EmbeddingConfig):
    """The imitators' TRPO settings and the embedding's (inherited, overridable) plus the
    reward's."""

    policy_average: float = added_later(0.0)
    """As the imitators' (`ImitationTRPOConfig`), but off by default: TCN returns its latest
    policy."""
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
        at_least(self, 0, "reward_alpha", "reward_beta")
        above(self, 0, "reward_gamma")


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

    # the reward is fixed once the embedding is trained: nothing of it to snapshot
    return trpo_on_reward(task, budget, seed, logger, cfg, reward_fn)
