"""The off-policy family: GAIfO and GAIL on SAC with absorbing states (DAC, Kostrikov et al.
2019; GAIfO on it is "DACfO"); its controls run the same optimizer through `train_on_reward`
(`algorithms.controls`), so every comparison among them stays matched.

Each SAC update samples a minibatch from the replay buffer; the discriminator D takes one
step on it against as many expert transitions, and the critic learns from D's reward for
that very minibatch, computed after the step: rewards always come from the current D, never
from the one in force when a step was taken. D, its features ((s, s') for GAIfO, (s, a) for
GAIL), its gradient penalty and its reward (the logit, either sign) are the on-policy
learners' (`algorithms.adversarial`); what differs is the optimizer and how terminations are
stored: DAC's way, (s, a, s_a) then the loop (s_a, 0, s_a) once, on both sides.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from algorithms.gaifo import state_transition
from algorithms.gail import state_action
from bench.harness.registry import Logger, Policy, Task, register, snapshots_of
from bench.imitation.data import ActionDemos, Demos
from bench.imitation.discriminator import (
    REWARDS,
    Discriminator,
    Features,
    RewardingDiscriminatorConfig,
    discriminator_log,
    discriminator_step,
)
from bench.imitation.rewards import replay_transitions
from bench.rl import flat_adam, resume, sac
from bench.rl.networks import RunningNorm
from bench.rl.replay import ReplayBatch, transitions_of_step


@dataclass
class OffPolicyConfig(sac.SACConfig):
    """SAC as the off-policy learners and their controls run it."""


@dataclass
class OffPolicyAdversarialConfig(OffPolicyConfig, RewardingDiscriminatorConfig):
    """The off-policy imitators' SAC settings plus D's (the on-policy learners' D)."""


def sac_budget(config: OffPolicyConfig) -> int:
    """Fewest env steps to learn anything: the random steps before the first update, plus one."""
    return config.learning_starts + config.n_envs


def expert_replay(
    demos: Demos, actions: tuple[np.ndarray, ...] | None, act_dim: int, absorbing: bool
) -> ReplayBatch:
    """Every demonstrated transition, stored as the agent's are (`transitions_of_step`):
    a terminated demonstration's last step leads into the absorbing loop."""
    rows = []
    for k, o in enumerate(demos.observations):
        a = actions[k] if actions is not None else np.zeros((len(o) - 1, act_dim), np.float32)
        ended = np.zeros(len(o) - 1, bool)
        ended[-1] = demos.terminated[k]
        rows.append(transitions_of_step(o[:-1], a, o[1:], np.zeros(len(a)), ended, absorbing))
    return ReplayBatch(*(torch.from_numpy(np.concatenate(x)) for x in zip(*rows, strict=True)))


def sample_of(batch: ReplayBatch, n: int, gen: torch.Generator) -> ReplayBatch:
    """n rows of `batch` drawn uniformly with replacement. The indices are drawn on the CPU
    with `gen` whatever the batch's device, so a seed draws the same rows on any device (as
    D's own draws are, `discriminator_loss`)."""
    idx = torch.randint(len(batch.obs), (n,), generator=gen).to(batch.obs.device)
    return ReplayBatch(*(x[idx] for x in vars(batch).values()))


class CurrentDReward(resume.Stateful):
    """The critic's reward hook: for each replay minibatch, one Adam step of D on it against
    as many expert transitions, then D's reward for that minibatch from D as it is after the
    step, with D's diagnostics to log."""

    def __init__(
        self,
        disc: Discriminator,
        expert: ReplayBatch,
        cfg: OffPolicyAdversarialConfig,
        seed: int,
    ) -> None:
        self.disc, self.expert, self.cfg = disc, expert, cfg
        self.opt = flat_adam.adam(disc.net.parameters(), lr=cfg.disc_lr)
        self.gen = torch.Generator().manual_seed(seed + 2)
        self.reward = REWARDS[cfg.reward]

    def __call__(self, batch: ReplayBatch) -> sac.Logged:
        disc = self.disc
        e_batch = sample_of(self.expert, len(batch.obs), self.gen)
        p = disc.inputs(replay_transitions(batch))
        e = disc.inputs(replay_transitions(e_batch))
        parts = discriminator_step(disc.net, self.opt, p, e, self.cfg, self.gen)
        with torch.no_grad():  # the reward of this very minibatch, from D as it is now
            rewards = self.reward(disc.net(p).squeeze(-1))
        logged = {**discriminator_log(parts), "reward_mean": rewards.mean().item()}
        return sac.Logged(rewards, logged)

    def parts(self) -> dict[str, Any]:
        return {"disc": self.disc, "opt": self.opt, "gen": self.gen}


def train_offpolicy_adversarial(
    task: Task,
    demos: Demos,
    expert_actions: tuple[np.ndarray, ...] | None,
    features: Features,
    budget: int,
    seed: int,
    logger: Logger,
    cfg: OffPolicyAdversarialConfig,
) -> Policy:
    device = sac.usable_device(cfg.device)
    expert = expert_replay(demos, expert_actions, task.act_dim, cfg.absorbing).to(device)
    norm = RunningNorm.of(np.concatenate(demos.observations))  # D's scale: the expert's, fixed
    disc = Discriminator(
        norm, features, task.obs_dim, task.act_dim, cfg.disc_hidden, True, cfg.disc_obs_dims
    )
    disc = disc.to(device)
    reward_fn = CurrentDReward(disc, expert, cfg, seed)
    return train_on_reward(task, budget, seed, logger, cfg, reward_fn)


def train_on_reward(
    task: Task,
    budget: int,
    seed: int,
    logger: Logger,
    cfg: OffPolicyConfig,
    reward_fn: sac.SACRewardFn | None,
    learner: sac.OffPolicyLearner | None = None,
) -> Policy:
    """SAC (or `learner`, as OPOLO's TD3) on `reward_fn` (None: the env's), logging and
    offering its policy as it goes, and saving snapshots where the runner keeps them."""

    def report(steps: int, learner: sac.SAC, info: dict[str, float]) -> None:
        logger.log(steps, **info)
        logger.checkpoint(steps, sac.DeterministicActor(learner.actor))

    learner = sac.train(
        task.make_env,
        budget,
        seed,
        cfg,
        reward_fn,
        callback=report,
        learner=learner,
        snapshots=snapshots_of(logger),
    )
    return sac.DeterministicActor(learner.actor)


@register(
    "gaifo-sac",
    config=OffPolicyAdversarialConfig,
    inputs="states",
    resumable=True,
    description="GAIfO on SAC with absorbing states (DACfO): D on (s, s')",
    min_budget=sac_budget,
    family="sac",
    label="GAIfO (SAC)",
)
def train_gaifo(task: Task, demos: Demos, budget: int, seed: int, logger: Logger, config) -> Policy:
    return train_offpolicy_adversarial(
        task, demos, None, state_transition, budget, seed, logger, config
    )


@register(
    "gail-sac",
    config=OffPolicyAdversarialConfig,
    inputs="actions",
    resumable=True,
    description="GAIL on SAC with absorbing states (DAC): D on (s, a)",
    min_budget=sac_budget,
    family="sac",
    label="GAIL (SAC)",
)
def train_gail(
    task: Task, demos: ActionDemos, budget: int, seed: int, logger: Logger, config
) -> Policy:
    return train_offpolicy_adversarial(
        task, demos.demos, demos.actions, state_action, budget, seed, logger, config
    )
