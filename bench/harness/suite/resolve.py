"""An algorithm's config on one env, built once: its config's defaults, the env's settings that
apply to it, and the suite entry's own overrides; and as the plain JSON a trial's id hashes."""

from __future__ import annotations

import dataclasses
import json
from typing import Any

from bench.fields import at_default_and_added_later
from bench.harness import registry
from bench.harness.suite.types import AlgorithmEntry, EnvSettings
from bench.rl.trpo import TRPOConfig


def fields_of(config: type) -> dict[str, dataclasses.Field]:
    """A config dataclass's fields by name."""
    return {f.name: f for f in dataclasses.fields(config)}


def as_json(config: Any) -> dict[str, Any]:
    """A built config, defaults included, as JSON: a changed default is a new trial. Fields
    added after trials were recorded (`bench.fields.added_later`) are left out while at their
    defaults, so those trials keep their ids."""
    unset = at_default_and_added_later(config)
    full = json.loads(json.dumps(dataclasses.asdict(config)))
    return {k: v for k, v in full.items() if k not in unset}


def settings_on(env: EnvSettings, entry: AlgorithmEntry) -> dict[str, Any]:
    """What the entry's config is built from on this env: the env's settings that apply to it
    (the env's TRPO settings if it is a TRPO learner, then the env's hyperparams that its
    config has) under the entry's own overrides."""
    algorithm = registry.get(entry.name)
    known = fields_of(algorithm.config)
    from_env = {k: v for k, v in env.hyperparams.items() if k in known}
    if env.trpo and issubclass(algorithm.config, TRPOConfig):
        from_env = {**env.trpo, **from_env}
    return {**from_env, **entry.overrides}


def config_on(env: EnvSettings, entry: AlgorithmEntry) -> Any:
    """The entry's config on this env, built (the one construction a trial's config has: the
    spec carries it). Raises what the config raises (SettingError, TypeError, ValueError)
    where the settings do not fit it."""
    return registry.get(entry.name).make_config(settings_on(env, entry))
