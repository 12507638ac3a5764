"""A policy filmed: one deterministic episode in colour, from the start state an episode seed
gives, a frame per step. `bench video` (`bench.analysis.video`) chooses the policies, titles
them and lays their films side by side; stepping the envs is the harness's, as evaluating is.

A learner that acts on pixels is stepped in the env it was trained in (its trial's plan), so
it sees the frames it learned from; a second, colour camera env stepped with the same actions
gives the full view, and the learner's newest frame is shown enlarged beside it.
"""

from __future__ import annotations

import numpy as np
from PIL import Image

from bench import envs
from bench.envs.pixels import PixelConfig
from bench.harness.registry import Policy
from bench.harness.trial import plan
from bench.harness.types import TrialSpec
from bench.rl.networks import observation

DIMMED = 0.45
"""A film that ended before the others holds its last frame at this brightness."""


def film_episode(
    policy: Policy,
    env_id: str,
    size: int,
    steps: int,
    episode_seed: int,
    spec: TrialSpec | None = None,
) -> list[np.ndarray]:
    """(H, W, 3) uint8 frames of one deterministic episode of `policy` on `env_id`, `steps` + 1
    of them: the start state and each step after it; past the episode's end its last frame,
    dimmed. H = `size`; W = `size`, or 2 `size` for a learner that acts on pixels (`spec`, its
    trial; None for a policy on states, e.g. the shipped expert)."""
    camera = envs.make(env_id, episode_seed, PixelConfig(size=size, stack=1, grayscale=False))
    trial = plan(spec) if spec is not None else None
    seen = trial.pixels if trial is not None else None
    actor = trial.make_env(episode_seed, training=False) if seen is not None else None
    try:
        view, info = camera.reset(seed=episode_seed)
        obs = actor.reset(seed=episode_seed)[0] if actor is not None else info["state"]
        frames = [_frame(view, size, obs, seen)]
        for _ in range(steps):
            action = policy(observation(obs)[None])[0]
            view, _, terminated, truncated, info = camera.step(action)
            obs = actor.step(action)[0] if actor is not None else info["state"]
            frames.append(_frame(view, size, obs, seen))
            if terminated or truncated:
                break
    finally:
        camera.close()
        if actor is not None:
            actor.close()
    ended = (frames[-1] * DIMMED).astype(np.uint8)
    return frames + [ended] * (steps + 1 - len(frames))


def _frame(view: np.ndarray, size: int, obs: np.ndarray, seen: PixelConfig | None) -> np.ndarray:
    """The colour view (H, W, 3); for a pixel learner, its newest frame enlarged beside it."""
    full = view.reshape(3, size, size).transpose(1, 2, 0)
    if seen is None:
        return full
    newest = obs.reshape(seen.shape)[-seen.frame_channels :]
    small = Image.fromarray(newest[0] if seen.grayscale else newest.transpose(1, 2, 0))
    learner = np.asarray(small.resize((size, size), Image.NEAREST).convert("RGB"))
    return np.concatenate([full, learner], axis=1)
