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

from bench import paths, reading, validate
from bench.demos.pools import POOL_SIZE as DEMO_POOL_SIZE
from bench.envs import EnvError, check_env_id
from bench.harness import registry
from bench.harness.suite import checks, resolve, schema
from bench.harness.suite.expand import expand
from bench.harness.suite.types import (
    AlgorithmEntry,
    EnvSettings,
    RunnerSettings,
    Suite,
    SuiteError,
)
from bench.rl.trpo import TRPOConfig
from bench.validate import show


def load_suite(path: str | Path) -> Suite:
    """Read and validate a suite file; raise SuiteError on the first problem."""
    path = Path(path)
    return _validate(_read_yaml(path), path)


# ---------------------------------------------------------------- reading


MERGE_TAG = "tag:yaml.org,2002:merge"


class _StrictLoader(yaml.SafeLoader):
    """SafeLoader that rejects duplicate keys (plain safe_load keeps the last one silently)."""


def _construct_mapping(loader: _StrictLoader, node: yaml.MappingNode) -> dict:
    seen: set = set()
    for key_node, _ in node.value:
        if key_node.tag == MERGE_TAG:
            continue  # `<<: *defaults`: merged keys may be overridden, as YAML says
        key = loader.construct_object(key_node)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark
            )
        seen.add(key)
    return loader.construct_mapping(node)


_StrictLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


MAX_YAML_BYTES = 2**20
"""A suite or settings file is read only up to this size (the largest shipped one is ~10 KB)."""
MAX_YAML_VALUES = 100_000
"""...and only if it holds at most this many values with its aliases expanded: a few
kilobytes of nested aliases (`&a [*b, *b, ...]`) would otherwise expand to gigabytes."""


def _read_yaml(path: Path, what: str = "suite") -> Any:
    if not path.exists() and not path.is_symlink():
        folder = path.parent
        others = sorted(p.stem for p in folder.glob("*.y*ml")) if folder.is_dir() else []
        hint = f" ({what}s there: {', '.join(others)})" if others else ""
        raise SuiteError(f"{path}: no such {what} file{hint}")
    try:
        text = reading.read_text(path, MAX_YAML_BYTES, f"{what} file")
    except reading.UnreadableFile as e:
        raise SuiteError(str(e)) from None
    try:
        loader = _StrictLoader(text)
        try:
            node = loader.get_single_node()
            if node is None:
                return None
            if _expanded_size(node, {}) > MAX_YAML_VALUES:
                raise SuiteError(
                    f"{path}: more than {MAX_YAML_VALUES:,} values once its aliases are"
                    f" expanded: not a {what} file"
                )
            return loader.construct_document(node)
        finally:
            loader.dispose()
    except RecursionError:
        raise SuiteError(f"{path}: invalid YAML: nested too deeply") from None
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark else ""
        raise SuiteError(f"{path}: {where}invalid YAML: {e.problem}") from None
    except yaml.YAMLError as e:
        raise SuiteError(f"{path}: invalid YAML: {checks.one_line(str(e))}") from None


def _expanded_size(node: yaml.Node, sizes: dict[int, int]) -> int:
    """How many values `node` stands for with every alias expanded (memoized by node, so
    counting is linear in the file; a node inside itself counts as too many)."""
    if id(node) in sizes:
        return sizes[id(node)]
    sizes[id(node)] = MAX_YAML_VALUES + 1  # while counting it: an alias to it is a cycle
    if isinstance(node, yaml.SequenceNode):
        children = node.value
    elif isinstance(node, yaml.MappingNode):
        children = [part for pair in node.value for part in pair]
    else:
        children = []
    total = 1
    for child in children:
        total += _expanded_size(child, sizes)
        if total > MAX_YAML_VALUES:
            break
    sizes[id(node)] = total
    return total


# ---------------------------------------------------------------- validating


def _validate(raw: Any, path: Path) -> Suite:
    try:
        return _suite(raw, path)
    except checks.Invalid as e:
        raise SuiteError(f"{path}: {e}") from None


def _suite(raw: Any, path: Path) -> Suite:
    if not isinstance(raw, dict):
        raise checks.Invalid(
            "", f"expected a mapping with keys envs, demos, algorithms, got {show(raw)}"
        )
    file = schema.parse(schema.SuiteFile, raw)
    name = file.name or path.stem
    if not re.fullmatch(schema.NAME_PATTERN, name):
        raise checks.Invalid(
            "name", f"expected a folder name (letters, digits, . _ -), got {show(name)}"
        )
    tuned = _settings(settings_path(path, file.settings)) if file.settings else {}
    envs = tuple(
        _env(env_id, settings, tuned.get(env_id)) for env_id, settings in file.envs.items()
    )
    # The shipped pools hold DEMO_POOL_SIZE episodes; a dataset is checked for its own count.
    if any(env.dataset is None for env in envs):
        for i, n in enumerate(file.demos):
            if n > DEMO_POOL_SIZE:
                raise checks.Invalid(
                    f"demos[{i}]",
                    f"expected at most {DEMO_POOL_SIZE} (the shipped demonstrations), got {n}",
                )
    timeout = file.runner.trial_timeout
    runner = RunnerSettings(
        file.runner.jobs,
        file.runner.backend,
        tuple(file.runner.first),
        None if timeout is None else validate.duration(timeout),
    )
    algorithms = _algorithms(file.algorithms)

    # Lookups last: they are the slow part and the structure is known good by now.
    for env in envs:
        try:
            check_env_id(env.env_id)
        except EnvError as e:
            raise checks.Invalid(f"envs.{env.env_id}", checks.one_line(str(e))) from None
        if env.hyperparams:
            checks.check_env_hyperparams(env, algorithms, file.envs[env.env_id].hyperparams)
        if env.observation is not None:
            checks.check_video_learners(env, algorithms)
        if env.dataset is not None:  # its demonstrator is the 1.0: no shipped expert needed
            checks.check_dataset(env, max(file.demos), algorithms)
        elif not paths.has_expert(env.env_id):
            raise checks.Invalid(
                f"envs.{env.env_id}",
                f"no trained expert in {paths.expert_dir(env.env_id)} (every suite needs one:"
                " it is the 1.0 of normalized scores; train it with `bench experts`)",
            )
    names = {n for a in algorithms for n in (a.name, a.shown)}
    named = {f"envs.{env.env_id}.seeds": env.seeds for env in envs} | {"runner.first": runner.first}
    for key, given in named.items():
        unknown = sorted(set(given) - names)
        if unknown:
            raise checks.Invalid(
                key,
                f"{', '.join(map(repr, unknown))} is no algorithm or label of the suite"
                f" ({', '.join(sorted(names))})",
            )
    suite = Suite(
        name,
        envs,
        file.demos,
        algorithms,
        file.seeds,
        file.eval_episodes,
        runner,
        file.curve_points,
        file.kernels,
    )
    checks.check_size(suite)
    trials = expand(suite, checks.build_configs(envs, algorithms))
    checks.check_budgets(trials)
    return dataclasses.replace(suite, trials=tuple(trials))


SHIPPED_SETTINGS = paths.REPO_ROOT / "suites"
"""Where the shipped settings files live (suites/settings/*.yaml): a suite anywhere names
them as the shipped suites do, `settings: settings/mujoco.yaml`."""


def settings_path(suite: Path, named: str) -> Path:
    """The settings file a suite at `suite` names: beside the suite (in its folder or below),
    else the shipped one of that name. A name that leads anywhere else (an absolute path,
    `..`, a link out of the folder) is refused before anything is read: a suite is a file a
    stranger may hand you, and its settings must not be a way to read the machine's files."""
    folders = (suite.parent, SHIPPED_SETTINGS)
    beside, shipped = (folder / named for folder in folders)
    path = shipped if not beside.exists() and shipped.is_file() else beside
    if Path(named).is_absolute() or not any(_inside(path, folder) for folder in folders):
        raise checks.Invalid(
            "settings",
            f"{named!r} leads out of the suite's folder; a settings file lives beside its suite"
            " or is a shipped one (settings/mujoco.yaml, settings/pybullet.yaml)",
        )
    return path


def _inside(path: Path, folder: Path) -> bool:
    return path.resolve().is_relative_to(folder.resolve())


def _settings(path: Path) -> dict[str, schema.SettingsEntry]:
    """A settings file: env id -> what the task needs from its learners, each entry checked
    as an env's `trpo` and `hyperparams` are."""
    raw = _read_yaml(path, "settings")
    if not isinstance(raw, dict):
        # nothing of the file is echoed: it may be something else than it was meant to be
        raise checks.Invalid("settings", f"{path}: expected a mapping of env ids")
    entries = {}
    for env_id, entry in raw.items():
        key = f"settings: {path}: {env_id}"
        entries[env_id] = schema.parse(schema.SettingsEntry, entry, key)
        _check_trpo(entries[env_id].trpo, f"{key}.trpo")
        checks.check_plain(entries[env_id].hyperparams, f"{key}.hyperparams")
        checks.check_known(entries[env_id].hyperparams, f"{key}.hyperparams")
    return entries


def _check_trpo(settings: dict, key: str) -> None:
    for name in settings:
        if name not in resolve.fields_of(TRPOConfig):
            raise checks.Invalid(
                f"{key}.{name}",
                f"not a TRPO setting (known: {', '.join(sorted(resolve.fields_of(TRPOConfig)))})",
            )
    checks.check_config(TRPOConfig, settings, key)


def _env(env_id: str, settings: schema.EnvFile, tuned: schema.SettingsEntry | None) -> EnvSettings:
    """An env's settings: the suite's own over the settings file's (`tuned`), if any."""
    key = f"envs.{env_id}"
    if tuned is not None:
        trpo = {**tuned.trpo, **settings.trpo}
        hyperparams = {**tuned.hyperparams, **settings.hyperparams}
        settings = settings.model_copy(update={"trpo": trpo, "hyperparams": hyperparams})
    _check_trpo(settings.trpo, f"{key}.trpo")
    checks.check_plain(settings.hyperparams, f"{key}.hyperparams")
    seen = None if settings.observation == "states" else settings.observation
    return EnvSettings(
        env_id,
        settings.budget,
        settings.dataset,
        seen,
        settings.frame_size,
        dict(settings.trpo),
        dict(settings.hyperparams),
        dict(settings.seeds),
    )


def _algorithms(raw: Any) -> tuple[AlgorithmEntry, ...]:
    """Entries: `name`, `{name: {hyperparameter: value}}` or `{algorithm: name, label: text,
    seeds: 3, hyperparameter: value, ...}` (label and seeds optional). A list where a
    hyperparameter takes one value is a sweep: one variant per value (a grid over several
    lists)."""
    entries: dict[str, AlgorithmEntry] = {}
    for i, item in enumerate(raw):
        key = f"algorithms[{i}]"
        name, label, seeds, overrides = _entry(item, key)
        try:
            algo = registry.get(name)
        except registry.RegistryError as e:
            raise checks.Invalid(key, checks.one_line(str(e))) from None
        for shown, variant in _variants(algo, label, overrides, key):
            checks.check_overrides(algo, variant, f"{key}.{name}")
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
                name, variant, uses_demos, label_or_none, seeds, key=f"{key}.{name}"
            )
    return tuple(entries.values())


def _entry(item: Any, key: str) -> tuple[str, str | None, tuple[int, ...] | None, dict]:
    """(algorithm name, label, seeds, hyperparameter overrides) of one `algorithms` item;
    label and seeds None unless given."""
    if isinstance(item, dict) and "algorithm" in item:
        entry = schema.parse(schema.EntryFile, item, key)
        if entry.label is not None and entry.label in registry.all_algorithms():
            raise checks.Invalid(
                f"{key}.label", f"{entry.label!r} is an algorithm's name; pick another label"
            )
        overrides = {k: v for k, v in item.items() if k not in schema.EntryFile.model_fields}
        return entry.algorithm, entry.label, entry.seeds, overrides
    if isinstance(item, dict) and len(item) == 1:
        name, overrides = next(iter(item.items()))
        overrides = {} if overrides is None else overrides  # `- gaifo:` with nothing after
    else:
        name, overrides = item, {}
    if not isinstance(name, str):
        raise checks.Invalid(
            key, f"expected a name or {{name: {{hyperparameter: value}}}}, got {show(item)}"
        )
    if not isinstance(overrides, dict):
        raise checks.Invalid(
            f"{key}.{name}", f"expected a mapping of hyperparameters, got {show(overrides)}"
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
    fields = resolve.fields_of(algo.config)
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
                f"{key}.{k}", f"expected distinct values to sweep, got {show(values)}"
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
