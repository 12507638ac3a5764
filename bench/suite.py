"""Suite files: YAML -> validated `Suite` -> list[TrialSpec].

A suite names everything one experiment runs::

    name: quick            # optional, defaults to the file stem; results go to results/<name>/
    envs:                  # env id -> settings; budget = env steps per training trial
      InvertedPendulumBulletEnv-v0: {budget: 100000}
      # optional per env: dataset (a Minari dataset's demos instead of the shipped expert's),
      # observation: pixels (learners see stacked 64x64 grayscale frames, demos are video),
      # or video-reward (learners act on states, demos are video: not the paper's setting);
      # with either, frame_size: 32 (frame side in pixels, default 64; ~3.5x cheaper per step);
      # trpo: {n_envs: 16} (TRPO settings for every TRPO learner on this env, e.g. its batch,
      # so the survival control stays matched; an algorithm's own setting wins);
      # hyperparams: {disc_steps: 25} (settings for every algorithm on this env that has
      # them, e.g. the adversarial learners' discriminator pace; an algorithm's own wins);
      # seeds: {gaifo: 5, bco: 3} (seeds per algorithm or label on this env, over the
      # entry's and the suite's: a dear env runs fewer)
    demos: [1, 5, 10, 25]  # demonstration counts: distinct ints in 1..DEMO_POOL_SIZE
    algorithms:            # a name, or {name: {hyperparameter: value}}
      - random
      - expert
      - gaifo: {disc_lr: 0.001}
    seeds: 10              # a count (seeds 0..n-1) or a list of distinct ints >= 0; default 10
    eval_episodes: 10      # episodes per evaluation; default 10
    runner: {jobs: 2, backend: loky}   # optional; jobs >= 1 or -1 (all cores), backend loky|dask

Everything is checked before any work starts: unknown keys, wrong types,
unknown algorithms, hyperparameters and env ids, and a missing expert (every
suite needs one per env, since it defines a normalized score of 1). Each
problem raises `SuiteError`, whose message is one line: file, key path, what
was expected.
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from bench import paths, registry
from bench.demos import POOL_SIZE as DEMO_POOL_SIZE
from bench.envs import EnvError, check_env_id
from bench.rl.trpo import TRPOConfig
from bench.types import TrialSpec

_SUITE_KEYS = ("name", "envs", "demos", "algorithms", "seeds", "eval_episodes", "runner")
_REQUIRED_KEYS = ("envs", "demos", "algorithms")
_ENV_KEYS = ("budget", "dataset", "observation", "frame_size", "trpo", "hyperparams", "seeds")
_OBSERVATIONS = ("states", "pixels", "video-reward")
_RUNNER_KEYS = ("jobs", "backend")
_BACKENDS = ("loky", "dask")
_NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")  # it becomes a folder name
_LABEL_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9._=,+\[\]-]*")  # as sweeps write them


class SuiteError(ValueError):
    """A suite file that cannot be run; the message is one line."""


@dataclass(frozen=True)
class RunnerSettings:
    jobs: int = -1
    """Parallel trials; -1 uses every core."""
    backend: str = "loky"
    """joblib backend: "loky" (this machine) or "dask" (a cluster)."""


@dataclass(frozen=True)
class EnvSettings:
    env_id: str
    budget: int
    """Env steps each training trial may take."""
    dataset: str | None = None
    """A Minari dataset (folder or local id) to take demonstrations from instead of the
    shipped expert's pool."""
    observation: str | None = None
    """None: learners observe states; "pixels": stacked rendered frames (`bench.pixels`);
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
    a dear env runs fewer seeds than a cheap one in the same figure."""


@dataclass(frozen=True)
class AlgorithmEntry:
    name: str
    hyperparams: dict[str, Any] = field(default_factory=dict, hash=False)
    """The algorithm's full config: defaults with the suite's overrides applied, validated."""
    overrides: dict[str, Any] = field(default_factory=dict, hash=False)
    """Just the suite's overrides: an env's `trpo` and `hyperparams` settings go under them."""
    uses_demos: bool = True
    """False for algorithms whose inputs are "none" or "expert": run once, with n_demos=0."""
    label: str | None = None
    """A variant's name in records, figures and reports (None: the algorithm's name)."""
    seeds: tuple[int, ...] | None = None
    """This entry's seeds (None: the suite's), e.g. fewer for costly controls."""

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


def load_suite(path: str | Path) -> Suite:
    """Read and validate a suite file; raise SuiteError on the first problem."""
    path = Path(path)
    return _validate(_read_yaml(path), path)


def expand(suite: Suite) -> list[TrialSpec]:
    """All trials of a suite, in a fixed order.

    Per env: the algorithms that take no demonstrations (once per seed, with
    n_demos=0), then demo count x algorithm x seed for the others.
    """
    no_demos = [a for a in suite.algorithms if not a.uses_demos]
    with_demos = [a for a in suite.algorithms if a.uses_demos]
    specs = []
    for env in suite.envs:
        specs += [_spec(suite, env, a, 0, s) for a in no_demos for s in seeds_of(suite, env, a)]
        specs += [
            _spec(suite, env, a, n, s)
            for n in suite.demos
            for a in with_demos
            for s in seeds_of(suite, env, a)
        ]
    return specs


def seeds_of(suite: Suite, env: EnvSettings, algo: AlgorithmEntry) -> tuple[int, ...]:
    """An entry's seeds on an env: the env's for it (by label, then by name), else the
    entry's own, else the suite's."""
    for name in (algo.shown, algo.name):
        if name in env.seeds:
            return env.seeds[name]
    return algo.seeds or suite.seeds


def select(
    specs: list[TrialSpec],
    source: str | Path,
    env: list[str] | None = None,
    algorithm: list[str] | None = None,
) -> list[TrialSpec]:
    """The trials of some envs and/or algorithms only (None: all); ids are unchanged.

    A name the suite does not have raises SuiteError, so a typo never silently runs nothing.
    """
    names = {
        "env_id": lambda s: {s.env_id},
        "algorithm": lambda s: {s.algorithm, s.shown},  # a variant by label, or all by algorithm
    }
    for key, label, wanted in (("env_id", "envs", env), ("algorithm", "algorithms", algorithm)):
        if wanted is None:
            continue
        have = sorted(set().union(*(names[key](s) for s in specs)))
        for name in wanted:
            if name not in have:
                raise SuiteError(f"{source}: {name!r} is not one of the suite's {label}: {have}")
        specs = [s for s in specs if names[key](s) & set(wanted)]
    return specs


def _spec(
    suite: Suite, env: EnvSettings, algo: AlgorithmEntry, n_demos: int, seed: int
) -> TrialSpec:
    return TrialSpec(
        suite=suite.name,
        env_id=env.env_id,
        algorithm=algo.name,
        n_demos=n_demos,
        seed=seed,
        budget=env.budget,
        eval_episodes=suite.eval_episodes,
        hyperparams=_hyperparams(env, algo),
        label=algo.label,
        dataset=env.dataset,
        observation=env.observation,
        frame_size=env.frame_size,
    )


def _hyperparams(env: EnvSettings, algo: AlgorithmEntry) -> dict[str, Any]:
    """The algorithm's resolved config on this env: its own, with the env's settings that apply
    to it under its overrides (the env's TRPO settings if it is a TRPO learner, then the env's
    hyperparams that its config has). A fresh dict: specs outlive the suite."""
    algorithm = registry.get(algo.name)
    from_env = {k: v for k, v in env.hyperparams.items() if k in _fields(algorithm.config)}
    if env.trpo and issubclass(algorithm.config, TRPOConfig):
        from_env = {**env.trpo, **from_env}
    if not from_env:
        return dict(algo.hyperparams)
    return _resolve(algorithm, {**from_env, **algo.overrides})


def _fields(config: type) -> dict[str, dataclasses.Field]:
    """A config dataclass's fields by name."""
    return {f.name: f for f in dataclasses.fields(config)}


def _resolve(algo: registry.Algorithm, overrides: dict[str, Any]) -> dict[str, Any]:
    # Specs carry the full resolved config, defaults included: a changed default is a new id.
    return json.loads(json.dumps(dataclasses.asdict(algo.make_config(overrides))))


# ---------------------------------------------------------------- reading


class _StrictLoader(yaml.SafeLoader):
    """SafeLoader that rejects duplicate keys (plain safe_load keeps the last one silently)."""


def _construct_mapping(loader: _StrictLoader, node: yaml.MappingNode) -> dict:
    seen: set = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark
            )
        seen.add(key)
    return loader.construct_mapping(node)


_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def _read_yaml(path: Path) -> Any:
    if not path.is_file():
        others = sorted(p.stem for p in path.parent.glob("*.y*ml")) if path.parent.is_dir() else []
        hint = f" (suites there: {', '.join(others)})" if others else ""
        raise SuiteError(f"{path}: no such suite file{hint}")
    try:
        return yaml.load(path.read_text(), Loader=_StrictLoader)  # a SafeLoader
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        raise SuiteError(f"{path}: {where}invalid YAML: {e.problem}") from None
    except (yaml.YAMLError, UnicodeDecodeError) as e:
        raise SuiteError(f"{path}: invalid YAML: {_one_line(str(e))}") from None


# ---------------------------------------------------------------- validating


class _Invalid(Exception):
    """One problem at one key path; load_suite adds the file name."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(f"{key}: {message}" if key else message)


def _validate(raw: Any, path: Path) -> Suite:
    try:
        return _suite(raw, path.stem)
    except _Invalid as e:
        raise SuiteError(f"{path}: {e}") from None


def _suite(raw: Any, default_name: str) -> Suite:
    if not isinstance(raw, dict):
        raise _Invalid(
            "", f"expected a mapping with keys {', '.join(_REQUIRED_KEYS)}, got {_show(raw)}"
        )
    _check_keys(raw, _SUITE_KEYS, "")
    for key in _REQUIRED_KEYS:
        if key not in raw:
            raise _Invalid(key, "missing (required)")

    name = raw.get("name", default_name)
    if not isinstance(name, str) or not _NAME_PATTERN.fullmatch(name):
        raise _Invalid(
            "name", f"expected a folder name (letters, digits, . _ -), got {_show(name)}"
        )

    envs = _envs(raw["envs"])
    # The shipped pools hold DEMO_POOL_SIZE episodes; a dataset is checked for its own count.
    pooled = any(env.dataset is None for env in envs)
    demos = _int_list(raw["demos"], "demos", 1, DEMO_POOL_SIZE if pooled else None)
    seeds = _seeds(raw.get("seeds", 10))
    eval_episodes = _int(raw.get("eval_episodes", 10), "eval_episodes", 1, None)
    runner = _runner(raw.get("runner", {}))
    algorithms = _algorithms(raw["algorithms"])

    # Lookups last: they are the slow part and the structure is known good by now.
    for env in envs:
        try:
            check_env_id(env.env_id)
        except EnvError as e:
            raise _Invalid(f"envs.{env.env_id}", _one_line(str(e))) from None
        if env.hyperparams:
            _check_env_hyperparams(env, algorithms)
        if env.trpo or env.hyperparams:
            _check_env_settings(env, algorithms)
        if env.observation is not None:
            _check_video_learners(env, algorithms)
        if env.dataset is not None:  # its demonstrator is the 1.0: no shipped expert needed
            _check_dataset(env, max(demos), algorithms)
        elif not paths.has_expert(env.env_id):
            raise _Invalid(
                f"envs.{env.env_id}",
                f"no trained expert in {paths.expert_dir(env.env_id)} (every suite needs one:"
                " it is the 1.0 of normalized scores; train it with `bench experts`)",
            )
    names = {n for a in algorithms for n in (a.name, a.shown)}
    for env in envs:
        unknown = sorted(set(env.seeds) - names)
        if unknown:
            raise _Invalid(
                f"envs.{env.env_id}.seeds",
                f"{', '.join(map(repr, unknown))} is no algorithm or label of the suite"
                f" ({', '.join(sorted(names))})",
            )
    suite = Suite(name, envs, demos, algorithms, seeds, eval_episodes, runner)
    _check_budgets(suite)
    return suite


def _check_budgets(suite: Suite) -> None:
    """Each trial's budget covers what its algorithm needs before it can learn anything (one
    TRPO batch, say), asked of the algorithm (`register(..., min_budget=)`): a trial that
    cannot train is refused at load, not recorded as failed an hour into the run."""
    for spec in expand(suite):
        algo = registry.get(spec.algorithm)
        if algo.min_budget is None:
            continue
        need = algo.min_budget(algo.make_config(spec.hyperparams))
        if spec.budget < need:
            raise _Invalid(
                f"envs.{spec.env_id}.budget",
                f"{spec.budget} env steps are fewer than {spec.shown} needs to train ({need})",
            )


def _check_video_learners(env: EnvSettings, algorithms: tuple) -> None:
    """pixels: every algorithm learns from frames, except the expert, which acts on the
    simulator state in either setting (its return is the task's, whatever the learners see).
    video-reward: every algorithm given demonstrations can imitate video; the others act on
    states as always."""
    if env.observation == "pixels":
        can = lambda a: a.pixels or a.inputs == "expert"  # noqa: E731
        able = sorted(n for n, a in registry.all_algorithms().items() if a.pixels)
        what = "learn from pixels"
    else:
        can = lambda a: a.video_reward or a.inputs not in ("states", "actions")  # noqa: E731
        able = sorted(n for n, a in registry.all_algorithms().items() if a.video_reward)
        what = "imitate video"
    blind = [a.shown for a in algorithms if not can(registry.get(a.name))]
    if blind:
        raise _Invalid(
            f"envs.{env.env_id}.observation",
            f"{', '.join(blind)} cannot {what} (those that can: {', '.join(able) or 'none'})",
        )


def _check_dataset(env: EnvSettings, most_demos: int, algorithms: tuple) -> None:
    """The dataset opens, comes from this env, has enough episodes, and has actions if an
    algorithm needs them."""
    from bench import minari_io

    key = f"envs.{env.env_id}.dataset"
    try:
        dataset = minari_io.open_dataset(env.dataset)
        minari_io.check_env(dataset, env.dataset, env.env_id)
    except minari_io.DatasetError as e:
        raise _Invalid(key, str(e)) from None
    if dataset.total_episodes < most_demos:
        raise _Invalid(
            key,
            f"{env.dataset} has {dataset.total_episodes} episodes, fewer than the"
            f" {most_demos} demonstrations asked for",
        )
    needs_actions = [a.shown for a in algorithms if registry.get(a.name).inputs == "actions"]
    if needs_actions and not minari_io.has_actions(dataset):
        raise _Invalid(
            key,
            f"{env.dataset} records no actions (NaN), which {', '.join(needs_actions)} needs;"
            " imitation from observation algorithms run without them",
        )


def _envs(raw: Any) -> tuple[EnvSettings, ...]:
    if not isinstance(raw, dict) or not raw:
        raise _Invalid(
            "envs", f"expected a non-empty mapping of env id -> {{budget: ...}}, got {_show(raw)}"
        )
    envs = []
    for env_id, settings in raw.items():
        if not isinstance(env_id, str):
            raise _Invalid("envs", f"expected env ids (strings) as keys, got {_show(env_id)}")
        key = f"envs.{env_id}"
        if not isinstance(settings, dict):
            raise _Invalid(
                key, f"expected a mapping like {{budget: 100000}}, got {_show(settings)}"
            )
        _check_keys(settings, _ENV_KEYS, key)
        if "budget" not in settings:
            raise _Invalid(f"{key}.budget", "missing (required: env steps per training trial)")
        dataset = settings.get("dataset")
        if dataset is not None and (not isinstance(dataset, str) or not dataset):
            raise _Invalid(
                f"{key}.dataset", f"expected a dataset folder or Minari id, got {_show(dataset)}"
            )
        budget = _int(settings["budget"], f"{key}.budget", 1, None)
        observation = settings.get("observation", "states")
        if observation not in _OBSERVATIONS:
            raise _Invalid(
                f"{key}.observation",
                f"expected one of {', '.join(_OBSERVATIONS)}, got {_show(observation)}",
            )
        if observation != "states" and dataset is not None:
            raise _Invalid(
                f"{key}.observation",
                f"{observation} needs video demonstrations; a dataset holds states",
            )
        frame_size = settings.get("frame_size")
        if frame_size is not None:
            if observation == "states":
                raise _Invalid(f"{key}.frame_size", "only with observation: pixels or video-reward")
            frame_size = _int(frame_size, f"{key}.frame_size", 24, 256)  # the conv trunk needs 20+
        seen = None if observation == "states" else observation
        trpo = _trpo_settings(settings.get("trpo", {}), f"{key}.trpo")
        hyperparams = _plain_mapping(settings.get("hyperparams", {}), f"{key}.hyperparams")
        seeds = _plain_mapping(settings.get("seeds", {}), f"{key}.seeds")
        seeds = {name: _seeds(value, f"{key}.seeds.{name}") for name, value in seeds.items()}
        envs.append(
            EnvSettings(env_id, budget, dataset, seen, frame_size, trpo, hyperparams, seeds)
        )
    return tuple(envs)


def _trpo_settings(raw: Any, key: str) -> dict[str, Any]:
    """An env's TRPOConfig overrides: known fields, values of the default's type."""
    if not isinstance(raw, dict):
        raise _Invalid(key, f"expected a mapping like {{n_envs: 16}}, got {_show(raw)}")
    fields = _fields(TRPOConfig)
    for name in raw:
        if name not in fields:
            raise _Invalid(
                f"{key}.{name}", f"not a TRPO setting (known: {', '.join(sorted(fields))})"
            )
    _check_types(fields, raw, key)
    try:
        TRPOConfig(**raw)
    except (TypeError, ValueError) as e:
        raise _Invalid(key, _one_line(str(e))) from None
    return dict(raw)


def _plain_mapping(raw: Any, key: str) -> dict[str, Any]:
    """A mapping of setting name -> plain (JSON) value, e.g. an env's hyperparams."""
    if not isinstance(raw, dict):
        raise _Invalid(key, f"expected a mapping like {{disc_steps: 25}}, got {_show(raw)}")
    _check_plain(raw, key)
    return dict(raw)


def _check_env_hyperparams(env: EnvSettings, algorithms: tuple[AlgorithmEntry, ...]) -> None:
    """Each of the env's hyperparams is a setting of some algorithm of the suite, of its type:
    a typo would otherwise reach no algorithm and change nothing, silently."""
    key = f"envs.{env.env_id}.hyperparams"
    configs = [_fields(registry.get(a.name).config) for a in algorithms]
    for name, value in env.hyperparams.items():
        having = [fields for fields in configs if name in fields]
        if not having:
            shown = ", ".join(sorted({a.shown for a in algorithms}))
            raise _Invalid(f"{key}.{name}", f"no algorithm of the suite has this setting ({shown})")
        for fields in having:
            _check_types(fields, {name: value}, key)


def _check_env_settings(env: EnvSettings, algorithms: tuple[AlgorithmEntry, ...]) -> None:
    """Each algorithm's config still builds with the env's settings under its own."""
    for entry in algorithms:
        try:
            _hyperparams(env, entry)
        except (TypeError, ValueError) as e:
            where = f"envs.{env.env_id}.{'hyperparams' if env.hyperparams else 'trpo'}"
            raise _Invalid(where, f"{entry.shown}: {_one_line(str(e))}") from None


def _seeds(raw: Any, key: str = "seeds") -> tuple[int, ...]:
    if isinstance(raw, list):
        return _int_list(raw, key, 0, None)
    return tuple(range(_int(raw, key, 1, None, what="a seed count or a list of seeds")))


def _runner(raw: Any) -> RunnerSettings:
    if not isinstance(raw, dict):
        raise _Invalid(
            "runner", f"expected a mapping like {{jobs: 2, backend: loky}}, got {_show(raw)}"
        )
    _check_keys(raw, _RUNNER_KEYS, "runner")
    jobs = raw.get("jobs", RunnerSettings.jobs)
    if not _is_int(jobs) or (jobs < 1 and jobs != -1):
        raise _Invalid(
            "runner.jobs", f"expected a positive integer or -1 (all cores), got {_show(jobs)}"
        )
    backend = raw.get("backend", RunnerSettings.backend)
    if backend not in _BACKENDS:
        raise _Invalid(
            "runner.backend", f"expected one of {', '.join(_BACKENDS)}, got {_show(backend)}"
        )
    return RunnerSettings(jobs, backend)


def _algorithms(raw: Any) -> tuple[AlgorithmEntry, ...]:
    """Entries: `name`, `{name: {hyperparameter: value}}` or `{algorithm: name, label: text,
    seeds: 3, hyperparameter: value, ...}` (label and seeds optional). A list where a
    hyperparameter takes one value is a sweep: one variant per value (a grid over several
    lists)."""
    if not isinstance(raw, list) or not raw:
        raise _Invalid("algorithms", f"expected a non-empty list of names, got {_show(raw)}")
    entries: dict[str, AlgorithmEntry] = {}
    for i, item in enumerate(raw):
        key = f"algorithms[{i}]"
        name, label, seeds, overrides = _entry(item, key)
        try:
            algo = registry.get(name)
        except registry.RegistryError as e:
            raise _Invalid(key, _one_line(str(e))) from None
        for shown, variant in _variants(algo, label, overrides, key):
            _check_hyperparams(algo, variant, f"{key}.{name}")
            resolved = _resolve(algo, variant)
            if shown in entries:
                # Records and plots group by what is shown, so two entries would silently merge.
                raise _Invalid(
                    key,
                    f"{shown!r} appears twice; give each variant its own label"
                    " ({algorithm: NAME, label: LABEL, ...})",
                )
            uses_demos = algo.inputs in ("states", "actions")
            label_or_none = None if shown == name else shown
            entries[shown] = AlgorithmEntry(
                name, resolved, variant, uses_demos, label_or_none, seeds
            )
    return tuple(entries.values())


def _entry(item: Any, key: str) -> tuple[str, str | None, tuple[int, ...] | None, dict]:
    """(algorithm name, label, seeds, hyperparameter overrides) of one `algorithms` item;
    label and seeds None unless given."""
    if isinstance(item, dict) and "algorithm" in item:
        reserved = ("algorithm", "label", "seeds")
        overrides = {k: v for k, v in item.items() if k not in reserved}
        seeds = None
        if "seeds" in item:
            seeds = _seeds(item["seeds"], f"{key}.seeds")
        name, label = item["algorithm"], item.get("label")
        if not isinstance(name, str):
            raise _Invalid(f"{key}.algorithm", f"expected an algorithm name, got {_show(name)}")
        if label is not None and (
            not isinstance(label, str) or not _LABEL_PATTERN.fullmatch(label)
        ):
            raise _Invalid(
                f"{key}.label",
                f"expected a name (letters, digits, . _ - = , + [ ]), got {_show(label)}",
            )
        if label is not None and label in registry.all_algorithms():
            raise _Invalid(f"{key}.label", f"{label!r} is an algorithm's name; pick another label")
        return name, label, seeds, overrides
    if isinstance(item, dict) and len(item) == 1:
        name, overrides = next(iter(item.items()))
        overrides = {} if overrides is None else overrides  # `- gaifo:` with nothing after
    else:
        name, overrides = item, {}
    if not isinstance(name, str):
        raise _Invalid(
            key, f"expected a name or {{name: {{hyperparameter: value}}}}, got {_show(item)}"
        )
    if not isinstance(overrides, dict):
        raise _Invalid(
            f"{key}.{name}", f"expected a mapping of hyperparameters, got {_show(overrides)}"
        )
    return name, None, None, overrides


def _variants(
    algo: registry.Algorithm, label: str | None, overrides: dict, key: str
) -> list[tuple[str, dict]]:
    """(label, overrides) per point of the grid spanned by the swept hyperparameters.

    A list sweeps where the field takes a scalar (`disc_lr: [1e-4, 3e-4]`), or a list of
    lists where it takes a list (`hidden: [[64, 64], [128, 128]]`); `hidden: [64, 64]` is
    one value. Labels say the values: `gaifo-disc_lr=0.0001`.
    """
    fields = _fields(algo.config)
    swept = {
        k: v
        for k, v in overrides.items()
        if k in fields and isinstance(v, list) and _is_sweep(fields[k], v)
    }
    base = label or algo.name
    if not swept:
        return [(base, overrides)]
    for k, values in swept.items():
        if len(values) != len({json.dumps(v) for v in values}):
            raise _Invalid(f"{key}.{k}", f"expected distinct values to sweep, got {_show(values)}")
    variants = []
    for point in itertools.product(*swept.values()):
        chosen = dict(zip(swept, point, strict=True))
        shown = base + "".join(
            f"-{k}={json.dumps(v, separators=(',', ':'))}" for k, v in chosen.items()
        )
        variants.append((shown, {**overrides, **chosen}))
    return variants


def _is_sweep(f: dataclasses.Field, values: list) -> bool:
    if not values:
        return False  # an empty list is no sweep; the value check reports it
    if _scalar_type(f) is not None:
        return True
    return all(isinstance(v, list) for v in values)


def _check_plain(values: dict, key: str) -> None:
    for name, value in values.items():
        try:
            json.dumps(value, allow_nan=False)  # they go into TrialSpec, which is hashed as JSON
        except (TypeError, ValueError):
            raise _Invalid(
                f"{key}.{name}",
                f"expected a plain value (number, string, list), got {_show(value)}",
            ) from None


def _check_hyperparams(algo: registry.Algorithm, overrides: dict, key: str) -> None:
    _check_plain(overrides, key)
    _check_types(_fields(algo.config), overrides, key)
    try:
        algo.make_config(overrides)
    except (TypeError, ValueError) as e:
        raise _Invalid(key, _one_line(str(e))) from None


def _check_types(fields: dict[str, dataclasses.Field], values: dict, key: str) -> None:
    """Each value has its field's scalar type (unknown names are make_config's to report)."""
    for name, value in values.items():
        expected = _scalar_type(fields[name]) if name in fields else None
        if expected is not None and not _matches(value, expected):
            raise _Invalid(
                f"{key}.{name}",
                f"expected {expected.__name__}, got {_show(value)}{_number_hint(value)}",
            )


def _scalar_type(f: dataclasses.Field) -> type | None:
    """The type of a field's scalar default; YAML typos (1e-3 is a string) fail here, not mid-run."""
    if f.default is dataclasses.MISSING:
        return None
    kind = type(f.default)
    return kind if kind in (bool, int, float, str) else None


def _matches(value: Any, expected: type) -> bool:
    if expected is float:
        return _is_int(value) or isinstance(value, float)
    if expected is int:
        return _is_int(value)
    return type(value) is expected


# ---------------------------------------------------------------- small checks


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)  # True is an int in Python


def _int(value: Any, key: str, lo: int, hi: int | None, what: str = "") -> int:
    if not _is_int(value) or value < lo or (hi is not None and value > hi):
        if not what:
            what = {0: "a non-negative integer", 1: "a positive integer"}.get(
                lo, f"an integer >= {lo}"
            )
            what += f" <= {hi}" if hi is not None else ""
        raise _Invalid(key, f"expected {what}, got {_show(value)}{_number_hint(value)}")
    return value


def _number_hint(value: Any) -> str:
    """PyYAML reads 1e5 and 1e-3 as strings (YAML 1.1 wants a dot and a sign); say so."""
    if not isinstance(value, str):
        return ""
    try:
        number = float(value)
    except ValueError:
        return ""
    plain = int(number) if number.is_integer() else number
    return f" (YAML reads {value} as a string; write {plain})"


def _int_list(raw: Any, key: str, lo: int, hi: int | None) -> tuple[int, ...]:
    if not isinstance(raw, list) or not raw:
        raise _Invalid(key, f"expected a non-empty list of integers, got {_show(raw)}")
    values = tuple(_int(v, f"{key}[{i}]", lo, hi) for i, v in enumerate(raw))
    if len(set(values)) != len(values):
        raise _Invalid(key, f"expected distinct values, got {_show(raw)}")
    return values


def _check_keys(raw: dict, allowed: tuple[str, ...], where: str) -> None:
    unknown = [k for k in raw if k not in allowed]
    if unknown:
        key = f"{where}.{unknown[0]}" if where else str(unknown[0])
        raise _Invalid(key, f"unknown key (expected one of {', '.join(allowed)})")


def _show(value: Any) -> str:
    text = repr(value)  # repr escapes newlines, so messages stay on one line
    return text if len(text) <= 60 else text[:57] + "..."


def _one_line(text: str) -> str:
    return " ".join(text.split())
