"""Demonstrations, the data every imitation learner starts from. Frozen; shapes checked on
construction. T is the steps in an episode, O the observation size, A the action size."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Demos:
    """State-only demonstrations: what an imitation-from-observation algorithm gets.

    There is deliberately no `actions` field anywhere on this type.
    """

    env_id: str
    observations: tuple[np.ndarray, ...]
    """One (T_i + 1, O) float32 array per episode; row T_i is the episode's true final observation.
    From pixels, (T_i + 1, C*H*W) uint8 flat stacks of frames (`bench.envs.pixels`)."""
    terminated: tuple[bool, ...] | None = None
    """Per episode: True if it ended in a terminal state (the agent fell), False if a time limit
    cut it. None means no episode terminated."""

    def __post_init__(self) -> None:
        if not self.observations:
            raise ValueError("Demos needs at least one episode")
        dims = {o.shape[1] for o in self.observations if o.ndim == 2}
        if len(dims) != 1 or any(o.ndim != 2 or len(o) < 2 for o in self.observations):
            raise ValueError("each episode must be a (T+1, O) array with T >= 1 and one O for all")
        terminated = (False,) * self.n_episodes if self.terminated is None else self.terminated
        if len(terminated) != self.n_episodes:
            raise ValueError("one terminated flag per episode")
        object.__setattr__(self, "terminated", tuple(bool(t) for t in terminated))

    @property
    def obs_dim(self) -> int:
        return self.observations[0].shape[1]

    @property
    def n_episodes(self) -> int:
        return len(self.observations)

    def transitions(self) -> tuple[np.ndarray, np.ndarray]:
        """All (s, s') pairs: two (sum T_i, O) arrays."""
        obs = np.concatenate([o[:-1] for o in self.observations])
        next_obs = np.concatenate([o[1:] for o in self.observations])
        return obs, next_obs


@dataclass(frozen=True)
class ActionDemos:
    """Demonstrations with the expert's actions. Only GAIL (and tests) may receive these."""

    demos: Demos
    actions: tuple[np.ndarray, ...]
    """One (T_i, A) float32 array per episode, aligned with `demos.observations[i][:-1]`."""

    def __post_init__(self) -> None:
        if len(self.actions) != self.demos.n_episodes:
            raise ValueError("one action array per episode")
        for o, a in zip(self.demos.observations, self.actions, strict=True):
            if a.ndim != 2 or len(a) != len(o) - 1:
                raise ValueError("actions of episode i must be (T_i, A) with T_i = len(obs_i) - 1")

    @property
    def env_id(self) -> str:
        return self.demos.env_id

    def state_actions(self) -> tuple[np.ndarray, np.ndarray]:
        """All (s, a) pairs: (sum T_i, O) and (sum T_i, A)."""
        obs = np.concatenate([o[:-1] for o in self.demos.observations])
        return obs, np.concatenate(self.actions)
