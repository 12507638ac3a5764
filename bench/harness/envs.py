"""The only place environments are built.

Any gymnasium id with Box observations and Box actions works; the PyBullet ids
are registered by importing `pybullet_envs_gymnasium`, whose C code prints to
the process's stdout, so every call that may reach it runs with fd 1 silenced.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from collections.abc import Iterator

import gymnasium as gym
import numpy as np

from bench.errors import BadInput
from bench.harness.pixels import Frames, PixelConfig

PAPER_ENVS = (
    "InvertedPendulumBulletEnv-v0",
    "InvertedDoublePendulumBulletEnv-v0",
    "HopperBulletEnv-v0",
    "Walker2DBulletEnv-v0",
    "HalfCheetahBulletEnv-v0",
    "AntBulletEnv-v0",
)


class EnvError(BadInput, ValueError):
    """An env id that cannot be made, or one whose spaces ifo-bench cannot use."""


_libc = ctypes.CDLL(None)


@contextlib.contextmanager
def quiet_stdout() -> Iterator[None]:
    """Silence file descriptors 1 and 2 (C-level prints included) for the block.

    PyBullet prints its build banner and `argv[0]=` from C; Python exceptions
    still propagate normally, they are not printed here.
    """
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        saved = [os.dup(1), os.dup(2)]
    except OSError:  # no real stdout (some notebook kernels): nothing to silence
        yield
        return
    devnull = os.open(os.devnull, os.O_WRONLY)
    try:
        os.dup2(devnull, 1)
        os.dup2(devnull, 2)
        yield
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        _libc.fflush(None)  # C stdio buffers too, or they drain into the real fds later
        for fd, copy in zip((1, 2), saved, strict=True):
            os.dup2(copy, fd)
            os.close(copy)
        os.close(devnull)


_registered = False


def _register_pybullet() -> None:
    global _registered
    if not _registered:
        with quiet_stdout():
            import pybullet_envs_gymnasium  # noqa: F401  (registers the *BulletEnv ids)

            from bench.harness import bullet_speed

            bullet_speed.apply()  # same trajectories, ~1.3x the steps per second
        _registered = True


def check_env_id(env_id: str) -> None:
    """Raise EnvError (one line) unless `env_id` is a registered id with Box spaces."""
    _register_pybullet()
    if env_id not in gym.registry:
        close = [k for k in gym.registry if env_id.lower().split("-")[0] in k.lower()][:3]
        hint = f" (did you mean {', '.join(close)}?)" if close else ""
        raise EnvError(f"unknown env id {env_id!r}{hint}")


def make(env_id: str, seed: int, pixels: PixelConfig | None = None) -> gym.Env:
    """Build `env_id`, reset it once with `seed`, and check its spaces.

    The first reset happens here (quietly: PyBullet connects to its physics
    server on it), so the env's random stream is fixed by `seed` alone.
    With `pixels`, observations are stacked rendered frames (`bench.harness.pixels.Frames`),
    flattened to (C*H*W,) uint8 like every observation the harness passes around
    (`pixels.shape` restores them), and the simulator state rides along in `info["state"]`.
    """
    check_env_id(env_id)
    with quiet_stdout():
        if pixels is None:
            env = gym.make(env_id, disable_env_checker=True)
        else:
            env = gym.wrappers.FlattenObservation(
                Frames(gym.make(env_id, render_mode="rgb_array", disable_env_checker=True), pixels)
            )
        env.reset(seed=seed)
    if not isinstance(env.action_space, gym.spaces.Box):
        env.close()
        raise EnvError(
            f"{env_id} has a {type(env.action_space).__name__} action space; "
            "ifo-bench needs continuous (Box) actions"
        )
    if not isinstance(env.observation_space, gym.spaces.Box):
        env.close()
        raise EnvError(
            f"{env_id} has a {type(env.observation_space).__name__} observation space; "
            "ifo-bench needs Box observations"
        )
    env.action_space.seed(seed)
    return env


def spaces(
    env_id: str, pixels: PixelConfig | None = None
) -> tuple[int, int, np.ndarray, np.ndarray]:
    """(obs_dim, act_dim, action low, action high) of `env_id` (seen through `pixels`, if given)."""
    env = make(env_id, seed=0, pixels=pixels)
    try:
        return (
            int(np.prod(env.observation_space.shape)),
            int(np.prod(env.action_space.shape)),
            env.action_space.low.astype(np.float32),
            env.action_space.high.astype(np.float32),
        )
    finally:
        env.close()
