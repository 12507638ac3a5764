"""An env's current episode as a seed and the actions taken since: enough to bring a new env
to the very state the old one was in (for snapshots, `bench.harness.snapshots`), since PyBullet steps
deterministically on one machine. On another machine the replayed state may differ in the
last bits, as any result does there."""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np
import torch


@dataclass
class Episode:
    """How an env's current episode began and the actions taken in it since."""

    start: int | dict
    """The seed of a seeded reset, or the env's random state just before an unseeded one."""
    actions: list[np.ndarray]

    @classmethod
    def begin(cls, env: gym.Env, seed: int | None = None) -> tuple[Any, dict, Episode]:
        """Reset `env` (with `seed`, if given): its first observation and info, and the new
        episode."""
        start = seed if seed is not None else copy.deepcopy(rng_state(env))
        obs, info = env.reset(seed=seed)
        return obs, info, cls(start, [])

    def replay(self, env: gym.Env) -> tuple[Any, dict]:
        """Bring `env`, a fresh env of the same seed, to where this episode is: its latest
        observation and info."""
        if isinstance(self.start, int):
            obs, info = env.reset(seed=self.start)
        else:
            env.unwrapped.np_random.bit_generator.state = self.start
            obs, info = env.reset()
        for action in self.actions:
            obs, _, _, _, info = env.step(action)
        return obs, info

    def state(self) -> dict:
        """As tensors and plain numbers (weights_only-safe). Actions keep their dtype: a
        float64 action rounded to float32 would step the env elsewhere."""
        actions = np.asarray(self.actions) if self.actions else np.zeros((0, 0), np.float32)
        return {"start": self.start, "actions": torch.from_numpy(actions)}

    @classmethod
    def of_state(cls, state: dict) -> Episode:
        return cls(state["start"], list(state["actions"].numpy()))


def rng_state(env: gym.Env) -> dict:
    """The state of the random generator an env resets with."""
    return env.unwrapped.np_random.bit_generator.state
