"""Experts: train with TRPO, save, load, evaluate.

An expert is two files in `bench.paths.expert_dir(env_id)`:
  policy.pt  the GaussianPolicy state dict (normalizer statistics included);
             load with torch.load(..., weights_only=True)
  meta.json  env id, sizes, training steps, wall time, seed, package version,
             and the return over `EVAL_EPISODES` deterministic episodes.
"""

from __future__ import annotations

import copy
import io
import json
import time
from contextlib import AbstractContextManager, closing, nullcontext
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tqdm import tqdm

import bench
from bench import atomic, envs, paths
from bench.errors import BadInput
from bench.rl.networks import DeterministicPolicy, GaussianPolicy, orthogonal_init
from bench.rl.rollout import evaluate
from bench.rl.trpo import TRPO, TRPOConfig, train
from bench.validate import at_least

EVAL_EPISODES = 50
SELECTION_SEED = 20_000
"""Episodes that choose among kept snapshots start here; the shipped return's at 10_000."""
REPORT_SEED = 10_000
CHECKPOINT = "checkpoint.pt"
"""Training progress, in the expert's folder until the expert is saved (not shipped)."""
CHECKPOINT_SECONDS = 120.0
"""How often a training run saves its progress: a killed run loses at most this much."""


@dataclass
class ExpertTraining(TRPOConfig):
    """TRPO as an expert is trained: the learners' settings, plus what only expert training
    varies (a field here would change every learner's trial ids in TRPOConfig)."""

    orthogonal_init: bool = False
    """Orthogonal initialization of policy and value (gains sqrt 2, last layers 0.01 and 1), as
    in the RL Baselines Zoo's TRPO references; off: PyTorch's defaults (the policy's last layer
    scaled by 0.01), as the learners start."""
    kept_snapshots: int = 0
    """Also keep this many snapshots evenly spaced over training, and ship whichever candidate
    (those, the best-seen and the final) scores highest on `selection_episodes` episodes
    of its own; the return shipped is then measured on the usual, separate episodes. For
    tasks where a policy that looks perfect in training still fails on rare starts
    (InvertedDoublePendulum): the training return cannot tell those snapshots apart. 0: the
    better of best-seen and final, as before."""
    selection_episodes: int = EVAL_EPISODES
    """Episodes each kept snapshot is scored on: a policy that fails one start in fifty needs
    more than fifty to be told from one that never fails."""

    def __post_init__(self) -> None:
        super().__post_init__()
        at_least(self, 0, "kept_snapshots")
        at_least(self, 1, "selection_episodes")


class ExpertError(BadInput, FileNotFoundError):
    def __str__(self) -> str:
        return str(self.args[0])


def evaluate_policy(policy, env_id: str, episodes: int, seed: int, n_envs: int = 10) -> list[float]:
    """Returns of a deterministic numpy policy over `episodes` episodes of fresh envs."""
    pool = [envs.make(env_id, seed + i) for i in range(min(n_envs, episodes))]
    try:
        return evaluate(policy, pool, episodes, seed)
    finally:
        for env in pool:
            env.close()


def save_expert(
    env_id: str, policy: GaussianPolicy, meta: dict, out_dir: Path | None = None
) -> Path:
    out = out_dir or paths.expert_dir(env_id)
    buf = io.BytesIO()
    torch.save({k: v.detach().cpu() for k, v in policy.state_dict().items()}, buf)
    atomic.write_bytes(out / "policy.pt", buf.getvalue())
    atomic.write_bytes(out / "meta.json", (json.dumps(meta, indent=2) + "\n").encode())
    return out


def read_meta(env_id: str) -> dict:
    if not paths.has_expert(env_id):
        raise ExpertError(
            f"no expert for {env_id} in {paths.EXPERTS_DIR} (train one: bench experts train {env_id})"
        )
    return json.loads((paths.expert_dir(env_id) / "meta.json").read_text())


def load_expert(env_id: str) -> DeterministicPolicy:
    """The shipped expert for `env_id` as a deterministic numpy policy."""
    meta = read_meta(env_id)
    state = torch.load(
        paths.expert_dir(env_id) / "policy.pt", weights_only=True, map_location="cpu"
    )
    policy = GaussianPolicy(meta["obs_dim"], meta["act_dim"], tuple(meta["hidden"]))
    policy.load_state_dict(state)
    return DeterministicPolicy(policy, np.array(meta["action_low"]), np.array(meta["action_high"]))


def list_experts() -> list[dict]:
    if not paths.EXPERTS_DIR.is_dir():
        return []
    return [
        json.loads((d / "meta.json").read_text())
        for d in sorted(paths.EXPERTS_DIR.iterdir())
        if paths.has_expert(d.name)
    ]


def train_expert(
    env_id: str,
    steps: int,
    seed: int = 0,
    cfg: ExpertTraining | TRPOConfig | None = None,
    out_dir: Path | None = None,
    progress: bool = True,
    command: str | None = None,
    checkpoint_every: float = CHECKPOINT_SECONDS,
) -> dict:
    """Train a TRPO expert on the env reward, keep the best of its candidates (the final
    policy, the best-seen, and any kept snapshots), save it and return its meta.json.

    `command` (the command line that asked for it) is kept in meta.json, so an expert says how
    to train it again. Training saves a snapshot to `CHECKPOINT` in the output folder every
    `checkpoint_every` seconds (`bench.rl.resume`, as trials do); started again with the same
    settings, it resumes from there as if it had never stopped, and the file is removed once
    the expert is saved.
    """
    cfg = cfg or ExpertTraining()
    out = out_dir or paths.expert_dir(env_id)
    spaces = envs.spaces(env_id)
    obs_dim, act_dim, low, high = spaces
    settings = json.dumps({"env_id": env_id, "steps": steps, "seed": seed, "cfg": asdict(cfg)})
    checkpoint = CheckpointFile(out / CHECKPOINT, settings, checkpoint_every)
    learner = TRPO(obs_dim, act_dim, cfg, seed)
    if getattr(cfg, "orthogonal_init", False):
        orthogonal_init(learner.policy.mean_net, last_gain=0.01)
        orthogonal_init(learner.value.net, last_gain=1.0)
    n_kept = getattr(cfg, "kept_snapshots", 0)  # a plain TRPOConfig keeps none
    run = Progress(kept_every=steps / n_kept if n_kept else None)
    bar = tqdm(
        total=steps, desc=f"expert {env_id}", unit="step", disable=not progress, smoothing=0.05
    )

    def on_update(n: int, learner: TRPO, batch, info: dict) -> None:
        run.after_update(n, learner, batch.episode_returns)
        bar.update(n - bar.n)
        bar.set_postfix(ret=f"{np.mean(run.recent):.0f}" if run.recent else "-")

    make_env = lambda s: envs.make(env_id, s)  # noqa: E731
    with closing(bar):
        train(
            make_env,
            steps,
            seed,
            callback=on_update,
            learner=learner,
            snapshots=checkpoint,
            keep={"progress": run},
        )
    candidates = [("final", copy.deepcopy(learner.policy.state_dict()), steps), *run.candidates()]
    chosen = choose(candidates, env_id, spaces, cfg, len(run.kept) > 0, progress)
    meta = {
        "env_id": env_id,
        "obs_dim": obs_dim,
        "act_dim": act_dim,
        "action_low": low.tolist(),
        "action_high": high.tolist(),
        "hidden": list(cfg.hidden),
        "train_steps": steps,
        "command": command,
        "snapshot": chosen.name,
        "snapshot_steps": chosen.steps,
        "seed": seed,
        "wall_time_s": round(run.spent(), 1),
        "resumes": run.resumes,
        "package_version": bench.__version__,
        "torch_version": torch.__version__,
        "trpo_config": {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(cfg).items()},
        "eval_episodes": EVAL_EPISODES,
        # What each candidate scored on the selection episodes: how much the choice mattered.
        **({"selection": chosen.selection} if run.kept else {}),
        "return_mean": round(float(np.mean(chosen.returns)), 2),
        "return_std": round(float(np.std(chosen.returns)), 2),
    }
    save_expert(env_id, chosen.policy, meta, out)
    checkpoint.path.unlink(missing_ok=True)
    return meta


class Progress:
    """What expert training keeps besides its learner, saved in its snapshots as a part
    (`bench.rl.resume`): the last training returns, the best-scoring policy seen, the
    snapshots kept every `kept_every` env steps, the wall time spent and the resumes."""

    def __init__(self, kept_every: float | None) -> None:
        self.kept_every = kept_every
        self.recent: list[float] = []
        self.best: dict[str, Any] = {"score": -np.inf, "state": None, "steps": 0}
        self.kept: list[dict[str, Any]] = []
        self.resumes = 0
        self.started = time.time()

    def after_update(self, steps: int, learner: TRPO, episode_returns: list[float]) -> None:
        self.recent = [*self.recent, *episode_returns][-20:]
        # Snapshot the best training return seen: TRPO sometimes slips late in a run.
        if len(self.recent) >= 5 and np.mean(self.recent) > self.best["score"]:
            state = copy.deepcopy(learner.policy.state_dict())
            self.best = {"score": float(np.mean(self.recent)), "state": state, "steps": steps}
        if self.kept_every is not None and steps >= (len(self.kept) + 1) * self.kept_every:
            self.kept.append({"state": copy.deepcopy(learner.policy.state_dict()), "steps": steps})

    def candidates(self) -> list[tuple[str, dict, int]]:
        """(name, policy state, env steps) of the best-seen and the kept snapshots."""
        best = self.best["state"]
        best = [] if best is None else [("best", best, self.best["steps"])]
        return best + [(f"kept at {k['steps']}", k["state"], k["steps"]) for k in self.kept]

    def spent(self) -> float:
        """Wall seconds of training, runs before a resume included."""
        return time.time() - self.started

    def state_dict(self) -> dict[str, Any]:
        return {
            "recent": self.recent,
            "best": self.best,
            "kept": self.kept,
            "resumes": self.resumes,
            "spent_s": self.spent(),
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        """Where a run resumes: it is one resume more than the run it goes on from."""
        self.recent, self.best, self.kept = state["recent"], state["best"], state["kept"]
        self.resumes = state["resumes"] + 1
        self.started = time.time() - state["spent_s"]


class CheckpointFile:
    """Expert training's snapshots (`bench.rl.resume.Snapshots`): one file, written atomically
    every `every_s` seconds, that only a run of the same `settings` resumes from."""

    def __init__(self, path: Path, settings: str, every_s: float) -> None:
        self.path, self.settings, self.every_s = path, settings, every_s
        self._last = time.monotonic()

    def due(self) -> bool:
        return time.monotonic() - self._last >= self.every_s

    def save(self, state: dict[str, Any]) -> None:
        buf = io.BytesIO()
        torch.save({"settings": self.settings, "state": state}, buf)
        atomic.write_bytes(self.path, buf.getvalue())
        self._last = time.monotonic()

    def load(self) -> dict[str, Any] | None:
        if not self.path.exists():
            return None
        saved = torch.load(self.path, weights_only=True)
        if saved.get("settings") != self.settings:
            raise ExpertError(
                f"{self.path} is from a training run with other settings: "
                "rerun that command to resume it, or delete the file to start afresh"
            )
        return saved["state"]

    def replaying(self) -> AbstractContextManager[None]:
        return nullcontext()  # no budget is counted outside trials


@dataclass(frozen=True)
class Chosen:
    """The candidate an expert ships: its name, env steps, policy, and returns on the report
    episodes; `selection`: what every candidate scored on the selection episodes."""

    name: str
    steps: int
    policy: GaussianPolicy
    returns: list[float]
    selection: dict[str, float]


def choose(
    candidates: list[tuple[str, dict, int]],
    env_id: str,
    spaces: tuple[int, int, np.ndarray, np.ndarray],
    cfg: TRPOConfig,
    many: bool,
    progress: bool,
) -> Chosen:
    """The candidate (name, policy state, env steps) with the highest deterministic return
    on `env_id`, whose `envs.spaces` are `spaces`. Where there are `many` (kept snapshots),
    they are chosen on episodes of their own, so that the return shipped is not the luckiest
    of many draws on the same episodes, and the one chosen is then measured on the report
    episodes."""
    obs_dim, act_dim, low, high = spaces

    def scored(state: dict, seed: int, episodes: int) -> tuple[list[float], GaussianPolicy]:
        policy = GaussianPolicy(obs_dim, act_dim, cfg.hidden)
        policy.load_state_dict(state)
        deterministic = DeterministicPolicy(policy, low, high)
        return evaluate_policy(deterministic, env_id, episodes, seed=seed), policy

    choose_on = SELECTION_SEED if many else REPORT_SEED
    episodes = getattr(cfg, "selection_episodes", EVAL_EPISODES) if many else EVAL_EPISODES
    judged = tqdm(
        candidates, desc="snapshots scored", unit="snapshot", disable=not progress or not many
    )
    ranked = []
    for name, state, at in judged:
        rets, policy = scored(state, choose_on, episodes)
        ranked.append((float(np.mean(rets)), rets, name, policy, at))
    _, rets, name, policy, at = max(ranked, key=lambda r: r[0])
    if many:
        rets, _ = scored(policy.state_dict(), REPORT_SEED, EVAL_EPISODES)
    selection = {name: round(m, 2) for m, _, name, _, _ in ranked}
    return Chosen(name, at, policy, rets, selection)
