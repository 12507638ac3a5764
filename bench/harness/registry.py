"""Algorithm registry: name -> how to train it.

An algorithm is one function plus a config dataclass::

    from dataclasses import dataclass
    from bench.harness.registry import register

    @dataclass
    class MyConfig:
        lr: float = 3e-4
        \"\"\"Adam learning rate.\"\"\"

    @register("my-ifo", config=MyConfig, inputs="states")
    def train(task, demos, budget, seed, logger, config: MyConfig):
        env = task.make_env(seed)            # counts every env step against `budget`
        ...                                  # learn from demos.observations only
        logger.checkpoint(steps_so_far, policy)   # optional: the runner evaluates it
        return policy                        # (B, O) float32 array -> (B, A) array

`inputs` says what `demos` is: "states" -> `Demos` (no actions, by type),
"actions" -> `ActionDemos` (GAIL only), "expert" -> the expert `Policy`,
"none" -> None. `pixels=True` says the algorithm can also learn from frames: in
a suite env with `observation: pixels`, observations (its envs' and the demos')
are flat uint8 stacks of frames and `task.pixels` says how to reshape them.
`video_reward=True`: in an env with `observation: video-reward` it acts on states
but its demonstrations are video (flat frames, `task.video` their shape), and its
envs film themselves too (`Batch.frames`), so its reward can judge video.
Every algorithm, built-in or not, registers through the entry-point group
`ifo_bench.algorithms`, whose entry points name a module (or callable) to
import, e.g. in a package's pyproject.toml::

    [project.entry-points."ifo_bench.algorithms"]
    my-ifo = "my_package.my_ifo"
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib.metadata
import re
import sys
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal, Protocol

import gymnasium as gym
import numpy as np

from bench import paths, validate
from bench.envs.pixels import PixelConfig
from bench.errors import BadInput
from bench.rl import sac, td3, trpo
from bench.rl.resume import Snapshots

Inputs = Literal["none", "states", "actions", "expert"]
Role = Literal["learner", "floor", "ceiling", "random", "expert"]
"""What an algorithm is in a comparison, declared at `register` and kept in every record, so
analysis reads it from the records and never guesses it from a name:

- "learner": imitates; scored, compared and drawn as a bar;
- "floor": a control paid for staying alive, no demonstrations (what a learner scores without
  imitating anything); drawn as a line;
- "ceiling": a control on the env's true reward (what its optimizer reaches at the budget, that
  learners of its family are read as fractions of); drawn as a line;
- "random" and "expert": the references that define normalized 0 and 1 on each env.
"""
ROLES: tuple[Role, ...] = ("learner", "floor", "ceiling", "random", "expert")
CONTROL_ROLES: tuple[Role, ...] = ("floor", "ceiling")
REFERENCE_ROLES: tuple[Role, ...] = ("random", "expert")
ENTRY_POINT_GROUP = "ifo_bench.algorithms"


class Policy(Protocol):
    """Maps a batch of observations (B, O) float32 to actions (B, A), deterministically."""

    def __call__(self, obs: np.ndarray) -> np.ndarray: ...


@dataclass(frozen=True)
class Task:
    """What an algorithm knows about the environment it trains on."""

    env_id: str
    obs_dim: int
    act_dim: int
    action_low: np.ndarray
    action_high: np.ndarray
    make_env: Callable[[int], gym.Env]
    """make_env(seed) -> a fresh env whose every step counts against the trial's budget."""
    pixels: PixelConfig | None = None
    """None: observations are the env's state vectors. Else they are (obs_dim,) uint8 flat
    stacks of rendered frames, `obs.reshape(-1, *pixels.shape)` their (C, H, W) images."""

    video: PixelConfig | None = None
    """Not None where observations are states but demonstrations are video: batches then carry
    the frames of each step (`Batch.frames`, `next_frames`) for a reward to judge."""

    @property
    def obs_shape(self) -> tuple[int, ...]:
        """One observation's shape as networks should see it: (O,) or (C, H, W)."""
        return (self.obs_dim,) if self.pixels is None else self.pixels.shape

    @property
    def judged_shape(self) -> tuple[int, ...]:
        """The shape of what a reward judges (`Batch.judged`): `obs_shape`, or where the policy
        acts on states but imitates video, the (C, H, W) of the frames filmed beside them."""
        return self.obs_shape if self.video is None else self.video.shape


class Logger(Protocol):
    """What the runner hands an algorithm to report progress."""

    def checkpoint(self, env_steps: int, policy: Policy) -> None:
        """Offer the current policy; the runner evaluates it when an eval is due."""

    def log(self, env_steps: int, **scalars: float) -> None:
        """Record diagnostics (e.g. discriminator accuracy) at `env_steps`. A record keeps up
        to ~10,000-20,000 calls, evenly thinned past that; TensorBoard gets every one."""


def snapshots_of(logger: Logger) -> Snapshots | None:
    """Where the runner keeps this trial's snapshots, for `bench.rl.resume.Resumable`; None
    where it keeps none (loggers outside the runner)."""
    return getattr(logger, "snapshots", None)


class TrainFn(Protocol):
    def __call__(
        self, task: Task, demos: Any, budget: int, seed: int, logger: Logger, config: Any
    ) -> Policy: ...


@dataclass(frozen=True, kw_only=True)
class Algorithm:
    name: str
    train: TrainFn
    config: type
    """A dataclass; suite overrides become config(**overrides)."""
    inputs: Inputs
    description: str = ""
    pixels: bool = False
    """It can learn from rendered frames (a suite env with `observation: pixels`)."""
    video_reward: bool = False
    """It can act on states and imitate video (a suite env with `observation: video-reward`)."""
    min_budget: Callable[[Any], int] | None = None
    """min_budget(config) -> the fewest env steps a trial can train with (e.g. one TRPO batch);
    a suite that gives less is refused at load."""
    resumable: bool = False
    """Its trials save snapshots where the runner offers them (`Snapshots`) and resume from
    them, so a run under a time limit may start one that will not finish by then: it pauses at
    the limit, and the next run goes on from there."""
    role: Role = "learner"
    """What it is in a comparison (`Role`)."""
    family: str | None = None
    """The optimizer family whose controls it is read against ("trpo", "sac", "td3"): a
    learner's ceiling is the ceiling of its own family. None: it has none (the references)."""
    label: str = ""
    """Its name in figures and reports ("GAIfO"); "" : its registered name."""
    code: str | None = None
    """The identity of the code that trains it (`code_identity`): a hash of a plugin's source,
    part of its trials' ids, so a changed plugin's trials run again; None for the built-ins,
    whose records are committed and whose changes are reviewed instead."""

    @property
    def uses_actions(self) -> bool:
        return self.inputs == "actions"

    def check_overrides(self, overrides: dict[str, Any]) -> None:
        """Raise ValueError naming any key that is not a field of the config, SettingError
        naming a value not of its field's type; builds nothing."""
        known = {f.name for f in dataclasses.fields(self.config)}
        unknown = sorted(set(overrides) - known)
        if unknown:
            raise ValueError(
                f"algorithm {self.name!r} has no hyperparameter {', '.join(map(repr, unknown))}"
                f" (known: {', '.join(sorted(known)) or 'none'})"
            )
        validate.check_types(self.config, overrides)

    def make_config(self, overrides: dict[str, Any]) -> Any:
        """config(**overrides), checked first (`check_overrides`)."""
        self.check_overrides(overrides)
        return self.config(**overrides)


class BrokenPluginWarning(UserWarning):
    """A plugin of the entry-point group failed to import: said once, by the process that
    loads the suite (a run's workers keep quiet about it)."""


class RegistryError(BadInput, KeyError):
    def __str__(self) -> str:
        return str(self.args[0])


_ALGORITHMS: dict[str, Algorithm] = {}
_loaded = False


NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]*")
"""What an algorithm's name may be: a suite's YAML names it, and TensorBoard's folders and
the report's figures are named after it."""


def register(
    name: str,
    *,
    config: type,
    inputs: Inputs,
    description: str = "",
    pixels: bool = False,
    video_reward: bool = False,
    min_budget: Callable[[Any], int] | None = None,
    resumable: bool = False,
    role: Role = "learner",
    family: str | None = None,
    label: str = "",
) -> Callable[[TrainFn], TrainFn]:
    """Decorator: register `train` under `name`, as a `role` of the optimizer `family`, shown
    as `label` (see `Algorithm`)."""
    if not isinstance(name, str) or not NAME.fullmatch(name):
        raise ValueError(
            f"algorithm name {name!r}: letters, digits and . _ + - only, starting with a letter"
            " or digit (suites name it, and folders and figures are named after it)"
        )
    if inputs not in ("none", "states", "actions", "expert"):
        raise ValueError(f"inputs must be none|states|actions|expert, not {inputs!r}")
    if role not in ROLES:
        raise ValueError(f"role must be one of {'|'.join(ROLES)}, not {role!r}")
    if role in CONTROL_ROLES and not family:
        raise ValueError(f"{name!r}: a {role} control needs the optimizer family it controls for")
    if not dataclasses.is_dataclass(config):
        raise TypeError(f"config of {name!r} must be a dataclass")
    if family is None and role == "learner":
        family = family_of(config)

    def wrap(train: TrainFn) -> TrainFn:
        doc = description or (train.__doc__ or "").strip().split("\n")[0]
        taken = _ALGORITHMS.get(name)
        if taken is not None and _origin(taken.train) != _origin(train):
            raise RegistryError(
                f"algorithm name {name!r} is registered twice: by {_origin(taken.train)} and by "
                f"{_origin(train)}; rename one"
            )
        _ALGORITHMS[name] = Algorithm(
            name=name,
            train=train,
            config=config,
            inputs=inputs,
            description=doc,
            pixels=pixels,
            video_reward=video_reward,
            min_budget=min_budget,
            resumable=resumable,
            role=role,
            family=family,
            label=label or name,
            code=code_identity(train),
        )
        return train

    return wrap


_BROKEN: dict[str, str] = {}
"""Algorithm and entry-point names of plugins that failed to import -> why: none of them runs,
even where the module registered something before it failed."""

FAMILY_CONFIGS: tuple[tuple[type, str], ...] = (
    (td3.TD3Config, "td3"),  # before SAC's: TD3's config extends it
    (sac.SACConfig, "sac"),
    (trpo.TRPOConfig, "trpo"),
)
"""The optimizer a learner trains through, told by the config it extends."""


def family_of(config: type) -> str | None:
    """The optimizer family a learner's config says it trains through (it extends that
    optimizer's config, as `ImitationTRPOConfig` extends TRPO's), or None."""
    for base, family in FAMILY_CONFIGS:
        if issubclass(config, base):
            return family
    return None


_code_of_file: dict[str, str] = {}


def code_identity(train: TrainFn) -> str | None:
    """A hash of the source of the package (or module) that defines `train`, where that is a
    plugin's; None for the built-ins (ifo-bench's own `algorithms` and `bench`) and for code
    with no source file. Every .py file of the top-level package counts, so a change in a
    helper module of the plugin counts too."""
    module = sys.modules.get(getattr(train, "__module__", "") or "")
    top = sys.modules.get((getattr(module, "__name__", "") or "").split(".")[0])
    source = getattr(top, "__file__", None)
    if source is None:
        return None
    root = Path(source).resolve()
    if root.parent.name in ("algorithms", "bench") and root.parents[1] == paths.REPO_ROOT:
        return None
    files = sorted(root.parent.rglob("*.py")) if root.name == "__init__.py" else [root]
    key = "\n".join(str(f) for f in files)
    if key not in _code_of_file:
        digest = hashlib.sha256()
        for f in files:
            digest.update(f.relative_to(root.parent).as_posix().encode() + b"\0")
            digest.update(f.read_bytes() + b"\0")
        _code_of_file[key] = digest.hexdigest()[:16]
    return _code_of_file[key]


def _load_all() -> None:
    """Import every module of the entry-point group once; importing one runs its @register.
    The built-ins are listed in ifo-bench's own pyproject.toml, so the registry depends on no
    algorithm and no algorithm module is imported before it is asked for. A module that fails
    to import registers nothing, even what it registered before it failed (`_BROKEN`)."""
    global _loaded
    if _loaded:
        return
    _loaded = True
    for ep in importlib.metadata.entry_points(group=ENTRY_POINT_GROUP):
        before = set(_ALGORITHMS)
        try:
            ep.load()
        except RegistryError:
            raise  # a name clash: which one a suite meant cannot be guessed
        except Exception as e:  # a broken plugin must not take every other algorithm down
            why = f"plugin {ep.name!r} ({ep.value}) failed to import: {type(e).__name__}: {e}"
            for name in {ep.name, *(set(_ALGORITHMS) - before)}:
                _ALGORITHMS.pop(name, None)
                _BROKEN[name] = why
            warnings.warn(f"{why}; none of its algorithms runs", BrokenPluginWarning, stacklevel=2)


def _origin(train: TrainFn) -> str:
    """Where a train function is defined: module and name."""
    return f"{train.__module__}.{getattr(train, '__qualname__', train)}"


def get(name: str) -> Algorithm:
    _load_all()
    if name in _BROKEN and name not in _ALGORITHMS:
        raise RegistryError(f"algorithm {name!r} cannot run: its {_BROKEN[name]}")
    if name not in _ALGORITHMS:
        raise RegistryError(
            f"unknown algorithm {name!r} (registered: {', '.join(sorted(_ALGORITHMS))})"
        )
    return _ALGORITHMS[name]


def config_of(spec: Any) -> Any:
    """A trial spec's config: the one its suite built (`TrialSpec.config`), or, for a spec
    read from a record, built from its hyperparams."""
    if spec.config is not None:
        return spec.config
    return get(spec.algorithm).make_config(spec.hyperparams)


def describe(name: str) -> tuple[Role, str | None, str]:
    """The role, family and label of `name` as registered now: for records written before
    records said them. A name not registered here (a plugin not installed) is a learner of no
    family, shown under its own name."""
    _load_all()
    algo = _ALGORITHMS.get(name)
    return ("learner", None, name) if algo is None else (algo.role, algo.family, algo.label)


def shown_as(algorithm: str, spec_label: str | None) -> str:
    """What a trial is called in records, figures and reports: its suite's label for it (a
    variant's), else its algorithm's registered label."""
    return spec_label or get(algorithm).label


def all_algorithms() -> dict[str, Algorithm]:
    _load_all()
    return dict(_ALGORITHMS)
