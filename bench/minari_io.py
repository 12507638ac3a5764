"""Demonstration pools as Minari datasets, the gymnasium ecosystem's format for offline RL and
imitation data (read by torchrl, d3rlpy, AgileRL and Minari itself).

An exported dataset holds the expert's whole pool: observations (final one included), actions,
rewards, and per episode whether it ended in a terminal state or a time limit. Its
`ref_min_score` / `ref_max_score` are the random and expert mean returns of a results folder, so
`minari.get_normalized_score` gives the normalization `bench plot` draws for that folder.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from pathlib import Path

import gymnasium as gym
import numpy as np

from bench import demos, envs

NAMESPACE = "ifo-bench"
DATASET_NAME = "expert-v0"


class DatasetError(ValueError):
    """A dataset that cannot be written or read as asked; the message is one line."""


def dataset_id(env_id: str) -> str:
    """Minari id of `env_id`'s exported pool: namespace/env/name-version."""
    return f"{NAMESPACE}/{env_id}/{DATASET_NAME}"


@contextlib.contextmanager
def _datasets_root(root: Path) -> Iterator[None]:
    """Minari finds datasets through MINARI_DATASETS_PATH; point it at `root` for the block."""
    saved = os.environ.get("MINARI_DATASETS_PATH")
    os.environ["MINARI_DATASETS_PATH"] = str(root)
    try:
        yield
    finally:
        if saved is None:
            del os.environ["MINARI_DATASETS_PATH"]
        else:
            os.environ["MINARI_DATASETS_PATH"] = saved


def episode_buffers(pool: dict[str, np.ndarray]) -> list:
    """The pool's episodes as Minari EpisodeBuffers (T + 1 observations, T of everything else)."""
    from minari.data_collector import EpisodeBuffer

    lengths = pool["obs_lengths"]
    observations = demos.split_episodes(pool["obs"], lengths)
    actions = demos.split_episodes(pool["actions"], lengths - 1)
    rewards = demos.split_episodes(pool["rewards"], lengths - 1)
    buffers = []
    for i, (obs, act, rew) in enumerate(zip(observations, actions, rewards, strict=True)):
        ended_by = np.zeros(len(act), dtype=bool)
        ended_by[-1] = True
        terminated = bool(pool["terminated"][i])
        buffers.append(
            EpisodeBuffer(
                id=i,
                seed=demos.POOL_SEED + i,
                observations=list(obs),
                actions=list(act),
                rewards=[float(r) for r in rew],
                terminations=list(ended_by & terminated),
                truncations=list(ended_by & (not terminated)),
            )
        )
    return buffers


def export(env_id: str, root: str | Path, random_return: float, expert_return: float) -> str:
    """Write `env_id`'s expert pool (recorded first if not cached) as a local Minari dataset
    under `root`; return its id. Refuses to overwrite an existing dataset."""
    import minari

    envs.check_env_id(env_id)
    root = Path(root)
    name = dataset_id(env_id)
    if (root / name).exists():
        raise DatasetError(f"{root / name} already exists; remove it or export to another folder")
    pool = dict(np.load(demos.ensure_pool(env_id), allow_pickle=False))
    env = gym.make(env_id)
    try:
        with _datasets_root(root), _quiet():
            minari.create_dataset_from_buffers(
                dataset_id=name,
                buffer=episode_buffers(pool),
                env=env_id,
                observation_space=env.observation_space,
                action_space=env.action_space,
                algorithm_name="ifo-bench TRPO expert (deterministic)",
                author="ifo-bench",
                description=(
                    f"{len(pool['obs_lengths'])} episodes of ifo-bench's shipped expert on "
                    f"{env_id}. ref_min_score / ref_max_score: mean returns of the random and "
                    "expert trials of the results folder named at export."
                ),
                ref_min_score=float(random_return),
                ref_max_score=float(expert_return),
            )
    finally:
        env.close()
    return name


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """Minari warns about unset metadata (eval_env and the like) that a local export leaves out."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        yield
