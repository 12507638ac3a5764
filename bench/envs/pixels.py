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


@dataclass(frozen=True)
class Camera:
    """Where `Frames` films an env from, where PyBullet's default (3 m, -30 deg, aimed at the
    world's origin) leaves the subject a few pixels tall."""

    distance: float
    pitch: float
    """Degrees; 0 looks level."""
    height: float = 0.0
    """Height of the point aimed at (the env's own camera aims at the origin)."""

    def key(self) -> str:
        """How the camera names the video it films (pool file names)."""
        parts = (self.distance, self.pitch, *((self.height,) if self.height else ()))
        return "-".join(f"{x:g}" for x in parts)


CAMERAS: dict[str, Camera] = {
    # Aimed level at the middle of the 0.6 m pole from 0.7 m, so pole and cart span the frame
    # (0.81 m of a 60-degree view): at 32x32 the tip then moves ~5 pixels by the time the
    # episode ends (0.2 rad) and one pixel per ~2.5 degrees, against ~2 pixels and ~5.5 degrees
    # with the old camera (1.6 m, aimed at the rail), from which the pixel policy learned
    # nothing in 300k steps. The expert's cart stays within 0.2 m of the centre, well inside
    # the view's +-0.4 m.
    "InvertedPendulumBulletEnv-v0": Camera(0.7, 0.0, 0.3),
    "InvertedPendulumSwingupBulletEnv-v0": Camera(1.6, -10.0),
    # Level at the 1.2 m double pole's middle from 1.5 m: the poles span ~28 of 32 pixels and
    # the view +-0.87 m of rail, where the expert's cart stays within 0.7 m of the centre. From
    # the earlier camera (2 m, -10 deg, aimed at the rail) they were ~10 pixels tall.
    "InvertedDoublePendulumBulletEnv-v0": Camera(1.5, 0.0, 0.6),
}
"""The pendulums' cameras; the locomotion envs' default camera follows the robot closely enough."""


def camera(env_id: str) -> Camera | None:
    """The camera `Frames` films `env_id` from; None: the env's own."""
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
        self.view = camera(env.spec.id if env.spec else "")
        if self.view is not None and not hasattr(base, "_cam_dist"):
            raise ValueError(f"{env.spec.id} has a camera in CAMERAS but is no PyBullet env")
        self.cfg = cfg
        self.observation_space = gym.spaces.Box(0, 255, cfg.shape, np.uint8)
        self._frames: deque[np.ndarray] = deque(maxlen=cfg.stack)

    def _render(self) -> np.ndarray:
        """(H, W, 3+) pixels: the env's own render, or through our camera (PyBullet's renderer,
        as the env's render calls it, aimed where the camera says)."""
        if self.view is None:
            return np.asarray(self.env.render())
        base, v = self.env.unwrapped, self.view
        view = base._p.computeViewMatrixFromYawPitchRoll(
            cameraTargetPosition=[0, 0, v.height],
            distance=v.distance,
            yaw=base._cam_yaw,
            pitch=v.pitch,
            roll=0,
            upAxisIndex=2,
        )
        projection = base._p.computeProjectionMatrixFOV(fov=60, aspect=1.0, nearVal=0.1, farVal=100)
        width, height, px, _, _ = base._p.getCameraImage(
            self.cfg.size,
            self.cfg.size,
            view,
            projection,
            renderer=base._p.ER_BULLET_HARDWARE_OPENGL,
        )
        return np.reshape(np.asarray(px, np.uint8), (height, width, -1))

    def _frame(self) -> np.ndarray:
        rgb = self._render()[..., :3]
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
