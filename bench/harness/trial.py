"""One trial, in a worker: `run_trial(spec, inputs) -> TrialResult`.

A trial's spec says everything: the algorithm, the env as its algorithm observes it (states,
frames, or states filmed beside for a video reward), the demonstrations it is handed, the
budget its envs count every step against, and how it is evaluated. Nothing here writes a
file: the driver (`bench.harness.runner`) writes records and policies as results come back.
"""

from __future__ import annotations

import copy
import time
import traceback
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from bench import envs, kernels
from bench.demos import experts, minari_io, pools
from bench.envs.pixels import PixelConfig, VideoBeside
from bench.harness import policies, registry, state_match
from bench.harness.isolate import Died, die_with_parent, isolated
from bench.harness.snapshots import SnapshotPlan, TrialPaused
from bench.harness.types import CURVE_POINTS, CurvePoint, TrialResult, TrialSpec
from bench.rl.rollout import evaluate

CURVE_EPISODES = 5
"""Episodes per learning-curve point; the final evaluation uses the suite's eval_episodes."""
EVAL_SEED = 100_000
"""Evaluation episodes of seed s start at env seed EVAL_SEED + 1000 s: the same for every algorithm."""


SNAPSHOT_FORMAT = 1
"""The layout of a trial's snapshot (`TrialSnapshots`); a snapshot of another is not resumed."""


class BudgetExceeded(RuntimeError):
    pass


@dataclass
class StepTally:
    """The env steps a trial has taken, shared by all its envs."""

    steps: int = 0
    counting: bool = True
    """Off while an env replays steps already counted (`TrialSnapshots.replaying`)."""


class StepCounter(gym.Wrapper):
    """Counts every step into a shared tally and stops the trial past its budget."""

    def __init__(self, env: gym.Env, tally: StepTally, budget: int) -> None:
        super().__init__(env)
        self.tally, self.budget = tally, budget

    def step(self, action):
        if self.tally.counting:
            self.tally.steps += 1
            if self.tally.steps > self.budget:
                raise BudgetExceeded(
                    f"algorithm took more than its budget of {self.budget} env steps"
                )
        return self.env.step(action)


@dataclass
class TrialLogger:
    """The runner's side of `registry.Logger`: evaluates offered checkpoints on a schedule."""

    eval_envs: list[gym.Env]
    eval_seed: int
    every: int
    curve: list[CurvePoint] = field(default_factory=list)
    logs: dict[str, list[float]] = field(default_factory=dict)
    _next: int = 0

    events: Any = None
    """A TensorBoard SummaryWriter that gets every scalar as it is logged (None: records only)."""
    snapshots: TrialSnapshots | None = None
    """The trial's `bench.rl.resume.Snapshots`, where the runner keeps them (None: it does not)."""

    def checkpoint(self, env_steps: int, policy: registry.Policy) -> None:
        if env_steps >= self._next:
            rets = evaluate(policy, self.eval_envs, CURVE_EPISODES, self.eval_seed)
            self.curve.append(CurvePoint(int(env_steps), float(np.mean(rets))))
            self._next = env_steps + self.every
            if self.events is not None:
                self.events.add_scalar("eval/return", self.curve[-1].mean_return, int(env_steps))

    def log(self, env_steps: int, **scalars: float) -> None:
        self.logs.setdefault("env_steps", []).append(float(env_steps))
        for k, v in scalars.items():
            self.logs.setdefault(k, []).append(float(v))
            if self.events is not None:
                self.events.add_scalar(f"train/{k}", float(v), int(env_steps))


@dataclass
class TrialSnapshots:
    """The runner's side of `bench.rl.resume.Snapshots` for one trial: the algorithm's state saved
    with the trial's own (env steps, learning curve, logs, time spent), so a resumed trial's
    record reads as if it had run in one go, but for `resumed_at`."""

    plan: SnapshotPlan
    spec: TrialSpec
    tally: StepTally
    logger: TrialLogger
    spent_before: float = 0.0
    """Wall seconds the trial trained before this run resumed it (up to its snapshot)."""
    resumed_at: list[int] = field(default_factory=list)
    started: float = field(default_factory=time.time)
    _last: float = field(default_factory=time.monotonic)

    def spent(self) -> float:
        """Wall seconds of training so far, runs before this one's included."""
        return self.spent_before + time.time() - self.started

    def due(self) -> bool:
        return self.plan.stopping() or time.monotonic() - self._last >= self.plan.every_s

    def save(self, state: dict[str, Any]) -> None:
        trial = {
            "env_steps": self.tally.steps,
            "curve": [[p.env_steps, p.mean_return] for p in self.logger.curve],
            "logs": self.logger.logs,
            "next_eval": self.logger._next,
            "spent_s": self.spent(),
            "resumed_at": self.resumed_at,
        }
        payload = {"format": SNAPSHOT_FORMAT, "trial": trial, "algorithm": state}
        self.plan.write(self.spec.trial_id, payload, self.tally.steps, self.spec.budget)
        self._last = time.monotonic()
        if self.plan.stopping():
            raise TrialPaused(f"paused at the time limit after {self.tally.steps} env steps")

    def load(self) -> dict[str, Any] | None:
        payload = self.plan.read(self.spec.trial_id)
        if payload is None or payload.get("format") != SNAPSHOT_FORMAT:
            return None  # none, or one of another layout: start afresh and overwrite it
        trial = payload["trial"]
        self.tally.steps = trial["env_steps"]
        self.logger.curve = [CurvePoint(int(s), float(r)) for s, r in trial["curve"]]
        self.logger.logs = trial["logs"]
        self.logger._next = trial["next_eval"]
        self.spent_before, self.started = trial["spent_s"], time.time()
        self.resumed_at = [*trial["resumed_at"], trial["env_steps"]]
        return payload["algorithm"]

    @contextmanager
    def replaying(self) -> Iterator[None]:
        self.tally.counting = False
        try:
            yield
        finally:
            self.tally.counting = True


def event_dir(root: str | Path, spec: TrialSpec) -> Path:
    """Where a trial's TensorBoard events go under `root`: one run per trial, named so that
    TensorBoard's run filter reads env/algorithm/demos/seed."""
    return (
        Path(root)
        / spec.suite
        / spec.env_id
        / spec.shown
        / f"{spec.n_demos}demos"
        / f"seed{spec.seed}"
    )


def open_events(root: str | Path | None, spec: TrialSpec) -> Any:
    """A SummaryWriter for the trial's events, or None without `root`."""
    if root is None:
        return None
    from torch.utils.tensorboard import SummaryWriter

    return SummaryWriter(str(event_dir(root, spec)), flush_secs=10)


def versions(env_id: str) -> dict[str, str]:
    """The versions of what decides a trial's numbers: ours, torch's, gymnasium's and the
    simulator's the env runs on."""
    simulator = "pybullet" if envs.is_pybullet(env_id) else "mujoco"
    packages = ("ifo-bench", "torch", "gymnasium", simulator)
    return {pkg: version(pkg) for pkg in packages if _installed(pkg)}


def computed_with(spec: TrialSpec) -> dict[str, str]:
    """`versions`, and for a portable trial the kernels it computed with (the native ones are
    the CPU's, as every record before kernels could be pinned)."""
    pinned = {"kernels": kernels.describe()} if spec.kernels else {}
    return versions(spec.env_id) | pinned


def _installed(package: str) -> bool:
    try:
        version(package)
    except PackageNotFoundError:
        return False
    return True


@dataclass(frozen=True)
class Plan:
    """A trial's spec resolved once, before it runs: its algorithm, how that algorithm observes
    the env, and from these its envs, its Task and the inputs it is handed."""

    spec: TrialSpec
    algorithm: registry.Algorithm
    pixels: PixelConfig | None
    """Frames the algorithm learns from, in a pixel suite env (the expert, which cannot learn
    from them, acts on states there too); None: states."""
    beside: PixelConfig | None
    """Frames filmed beside the states, in a video-reward env, for an algorithm that imitates
    video while acting on states; else None."""

    @property
    def filmed(self) -> PixelConfig | None:
        """How the demonstrations are filmed: as the learner sees them (pixels) or as its
        reward judges them (video-reward); None: they are states."""
        return self.pixels or self.beside

    def make_env(self, seed: int, training: bool = True) -> gym.Env:
        """An env of the trial, observed as its algorithm observes it. Where it imitates video
        while acting on states, training envs film themselves beside (`VideoBeside`);
        evaluation envs need not."""
        if training and self.beside is not None:
            return VideoBeside(envs.make(self.spec.env_id, seed, self.beside))
        return envs.make(self.spec.env_id, seed, self.pixels)

    def task(self, tally: StepTally) -> registry.Task:
        """The trial's Task: its envs count every step into `tally` and stop past the
        budget."""
        obs_dim, act_dim, low, high = envs.spaces(self.spec.env_id, self.pixels)
        budget = self.spec.budget
        return registry.Task(
            self.spec.env_id,
            obs_dim,
            act_dim,
            low,
            high,
            make_env=lambda s: StepCounter(self.make_env(s), tally, budget),
            pixels=self.pixels,
            video=self.beside,
        )

    def inputs(self) -> Any:
        """What the algorithm is handed as `demos`, according to its `inputs`."""
        kind, spec = self.algorithm.inputs, self.spec
        if kind == "none":
            return None
        if kind == "expert":
            return None if spec.dataset else experts.load_expert(spec.env_id)
        pool = demo_pool(spec.env_id, spec.dataset, self.filmed)
        load = pools.load_demos if kind == "states" else pools.load_action_demos
        return load(pool, spec.env_id, spec.n_demos, spec.seed, self.filmed)


def plan(spec: TrialSpec) -> Plan:
    algorithm = registry.get(spec.algorithm)
    frames = PixelConfig() if spec.frame_size is None else PixelConfig(size=spec.frame_size)
    seen = frames if spec.observation == "pixels" and algorithm.pixels else None
    beside = frames if spec.observation == "video-reward" and algorithm.video_reward else None
    return Plan(spec, algorithm, seen, beside)


def demo_pool(env_id: str, dataset: str | None, video: PixelConfig | None = None) -> Path:
    """The demonstration pool file of `env_id`: converted from the Minari `dataset` if given,
    else recorded from the shipped expert (with its video, given `video`); made on first use,
    cached after."""
    if dataset:
        return minari_io.ensure_pool(dataset, env_id)
    return pools.ensure_pool(env_id, video)


def expert_distance(spec: TrialSpec, visited: list[np.ndarray]) -> float | None:
    """`state_match.state_distance` of the states a trial's evaluation visited from its expert
    pool's states; None where the env has no expert (or dataset) to compare with."""
    try:
        pool = demo_pool(spec.env_id, spec.dataset)
    except FileNotFoundError:  # ExpertError: a random policy can run where no expert exists
        return None
    expert_states = pools.pool_states(pool, spec.env_id)
    return state_match.state_distance(np.concatenate(visited), expert_states)


def run_trial(
    spec: TrialSpec,
    inputs: Any,
    tensorboard: str | Path | None = None,
    snapshots: SnapshotPlan | None = None,
) -> TrialResult:
    """Train `spec.algorithm` and evaluate it; never raises (a failure is a failed record).
    With `tensorboard`, every scalar it logs is also written there as it comes (`event_dir`).
    With `snapshots`, an algorithm that takes them saves its state there as it trains and
    resumes from it, where an earlier run of this trial was cut off; past the plan's `stop_at`
    it saves and stops, and the result's status is "paused" (no record: the trial is not
    over)."""
    torch.set_num_threads(1)  # joblib workers share the cores: one thread each
    start = time.time()
    tally = StepTally()
    eval_seed = EVAL_SEED + 1000 * spec.seed
    eval_envs: list[gym.Env] = []
    points = spec.curve_points or CURVE_POINTS
    logger = TrialLogger(eval_envs, eval_seed, every=max(1, spec.budget // points))
    if snapshots is not None:
        logger.snapshots = TrialSnapshots(snapshots, spec, tally, logger)
    given = reference = distance = saved = role = family = label = None
    status, returns = "failed", []
    try:
        kernels.require(spec.kernels)
        logger.events = open_events(tensorboard, spec)
        torch.manual_seed(spec.seed)
        trial = plan(spec)
        algo = trial.algorithm
        given, role, family = algo.inputs, algo.role, algo.family
        label = registry.shown_as(spec.algorithm, spec.label)
        if spec.dataset and algo.inputs == "expert":
            # The demonstrator of an imported dataset cannot be run: its returns stand in.
            returns, reference = minari_io.expert_reference(minari_io.open_dataset(spec.dataset))
        else:
            eval_envs += [trial.make_env(eval_seed + i) for i in range(min(10, spec.eval_episodes))]
            task = trial.task(tally)
            # a copy: trials that share a spec's config in one process must not share its state
            config = copy.deepcopy(registry.config_of(spec))
            policy = algo.train(task, inputs, spec.budget, spec.seed, logger, config)
            if tally.steps > spec.budget:  # it caught the budget's error and went on
                raise BudgetExceeded(
                    f"{spec.algorithm} took {tally.steps} env steps, more than its budget of"
                    f" {spec.budget} (the budget's error was caught inside the algorithm)"
                )
            visited: list[np.ndarray] | None = None if trial.pixels else []
            returns = evaluate(policy, eval_envs, spec.eval_episodes, eval_seed, visited)
            # the expert's policy is shipped (results/experts), not kept per trial
            saved = None if algo.role == "expert" else policies.to_bytes(policy)
            if saved is not None:
                policies.from_bytes(saved)  # it must load back, or the trial did not end well
            distance = expert_distance(spec, visited) if visited else None
        if not np.all(np.isfinite(returns)):
            raise FloatingPointError("evaluation returned a non-finite return")
        status, tb = "ok", None
    except TrialPaused:  # at its run's time limit, its snapshot saved: the next run goes on
        returns, status, tb = [], "paused", None
    except Exception:
        returns, status, tb = [], "failed", traceback.format_exc()
    finally:
        for env in eval_envs:
            env.close()
        if logger.events is not None:
            if status == "ok":
                logger.events.add_scalar("eval/final_return", float(np.mean(returns)), tally.steps)
            logger.events.close()
    resumed = logger.snapshots
    return TrialResult(
        spec=spec,
        status=status,
        returns=[float(r) for r in returns],
        curve=logger.curve,
        env_steps=tally.steps,
        wall_time=round(time.time() - start if resumed is None else resumed.spent(), 3),
        versions=computed_with(spec),
        traceback=tb,
        logs=logger.logs,
        inputs=given,
        reference=reference,
        state_distance=distance,
        role=role,
        family=family,
        label=label,
        resumed_at=[] if resumed is None else resumed.resumed_at,
        policy=saved if status == "ok" else None,
    )


OVERRUN_S = 60.0
"""How long past its run's time limit a trial that has not paused by itself (one that takes no
snapshots, or has no chance to) is given before it is stopped and left pending."""


def run_trial_apart(
    spec: TrialSpec,
    inputs: Any,
    tensorboard: str | Path | None = None,
    snapshots: SnapshotPlan | None = None,
    in_worker: bool = False,
    timeout: float | None = None,
) -> TrialResult:
    """`run_trial` in a process of its own (`bench.harness.isolate`): where that process dies (a
    segfault, a kill for memory, an exit inside the algorithm) or runs past `timeout` seconds,
    the trial is recorded as failed with how it ended, and the run goes on with the others.
    Past its run's time limit (`snapshots.stop_at`) by OVERRUN_S, it is stopped and left
    pending ("paused"), its last snapshot kept. `in_worker`: this is a worker process of the
    run's pool, which must die with the run's driver."""
    if in_worker:
        die_with_parent()
    start = time.time()
    stop_at = None if snapshots is None or snapshots.stop_at is None else snapshots.stop_at
    limits = [timeout] if timeout is not None else []
    if stop_at is not None:
        limits.append(max(0.0, stop_at + OVERRUN_S - start))
    result = isolated(
        run_trial, spec, inputs, tensorboard, snapshots, timeout=min(limits, default=None)
    )
    if not isinstance(result, Died):
        return result
    ran_out = result.timed_out is not None and (timeout is None or result.timed_out < timeout)
    if ran_out:  # the run's time limit, not the trial's own
        return ended(spec, start, "paused", None)
    if result.timed_out is not None:
        return ended(spec, start, "failed", f"TrialTimedOut: {result} (the suite's trial_timeout)")
    return ended(spec, start, "failed", f"TrialDied: {result}")


def ended(spec: TrialSpec, start: float, status: str, traceback: str | None) -> TrialResult:
    """The result of a trial (started at `start`) whose process ended without one."""
    return TrialResult(
        spec=spec,
        status=status,
        returns=[],
        curve=[],
        env_steps=0,
        wall_time=round(time.time() - start, 3),
        versions=versions(spec.env_id),
        traceback=traceback,
    )
