"""The off-policy learners' replay: a ring buffer of transitions (`ReplayBuffer`), the
minibatches it gives (`ReplayBatch`), and how one env step's transitions are stored
(`transitions_of_step`), terminations the way DAC stores them (Kostrikov et al. 2019).

With absorbing states, an episode that terminates leads into an absorbing state that loops on
itself for ever: the last step is stored as (s, a, s_a) and the loop once as (s_a, 0, s_a), and
nothing is masked as "done" (`bench.rl.absorbing` says why). An absorbing observation is all
zeros with a flag set; every network reads observations with that flag appended (`flagged`).
Without, a termination is masked (`not_done` 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from bench.rl.absorbing import FLAG


@dataclass
class ReplayBatch:
    """A minibatch of transitions as torch tensors; observations with the absorbing flag last."""

    obs: torch.Tensor
    """(B, O+1)"""
    actions: torch.Tensor
    """(B, A); zeros on the absorbing loop."""
    next_obs: torch.Tensor
    """(B, O+1)"""
    env_rewards: torch.Tensor
    """(B,) the env's reward; 0 into and on the absorbing loop after it."""
    not_done: torch.Tensor
    """(B,) 0 where a termination is masked (absorbing off), else 1."""

    def to(self, device: torch.device | str) -> ReplayBatch:
        return ReplayBatch(*(x.to(device) for x in vars(self).values()))

    @property
    def obs_absorbing(self) -> torch.Tensor:
        return self.obs[:, -1] > 0

    @property
    def next_absorbing(self) -> torch.Tensor:
        return self.next_obs[:, -1] > 0

    def raw(self, which: str) -> torch.Tensor:
        """`obs` or `next_obs` without the flag column."""
        return getattr(self, which)[:, :-1]


class ReplayBuffer:
    """A ring buffer of transitions in preallocated arrays; observations stored with their flag."""

    def __init__(self, obs_dim: int, act_dim: int, size: int, seed: int) -> None:
        self.obs = np.zeros((size, obs_dim + 1), np.float32)
        self.next_obs = np.zeros((size, obs_dim + 1), np.float32)
        self.actions = np.zeros((size, act_dim), np.float32)
        self.env_rewards = np.zeros(size, np.float32)
        self.not_done = np.ones(size, np.float32)
        self.size, self.count, self.cursor = size, 0, 0
        self.rng = np.random.default_rng(seed)

    def add(self, obs, actions, next_obs, env_rewards, not_done) -> None:
        """Append n rows (observations (n, O+1), flag included), overwriting the oldest."""
        rows = (self.cursor + np.arange(len(obs))) % self.size
        self.obs[rows], self.actions[rows], self.next_obs[rows] = obs, actions, next_obs
        self.env_rewards[rows], self.not_done[rows] = env_rewards, not_done
        self.cursor = int(rows[-1] + 1) % self.size
        self.count = min(self.count + len(obs), self.size)

    def sample(self, n: int, device: torch.device | str = "cpu") -> ReplayBatch:
        idx = self.rng.integers(self.count, size=n)
        return ReplayBatch(*(torch.from_numpy(x[idx]).to(device) for x in self._fields()))

    def _fields(self) -> tuple[np.ndarray, ...]:
        return self.obs, self.actions, self.next_obs, self.env_rewards, self.not_done

    def state_dict(self) -> dict:
        """The rows filled so far (as tensors: weights_only-safe), the cursor and the RNG."""
        rows = [torch.from_numpy(x[: self.count].copy()) for x in self._fields()]
        return {"rows": rows, "cursor": self.cursor, "rng": self.rng.bit_generator.state}

    def load_state_dict(self, state: dict) -> None:
        rows = state["rows"]
        self.count, self.cursor = len(rows[0]), state["cursor"]
        for field_, saved in zip(self._fields(), rows, strict=True):
            field_[: self.count] = saved.numpy()
        self.rng.bit_generator.state = state["rng"]


def flagged(obs: np.ndarray, absorbing: bool = False) -> np.ndarray:
    """(n, O) observations -> (n, O+1): the flag column appended (FLAG and zeros if absorbing)."""
    obs = np.asarray(obs, np.float32).reshape(len(obs), -1)
    if absorbing:
        out = np.zeros((len(obs), obs.shape[1] + 1), np.float32)
        out[:, -1] = FLAG
        return out
    return np.concatenate([obs, np.zeros((len(obs), 1), np.float32)], axis=1)


def transitions_of_step(obs, actions, next_obs, rewards, terminated, absorbing: bool) -> tuple:
    """One vectorized env step's rows for the buffer: (obs, actions, next_obs, rewards,
    not_done), each (n, ...). A terminated env's row leads into the absorbing state, and the
    absorbing loop is added once (with `absorbing`), or is masked (without)."""
    n, act_dim = len(obs), actions.shape[1]
    s, s_next = flagged(obs), flagged(next_obs)
    not_done = np.ones(n, np.float32)
    rewards = np.asarray(rewards, np.float32)
    if not absorbing:
        return s, actions, s_next, rewards, np.where(terminated, 0.0, 1.0).astype(np.float32)
    ended = np.flatnonzero(terminated)
    if len(ended) == 0:
        return s, actions, s_next, rewards, not_done
    s_next[ended] = flagged(next_obs[ended], absorbing=True)
    loop = flagged(np.zeros((len(ended), obs.shape[1])), absorbing=True)
    return (
        np.concatenate([s, loop]),
        np.concatenate([actions, np.zeros((len(ended), act_dim), np.float32)]),
        np.concatenate([s_next, loop]),
        np.concatenate([rewards, np.zeros(len(ended), np.float32)]),
        np.ones(n + len(ended), np.float32),
    )
