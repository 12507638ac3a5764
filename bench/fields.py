"""Config fields added after trials were recorded with their config.

A trial's id hashes its resolved config, defaults included (`bench.harness.suite.resolve`), so
a new field would change the id of every recorded trial whose config is written out in full,
and their records would no longer be found. A field declared with `added_later` is left out of
that config while it holds its default: a trial that does not use it keeps its id, and one
that sets it is a new trial.
"""

from __future__ import annotations

import dataclasses
from typing import Any

ADDED_LATER = "bench.added_later"
"""Metadata key that marks such a field."""


def added_later(default: Any) -> Any:
    """`field(default=...)` for a config field added after trials were recorded."""
    return dataclasses.field(default=default, metadata={ADDED_LATER: True})


def at_default_and_added_later(config: Any) -> set[str]:
    """The names of `config`'s added-later fields that hold their defaults."""
    return {
        f.name
        for f in dataclasses.fields(config)
        if f.metadata.get(ADDED_LATER) and getattr(config, f.name) == f.default
    }
