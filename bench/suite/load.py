"""A suite file -> a validated `Suite`: strict YAML, structure, types and ranges, and the
look-ups (envs, algorithms, experts, datasets), each problem one line naming its key."""

from __future__ import annotations

import dataclasses
import itertools
import json
import re
from pathlib import Path
from typing import Any

import yaml

from bench import paths, registry
from bench.demos import POOL_SIZE as DEMO_POOL_SIZE
from bench.envs import EnvError, check_env_id
from bench.rl.trpo import TRPOConfig
from bench.suite import checks
from bench.suite.expand import _fields, _resolve
from bench.suite.types import (
    AlgorithmEntry,
    EnvSettings,
    RunnerSettings,
    Suite,
    SuiteError,
)

_SUITE_KEYS = ("name", "envs", "demos", "algorithms", "seeds", "eval_episodes", "runner")
_REQUIRED_KEYS = ("envs", "demos", "algorithms")
_ENV_KEYS = ("budget", "dataset", "observation", "frame_size", "trpo", "hyperparams", "seeds")
_OBSERVATIONS = ("states", "pixels", "video-reward")
_RUNNER_KEYS = ("jobs", "backend")
_BACKENDS = ("loky", "dask")
_NAME_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]*")  # it becomes a folder name
_LABEL_PATTERN = re.compile(r"[A-Za-z0-9][A-Za-z0-9._=,+\[\]-]*")  # as sweeps write them


def load_suite(path: str | Path) -> Suite:
    """Read and validate a suite file; raise SuiteError on the first problem."""
    path = Path(path)
    return _validate(_read_yaml(path), path)


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
        raise SuiteError(f"{path}: invalid YAML: {checks.one_line(str(e))}") from None


# ---------------------------------------------------------------- validating


def _validate(raw: Any, path: Path) -> Suite:
    try:
        return _suite(raw, path.stem)
    except checks.Invalid as e:
        raise SuiteError(f"{path}: {e}") from None


def _suite(raw: Any, default_name: str) -> Suite:
    if not isinstance(raw, dict):
        raise checks.Invalid(
            "", f"expected a mapping with keys {', '.join(_REQUIRED_KEYS)}, got {checks.show(raw)}"
        )
    checks.check_keys(raw, _SUITE_KEYS, "")
    for key in _REQUIRED_KEYS:
        if key not in raw:
            raise checks.Invalid(key, "missing (required)")

    name = raw.get("name", default_name)
    if not isinstance(name, str) or not _NAME_PATTERN.fullmatch(name):
        raise checks.Invalid(
            "name", f"expected a folder name (letters, digits, . _ -), got {checks.show(name)}"
        )

    envs = _envs(raw["envs"])
    # The shipped pools hold DEMO_POOL_SIZE episodes; a dataset is checked for its own count.
    pooled = any(env.dataset is None for env in envs)
    demos = checks.int_list(raw["demos"], "demos", 1, DEMO_POOL_SIZE if pooled else None)
    seeds = _seeds(raw.get("seeds", 10))
    eval_episodes = checks.integer(raw.get("eval_episodes", 10), "eval_episodes", 1, None)
    runner = _runner(raw.get("runner", {}))
    algorithms = _algorithms(raw["algorithms"])

    # Lookups last: they are the slow part and the structure is known good by now.
    for env in envs:
        try:
            check_env_id(env.env_id)
        except EnvError as e:
            raise checks.Invalid(f"envs.{env.env_id}", checks.one_line(str(e))) from None
        if env.hyperparams:
            checks.check_env_hyperparams(env, algorithms)
        if env.trpo or env.hyperparams:
            checks.check_env_settings(env, algorithms)
        if env.observation is not None:
            checks.check_video_learners(env, algorithms)
        if env.dataset is not None:  # its demonstrator is the 1.0: no shipped expert needed
            checks.check_dataset(env, max(demos), algorithms)
        elif not paths.has_expert(env.env_id):
            raise checks.Invalid(
                f"envs.{env.env_id}",
                f"no trained expert in {paths.expert_dir(env.env_id)} (every suite needs one:"
                " it is the 1.0 of normalized scores; train it with `bench experts`)",
            )
    names = {n for a in algorithms for n in (a.name, a.shown)}
    for env in envs:
        unknown = sorted(set(env.seeds) - names)
        if unknown:
            raise checks.Invalid(
                f"envs.{env.env_id}.seeds",
                f"{', '.join(map(repr, unknown))} is no algorithm or label of the suite"
                f" ({', '.join(sorted(names))})",
            )
    suite = Suite(name, envs, demos, algorithms, seeds, eval_episodes, runner)
    checks.check_budgets(suite)
    return suite


def _envs(raw: Any) -> tuple[EnvSettings, ...]:
    if not isinstance(raw, dict) or not raw:
        raise checks.Invalid(
            "envs",
            f"expected a non-empty mapping of env id -> {{budget: ...}}, got {checks.show(raw)}",
        )
    envs = []
    for env_id, settings in raw.items():
        if not isinstance(env_id, str):
            raise checks.Invalid(
                "envs", f"expected env ids (strings) as keys, got {checks.show(env_id)}"
            )
        key = f"envs.{env_id}"
        if not isinstance(settings, dict):
            raise checks.Invalid(
                key, f"expected a mapping like {{budget: 100000}}, got {checks.show(settings)}"
            )
        checks.check_keys(settings, _ENV_KEYS, key)
        if "budget" not in settings:
            raise checks.Invalid(
                f"{key}.budget", "missing (required: env steps per training trial)"
            )
        dataset = settings.get("dataset")
        if dataset is not None and (not isinstance(dataset, str) or not dataset):
            raise checks.Invalid(
                f"{key}.dataset",
                f"expected a dataset folder or Minari id, got {checks.show(dataset)}",
            )
        budget = checks.integer(settings["budget"], f"{key}.budget", 1, None)
        observation = settings.get("observation", "states")
        if observation not in _OBSERVATIONS:
            raise checks.Invalid(
                f"{key}.observation",
                f"expected one of {', '.join(_OBSERVATIONS)}, got {checks.show(observation)}",
            )
        if observation != "states" and dataset is not None:
            raise checks.Invalid(
                f"{key}.observation",
                f"{observation} needs video demonstrations; a dataset holds states",
            )
        frame_size = settings.get("frame_size")
        if frame_size is not None:
            if observation == "states":
                raise checks.Invalid(
                    f"{key}.frame_size", "only with observation: pixels or video-reward"
                )
            frame_size = checks.integer(
                frame_size, f"{key}.frame_size", 24, 256
            )  # the conv trunk needs 20+
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
        raise checks.Invalid(key, f"expected a mapping like {{n_envs: 16}}, got {checks.show(raw)}")
    fields = _fields(TRPOConfig)
    for name in raw:
        if name not in fields:
            raise checks.Invalid(
                f"{key}.{name}", f"not a TRPO setting (known: {', '.join(sorted(fields))})"
            )
    checks.check_types(fields, raw, key)
    try:
        TRPOConfig(**raw)
    except (TypeError, ValueError) as e:
        raise checks.Invalid(key, checks.one_line(str(e))) from None
    return dict(raw)


def _plain_mapping(raw: Any, key: str) -> dict[str, Any]:
    """A mapping of setting name -> plain (JSON) value, e.g. an env's hyperparams."""
    if not isinstance(raw, dict):
        raise checks.Invalid(
            key, f"expected a mapping like {{disc_steps: 25}}, got {checks.show(raw)}"
        )
    checks.check_plain(raw, key)
    return dict(raw)


def _seeds(raw: Any, key: str = "seeds") -> tuple[int, ...]:
    if isinstance(raw, list):
        return checks.int_list(raw, key, 0, None)
    return tuple(range(checks.integer(raw, key, 1, None, what="a seed count or a list of seeds")))


def _runner(raw: Any) -> RunnerSettings:
    if not isinstance(raw, dict):
        raise checks.Invalid(
            "runner", f"expected a mapping like {{jobs: 2, backend: loky}}, got {checks.show(raw)}"
        )
    checks.check_keys(raw, _RUNNER_KEYS, "runner")
    jobs = raw.get("jobs", RunnerSettings.jobs)
    if not checks.is_int(jobs) or (jobs < 1 and jobs != -1):
        raise checks.Invalid(
            "runner.jobs", f"expected a positive integer or -1 (all cores), got {checks.show(jobs)}"
        )
    backend = raw.get("backend", RunnerSettings.backend)
    if backend not in _BACKENDS:
        raise checks.Invalid(
            "runner.backend", f"expected one of {', '.join(_BACKENDS)}, got {checks.show(backend)}"
        )
    return RunnerSettings(jobs, backend)


def _algorithms(raw: Any) -> tuple[AlgorithmEntry, ...]:
    """Entries: `name`, `{name: {hyperparameter: value}}` or `{algorithm: name, label: text,
    seeds: 3, hyperparameter: value, ...}` (label and seeds optional). A list where a
    hyperparameter takes one value is a sweep: one variant per value (a grid over several
    lists)."""
    if not isinstance(raw, list) or not raw:
        raise checks.Invalid(
            "algorithms", f"expected a non-empty list of names, got {checks.show(raw)}"
        )
    entries: dict[str, AlgorithmEntry] = {}
    for i, item in enumerate(raw):
        key = f"algorithms[{i}]"
        name, label, seeds, overrides = _entry(item, key)
        try:
            algo = registry.get(name)
        except registry.RegistryError as e:
            raise checks.Invalid(key, checks.one_line(str(e))) from None
        for shown, variant in _variants(algo, label, overrides, key):
            checks.check_hyperparams(algo, variant, f"{key}.{name}")
            resolved = _resolve(algo, variant)
            if shown in entries:
                # Records and plots group by what is shown, so two entries would silently merge.
                raise checks.Invalid(
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
            raise checks.Invalid(
                f"{key}.algorithm", f"expected an algorithm name, got {checks.show(name)}"
            )
        if label is not None and (
            not isinstance(label, str) or not _LABEL_PATTERN.fullmatch(label)
        ):
            raise checks.Invalid(
                f"{key}.label",
                f"expected a name (letters, digits, . _ - = , + [ ]), got {checks.show(label)}",
            )
        if label is not None and label in registry.all_algorithms():
            raise checks.Invalid(
                f"{key}.label", f"{label!r} is an algorithm's name; pick another label"
            )
        return name, label, seeds, overrides
    if isinstance(item, dict) and len(item) == 1:
        name, overrides = next(iter(item.items()))
        overrides = {} if overrides is None else overrides  # `- gaifo:` with nothing after
    else:
        name, overrides = item, {}
    if not isinstance(name, str):
        raise checks.Invalid(
            key, f"expected a name or {{name: {{hyperparameter: value}}}}, got {checks.show(item)}"
        )
    if not isinstance(overrides, dict):
        raise checks.Invalid(
            f"{key}.{name}", f"expected a mapping of hyperparameters, got {checks.show(overrides)}"
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
            raise checks.Invalid(
                f"{key}.{k}", f"expected distinct values to sweep, got {checks.show(values)}"
            )
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
    if checks.scalar_type(f) is not None:
        return True
    return all(isinstance(v, list) for v in values)


# ---------------------------------------------------------------- small checks
