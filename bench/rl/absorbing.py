"""Absorbing states (Kostrikov et al. 2019, "Discriminator-Actor-Critic") for on-policy learners.

Why. When an episode terminates (the agent fell), an RL update normally values
what follows as 0. With a learned reward, 0 is not neutral: a reward that is
positive everywhere makes every live step beat falling (a bias towards mere
survival), one that is negative everywhere makes falling beat living. DAC lets
a terminal state lead into an absorbing state `s_a` that loops on itself
forever and lets the learned reward judge it like any other input, so the
reward itself decides what ending an episode is worth.

The tail. After the agent's last real transition into the terminal state
`s_T`, the episode goes on in the absorbing MDP with

    x_1 = (s_T, 0, s_a)        once        reward r_1 = r(x_1)
    x_2 = (s_a, 0, s_a)        for ever    reward r_2 = r(x_2)

(a zero action: nothing is acted in the tail). Its discounted value from s_T is

    V(s_T) = r_1 + gamma r_2 + gamma^2 r_2 + ... = r_1 + gamma r_2 / (1 - gamma).

Bootstrapping on-policy. The last real step (s_{T-1}, a, s_T) bootstraps from
that value exactly as a live step bootstraps from V(s'):

    delta_{T-1} = r_{T-1} + gamma V(s_T) - V(s_{T-1}),

and GAE's advantage chain stops there: the tail's values are exact, so every
tail step's TD error r_k + gamma V_{k+1} - V_k is 0 and adds nothing upstream.
A trainer takes these values as `Rewards.after_termination` (see
`bench.rl.rollout`). Truncation is different: an episode cut by its time
limit, or a batch cut mid-episode, did not end, so it has no absorbing state
and bootstraps from the value network's V(s') as always. Expert episodes get
the same treatment: a demonstration that terminated contributes its tail to
the expert's samples, one that was truncated contributes none.

Weight. A learned reward trained on samples must see the absorbing state as
often as an agent occupies it. One termination is one real step, but the
absorbing state it leads into is occupied for the rest of the horizon: in the
discounted occupancy measure, relative to the step into it, the loop weighs
sum_{k>=1} gamma^k = gamma / (1 - gamma), rounded up to 1/(1 - gamma). `tails` gives the loop row that
weight; samplers draw rows in proportion to `Transitions.weight`. Drawn once
per termination instead (DAC's replay buffer, with episodes of ~1000 steps), a
policy that falls after 50 steps would spend 2% of D's samples on the state
that tells it apart from the expert, and D would barely judge it.

Representation. An absorbing observation is all zeros with a flag set; real
observations carry the flag 0. A learner appends the flag after normalizing
(`Transitions.obs_absorbing` / `next_absorbing`), so the absorbing state is
the same input whatever the running statistics.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from bench.rl.networks import observation

FLAG = 10.0
"""The absorbing flag's value in a learner's input, against O(1) normalized features. A flag of
1 would put the absorbing state within one unit of the data's centre, where a smooth
(gradient-penalized) discriminator cannot judge it apart from the expert's states."""


def tail_value(rewards: np.ndarray, gamma: float) -> np.ndarray:
    """Discounted value of tails whose last transition repeats for ever.

    rewards: (n, k), the rewards of each tail's k transitions, in order; the
    k-th repeats. Returns (n,): sum_{i<k-1} gamma^i r_i + gamma^(k-1) r_{k-1} / (1 - gamma).
    """
    rewards = np.asarray(rewards, dtype=np.float64)
    k = rewards.shape[1]
    weights = gamma ** np.arange(k, dtype=np.float64)
    weights[-1] /= 1.0 - gamma
    return rewards @ weights


@dataclass(frozen=True)
class Transitions:
    """N transitions (s, a, s') as a learned reward sees them; numpy arrays or torch tensors.

    An absorbing observation is stored as zeros with its flag set. `actions` may
    have width 0 (state-only demonstrations carry none).
    """

    obs: Any
    """(N, O) float32 (uint8 for flat frames, kept so: a quarter of the memory)."""
    actions: Any
    """(N, A) float32; zeros in an absorbing tail."""
    next_obs: Any
    """(N, O), like obs."""
    obs_absorbing: Any
    """(N,) bool: s is the absorbing state."""
    next_absorbing: Any
    """(N,) bool: s' is the absorbing state."""
    weight: Any
    """(N,) float32: how many steps of occupancy the row stands for (1, or 1/(1-gamma) for the
    absorbing loop); draw samples in proportion to it."""

    def __post_init__(self) -> None:
        n = len(self.obs)
        if any(len(x) != n for x in self.fields()):
            raise ValueError("every field of Transitions needs the same number of rows")

    def fields(self) -> list[Any]:
        return [getattr(self, f.name) for f in dataclasses.fields(self)]

    def __len__(self) -> int:
        return len(self.obs)

    def map(self, fn: Callable[[Any], Any]) -> Transitions:
        """The same transitions with `fn` applied to every field (indexing, to tensors, ...)."""
        return Transitions(*(fn(x) for x in self.fields()))

    @staticmethod
    def concat(parts: list[Transitions]) -> Transitions:
        """Rows of `parts` one after another (numpy)."""
        return Transitions(*map(np.concatenate, zip(*(p.fields() for p in parts), strict=True)))

    @staticmethod
    def real(obs: np.ndarray, actions: np.ndarray, next_obs: np.ndarray) -> Transitions:
        """Transitions between real (non-absorbing) observations."""
        live = np.zeros(len(obs), dtype=bool)
        return Transitions(
            observation(obs),
            np.asarray(actions, np.float32),
            observation(next_obs),
            live,
            live.copy(),
            np.ones(len(obs), np.float32),
        )


def tails(final_obs: np.ndarray, act_dim: int, gamma: float) -> Transitions:
    """The absorbing tails of n terminated episodes: 2n rows, the n (s_T, 0, s_a) first (weight
    1), then n copies of the loop (s_a, 0, s_a) (weight 1/(1 - gamma)).
    final_obs: (n, O), each episode's terminal observation."""
    final_obs = observation(final_obs)
    n, obs_dim = final_obs.shape
    zeros_obs = np.zeros((n, obs_dim), final_obs.dtype)
    no, yes = np.zeros(n, dtype=bool), np.ones(n, dtype=bool)
    return Transitions(
        obs=np.concatenate([final_obs, zeros_obs]),
        actions=np.zeros((2 * n, act_dim), np.float32),
        next_obs=np.concatenate([zeros_obs, zeros_obs]),
        obs_absorbing=np.concatenate([no, yes]),
        next_absorbing=np.concatenate([yes, yes]),
        weight=np.concatenate([np.ones(n), np.full(n, 1.0 / (1.0 - gamma))]).astype(np.float32),
    )


def tail_rewards(rewards: np.ndarray, n: int) -> np.ndarray:
    """(n, 2) rewards of `tails(...)`'s 2n rows, laid out for `tail_value`."""
    return np.asarray(rewards).reshape(2, n).T
