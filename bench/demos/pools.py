"""Record expert demonstrations and load them as state-only `Demos` (or, for GAIL, `ActionDemos`).

A demo file (.npz) stores observations per episode, final observation
included, and separately the actions and rewards, with the env id and shapes:
  env_id, obs_dim, act_dim       scalars
  obs          (sum (T_i + 1), O)  episodes back to back
  obs_lengths  (N,)                T_i + 1 per episode
  terminated   (N,)                True where the episode ended in a terminal state, False
                                   where its time limit cut it
  actions      (sum T_i, A)        kept apart; read only by `load_action_demos`
  rewards      (sum T_i,)
A pool recorded for visual observations also stores the video, one frame per observation
(stacks are rebuilt on loading, `bench.envs.pixels.stack_episode`), compressed:
  frames       (sum (T_i + 1), c, H, W) uint8
Pixel pools are caches like any other: they regenerate from the shipped experts.
"""

from __future__ import annotations

import hashlib
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from bench import atomic, envs, kernels, paths
from bench.demos.experts import load_expert
from bench.envs.pixels import PixelConfig, camera, newest_frames, stack_episode
from bench.errors import BadInput
from bench.imitation.data import ActionDemos, Demos

POOL_SIZE = 25
"""Episodes recorded per env; a trial with k demonstrations draws k of them."""
POOL_SEED = 20_000
"""Env seeds of the pool's episodes are POOL_SEED + i: disjoint from evaluation seeds."""


FORMAT = "v2"
"""Bumped when the file layout changes, so a cached pool of the old layout is re-recorded."""


class DemoError(BadInput, ValueError):
    """A demo file that is missing, malformed, or recorded in another env."""


def record(
    env_id: str, policy, n_episodes: int, seed: int, pixels: PixelConfig | None = None
) -> dict[str, np.ndarray]:
    """Run `policy` (numpy, deterministic, on states) for `n_episodes` full episodes; arrays as
    stored. With `pixels`, the video of the same episodes is recorded too (rendering leaves the
    physics alone, so states, actions and rewards are those of a recording without it)."""
    env = envs.make(env_id, seed, pixels)
    obs_eps, act_eps, rew_eps, terminated, frame_eps = [], [], [], [], []

    def state(o: np.ndarray, info: dict) -> np.ndarray:
        return np.asarray(o if pixels is None else info["state"], np.float32)

    try:
        for k in range(n_episodes):
            o, info = env.reset(seed=seed + k)
            obs, acts, rews, views = [state(o, info)], [], [], [o]
            done = False
            while not done:
                a = policy(obs[-1][None])[0]
                o, r, term, trunc, info = env.step(a)
                obs.append(state(o, info))  # the true final observation too
                views.append(o)
                acts.append(np.asarray(a, np.float32))
                rews.append(float(r))
                done = term or trunc
            terminated.append(bool(term))
            obs_eps.append(np.stack(obs))
            act_eps.append(np.stack(acts))
            rew_eps.append(np.asarray(rews, np.float32))
            if pixels is not None:
                frame_eps.append(newest_frames(np.stack(views), pixels))
    finally:
        env.close()
    arrays = pool_arrays(env_id, obs_eps, act_eps, rew_eps, terminated)
    if pixels is not None:
        arrays["frames"] = np.concatenate(frame_eps)
    return arrays


def pool_arrays(
    env_id: str,
    observations: list[np.ndarray],
    actions: list[np.ndarray],
    rewards: list[np.ndarray],
    terminated: list[bool],
) -> dict[str, np.ndarray]:
    """Episodes laid out as a pool file stores them: (T_i + 1, O) observations, (T_i, A)
    actions and (T_i,) rewards per episode, back to back, with their lengths."""
    return {
        "env_id": np.array(env_id),
        "obs_dim": np.array(observations[0].shape[1]),
        "act_dim": np.array(actions[0].shape[1]),
        "obs": np.concatenate(observations),
        "obs_lengths": np.array([len(o) for o in observations]),
        "terminated": np.array(terminated),
        "actions": np.concatenate(actions),
        "rewards": np.concatenate(rewards),
    }


def save(path: Path, arrays: dict[str, np.ndarray]) -> Path:
    buf = io.BytesIO()
    # Video compresses ~10x (a still background); states barely, and are read more often.
    (np.savez_compressed if "frames" in arrays else np.savez)(buf, **arrays)
    atomic.write_bytes(path, buf.getvalue())
    return path


def pool_path(env_id: str, pixels: PixelConfig | None = None) -> Path:
    """Cache path of `env_id`'s pool, keyed by the expert's weights so a retrained expert
    re-records, and by how frames are made if it holds video."""
    digest = hashlib.sha256((paths.expert_dir(env_id) / "policy.pt").read_bytes()).hexdigest()[:12]
    video = ""
    if pixels is not None:  # and where the camera stood: a moved camera films another video
        view = camera(env_id)
        cam = "" if view is None else f"-cam{view.key()}"
        video = f"-frames{pixels.size}{'g' if pixels.grayscale else 'rgb'}{cam}"
    # Recorded with portable kernels, a pool is another pool (the expert's rollouts are floats)
    pinned = "-portable" if kernels.active() == "portable" else ""
    return paths.CACHE_DIR / "demos" / f"{env_id}-{digest}-{FORMAT}{video}{pinned}.npz"


def ensure_pool(env_id: str, pixels: PixelConfig | None = None) -> Path:
    """Path of the expert's demonstration pool (with video, given `pixels`), recording it first
    if it is not cached."""
    path = pool_path(env_id, pixels)
    if not path.exists():
        save(path, record(env_id, load_expert(env_id), POOL_SIZE, POOL_SEED, pixels))
    return path


def _open(path: Path, env_id: str) -> np.lib.npyio.NpzFile:
    try:
        data = np.load(path, allow_pickle=False)
    except FileNotFoundError:
        raise DemoError(f"demo file {path} does not exist") from None
    except Exception as e:  # zip/npy format errors come in many types
        raise DemoError(f"{path} is not a demo file ({e})") from None
    if not {"env_id", "obs_lengths", "terminated"} <= set(data.files):
        raise DemoError(
            f"{path} is not a demo file of format {FORMAT} (no env_id/obs_lengths/terminated)"
        )
    if str(data["env_id"]) != env_id:
        raise DemoError(f"{path} holds demonstrations of {data['env_id']}, not {env_id}")
    return data


def split_episodes(flat: np.ndarray, lengths: np.ndarray) -> tuple[np.ndarray, ...]:
    """Arrays stored back to back, split into episodes of the given lengths."""
    return tuple(np.split(flat, np.cumsum(lengths)[:-1]))


def _pick(n_pool: int, k: int | None, seed: int) -> np.ndarray:
    if k is None:
        return np.arange(n_pool)
    if not 1 <= k <= n_pool:
        raise DemoError(f"asked for {k} demonstrations, the pool has {n_pool}")
    # Same (k, seed) -> same episodes, whatever else the suite contains.
    return np.sort(np.random.default_rng([seed, k]).choice(n_pool, size=k, replace=False))


def load_demos(
    path: Path,
    env_id: str,
    k: int | None = None,
    seed: int = 0,
    pixels: PixelConfig | None = None,
) -> Demos:
    """State-only demonstrations: k episodes drawn by `seed` (all if k is None). Never reads
    actions. With `pixels`, each episode is its video as the imitator would see it: (T_i + 1,
    C*H*W) uint8 stacks of frames, the same episodes as without."""
    data = _open(path, env_id)
    lengths = data["obs_lengths"]
    idx = _pick(len(lengths), k, seed)
    if pixels is None:
        eps = split_episodes(data["obs"], lengths)
        chosen = tuple(eps[i] for i in idx)
    else:
        if "frames" not in data.files:
            raise DemoError(f"{path} holds no video (record it with pixels)")
        video = data["frames"]  # decompressed on each access: once
        if video.shape[1:] != pixels.frame_shape:
            raise DemoError(
                f"{path} holds frames of shape {video.shape[1:]}, not {pixels.frame_shape}"
            )
        frames = split_episodes(video, lengths)
        chosen = tuple(stack_episode(frames[i], pixels) for i in idx)
    terminated = data["terminated"]
    return Demos(env_id, chosen, tuple(bool(terminated[i]) for i in idx))


def load_action_demos(
    path: Path,
    env_id: str,
    k: int | None = None,
    seed: int = 0,
    pixels: PixelConfig | None = None,
) -> ActionDemos:
    """The same episodes as `load_demos(path, env_id, k, seed, pixels)`, with the expert's actions."""
    data = _open(path, env_id)
    demos = load_demos(path, env_id, k, seed, pixels)
    lengths = data["obs_lengths"]
    acts = split_episodes(data["actions"], lengths - 1)
    idx = _pick(len(lengths), k, seed)
    return ActionDemos(demos, tuple(acts[i] for i in idx))


@dataclass(frozen=True)
class PoolEpisode:
    """One recorded episode of a pool, as `bench demos show` lists it."""

    index: int
    steps: int
    expert_return: float
    terminated: bool
    """It ended in a terminal state (a fall, in locomotion) rather than at the time limit."""


def pool_episodes(path: Path, env_id: str) -> list[PoolEpisode]:
    """Every episode of a pool: its length, the expert's return in it, and how it ended."""
    data = _open(path, env_id)
    steps = data["obs_lengths"] - 1
    returns = [float(r.sum()) for r in split_episodes(data["rewards"], steps)]
    return [
        PoolEpisode(i, int(n), ret, bool(term))
        for i, (n, ret, term) in enumerate(zip(steps, returns, data["terminated"], strict=True))
    ]


def drawn_by(n_pool: int, k: int, seeds: range) -> dict[int, list[int]]:
    """Pool episode -> the seeds whose trials with `k` demonstrations are given it."""
    drawn: dict[int, list[int]] = {}
    for seed in seeds:
        for i in _pick(n_pool, k, seed):
            drawn.setdefault(int(i), []).append(seed)
    return drawn


def pool_states(path: Path, env_id: str) -> np.ndarray:
    """(N, O) every observation of every episode of a pool, back to back."""
    return _open(path, env_id)["obs"]
