"""What an algorithm built on TRPO needs from the harness, built-in or plugin: the imitators'
TRPO settings (extend `ImitationTRPOConfig` and the controls stay matched), the averaged
policy the runner evaluates, the per-update report, and `trpo_on_reward`, which runs all of it
on a reward of the algorithm's own (from states or frames alike)."""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

import torch

from bench.harness.registry import Logger, Task, snapshots_of
from bench.rl.networks import DeterministicPolicy, GaussianPolicy
from bench.rl.rollout import Batch, RewardFn
from bench.rl.shared_trunk import make_trpo
from bench.rl.trpo import TRPO, OnUpdate, TRPOConfig, train


@dataclass
class ImitationTRPOConfig(TRPOConfig):
    """TRPO as the imitators run it. GAIfO, GAIL and TCN extend it and the TRPO controls run it
    as is, so a default changed here changes for the controls too: they stay matched."""

    init_log_std: float = 0.0
    """Action noise at the start (log of the Gaussian's std; docs/design/settings.md)."""
    policy_average: float = 0.9
    """Decay per update of the moving average of the policy's weights that is evaluated and
    returned (`PolicyAverage`); 0: the latest policy (docs/design/settings.md)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        if not 0 <= self.policy_average < 1:
            raise ValueError(f"policy_average must be in [0, 1), not {self.policy_average}")


def one_batch(config: TRPOConfig) -> int:
    """A TRPO learner's smallest budget: one batch (`register(..., min_budget=one_batch)`)."""
    return config.batch_size


def deterministic(learner: TRPO, task: Task) -> DeterministicPolicy:
    """A snapshot of the learner's mean policy, clipped to the task's action bounds."""
    return DeterministicPolicy(learner.policy, task.action_low, task.action_high)


class PolicyAverage:
    """Exponential moving average of a learner's policy weights, one step per TRPO update.

    Adversarial imitation does not settle at a point: once D is at chance its reward is noise,
    and TRPO still takes a full trust-region step on the normalized advantages of every batch,
    so the latest policy is a random draw around the imitation. Averaging the weights of the
    last updates, as is done for GAN generators, returns the centre instead."""

    def __init__(self, decay: float, like: GaussianPolicy | None = None) -> None:
        """`like`: a policy of the averaged one's shape, to load a saved average into."""
        self.decay, self.like = decay, like
        self.weights: GaussianPolicy | None = None

    def state_dict(self) -> dict:
        return {"weights": None if self.weights is None else self.weights.state_dict()}

    def load_state_dict(self, state: dict) -> None:
        if state["weights"] is None:
            self.weights = None
            return
        if self.like is None:
            raise ValueError("PolicyAverage needs `like` to load a saved average into")
        self.weights = copy.deepcopy(self.like)
        self.weights.load_state_dict(state["weights"])

    @torch.no_grad()
    def update(self, policy: GaussianPolicy) -> None:
        if self.weights is None or self.decay == 0.0:
            self.weights = copy.deepcopy(policy)
            return
        for mine, theirs in zip(self.weights.parameters(), policy.parameters(), strict=True):
            mine.lerp_(theirs, 1.0 - self.decay)
        for mine, theirs in zip(self.weights.buffers(), policy.buffers(), strict=True):
            mine.copy_(theirs)  # observation statistics: the latest, as the policy's own

    def policy(self, learner: TRPO, task: Task) -> DeterministicPolicy:
        """The averaged mean policy (the learner's latest before any update)."""
        weights = self.weights if self.weights is not None else learner.policy
        return DeterministicPolicy(weights, task.action_low, task.action_high)


def report_each_update(
    task: Task, logger: Logger, average: PolicyAverage | None = None
) -> OnUpdate:
    """A TRPO callback: log the update's diagnostics (the optimizer's, and the reward's own:
    `Rewards.logged`) and the policy's action noise (mean std), fold the policy into `average`
    if given, and offer the policy (the average, if given) for evaluation."""

    def on_update(steps: int, learner: TRPO, batch: Batch, info: dict[str, float]) -> None:
        noise = learner.policy.log_std.detach().exp().mean().item()
        logger.log(steps, **info, policy_std=noise)
        if average is None:
            logger.checkpoint(steps, deterministic(learner, task))
        else:
            average.update(learner.policy)
            logger.checkpoint(steps, average.policy(learner, task))

    return on_update


def trpo_on_reward(
    task: Task,
    budget: int,
    seed: int,
    logger: Logger,
    config: ImitationTRPOConfig,
    reward_fn: RewardFn | None,
    learner: TRPO | None = None,
) -> DeterministicPolicy:
    """The imitators' TRPO, with their settings and their averaged policy, on `reward_fn` (None:
    the env's own reward, as the `oracle` control): the one path from a reward to TRPO, which
    every TRPO learner and control takes. `learner`: one built beforehand (`make_trpo`), for a
    reward that shares its observation statistics (GAIfO's D). Resumable as every built-in loop
    is: a reward that learns as it goes is an object with `state_dict` and `load_state_dict`
    (`bench.rl.resume.Stateful`), saved with the learner; a plain function is taken to be fixed."""
    learner = learner or make_trpo(task.obs_shape, task.act_dim, config, seed)
    average = PolicyAverage(config.policy_average, like=learner.policy)
    # At 0 the average is the latest policy, which is saved with the learner.
    keep: dict[str, Any] = {"average": average} if config.policy_average > 0 else {}
    if hasattr(reward_fn, "state_dict"):
        keep["reward"] = reward_fn
    train(
        task.make_env,
        budget,
        seed,
        reward_fn=reward_fn,
        callback=report_each_update(task, logger, average=average),
        learner=learner,
        snapshots=snapshots_of(logger),
        keep=keep,
    )
    return average.policy(learner, task)
