"""What a loaded suite is: its envs, algorithm entries and runner settings."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from bench.errors import BadInput
from bench.harness.types import CURVE_POINTS, TrialSpec


class SuiteError(BadInput, ValueError):
    """A suite file that cannot be run; the message is one line."""


@dataclass(frozen=True)
class RunnerSettings:
    jobs: int = -1
    """Parallel trials; -1 uses every core."""
    backend: str = "loky"
    """joblib backend: "loky" (this machine) or "dask" (a cluster)."""
    first: tuple[str, ...] = ()
    """Algorithms (names or labels) whose trials run before the others': the headline
    learners of a long run land first, so a run cut short has them at every demo count."""
    trial_timeout: float | None = None
    """Seconds after which a trial still running is stopped and recorded as failed (a stuck
    plugin frees its worker); None: no limit."""


@dataclass(frozen=True)
class EnvSettings:
    env_id: str
    budget: int
    """Env steps each training trial may take."""
    dataset: str | None = None
    """A Minari dataset (folder or local id) to take demonstrations from instead of the
    shipped expert's pool."""
    observation: str | None = None
    """None: learners observe states; "pixels": stacked rendered frames (`bench.envs.pixels`);
    "video-reward": learners act on states and imitate the expert's video."""
    frame_size: int | None = None
    """Frame side in pixels with pixels or video-reward (None: 64). 32 costs ~3.5x less per step."""
    trpo: dict[str, Any] = field(default_factory=dict, hash=False)
    """TRPOConfig overrides for every algorithm on this env whose config extends TRPOConfig:
    what a task needs from the optimizer (its batch, say) is the task's, and applying it to
    all TRPO learners keeps the survival control matched to the imitators."""
    hyperparams: dict[str, Any] = field(default_factory=dict, hash=False)
    """Settings for every algorithm on this env whose config has them (each key goes to the
    algorithms that know it), above `trpo` and under an algorithm's own overrides: what a
    task needs from, say, a discriminator is the task's, not the suite's."""
    seeds: dict[str, tuple[int, ...]] = field(default_factory=dict, hash=False)
    """Seeds per algorithm (name or label) on this env, over the entry's and the suite's:
    a dear env runs fewer seeds than a cheap one in the same figure; none (from 0), an
    algorithm the suite runs elsewhere but not here."""


@dataclass(frozen=True)
class AlgorithmEntry:
    name: str
    overrides: dict[str, Any] = field(default_factory=dict, hash=False)
    """The suite's settings for it (a sweep's point included), checked against its config's
    fields and types: an env's `trpo` and `hyperparams` settings go under them."""
    uses_demos: bool = True
    """False for algorithms whose inputs are "none" or "expert": run once, with n_demos=0."""
    label: str | None = None
    """A variant's name in records, figures and reports (None: the algorithm's name)."""
    seeds: tuple[int, ...] | None = None
    """This entry's seeds (None: the suite's), e.g. fewer for costly controls."""
    key: str = field(default="", compare=False)
    """Where it stands in the suite file (`algorithms[2].gaifo`), for errors found later."""

    @property
    def shown(self) -> str:
        return self.label or self.name


@dataclass(frozen=True)
class Suite:
    name: str
    envs: tuple[EnvSettings, ...]
    demos: tuple[int, ...]
    algorithms: tuple[AlgorithmEntry, ...]
    seeds: tuple[int, ...]
    eval_episodes: int = 10
    runner: RunnerSettings = RunnerSettings()
    curve_points: int = CURVE_POINTS
    kernels: str = "native"
    """The CPU kernels its trials compute with (`bench.kernels`)."""
    trials: tuple[TrialSpec, ...] = field(default=(), hash=False)
    """Every trial of the suite, each setting resolved, in a fixed order: made once, at load
    (`bench.harness.suite.expand`)."""
