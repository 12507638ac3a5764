"""The suite file's schema: every field's type and range, checked by pydantic (strict, as JSON
would carry the values: `true` is no count, "1e5" no budget), and its errors turned into one
line naming the key path.

Only the file's shape lives here. What needs a look-up (env ids, algorithms and their
settings, experts, datasets) is `bench.harness.suite.load`'s, after the shape is known good.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

import pydantic
from pydantic import BaseModel, ConfigDict, Field, JsonValue, model_validator

from bench import validate
from bench.harness.suite.checks import Invalid, joined
from bench.harness.types import CURVE_POINTS
from bench.validate import show

NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9._-]*$"  # it becomes a folder name
LABEL_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9._=,+\[\]-]*$"  # as sweeps write them

_STRICT = ConfigDict(extra="forbid", strict=True)

SEED_LIMIT = 10**15
"""Seeds are below this: a trial seeds torch generators with its seed times 1000 plus small
offsets (its envs', its evaluation's), and torch takes seeds below 2^64 (~1.8e19)."""
MAX_SEEDS = 100_000
"""A seed count above this is refused before it is expanded into a list."""

Count = Annotated[int, Field(ge=1)]
Seed = Annotated[int, Field(ge=0, lt=SEED_LIMIT)]


def _distinct(values: list) -> tuple:
    if len(set(values)) != len(values):
        raise ValueError(f"expected distinct values, got {show(values)}")
    return tuple(values)


SeedList = Annotated[list[Seed], Field(min_length=1), pydantic.AfterValidator(_distinct)]


def _seeds(value: Any) -> Any:
    """A count (seeds 0..n-1) or a list of seeds; said once, not as two union branches."""
    if isinstance(value, list):
        return value
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"expected a seed count or a list of seeds, got {show(value)}")
    if value > MAX_SEEDS:
        raise ValueError(f"expected at most {MAX_SEEDS:,} seeds, got {value:,}")
    return list(range(value))


Seeds = Annotated[SeedList, pydantic.BeforeValidator(_seeds)]
"""Seeds as a tuple: a count n becomes 0..n-1."""


def _env_seeds(value: Any) -> Any:
    """As `_seeds`, and 0: the algorithm does not run on this env."""
    return [] if type(value) is int and value == 0 else _seeds(value)


EnvSeeds = Annotated[
    list[Seed], pydantic.AfterValidator(_distinct), pydantic.BeforeValidator(_env_seeds)
]
"""An env's seeds for one algorithm: as `Seeds`, or 0 for none (not on this env)."""


class RunnerFile(BaseModel):
    model_config = _STRICT

    jobs: int = -1
    """Parallel trials; -1 uses every core."""
    backend: Literal["loky", "dask"] = "loky"
    first: Annotated[
        list[Annotated[str, Field(min_length=1)]], pydantic.AfterValidator(_distinct)
    ] = []
    """Algorithms (names or labels) whose trials run before the others'."""
    trial_timeout: str | None = None
    """A trial still running this long after it started (a duration: 90m, 2h) is stopped and
    recorded as failed; none by default."""

    @pydantic.field_validator("trial_timeout")
    @classmethod
    def _trial_timeout(cls, text: str | None) -> str | None:
        if text is not None:
            validate.duration(text)
        return text

    @pydantic.field_validator("jobs")
    @classmethod
    def _jobs(cls, jobs: int) -> int:
        if jobs < 1 and jobs != -1:
            raise ValueError(f"expected a positive integer or -1 (all cores), got {jobs}")
        return jobs


class EnvFile(BaseModel):
    """One `envs` entry; `bench.harness.suite.types.EnvSettings` documents each field."""

    model_config = _STRICT

    budget: Count
    dataset: Annotated[str, Field(min_length=1)] | None = None
    observation: Literal["states", "pixels", "video-reward"] = "states"
    frame_size: Annotated[int, Field(ge=24, le=256)] | None = None  # the conv trunk needs 20+
    trpo: dict[str, JsonValue] = {}
    hyperparams: dict[str, JsonValue] = {}
    seeds: dict[str, EnvSeeds] = {}

    @model_validator(mode="after")
    def _observation_fits(self) -> EnvFile:
        if self.observation != "states" and self.dataset is not None:
            raise _At(
                "observation",
                f"{self.observation} needs video demonstrations; a dataset holds states",
            )
        if self.frame_size is not None and self.observation == "states":
            raise _At("frame_size", "only with observation: pixels or video-reward")
        return self


class SettingsEntry(BaseModel):
    """One env's entry in a settings file (`SuiteFile.settings`): what the task needs from its
    learners, as an `envs` entry's `trpo` and `hyperparams` say it."""

    model_config = _STRICT

    trpo: dict[str, JsonValue] = {}
    hyperparams: dict[str, JsonValue] = {}


class SuiteFile(BaseModel):
    model_config = _STRICT

    name: Annotated[str, Field(pattern=NAME_PATTERN)] | None = None
    envs: Annotated[dict[str, EnvFile], Field(min_length=1)]
    demos: Annotated[list[Count], Field(min_length=1), pydantic.AfterValidator(_distinct)]
    algorithms: Annotated[list[Any], Field(min_length=1)]
    """Entries of several shapes (a name, {name: settings}, {algorithm: name, ...}): read by
    `bench.harness.suite.load`, which knows each algorithm's settings."""
    seeds: Seeds = (0, 1, 2, 3, 4, 5, 6, 7, 8, 9)
    eval_episodes: Count = 10
    curve_points: Count = CURVE_POINTS
    runner: RunnerFile = RunnerFile()
    kernels: Literal["native", "portable"] = "native"
    """The CPU kernels every trial computes with (`bench.kernels`): "portable" for
    numbers any x86-64 CPU reproduces, "native" for each CPU's fastest."""
    settings: Annotated[str, Field(min_length=1)] | None = None
    """A YAML file (relative to the suite's folder) of tuned settings per env, {env id:
    SettingsEntry}: each env of the suite it lists gets its `trpo` and `hyperparams` under the
    suite's own, so suites that run a task share one measured setting instead of copies."""


class EntryFile(BaseModel):
    """The reserved keys of an `{algorithm: name, label: ..., seeds: ..., setting: value}`
    entry; the other keys are the algorithm's settings."""

    model_config = ConfigDict(extra="allow", strict=True)

    algorithm: str
    label: Annotated[str, Field(pattern=LABEL_PATTERN)] | None = None
    seeds: Seeds | None = None


class _At(ValueError):
    """A model validator's problem at one of its fields."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(message)
        self.field = field


def parse(model: type[BaseModel], raw: Any, key: str = "") -> Any:
    """`model` validated from `raw`, or Invalid: the first problem, one line at its key path."""
    try:
        return model.model_validate(raw)
    except pydantic.ValidationError as err:
        error = err.errors()[0]
        if "[key]" in error["loc"]:  # a mapping's key, not a value, is the problem
            at = joined(key, validate.path(error["loc"][: error["loc"].index("[key]") - 1]))
            raise Invalid(at, f"expected names as keys, got {show(error['input'])}") from None
        cause = (error.get("ctx") or {}).get("error")
        loc = (*error["loc"], *([cause.field] if isinstance(cause, _At) else []))
        problem = validate.setting_error({**error, "loc": loc})
        at = joined(key, problem.field)
        if error["type"] == "extra_forbidden":
            allowed = ", ".join(_model_at(model, list(error["loc"])[:-1]).model_fields)
            raise Invalid(at, f"unknown key (expected one of {allowed})") from None
        raise Invalid(at, problem.message) from None


def _model_at(model: type[BaseModel], loc: list) -> type[BaseModel]:
    """The model that holds the mapping at `loc` (an env's settings under envs.<id>)."""
    if loc[:1] == ["envs"] and len(loc) == 2:
        return EnvFile
    if loc[:1] == ["runner"]:
        return RunnerFile
    return model
