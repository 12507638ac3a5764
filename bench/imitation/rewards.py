"""One reward signature for both optimizers: a function of transitions.

    reward(x: Transitions) -> (N,) tensor, one reward per row of x

Rows are what an observer sees of each step (s, a, s'), with the absorbing flags of
`bench.rl.absorbing`: a learned reward judges the absorbing state like any other input, so
ending an episode is worth what the reward makes of it. `on_trpo` and `on_sac` hand such a
function to each optimizer as its loop asks for rewards: TRPO's whole batches of (T, E) steps,
where a termination's absorbing tail is valued and folded into `Rewards.after_termination`,
and SAC's replay minibatches, which store the absorbing loop as rows of their own.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import torch

from bench.rl import absorbing, replay, sac
from bench.rl.absorbing import Transitions
from bench.rl.rollout import Batch, RewardFn, Rewards

TransitionReward = Callable[[Transitions], torch.Tensor]
"""reward(x) -> (N,) rewards of the N transitions x: observations as the env gives them (or
the frames a reward judges, `Batch.judged`), actions as applied, absorbing rows flagged."""


def batch_transitions(
    batch: Batch, low: np.ndarray, high: np.ndarray, gamma: float, with_absorbing: bool = True
) -> tuple[Transitions, np.ndarray]:
    """A TRPO batch's (T*E) transitions, actions clipped to [low, high] as the env applied
    them, followed (`with_absorbing`) by the absorbing tail of each step that terminated; and
    the (T*E,) terminated flags."""
    actions = np.clip(batch.flat("actions"), low, high)
    real = Transitions.real(batch.judged("obs"), actions, batch.judged("next_obs"))
    terminated = batch.flat("terminated")
    parts = [real]
    if with_absorbing and terminated.any():
        parts.append(absorbing.tails(real.next_obs[terminated], actions.shape[1], gamma))
    return Transitions.concat(parts), terminated


def batch_rewards(
    r: np.ndarray,
    batch: Batch,
    terminated: np.ndarray,
    gamma: float,
    with_absorbing: bool = True,
    logged: dict[str, float] | None = None,
) -> Rewards:
    """Rewards of `batch_transitions`' rows, `r`, as TRPO takes them: the (T, E) real steps',
    and where a step terminated, its absorbing tail's discounted value."""
    n_real = batch.n_steps
    per_step = r[:n_real].reshape(batch.rewards.shape)
    if not with_absorbing:
        return Rewards(per_step, logged=logged or {})
    after = np.zeros(n_real)
    n_term = int(terminated.sum())
    if n_term:
        tail = absorbing.tail_rewards(r[n_real:], n_term)
        after[terminated] = absorbing.tail_value(tail, gamma)
    return Rewards(per_step, after.reshape(batch.rewards.shape), logged or {})


def on_trpo(reward: TransitionReward, low: np.ndarray, high: np.ndarray, gamma: float) -> RewardFn:
    """`reward` as TRPO's loop asks for it (`bench.rl.trpo.train`'s `reward_fn`), with
    absorbing states: for the task's action bounds and TRPO's discount `gamma`."""

    def reward_fn(batch: Batch) -> Rewards:
        x, terminated = batch_transitions(batch, low, high, gamma)
        with torch.no_grad():
            r = reward(x.map(torch.as_tensor)).cpu().numpy()
        return batch_rewards(r, batch, terminated, gamma)

    return reward_fn


def replay_transitions(batch: replay.ReplayBatch) -> Transitions:
    """A replay minibatch as a reward reads transitions."""
    return Transitions(
        batch.raw("obs"),
        batch.actions,
        batch.raw("next_obs"),
        batch.obs_absorbing,
        batch.next_absorbing,
        torch.ones(len(batch.obs), device=batch.obs.device),
    )


def on_sac(reward: TransitionReward) -> sac.SACRewardFn:
    """`reward` as SAC's loop asks for it (`bench.rl.sac.train`'s `reward_fn`), on every
    replay minibatch the critic learns from."""

    def reward_fn(batch: replay.ReplayBatch) -> torch.Tensor:
        with torch.no_grad():
            return reward(replay_transitions(batch))

    return reward_fn
