"""The only place environments are built, for both simulators.

Any gymnasium id with Box observations and Box actions works. The paper's six tasks exist twice:
on PyBullet (`PYBULLET_ENVS`, the paper's own, reproduced in results/pybullet) and on MuJoCo
through gymnasium v5 (`MUJOCO_ENVS`, where the field compares today). PyBullet is optional: it
has no wheels past Python 3.11, so it is imported only when a PyBullet id is asked for. Its ids
are registered by importing `pybullet_envs_gymnasium`, whose C code prints to the process's
stdout (as MuJoCo's model compiler prints deprecation notes to stderr), so every call that may
reach either runs with fds 1 and 2 silenced.
"""

from __future__ import annotations

import contextlib
import ctypes
import os
import sys
from collections.abc import Iterator

import gymnasium as gym
import numpy as np

from bench.envs.pixels import Frames, PixelConfig
from bench.errors import BadInput

PYBULLET_ENVS = (
    "InvertedPendulumBulletEnv-v0",
    "InvertedDoublePendulumBulletEnv-v0",
    "HopperBulletEnv-v0",
    "Walker2DBulletEnv-v0",
    "HalfCheetahBulletEnv-v0",
    "AntBulletEnv-v0",
)
MUJOCO_ENVS = (
    "InvertedPendulum-v5",
    "InvertedDoublePendulum-v5",
    "Hopper-v5",
    "Walker2d-v5",
    "HalfCheetah-v5",
    "Ant-v5",
)
PAPER_ENVS = PYBULLET_ENVS + MUJOCO_ENVS
"""The paper's six tasks on each simulator, in the paper's order (figures' panels follow it)."""
PYBULLET_INSTALL = "pip install 'ifo-bench[pybullet]' (PyBullet has wheels up to Python 3.11)"


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


def is_pybullet(env_id: str) -> bool:
    """Whether `env_id` is one of PyBullet's (pybullet_envs_gymnasium's ids say "Bullet")."""
    return "Bullet" in env_id


def _register_pybullet() -> bool:
    """Register PyBullet's ids (once); False where PyBullet is not installed."""
    global _registered
    if not _registered:
        try:
            with quiet_stdout():
                import pybullet_envs_gymnasium  # noqa: F401  (registers the *BulletEnv ids)

                from bench.envs import bullet_speed

                bullet_speed.apply()  # same trajectories, ~1.3x the steps per second
        except ImportError:
            return False
        _registered = True
    return True


def check_env_id(env_id: str) -> None:
    """Raise EnvError (one line) unless `env_id` is a registered id with Box spaces."""
    needs_pybullet = is_pybullet(env_id) or env_id not in gym.registry
    if needs_pybullet and not _register_pybullet() and is_pybullet(env_id):
        raise EnvError(f"{env_id} needs PyBullet, which is not installed: {PYBULLET_INSTALL}")
    if env_id not in gym.registry:
        close = [k for k in gym.registry if env_id.lower().split("-")[0] in k.lower()][:3]
        hint = f" (did you mean {', '.join(close)}?)" if close else ""
        raise EnvError(f"unknown env id {env_id!r}{hint}")


def make(env_id: str, seed: int, pixels: PixelConfig | None = None) -> gym.Env:
    """Build `env_id`, reset it once with `seed`, and check its spaces.

    The first reset happens here (quietly: PyBullet connects to its physics
    server on it), so the env's random stream is fixed by `seed` alone.
    With `pixels`, observations are stacked rendered frames (`bench.envs.pixels.Frames`),
    flattened to (C*H*W,) uint8 like every observation the harness passes around
    (`pixels.shape` restores them), and the simulator state rides along in `info["state"]`.
    """
    check_env_id(env_id)
    on_mujoco = is_mujoco(env_id)
    if on_mujoco:
        _route_mujoco_warnings()
    with quiet_stdout():
        if pixels is None:
            env = gym.make(env_id, disable_env_checker=True)
        else:
            rendered = gym.make(
                env_id, render_mode="rgb_array", disable_env_checker=True, **_canvas(env_id, pixels)
            )
            env = gym.wrappers.FlattenObservation(Frames(rendered, pixels))
        if on_mujoco:
            from bench.envs import mujoco_speed  # imports mujoco: only where it is used

            mujoco_speed.speed_up(env)  # the same trajectories, less Python per step
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


KNOWN_MUJOCO_NOTES = ("compiler attribute 'settotalmass' is deprecated",)
"""What MuJoCo says of gymnasium's own model files on every load (Ant's): nothing to act on."""
_mujoco_warnings_routed = False


def _route_mujoco_warnings() -> None:
    """MuJoCo writes its warnings to MUJOCO_LOG.TXT in the working folder; route them to
    Python's warnings instead (once per process), leaving out the known notes on gymnasium's
    models, so no log file lands in a user's folder and a real one (an unstable simulation)
    is still seen."""
    global _mujoco_warnings_routed
    if _mujoco_warnings_routed:
        return
    import warnings

    import mujoco

    def warn(message: str) -> None:
        if not any(note in message for note in KNOWN_MUJOCO_NOTES):
            warnings.warn(f"MuJoCo: {message}", RuntimeWarning, stacklevel=2)

    mujoco.set_mju_user_warning(warn)
    _mujoco_warnings_routed = True


def is_mujoco(env_id: str) -> bool:
    """Whether `env_id` is one of gymnasium's MuJoCo tasks."""
    entry = gym.spec(env_id).entry_point
    return isinstance(entry, str) and entry.startswith("gymnasium.envs.mujoco")


def _canvas(env_id: str, pixels: PixelConfig) -> dict[str, int]:
    """What an env renders at: MuJoCo's renderer draws the frame's own size (its default,
    480 x 480, would be drawn and then shrunk), headless through EGL unless MUJOCO_GL says
    otherwise; PyBullet's size is set on the env (`Frames`)."""
    if not is_mujoco(env_id):
        return {}
    os.environ.setdefault("MUJOCO_GL", "egl")
    return {"width": pixels.size, "height": pixels.size}


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
