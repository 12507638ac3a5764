"""Snapshots: a long trial's state, kept on disk as it trains, so that a trial cut off (a
session that ends, a preempted cluster job, a killed run) resumes from its last snapshot
instead of from scratch.

An algorithm opts in (every built-in one does: `bench.rl.trpo.train`, `bench.rl.sac.train`,
BCO's loop); the runner gives each trial a file under `<results dir>/.partial/` and removes
it once the trial's record is written. A snapshot is one `torch.save` file, written atomically, read back with
`weights_only=True`; beside it a small JSON says how far the trial got, which the runner
reads to price what a resumed trial has left without loading the snapshot itself.
"""

from __future__ import annotations

import contextlib
import io
import json
import time
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch

from bench import atomic, reading
from bench.harness.types import TrialSpec

FOLDER = ".partial"
"""Snapshots' folder in a results folder (hidden: it holds no records)."""
TRIAL_KEY = "__trial__"
"""The key under which a snapshot names its trial."""
EVERY_S = 600.0
"""Default seconds between two snapshots of a trial: at most ~10 min of work lost."""


class TrialPaused(Exception):
    """Raised by a trial's snapshot save past its run's `stop_at`: the trial stops there, its
    snapshot kept, and the next run resumes it."""


@dataclass(frozen=True)
class SnapshotPlan:
    """Where a run keeps its trials' snapshots, how often, and until when: shipped to each
    worker."""

    folder: Path
    every_s: float = EVERY_S
    stop_at: float | None = None
    """Wall-clock time (`time.time()`) past which each trial in flight saves a snapshot at its
    next chance and stops (the run's time limit); None: trials run to the end."""

    @classmethod
    def of(
        cls, results_dir: str | Path, every_s: float = EVERY_S, stop_at: float | None = None
    ) -> SnapshotPlan:
        return cls(Path(results_dir) / FOLDER, every_s, stop_at)

    def stopping(self) -> bool:
        """Whether the run's time limit has passed: trials should save and stop."""
        return self.stop_at is not None and time.time() >= self.stop_at

    def path(self, trial_id: str) -> Path:
        return self.folder / f"{trial_id}.pt"

    def progress_path(self, trial_id: str) -> Path:
        return self.folder / f"{trial_id}.json"

    def write(self, trial_id: str, state: dict[str, Any], env_steps: int, budget: int) -> None:
        """Keep `state` as the trial's snapshot, then how far it got (in that order: progress
        never claims more than the snapshot holds). The snapshot names its trial, so a copy
        under another trial's name is never resumed. Where it cannot be kept (its path taken
        by a folder, a full disk), the trial says so and trains on without one."""
        data = io.BytesIO()
        torch.save({**state, TRIAL_KEY: trial_id}, data)
        try:
            atomic.write_bytes(self.path(trial_id), data.getvalue())
            progress = {"env_steps": env_steps, "budget": budget}
            atomic.write_text(self.progress_path(trial_id), json.dumps(progress))
        except OSError as e:
            warnings.warn(
                f"trial {trial_id}: cannot keep a snapshot at {self.path(trial_id)}"
                f" ({e.strerror or e}); it trains on, and a cut-off would restart it",
                stacklevel=2,
            )

    def read(self, trial_id: str) -> dict[str, Any] | None:
        """The trial's last snapshot, or None where it has none (or only one of another trial,
        copied under its name, or one that does not load: those are passed over with a
        warning, and the trial starts afresh)."""
        path = self.path(trial_id)
        if not path.is_file():
            return None
        try:
            state = torch.load(path, map_location="cpu", weights_only=True)
        except Exception as e:  # a damaged file, or a stranger's: never a trial that cannot run
            reason = str(e).splitlines()[0] if str(e) else type(e).__name__
            warnings.warn(
                f"{path} does not load ({reason}): not resumed; the trial starts afresh",
                stacklevel=2,
            )
            return None
        saved_for = state.pop(TRIAL_KEY, trial_id) if isinstance(state, dict) else None
        if saved_for != trial_id:
            warnings.warn(
                f"{path} is a snapshot of trial {saved_for}, not of {trial_id}: not resumed;"
                " the trial starts afresh",
                stacklevel=2,
            )
            return None
        return state

    def done_before(self, specs: Iterable[TrialSpec]) -> dict[str, float]:
        """Trial id -> `done_fraction`, for `costs.CostModel.done_before`."""
        return {spec.trial_id: self.done_fraction(spec.trial_id) for spec in specs}

    def done_fraction(self, trial_id: str) -> float:
        """How much of its budget the trial's last snapshot has behind it (0: none)."""
        try:
            progress = json.loads(reading.read_bytes(self.progress_path(trial_id), 4096))
            return min(1.0, max(0.0, progress["env_steps"] / progress["budget"]))
        except (OSError, ValueError, KeyError, TypeError, ZeroDivisionError):
            return 0.0

    def saved(self) -> set[str]:
        """The trial ids with a snapshot here."""
        return {path.stem for path in self.folder.glob("*.pt")}

    def discard(self, trial_id: str) -> None:
        """Remove the trial's snapshot (its record is written: nothing to resume), and what a
        run killed while writing one left of it (`bench.atomic`'s temp files)."""
        leftovers = self.folder.glob(f"{trial_id}.*.tmp")
        for path in (self.progress_path(trial_id), self.path(trial_id), *leftovers):
            with contextlib.suppress(OSError):  # gone already, or never a file (a folder)
                path.unlink()
