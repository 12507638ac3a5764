"""Type checks of config overrides against a config dataclass's annotations, with pydantic.

Configs are still built as `config(**overrides)` (so trial ids and records stay as they were);
this only checks first that every value has its field's type, strictly, as JSON would carry
it: `true` is no int, "abc" is no tuple of ints, 1 is a float. Ranges are the dataclass's own
(`__post_init__`), so they live beside the field they bound.
"""

from __future__ import annotations

import json
from functools import cache
from typing import Any

import pydantic


@cache
def _adapter(config: type) -> pydantic.TypeAdapter:
    return pydantic.TypeAdapter(config)


def check_types(config: type, overrides: dict[str, Any]) -> None:
    """Raise ValueError (one line, naming the field, its value and the type it needs) unless
    every value in `overrides` has its field's type in the dataclass `config`."""
    try:
        text = json.dumps(overrides, allow_nan=False)
    except (TypeError, ValueError):
        raise ValueError(f"settings must be JSON values: {overrides!r}") from None
    try:
        _adapter(config).validate_json(text, strict=True)
    except pydantic.ValidationError as err:
        first = err.errors()[0]
        field = ".".join(str(part) for part in first["loc"])
        if not field:  # the dataclass's own check (its __post_init__) refused the values
            raise ValueError(first["msg"].removeprefix("Value error, ")) from None
        raise ValueError(f"{field}: {first['msg'].lower()}, not {first['input']!r}") from None


def at_least(config: object, minimum: float, *names: str) -> None:
    """For a config's `__post_init__`: raise ValueError naming the first of `names` whose value
    is below `minimum` (None is allowed: an unset optional)."""
    for name in names:
        value = getattr(config, name)
        if value is not None and value < minimum:
            raise ValueError(f"{name} must be >= {minimum}, not {value}")


def above(config: object, minimum: float, *names: str) -> None:
    """As `at_least`, strictly: each of `names` must be > `minimum` (learning rates, say)."""
    for name in names:
        value = getattr(config, name)
        if value is not None and value <= minimum:
            raise ValueError(f"{name} must be > {minimum}, not {value}")
