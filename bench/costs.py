"""What trials cost: the runner's dispatch order and `bench run --estimate`, learned from the
wall times of finished records."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

import numpy as np

from bench.types import TrialResult, TrialSpec


def observed(spec: TrialSpec) -> str | None:
    """How a trial sees its env, where that is not the state vector: "pixels", "video-reward",
    with the frame size where it is not the default ("pixels 32px")."""
    if spec.observation is None or spec.frame_size is None:
        return spec.observation
    return f"{spec.observation} {spec.frame_size}px"


def cost_kind(spec: TrialSpec) -> tuple[str, str]:
    """What a trial's cost per env step depends on: its env as observed, and its algorithm.
    Frames cost ~100x states per step, so they are another kind: "ENV (pixels)"."""
    seen = observed(spec)
    return (spec.env_id if seen is None else f"{spec.env_id} ({seen})"), spec.algorithm


@dataclass
class CostModel:
    """Wall seconds per env step of each (env, algorithm), learned from finished trials.

    It orders dispatch longest-first, so that the run does not end with one
    long trial on one core while the others idle. Budget alone is a poor
    guide: at the same budget a BCO trial takes 3x a GAIfO one, and the
    references (random, expert) take almost nothing.
    """

    totals: dict[tuple[str, str], tuple[float, int]] = field(default_factory=dict)
    """(sum of seconds per env step, trials) by (env, algorithm)."""
    lock: threading.Lock = field(default_factory=threading.Lock)  # joblib dispatches from a thread

    def observe(self, spec: TrialSpec, wall_time: float) -> None:
        key = cost_kind(spec)
        with self.lock:
            total, n = self.totals.get(key, (0.0, 0))
            self.totals[key] = (total + wall_time / max(spec.budget, 1), n + 1)

    def seconds(self, spec: TrialSpec) -> float | None:
        """Expected wall seconds of `spec` (None: its kind never timed)."""
        with self.lock:
            seen = self.totals.get(cost_kind(spec))
        if seen is None:
            return None
        total, n = seen
        return total / n * spec.budget

    def priority(self, spec: TrialSpec) -> tuple[int, float]:
        """Higher runs sooner: never-seen kinds first (by budget), then by expected seconds."""
        seconds = self.seconds(spec)
        return (1, float(spec.budget)) if seconds is None else (0, seconds)

    def time_left(self, specs: Iterable[TrialSpec], workers: int) -> str:
        """What `specs` should take on `workers` cores, for a progress bar: "~2.5 h", with
        "+N unpriced" for trials of kinds never timed."""
        expected = [self.seconds(spec) for spec in specs]
        hours = sum(s for s in expected if s is not None) / 3600 / max(workers, 1)
        text = f"~{hours:.1f} h" if hours >= 1 else f"~{hours * 60:.0f} min"
        unpriced = sum(s is None for s in expected)
        return text + (f" +{unpriced} unpriced" if unpriced else "")


@dataclass(frozen=True)
class Estimate:
    env_id: str
    """The env id, with its observation in parentheses where it is not states."""
    algorithm: str
    trials: int
    seconds: float | None
    """Expected wall seconds of one trial on one core (None: nothing to go by)."""
    basis: str
    """What the estimate rests on."""


def _seconds_at(record: TrialResult, budget: float) -> float:
    """What `record` predicts a like trial of `budget` env steps takes: training time scales
    with the budget, but a trial that trained on no env step (the references: random, expert)
    costs its evaluation alone, at any budget."""
    return record.wall_time * budget / record.spec.budget if record.env_steps else record.wall_time


def estimate(specs: list[TrialSpec], records: Iterable[TrialResult]) -> list[Estimate]:
    """Expected cost of `specs` per (env, algorithm), from the seconds per env step that
    finished `records` took: their mean on the same env if any, else the slowest measured
    env's seen the same way (rough: envs step at different speeds; a state trial never goes by
    a pixel one's). Records made while the machine was busy make an estimate high."""
    # Keyed by how the env is seen as well: a state trial only goes by state trials.
    done: dict[tuple[str | None, str, str], list[TrialResult]] = {}
    for r in records:
        if r.status == "ok" and r.spec.budget > 0:
            done.setdefault((observed(r.spec), *cost_kind(r.spec)), []).append(r)
    groups: dict[tuple[str, str], list[TrialSpec]] = {}
    for spec in specs:
        groups.setdefault(cost_kind(spec), []).append(spec)
    out = []
    for (env_id, algorithm), group in groups.items():
        budget = sum(s.budget for s in group) / len(group)
        seen = observed(group[0])
        by_env = {  # this env's, if measured, and every other env's seen the same way
            e: float(np.mean([_seconds_at(r, budget) for r in rs]))
            for (o, e, a), rs in done.items()
            if o == seen and a == algorithm
        }
        if env_id in by_env:
            seconds = by_env[env_id]
            basis = f"mean of {len(done[seen, env_id, algorithm])} trials"
        elif by_env:
            slowest = max(by_env, key=by_env.get)
            seconds = by_env[slowest]
            basis = f"rough: as on {slowest}, the slowest measured"
        else:
            seconds, basis = None, f"no finished {algorithm} trial"
        out.append(Estimate(env_id, algorithm, len(group), seconds, basis))
    return out


def seconds_each(specs: list[TrialSpec], records: Iterable[TrialResult]) -> dict[str, float | None]:
    """Each trial's expected wall seconds on one core, by trial id, as `estimate` prices its
    kind at its own budget (None: nothing to go by)."""
    records = list(records)
    groups: dict[tuple, list[TrialSpec]] = {}
    for spec in specs:
        groups.setdefault((*cost_kind(spec), spec.budget), []).append(spec)
    out: dict[str, float | None] = {}
    for group in groups.values():
        (row,) = estimate(group, records)
        out.update({spec.trial_id: row.seconds for spec in group})
    return out


@dataclass(frozen=True)
class TimeLimit:
    """A wall-clock end for a run: a trial starts only if its expected seconds (`seconds_each`)
    fit in what is left, so none is cut off, and a run on a cluster's wall-clock allowance or
    in a session that ends loses no work. A trial with nothing to go by never fits."""

    deadline: float
    """On `clock`'s scale."""
    seconds: dict[str, float | None]
    """Expected seconds by trial id."""
    clock: Callable[[], float] = time.monotonic

    @classmethod
    def starting_now(
        cls,
        limit: float,
        seconds: dict[str, float | None],
        clock: Callable[[], float] = time.monotonic,
    ) -> TimeLimit:
        return cls(clock() + limit, seconds, clock)

    def fits(self, spec: TrialSpec) -> bool:
        expected = self.seconds.get(spec.trial_id)
        return expected is not None and self.clock() + expected <= self.deadline
