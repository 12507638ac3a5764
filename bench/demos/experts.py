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
from dataclasses import asdict, dataclass
from pathlib import Path

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
class ExpertConfig(TRPOConfig):
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
    cfg: ExpertConfig | TRPOConfig | None = None,
    out_dir: Path | None = None,
    progress: bool = True,
    command: str | None = None,
    checkpoint_every: float = CHECKPOINT_SECONDS,
) -> dict:
    """Train a TRPO expert on the env reward, keep the better of final and best-seen, save it.

    `command` (the command line that asked for it) is kept in meta.json, so an expert says how
    to train it again. Progress goes to `CHECKPOINT` in the output folder every
    `checkpoint_every` seconds; started again with the same settings, training resumes from
    it (with fresh episodes, so not bit for bit the run it would have been), and the file is
    removed once the expert is saved.
    """
    cfg = cfg or ExpertConfig()
    out = out_dir or paths.expert_dir(env_id)
    obs_dim, act_dim, low, high = envs.spaces(env_id)
    settings = json.dumps({"env_id": env_id, "steps": steps, "seed": seed, "cfg": asdict(cfg)})
    learner = TRPO(obs_dim, act_dim, cfg, seed)
    if getattr(cfg, "orthogonal_init", False):
        orthogonal_init(learner.policy.mean_net, last_gain=0.01)
        orthogonal_init(learner.value.net, last_gain=1.0)
    run = {"steps": 0, "wall_time_s": 0.0, "resumes": 0, "recent": [], "kept": []}
    best = {"score": -np.inf, "state": None, "steps": 0}
    if (out / CHECKPOINT).exists():
        saved = torch.load(out / CHECKPOINT, weights_only=True)
        if saved["settings"] != settings:
            raise ExpertError(
                f"{out / CHECKPOINT} is from a training run with other settings: "
                "rerun that command to resume it, or delete the file to start afresh"
            )
        learner.load_state_dict(saved["learner"])
        run, best = saved["run"], saved["best"]
        run.setdefault("kept", [])
        run["resumes"] += 1
    start, last_save = time.time() - run["wall_time_s"], time.time()
    recent: list[float] = run["recent"]
    kept: list[dict] = run["kept"]
    n_kept = getattr(cfg, "kept_snapshots", 0)  # a plain TRPOConfig keeps none
    spacing = steps / n_kept if n_kept else None
    bar = tqdm(
        total=steps,
        initial=run["steps"],
        desc=f"expert {env_id}",
        unit="step",
        disable=not progress,
        smoothing=0.05,
    )

    def save_checkpoint() -> None:
        run.update(wall_time_s=time.time() - start, recent=recent)
        state = {"settings": settings, "learner": learner.state_dict(), "run": run, "best": best}
        buf = io.BytesIO()
        torch.save(state, buf)
        atomic.write_bytes(out / CHECKPOINT, buf.getvalue())

    done_before = run["steps"]

    def on_update(n: int, learner: TRPO, batch, info: dict) -> None:
        nonlocal last_save
        run["steps"] = done_before + n
        recent.extend(batch.episode_returns)
        del recent[:-20]
        # Snapshot the best training return seen: TRPO sometimes slips late in a run.
        if len(recent) >= 5 and np.mean(recent) > best["score"]:
            best.update(
                score=float(np.mean(recent)),
                state=copy.deepcopy(learner.policy.state_dict()),
                steps=run["steps"],
            )
        if spacing is not None and run["steps"] >= (len(kept) + 1) * spacing:
            kept.append(
                {"state": copy.deepcopy(learner.policy.state_dict()), "steps": run["steps"]}
            )
        bar.update(batch.n_steps)
        bar.set_postfix(ret=f"{np.mean(recent):.0f}" if recent else "-")
        if time.time() - last_save >= checkpoint_every:
            save_checkpoint()
            last_save = time.time()

    if steps - done_before >= cfg.batch_size:
        # A resumed run steps envs of other seeds than the first: no episode is replayed.
        make_env = lambda s: envs.make(env_id, s)  # noqa: E731
        train(
            make_env,
            steps - done_before,
            seed + run["resumes"],
            callback=on_update,
            learner=learner,
        )
    bar.close()
    candidates = [("final", copy.deepcopy(learner.policy.state_dict()), steps)]
    if best["state"] is not None:
        candidates.append(("best", best["state"], best["steps"]))
    candidates += [(f"kept at {k['steps']}", k["state"], k["steps"]) for k in kept]

    def scored(state: dict, seed: int, episodes: int) -> tuple[list[float], GaussianPolicy]:
        policy = GaussianPolicy(obs_dim, act_dim, cfg.hidden)
        policy.load_state_dict(state)
        deterministic = DeterministicPolicy(policy, low, high)
        return evaluate_policy(deterministic, env_id, episodes, seed=seed), policy

    # Chosen on episodes of their own where there are many candidates, so that the return
    # shipped is not the luckiest of many draws on the same episodes.
    choose_on = SELECTION_SEED if kept else REPORT_SEED
    ranked = []
    judged = tqdm(
        candidates, desc="snapshots scored", unit="snapshot", disable=not progress or not kept
    )
    for name, state, at in judged:
        rets, policy = scored(state, choose_on, cfg.selection_episodes if kept else EVAL_EPISODES)
        ranked.append((float(np.mean(rets)), rets, name, policy, at))
    _, rets, which, policy, at = max(ranked, key=lambda r: r[0])
    if kept:
        rets, _ = scored(policy.state_dict(), REPORT_SEED, EVAL_EPISODES)
    mean, std = float(np.mean(rets)), float(np.std(rets))
    meta = {
        "env_id": env_id,
        "obs_dim": obs_dim,
        "act_dim": act_dim,
        "action_low": low.tolist(),
        "action_high": high.tolist(),
        "hidden": list(cfg.hidden),
        "train_steps": steps,
        "command": command,
        "snapshot": which,
        "snapshot_steps": at,
        "seed": seed,
        "wall_time_s": round(time.time() - start, 1),
        "resumes": run["resumes"],
        "package_version": bench.__version__,
        "torch_version": torch.__version__,
        "trpo_config": {k: list(v) if isinstance(v, tuple) else v for k, v in asdict(cfg).items()},
        "eval_episodes": EVAL_EPISODES,
        # What each candidate scored on the selection episodes: how much the choice mattered.
        **({"selection": {name: round(m, 2) for m, _, name, _, _ in ranked}} if kept else {}),
        "return_mean": round(mean, 2),
        "return_std": round(std, 2),
    }
    save_expert(env_id, policy, meta, out)
    (out / CHECKPOINT).unlink(missing_ok=True)
    return meta
