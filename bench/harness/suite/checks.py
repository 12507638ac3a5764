"""The checks a suite passes at load, one line each naming the key path, what was expected and
what was found; and the look-ups that need the registry, env ids, experts and datasets."""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Collection
from typing import Any

from bench import validate
from bench.harness import registry
from bench.harness.suite import resolve
from bench.harness.suite.expand import seeds_of
from bench.harness.suite.types import AlgorithmEntry, EnvSettings, Suite
from bench.harness.types import TrialSpec
from bench.validate import show


class Invalid(Exception):
    """One problem at one key path; load_suite adds the file name."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(f"{key}: {message}" if key else message)


def joined(key: str, field: str) -> str:
    """A key path and a field under it: envs.X + budget, demos + [1]; either may be empty."""
    if not (key and field):
        return key or field
    return f"{key}{'' if field.startswith('[') else '.'}{field}"


def at_setting(key: str, error: validate.SettingError) -> Invalid:
    """A setting's problem (`bench.validate`) at its path under `key`."""
    return Invalid(joined(key, error.field), error.message)


def config_error(key: str, error: TypeError | ValueError) -> Invalid:
    """Why a config does not build, at `key`: at the setting's own path where it names one
    (`SettingError`), else the error's message in one line."""
    if isinstance(error, validate.SettingError):
        return at_setting(key, error)
    return Invalid(key, one_line(str(error)))


def check_budgets(trials: list[TrialSpec]) -> None:
    """Each trial's budget covers what its algorithm needs before it can learn anything (one
    TRPO batch, say), asked of the algorithm (`register(..., min_budget=)`): a trial that
    cannot train is refused at load, not recorded as failed an hour into the run."""
    asked: set[tuple[str, int, str]] = set()
    for spec in trials:
        case = (spec.algorithm, spec.budget, json.dumps(spec.hyperparams, sort_keys=True))
        algo = registry.get(spec.algorithm)
        if algo.min_budget is None or case in asked:
            continue  # seeds and demo counts of one setting need the same
        asked.add(case)
        need = algo.min_budget(registry.config_of(spec))
        if spec.budget < need:
            raise Invalid(
                f"envs.{spec.env_id}.budget",
                f"{spec.budget} env steps are fewer than {spec.shown} needs to train ({need})",
            )


MAX_TRIALS = 1_000_000
"""A suite that expands to more trials is refused before it is expanded: a million trials of
the smallest budget are weeks of cores, and their specs alone take gigabytes."""


def check_size(suite: Suite) -> None:
    """The suite's trial count, counted without expanding it, is at most `MAX_TRIALS`."""
    count = 0
    for env in suite.envs:
        for entry in suite.algorithms:
            runs = len(suite.demos) if entry.uses_demos else 1
            count += runs * len(seeds_of(suite, env, entry))
    if count > MAX_TRIALS:
        raise Invalid("", f"the suite has {count:,} trials, more than {MAX_TRIALS:,}; split it")


def check_video_learners(env: EnvSettings, algorithms: tuple) -> None:
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
        raise Invalid(
            f"envs.{env.env_id}.observation",
            f"{', '.join(blind)} cannot {what} (those that can: {', '.join(able) or 'none'})",
        )


def check_dataset(env: EnvSettings, most_demos: int, algorithms: tuple) -> None:
    """The dataset opens, comes from this env, has enough episodes, and has actions if an
    algorithm needs them."""
    from bench.demos import minari_io

    key = f"envs.{env.env_id}.dataset"
    try:
        dataset = minari_io.open_dataset(env.dataset)
        minari_io.check_env(dataset, env.dataset, env.env_id)
    except minari_io.DatasetError as e:
        raise Invalid(key, str(e)) from None
    if dataset.total_episodes < most_demos:
        raise Invalid(
            key,
            f"{env.dataset} has {dataset.total_episodes} episodes, fewer than the"
            f" {most_demos} demonstrations asked for",
        )
    needs_actions = [a.shown for a in algorithms if registry.get(a.name).inputs == "actions"]
    if needs_actions and not minari_io.has_actions(dataset):
        raise Invalid(
            key,
            f"{env.dataset} records no actions (NaN), which {', '.join(needs_actions)} needs;"
            " imitation from observation algorithms run without them",
        )


def check_env_hyperparams(
    env: EnvSettings, algorithms: tuple[AlgorithmEntry, ...], own: Collection[str]
) -> None:
    """Each of the env's hyperparams fits the type of every algorithm of the suite that has
    it, and each the suite sets itself (`own`) is a setting of one of them: a typo would
    otherwise reach no algorithm and change nothing, silently. A settings file's entries
    serve many suites, so one the suite's algorithms lack is left unused (`check_known`)."""
    key = f"envs.{env.env_id}.hyperparams"
    configs = [registry.get(a.name).config for a in algorithms]
    for name, value in env.hyperparams.items():
        having = [config for config in configs if name in resolve.fields_of(config)]
        if not having and name in own:
            shown = ", ".join(sorted({a.shown for a in algorithms}))
            raise Invalid(f"{key}.{name}", f"no algorithm of the suite has this setting ({shown})")
        for config in having:
            try:
                validate.check_types(config, {name: value})
            except validate.SettingError as e:
                raise at_setting(key, e) from None


def check_known(hyperparams: dict, key: str) -> None:
    """Each name is a setting of some registered algorithm (a settings file's typo)."""
    known = {
        f for algo in registry.all_algorithms().values() for f in resolve.fields_of(algo.config)
    }
    for name in hyperparams:
        if name not in known:
            raise Invalid(f"{key}.{name}", "no registered algorithm has this setting")


def build_configs(
    envs: tuple[EnvSettings, ...], algorithms: tuple[AlgorithmEntry, ...]
) -> dict[tuple[str, str], Any]:
    """Each entry's config on each env, built once (`resolve.config_on`), by (env id, shown
    name); a config that does not build is Invalid at the entry's key where its own overrides
    are at fault, else at the env's settings."""
    built = {}
    for env in envs:
        for entry in algorithms:
            try:
                built[env.env_id, entry.shown] = resolve.config_on(env, entry)
            except (TypeError, ValueError) as e:
                raise _blame(env, entry, e) from None
    return built


def _blame(env: EnvSettings, entry: AlgorithmEntry, error: Exception) -> Invalid:
    """Where a config that does not build is wrong: the entry's overrides if they fail alone,
    else the env's settings under them."""
    try:
        registry.get(entry.name).make_config(entry.overrides)
    except (TypeError, ValueError) as own:
        return config_error(entry.key, own)
    where = f"envs.{env.env_id}.{'hyperparams' if env.hyperparams else 'trpo'}"
    return Invalid(where, f"{entry.shown}: {one_line(str(error))}")


def check_plain(values: dict, key: str) -> None:
    for name, value in values.items():
        try:
            json.dumps(value, allow_nan=False)  # they go into TrialSpec, which is hashed as JSON
        except (TypeError, ValueError):
            raise Invalid(
                f"{key}.{name}",
                f"expected a plain value (number, string, list), got {show(value)}",
            ) from None


def check_overrides(algo: registry.Algorithm, overrides: dict, key: str) -> None:
    """An entry's overrides are plain values, settings of its config and of their types, or
    Invalid at `key`; whether they build is asked per env (`build_configs`)."""
    check_plain(overrides, key)
    try:
        algo.check_overrides(overrides)
    except ValueError as e:
        raise config_error(key, e) from None


def check_config(config: type, values: dict, key: str) -> None:
    """`values` are settings of the dataclass `config`, of their types, and it builds."""
    try:
        validate.check_types(config, values)
        config(**values)
    except (TypeError, ValueError) as e:
        raise config_error(key, e) from None


def scalar_type(f: dataclasses.Field) -> type | None:
    """The type of a field's scalar default; YAML typos (1e-3 is a string) fail here, not mid-run."""
    if f.default is dataclasses.MISSING:
        return None
    kind = type(f.default)
    return kind if kind in (bool, int, float, str) else None


def one_line(text: str) -> str:
    return " ".join(text.split())
