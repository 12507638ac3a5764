"""Visual observations: an env whose observation is a stack of small rendered frames.

The GAIfO paper's second setting: the imitator sees only video. `Frames` wraps a
PyBullet env built with `render_mode="rgb_array"`, renders each state at `size` x `size`
and returns the last `stack` frames, uint8, channels first, oldest first, so a
convolutional network sees motion. The simulator state stays available in
`info["state"]`: the state-based experts act on it while the demonstration records
the frames.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import gymnasium as gym
import numpy as np

LUMA = np.array([0.299, 0.587, 0.114], np.float32)
"""ITU-R BT.601 weights, the grayscale conversion of the Atari preprocessing convention."""


@dataclass(frozen=True)
class PixelConfig:
    """How frames are made: the same for the expert's video and for the imitator."""

    size: int = 64
    """Frame height and width in pixels."""
    stack: int = 4
    """Frames per observation, oldest first: velocities are visible in the differences."""
    grayscale: bool = True
    """One luminance channel per frame instead of three colour channels."""

    def __post_init__(self) -> None:
        if self.size < 8 or self.stack < 1:
            raise ValueError(f"frames need size >= 8 and stack >= 1, not {self.size}, {self.stack}")

    @property
    def frame_channels(self) -> int:
        return 1 if self.grayscale else 3

    @property
    def shape(self) -> tuple[int, int, int]:
        """(channels, height, width) of one observation."""
        return (self.frame_channels * self.stack, self.size, self.size)

    @property
    def frame_shape(self) -> tuple[int, int, int]:
        """(channels, height, width) of one frame."""
        return (self.frame_channels, self.size, self.size)


def newest_frames(observations: np.ndarray, cfg: PixelConfig) -> np.ndarray:
    """The last frame of each flat observation: (N, C*H*W) -> (N, c, H, W), what a pool stores
    (a stack repeats each frame `stack` times)."""
    return observations.reshape(-1, *cfg.shape)[:, -cfg.frame_channels :]


def stack_episode(frames: np.ndarray, cfg: PixelConfig) -> np.ndarray:
    """An episode's (T + 1, c, H, W) frames -> its (T + 1, C*H*W) flat observations, exactly as
    `Frames` produced them: frame t stacked after its `stack - 1` predecessors, the first frame
    standing in for those before the episode began."""
    index = np.arange(len(frames))[:, None] + np.arange(1 - cfg.stack, 1)[None, :]
    return frames[np.maximum(index, 0)].reshape(len(frames), -1)


CAMERAS: dict[str, tuple[float, float]] = {
    "InvertedPendulumBulletEnv-v0": (1.6, -10.0),
    "InvertedPendulumSwingupBulletEnv-v0": (1.6, -10.0),
    "InvertedDoublePendulumBulletEnv-v0": (2.0, -10.0),
}
"""(distance, pitch) of the camera where PyBullet's default (3 m, -30 deg) leaves the subject a
few pixels tall at 64x64: the pendulums' pole, seen from nearly level, fills the frame's height.
The locomotion envs' default camera follows the robot closely enough."""


def camera(env_id: str) -> tuple[float, float] | None:
    """The (distance, pitch) `Frames` films `env_id` from; None: the env's own camera."""
    return CAMERAS.get(env_id)


class Frames(gym.Wrapper):
    """Observations are the last `cfg.stack` rendered frames, (C, H, W) uint8.

    On reset the stack is filled with copies of the first frame, as Atari frame stacking
    does: an episode's first observation shows no motion rather than the previous episode's.
    """

    def __init__(self, env: gym.Env, cfg: PixelConfig) -> None:
        super().__init__(env)
        if env.render_mode != "rgb_array":
            raise ValueError("Frames needs an env made with render_mode='rgb_array'")
        base = env.unwrapped
        if hasattr(base, "_render_width"):  # PyBullet envs: render at the size we keep
            base._render_width = base._render_height = cfg.size
        view = camera(env.spec.id if env.spec else "")
        if view is not None and hasattr(base, "_cam_dist"):
            base._cam_dist, base._cam_pitch = view
        self.cfg = cfg
        self.observation_space = gym.spaces.Box(0, 255, cfg.shape, np.uint8)
        self._frames: deque[np.ndarray] = deque(maxlen=cfg.stack)

    def _frame(self) -> np.ndarray:
        rgb = np.asarray(self.env.render())[..., :3]
        if rgb.shape[:2] != (self.cfg.size, self.cfg.size):
            rgb = _resize(rgb, self.cfg.size)
        if self.cfg.grayscale:
            return (rgb.astype(np.float32) @ LUMA).round().astype(np.uint8)[None]
        return np.ascontiguousarray(rgb.transpose(2, 0, 1), dtype=np.uint8)

    def _observation(self) -> np.ndarray:
        return np.concatenate(self._frames, axis=0)

    def reset(self, **kwargs):
        state, info = self.env.reset(**kwargs)
        first = self._frame()
        self._frames.extend([first] * self.cfg.stack)
        return self._observation(), {**info, "state": state}

    def step(self, action):
        state, reward, terminated, truncated, info = self.env.step(action)
        self._frames.append(self._frame())
        return self._observation(), reward, terminated, truncated, {**info, "state": state}


def _resize(rgb: np.ndarray, size: int) -> np.ndarray:
    """Nearest-neighbour resize for envs whose render size cannot be set."""
    rows = np.linspace(0, rgb.shape[0] - 1, size).round().astype(int)
    cols = np.linspace(0, rgb.shape[1] - 1, size).round().astype(int)
    return rgb[rows][:, cols]


class VideoBeside(gym.Wrapper):
    """A `Frames` env turned inside out: observations are the simulator state again, and the flat
    frames ride along in `info["frames"]`. For a learner that acts on states and is rewarded on
    video (`observation: video-reward`): not the paper's pixel setting, a cheaper relative of it."""

    def __init__(self, env: gym.Env) -> None:
        super().__init__(env)
        state = env.unwrapped.observation_space
        self.observation_space = gym.spaces.Box(state.low, state.high, state.shape, np.float32)

    def reset(self, **kwargs):
        frames, info = self.env.reset(**kwargs)
        return info["state"], {**info, "frames": frames}

    def step(self, action):
        frames, reward, terminated, truncated, info = self.env.step(action)
        return info["state"], reward, terminated, truncated, {**info, "frames": frames}
