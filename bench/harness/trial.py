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
import warnings
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
from bench.harness.trial_log import (
    BudgetExceeded,
    StepCounter,
    StepTally,
    TrialLogger,
    TrialSnapshots,
    open_events,
)
from bench.harness.types import CURVE_POINTS, TrialResult, TrialSpec
from bench.rl.rollout import evaluate

EVAL_SEED = 100_000
"""Evaluation episodes of seed s start at env seed EVAL_SEED + 1000 s: the same for every algorithm."""


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


@dataclass
class Outcome:
    """What a trial that ran to its end has to show."""

    returns: list[float] = field(default_factory=list)
    """Undiscounted return of each evaluation episode."""
    reference: str | None = None
    """Where an imported dataset's demonstrator's returns come from (`TrialResult.reference`)."""
    distance: float | None = None
    """How far its evaluation states lie from the expert's (`expert_distance`)."""
    policy: bytes | None = None
    """The final policy's file (`policies.to_bytes`); None for the expert's (shipped)."""


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
    start, cpu_start = time.time(), time.process_time()
    tally = StepTally()
    eval_seed = EVAL_SEED + 1000 * spec.seed
    eval_envs: list[gym.Env] = []
    points = spec.curve_points or CURVE_POINTS
    logger = TrialLogger(eval_envs, eval_seed, every=max(1, spec.budget // points))
    if snapshots is not None:
        logger.snapshots = TrialSnapshots(snapshots, spec, tally, logger)
    algo: registry.Algorithm | None = None
    outcome, status, tb = Outcome(), "failed", None
    try:
        kernels.require(spec.kernels)
        logger.events = open_events(tensorboard, spec)
        torch.manual_seed(spec.seed)
        trial = plan(spec)
        algo = trial.algorithm
        outcome = train_and_evaluate(trial, inputs, tally, logger, eval_envs, eval_seed)
        status = "ok"
    except TrialPaused:  # at its run's time limit, its snapshot saved: the next run goes on
        status = "paused"
    except Exception:
        tb = traceback.format_exc()
    finally:
        for env in eval_envs:
            env.close()
        if logger.events is not None:
            if status == "ok":
                final = float(np.mean(outcome.returns))
                logger.events.add_scalar("eval/final_return", final, tally.steps)
            logger.events.close()
    resumed = logger.snapshots
    ok = status == "ok"
    return TrialResult(
        spec=spec,
        status=status,
        returns=[float(r) for r in outcome.returns] if ok else [],
        curve=logger.curve,
        env_steps=tally.steps,
        wall_time=round(time.time() - start if resumed is None else resumed.spent(), 3),
        versions=computed_with(spec),
        traceback=tb,
        logs=logger.logs,
        inputs=None if algo is None else algo.inputs,
        reference=outcome.reference if ok else None,
        state_distance=outcome.distance if ok else None,
        role=None if algo is None else algo.role,
        family=None if algo is None else algo.family,
        label=None if algo is None else registry.shown_as(spec.algorithm, spec.label),
        resumed_at=[] if resumed is None else resumed.resumed_at,
        cpu_time=_rounded(
            time.process_time() - cpu_start if resumed is None else resumed.cpu_spent()
        ),
        policy=outcome.policy if ok else None,
    )


def _rounded(seconds: float | None) -> float | None:
    return None if seconds is None else round(seconds, 3)


def train_and_evaluate(
    trial: Plan,
    inputs: Any,
    tally: StepTally,
    logger: TrialLogger,
    eval_envs: list[gym.Env],
    eval_seed: int,
) -> Outcome:
    """Train the trial's algorithm within its budget and evaluate the policy it returns on
    `eval_envs` (opened here, closed by the caller); raises what goes wrong."""
    spec, algo = trial.spec, trial.algorithm
    if spec.dataset and algo.inputs == "expert":
        # The demonstrator of an imported dataset cannot be run: its returns stand in.
        returns, reference = minari_io.expert_reference(minari_io.open_dataset(spec.dataset))
        outcome = Outcome(returns, reference)
    else:
        eval_envs += [trial.make_env(eval_seed + i) for i in range(min(10, spec.eval_episodes))]
        task = trial.task(tally)
        # a copy: trials that share a spec's config in one process must not share its state
        config = copy.deepcopy(registry.config_of(spec))
        policy = algo.train(task, inputs, spec.budget, spec.seed, logger, config)
        if not callable(policy):  # a plugin that forgot to return it, say
            raise TypeError(
                f"{spec.algorithm}'s train returned {type(policy).__name__}, not a policy (a"
                " callable from a batch of observations to a batch of actions)"
            )
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
        outcome = Outcome(returns, None, distance, saved)
    if not np.all(np.isfinite(outcome.returns)):
        raise FloatingPointError("evaluation returned a non-finite return")
    return outcome


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
        # Loaded here once, each trial's fork inherits the registry rather than importing every
        # plugin again, and a broken one is not warned about once per trial: the driver has.
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", registry.BrokenPluginWarning)
            registry.all_algorithms()
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
