"""The adversarial imitation loop GAIfO and GAIL share; they differ only in D's inputs.

Each iteration: collect a batch with the current policy, train the
discriminator D (Adam, cross-entropy, expert = 1) on policy vs expert samples,
then take one TRPO step on the reward D gives the batch.

Termination bias: PyBullet tasks end early when the agent falls. Valued as 0,
a fall is worth less than any step of a reward that is always positive
(-log(1 - D)), which then pays for survival whatever D says, and more than any
step of one that is always negative (log D), which pays for falling fast. By
default (`absorbing: true`) a termination leads into an absorbing state that D
judges like any other input (`bench.rl.absorbing`), and the signed reward
log D - log(1 - D) pays neither for survival nor for falling. With
`absorbing: false, reward: "-log(1-D)"` the learner is the paper's, bit for bit.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from bench.fields import added_later
from bench.harness.learners import ImitationTRPOConfig, trpo_on_reward
from bench.harness.registry import Logger, Task
from bench.imitation.data import Demos
from bench.imitation.discriminator import (
    REWARDS,
    Discriminator,
    Features,
    Head,
    Objective,
    RewardingDiscriminatorConfig,
    discriminator_log,
    discriminator_step,
    expert_transitions,
    logistic,
)
from bench.imitation.rewards import batch_rewards, batch_transitions
from bench.rl import absorbing, flat_adam
from bench.rl.absorbing import Transitions
from bench.rl.networks import (
    DeterministicPolicy,
    PixelScale,
    RunningNorm,
    normalizer,
)
from bench.rl.resume import Stateful
from bench.rl.rollout import Batch, Rewards
from bench.rl.shared_trunk import make_trpo
from bench.validate import at_least, one_of

DISC_NORMS = ("policy", "expert")
"""How D may scale states: by the policy's running statistics, or the demonstrations' fixed ones."""

ABSORBING_FLOORS = ("none", "mean", "min")
"""What may bound the absorbing state's reward from below: nothing, or the batch's real steps'
mean or lowest reward."""


@dataclass
class AdversarialConfig(ImitationTRPOConfig, RewardingDiscriminatorConfig):
    """The imitators' TRPO settings (inherited, shared with the survival control), D's, and how
    the on-policy loop trains D and rewards the policy."""

    disc_steps: int = 5
    """Discriminator minibatch steps per policy update (docs/design/d-pace.md)."""
    disc_minibatch: int = 256
    """Policy samples (and as many expert samples) per discriminator step."""
    absorbing: bool = True
    """Terminations lead into an absorbing state that D judges (bench.rl.absorbing); off: valued 0."""
    disc_norm: str = "policy"
    """How D scales the states it judges: by the policy's running statistics ("policy") or the
    demonstrations' fixed ones ("expert"); frames are scaled to [0, 1] either way."""
    disc_pause_above: float = 1.0
    """D takes no step in an update where it already tells more than this share of the policy's
    new batch from the expert; 1 never pauses (docs/design/settings.md)."""

    absorbing_floor: str = added_later("none")
    """A floor under D's reward for the absorbing state, per batch: "none", or the batch's real
    steps' "mean" or "min" reward (docs/design/settings.md)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        one_of(self, "absorbing_floor", ABSORBING_FLOORS)
        if self.absorbing_floor != "none" and not self.absorbing:
            raise ValueError("absorbing_floor needs absorbing states (absorbing: true)")
        one_of(self, "disc_norm", DISC_NORMS)
        at_least(self, 1, "disc_steps", "disc_minibatch")
        if self.disc_minibatch > self.batch_size:  # D draws its policy side from one batch
            raise ValueError(
                f"disc_minibatch ({self.disc_minibatch}) is more than a TRPO batch holds"
                f" ({self.n_envs} x {self.steps_per_env} = {self.batch_size} steps)"
            )
        if not 0.5 <= self.disc_pause_above <= 1:
            raise ValueError(f"disc_pause_above must be in [0.5, 1], not {self.disc_pause_above}")


def disc_normalizer(
    task: Task, policy_norm: RunningNorm | PixelScale, demos: Demos, disc_norm: str
) -> RunningNorm | PixelScale:
    """What D scales its input with. States: the policy's running statistics ("policy"), or the
    demonstrations' fixed ones ("expert": then a state's scale does not drift as the policy
    learns, and D weighs each feature by how far it lies from the expert's spread of it).
    Frames have a fixed scale whatever `disc_norm` says: the policy's own frames share the
    policy's, and frames the policy never sees (video filmed beside states) get their own."""
    if task.judged_shape != task.obs_shape:
        return normalizer(task.judged_shape)
    if disc_norm == "policy" or task.pixels is not None:
        return policy_norm
    return RunningNorm.of(np.concatenate(demos.observations))


def floor_absorbing(r: np.ndarray, n_real: int, kind: str) -> tuple[np.ndarray, float]:
    """`batch_transitions`' rewards `r` (the n_real real steps', then the absorbing tails')
    with the tails' raised to at least the floor `kind` ("mean" or "min") of the real steps'
    rewards; and that floor."""
    real = r[:n_real]
    floor = float(real.mean() if kind == "mean" else real.min())
    return np.concatenate([real, np.maximum(r[n_real:], floor)]), floor


def minibatch(x: Transitions, n: int, weighted: bool, gen: torch.Generator) -> Transitions:
    """n rows of `x` drawn with replacement: in proportion to occupancy (`weighted`: the
    absorbing loop stands for many steps, `bench.rl.absorbing`), else uniformly."""
    if weighted:
        idx = torch.multinomial(x.weight, n, replacement=True, generator=gen)
    else:
        idx = torch.randint(len(x), (n,), generator=gen)
    return x.map(lambda field: field[idx])


class DiscriminatorReward(Stateful):
    """TRPO's reward hook: on each batch, D takes `disc_steps` minibatch steps of the policy's
    transitions against the expert's, then rewards the batch from D as it is after them,
    with D's diagnostics to log."""

    def __init__(
        self,
        disc: Discriminator,
        expert: Transitions,
        task: Task,
        cfg: AdversarialConfig,
        seed: int,
        objective: Objective = logistic,
    ) -> None:
        """`expert`: the expert's transitions as tensors (`expert_transitions`). `objective`:
        what D minimizes (`bench.imitation.discriminator.logistic` or `wasserstein`)."""
        self.disc, self.expert, self.task, self.cfg = disc, expert, task, cfg
        self.objective = objective
        self.opt = flat_adam.adam(disc.parameters(), lr=cfg.disc_lr)
        self.gen = torch.Generator().manual_seed(seed + 2)
        self.reward = REWARDS[cfg.reward]
        seen_dim = int(np.prod(task.judged_shape))
        probe = absorbing.tails(np.zeros((1, seen_dim)), task.act_dim, cfg.gamma)
        self.absorbing_probe = probe.map(torch.as_tensor)

    def parts(self) -> dict[str, Any]:
        return {"disc": self.disc, "disc_opt": self.opt, "disc_gen": self.gen}

    def train_disc(self, policy_x: Transitions, pause: bool) -> dict[str, float]:
        """`disc_steps` steps of D on minibatches of `policy_x` against the expert's; what is
        logged of the last. `pause`: no step, the losses of one minibatch only."""
        disc, cfg, gen = self.disc, self.cfg, self.gen
        for _ in range(cfg.disc_steps):
            p = disc.inputs(minibatch(policy_x, cfg.disc_minibatch, cfg.absorbing, gen))
            e = disc.inputs(minibatch(self.expert, cfg.disc_minibatch, cfg.absorbing, gen))
            parts = discriminator_step(
                disc.net, self.opt, p, e, cfg, gen, learn=not pause, objective=self.objective
            )
            if pause:
                break
        return {**discriminator_log(parts), "disc_grad_penalty": parts["penalty"].item()}

    def __call__(self, batch: Batch) -> Rewards:
        disc, cfg = self.disc, self.cfg
        low, high = self.task.action_low, self.task.action_high
        x, terminated = batch_transitions(batch, low, high, cfg.gamma, cfg.absorbing)
        policy_x = x.map(torch.as_tensor)
        n_real = batch.n_steps
        pause = False
        if cfg.disc_pause_above < 1:
            with torch.no_grad():
                told_apart = (disc(policy_x)[:n_real] < 0).float().mean().item()
            pause = told_apart > cfg.disc_pause_above
        stats = self.train_disc(policy_x, pause)
        if cfg.disc_pause_above < 1:
            stats["disc_paused"] = float(pause)
        with torch.no_grad():
            r = self.reward(disc(policy_x)).numpy()
        stats["reward_mean"] = float(r[:n_real].reshape(batch.rewards.shape).mean())
        if cfg.absorbing_floor != "none":
            r, stats["absorbing_floor"] = floor_absorbing(r, n_real, cfg.absorbing_floor)
        stats["terminations"] = float(terminated.sum())
        if cfg.absorbing:
            # D's current reward for the absorbing loop, logged every update: in batches
            # without a termination D has no absorbing sample to train on, and what it makes
            # of the state then drifts; that drift is what a collapse after reaching the expert
            # needs watching for.
            with torch.no_grad():
                stats["reward_absorbing"] = float(self.reward(disc(self.absorbing_probe))[1])
        return batch_rewards(r, batch, terminated, cfg.gamma, cfg.absorbing, stats)


def train_adversarial(
    *,
    task: Task,
    demos: Demos,
    expert_actions: tuple[np.ndarray, ...] | None = None,
    features: Features,
    budget: int,
    seed: int,
    logger: Logger,
    cfg: AdversarialConfig,
    head: Head | None = None,
    objective: Objective = logistic,
) -> DeterministicPolicy:
    """The shared loop: D on `features` of expert vs policy transitions, TRPO on D's reward.

    `expert_actions`: (T_i, A) per demonstration, for a variant whose features use them (GAIL).
    `head`: D's network on the features (None: an MLP, `Discriminator`); `objective`: what D
    minimizes (a classifier's cross-entropy; a critic's, `wasserstein`).
    """
    # Built first: D may scale its inputs with the policy's running statistics.
    learner = make_trpo(task.obs_shape, task.act_dim, cfg, seed)
    expert = expert_transitions(
        demos.observations, demos.terminated, expert_actions, cfg.absorbing, cfg.gamma
    )
    disc = Discriminator(
        disc_normalizer(task, learner.policy.norm, demos, cfg.disc_norm),
        features,
        task.judged_shape,
        task.act_dim,
        cfg.disc_hidden,
        cfg.absorbing,
        cfg.disc_obs_dims,
        head,
    )
    reward = DiscriminatorReward(disc, expert.map(torch.as_tensor), task, cfg, seed, objective)
    return trpo_on_reward(task, budget, seed, logger, cfg, reward, learner)
