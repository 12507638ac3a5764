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
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import gymnasium as gym
import numpy as np

from bench import envs
from bench.demos import pools
from bench.errors import BadInput

NAMESPACE = "ifo-bench"
DATASET_NAME = "expert-v0"


class DatasetError(BadInput, ValueError):
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
    observations = pools.split_episodes(pool["obs"], lengths)
    actions = pools.split_episodes(pool["actions"], lengths - 1)
    rewards = pools.split_episodes(pool["rewards"], lengths - 1)
    buffers = []
    for i, (obs, act, rew) in enumerate(zip(observations, actions, rewards, strict=True)):
        ended_by = np.zeros(len(act), dtype=bool)
        ended_by[-1] = True
        terminated = bool(pool["terminated"][i])
        buffers.append(
            EpisodeBuffer(
                id=i,
                seed=pools.POOL_SEED + i,
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
    pool = dict(np.load(pools.ensure_pool(env_id), allow_pickle=False))
    env = gym.make(env_id)
    root.mkdir(parents=True, exist_ok=True)
    # Written whole beside its place, then renamed into it: a run killed mid-export leaves a
    # hidden folder behind, never a half-written dataset that blocks the next export.
    staging = Path(tempfile.mkdtemp(dir=root, prefix=".export-"))
    try:
        with _datasets_root(staging), _quiet():
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
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        os.rename(staging / name, root / name)
    finally:
        env.close()
        shutil.rmtree(staging, ignore_errors=True)
    return name


@contextlib.contextmanager
def _quiet() -> Iterator[None]:
    """Minari warns about unset metadata (eval_env and the like) that a local export leaves out."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UserWarning)
        yield


# ---------------------------------------------------------------- import


def open_dataset(source: str):
    """A Minari dataset from a folder (the dataset's, or its data/) or a dataset id already on
    this machine (Minari's local root); DatasetError when it is neither. Never downloads."""
    import minari

    path = Path(source).expanduser()
    if path.exists():
        data = path / "data" if (path / "data").is_dir() else path
        try:
            with _quiet():
                return minari.MinariDataset(data)
        except Exception as e:  # h5py and Minari raise many kinds
            raise DatasetError(f"{source}: not a Minari dataset ({_one_line(e)})") from None
    try:
        with _quiet():
            return minari.load_dataset(source, download=False)
    except Exception:
        raise DatasetError(
            f"{source}: no such dataset folder, nor a Minari dataset id on this machine"
            f" (looked in {path.resolve().parent} and {minari.storage.get_dataset_path()})"
        ) from None


def check_env(dataset, source: str, env_id: str) -> None:
    """The dataset must come from `env_id`, or from an env with the same spaces."""
    recorded = dataset.env_spec.id if dataset.env_spec is not None else None
    if recorded == env_id:
        return
    obs_dim, act_dim, _, _ = envs.spaces(env_id)
    obs_shape, act_shape = dataset.observation_space.shape, dataset.action_space.shape
    if obs_shape == (obs_dim,) and act_shape == (act_dim,):
        return
    raise DatasetError(
        f"{source} was recorded in {recorded or 'an unnamed env'} (observations {obs_shape},"
        f" actions {act_shape}), not in {env_id} (({obs_dim},), ({act_dim},))"
    )


def episodes(dataset) -> list:
    """Every episode of `dataset`, read now; DatasetError (one line) where its data cannot be
    read (a truncated or corrupted HDF5 file opens on its metadata alone)."""
    try:
        with _quiet():
            return list(dataset.iterate_episodes())
    except Exception as e:  # h5py raises OSError, KeyError, ValueError...
        where = getattr(dataset.storage, "data_path", "the dataset")
        raise DatasetError(f"{where}: episodes cannot be read ({_one_line(e)})") from None


def has_actions(dataset) -> bool:
    """False when the recorded actions are missing (NaN): a state-only dataset."""
    return all(np.isfinite(ep.actions).all() for ep in episodes(dataset))


def to_pool(dataset, env_id: str) -> dict[str, np.ndarray]:
    """The dataset's episodes as a demonstration pool, laid out as `pools.record` writes one
    (actions NaN where the dataset has none)."""
    read = episodes(dataset)
    obs = [np.asarray(ep.observations, np.float32) for ep in read]
    return pools.pool_arrays(
        env_id,
        obs,
        [
            np.asarray(ep.actions, np.float32).reshape(len(o) - 1, -1)
            for ep, o in zip(read, obs, strict=True)
        ],
        [np.asarray(ep.rewards, np.float32) for ep in read],
        [bool(ep.terminations[-1]) for ep in read],
    )


def expert_reference(dataset) -> tuple[list[float], str]:
    """The returns that stand for "expert" (normalized 1.0) with this dataset's demonstrations:
    its `ref_max_score` if it has one, else its episodes' returns; and which it was."""
    score = dataset.storage.metadata.get("ref_max_score")
    if score is not None:
        return [float(score)], "dataset ref_max_score"
    returns = [float(np.sum(ep.rewards)) for ep in episodes(dataset)]
    return returns, f"returns of the dataset's {len(returns)} episodes"


def _one_line(error: Exception) -> str:
    return " ".join(str(error).split()) or type(error).__name__


def content_digest(dataset) -> str:
    """sha256 of every file of the dataset's data folder (names and bytes): the same content
    wherever it lies, and another as soon as one byte is rewritten in place."""
    import hashlib

    digest = hashlib.sha256()
    folder = Path(dataset.storage.data_path)
    for file in sorted(p for p in folder.rglob("*") if p.is_file()):
        digest.update(str(file.relative_to(folder)).encode())
        with open(file, "rb") as f:
            digest.update(hashlib.file_digest(f, "sha256").digest())
    return digest.hexdigest()


def ensure_pool(source: str, env_id: str) -> Path:
    """Path of the dataset's episodes converted to a demonstration pool (cached: converted once
    per dataset content, so a dataset rewritten in place is converted again)."""
    from bench import paths

    dataset = open_dataset(source)
    digest = content_digest(dataset)[:12]
    path = paths.CACHE_DIR / "datasets" / f"{env_id}-{digest}-{pools.FORMAT}.npz"
    if not path.exists():
        check_env(dataset, source, env_id)
        pools.save(path, to_pool(dataset, env_id))
    return path
