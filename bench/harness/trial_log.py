"""What a trial's training is watched through: its env steps counted against its budget
(`StepTally`, `StepCounter`), the checkpoints it offers evaluated into a learning curve and the
scalars it logs kept (`TrialLogger`, TensorBoard events too), and its state saved with the
trial's own in snapshots (`TrialSnapshots`)."""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from bench.harness import registry
from bench.harness.snapshots import SnapshotPlan, TrialPaused
from bench.harness.types import CurvePoint, TrialSpec
from bench.rl.rollout import evaluate

CURVE_EPISODES = 5
"""Episodes per learning-curve point; the final evaluation uses the suite's eval_episodes."""
SNAPSHOT_FORMAT = 1
"""The layout of a trial's snapshot (`TrialSnapshots`); a snapshot of another is not resumed."""
MAX_LOGGED = 10_000
"""Log calls a record keeps, within a factor of two: past 2 x MAX_LOGGED, every other one is
dropped and from then on every other call is kept, and so on (a learner that logs every env
step would otherwise write a record too large to read back, and run again each time). A
10M-step TRPO trial logs ~2,500 times."""


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
    log_calls: int = 0
    """`log` calls so far; every `log_stride`-th is kept (`MAX_LOGGED`)."""
    log_stride: int = 1

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
        if self.events is not None:  # TensorBoard streams every one
            for k, v in scalars.items():
                self.events.add_scalar(f"train/{k}", float(v), int(env_steps))
        self.log_calls += 1
        if (self.log_calls - 1) % self.log_stride:
            return
        self.logs.setdefault("env_steps", []).append(float(env_steps))
        for k, v in scalars.items():
            self.logs.setdefault(k, []).append(float(v))
        if len(self.logs["env_steps"]) >= 2 * MAX_LOGGED:
            self.logs = {k: v[::2] for k, v in self.logs.items()}
            self.log_stride *= 2


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
    cpu_before: float | None = 0.0
    """CPU seconds of those runs (None: a snapshot from before they were kept)."""
    resumed_at: list[int] = field(default_factory=list)
    started: float = field(default_factory=time.time)
    cpu_started: float = field(default_factory=time.process_time)
    _last: float = field(default_factory=time.monotonic)

    def spent(self) -> float:
        """Wall seconds of training so far, runs before this one's included."""
        return self.spent_before + time.time() - self.started

    def cpu_spent(self) -> float | None:
        """CPU seconds of this trial's process so far, runs before this one's included (None
        where a run before did not keep them)."""
        if self.cpu_before is None:
            return None
        return self.cpu_before + time.process_time() - self.cpu_started

    def due(self) -> bool:
        return self.plan.stopping() or time.monotonic() - self._last >= self.plan.every_s

    def save(self, state: dict[str, Any]) -> None:
        trial = {
            "env_steps": self.tally.steps,
            "curve": [[p.env_steps, p.mean_return] for p in self.logger.curve],
            "logs": self.logger.logs,
            "next_eval": self.logger._next,
            "log_calls": self.logger.log_calls,
            "log_stride": self.logger.log_stride,
            "spent_s": self.spent(),
            "cpu_s": self.cpu_spent(),
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
        # snapshots from before logs were thinned kept every call
        kept = len(trial["logs"].get("env_steps", []))
        self.logger.log_calls = trial.get("log_calls", kept)
        self.logger.log_stride = trial.get("log_stride", 1)
        self.spent_before, self.started = trial["spent_s"], time.time()
        self.cpu_before, self.cpu_started = trial.get("cpu_s"), time.process_time()
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
