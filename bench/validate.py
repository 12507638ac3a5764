"""Validation with pydantic, and its errors as one line naming the setting.

Algorithm configs are still built as `config(**overrides)` (so trial ids and records stay as
they were); `check_types` only checks first that every value has its field's type, strictly,
as JSON would carry it: `true` is no int, "abc" is no tuple of ints, 1 is a float. Ranges are
the dataclass's own (`__post_init__`, with `at_least` and `above`), so they live beside the
field they bound. The suite file's own schema is `bench.harness.suite.schema`.
"""

from __future__ import annotations

import json
import re
from collections.abc import Collection
from functools import cache
from typing import Any

import pydantic


class SettingError(ValueError):
    """One bad value: `field` is its dotted path ("" for a check over several fields)."""

    def __init__(self, field: str, message: str) -> None:
        super().__init__(f"{field}: {message}" if field else message)
        self.field, self.message = field, message


@cache
def _adapter(config: type) -> pydantic.TypeAdapter:
    return pydantic.TypeAdapter(config)


def check_types(config: type, overrides: dict[str, Any]) -> None:
    """Raise SettingError (one line, naming the field, its value and the type it needs) unless
    every value in `overrides` has its field's type in the dataclass `config`."""
    try:
        text = json.dumps(overrides, allow_nan=False)
    except (TypeError, ValueError):
        raise SettingError("", f"settings must be JSON values: {overrides!r}") from None
    try:
        _adapter(config).validate_json(text, strict=True)
    except pydantic.ValidationError as err:
        raise setting_error(err.errors()[0]) from None


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


def one_of(config: object, name: str, choices: Collection[str]) -> None:
    """For a config's `__post_init__`: raise ValueError unless `name`'s value is one of
    `choices` (a setting that picks a variant by name)."""
    value = getattr(config, name)
    if value not in choices:
        raise ValueError(f"{name} must be one of {', '.join(map(repr, choices))}, not {value!r}")


def layers(config: object, *names: str) -> None:
    """For a config's `__post_init__`: each of `names` is a list of hidden layer sizes, each at
    least 1 (a zero-width layer makes a network output a constant, which trains "fine"), and
    makes it a tuple (YAML gives lists)."""
    for name in names:
        sizes = tuple(getattr(config, name))
        for i, size in enumerate(sizes):
            if size < 1:
                raise ValueError(f"{name}[{i}] must be >= 1 (a layer's width), not {size}")
        setattr(config, name, sizes)


# ---------------------------------------------------------------- pydantic errors, one line

_EXPECTED = {
    "int_type": "an integer",
    "int_parsing": "an integer",
    "int_from_float": "an integer",
    "float_type": "a number",
    "float_parsing": "a number",
    "string_type": "a string",
    "bool_type": "true or false",
    "bool_parsing": "true or false",
    "list_type": "a list",
    "tuple_type": "a list",
    "dict_type": "a mapping",
    "model_type": "a mapping",
    "dataclass_type": "a mapping",
}


def setting_error(error: dict) -> SettingError:
    """One pydantic error as a SettingError: the path, what was expected, what was found."""
    kind, value, context = error["type"], error.get("input"), error.get("ctx") or {}
    field = path(error["loc"])
    got = f"got {show(value)}{number_hint(value)}"
    if kind == "missing":
        return SettingError(field, "missing (required)")
    if kind == "extra_forbidden":
        return SettingError(field, "unknown key")
    if kind in ("value_error", "assertion_error"):
        cause = context.get("error")
        return SettingError(field, str(cause) if cause is not None else error["msg"])
    if kind == "literal_error":
        return SettingError(
            field, f"expected one of {context['expected'].replace(chr(39), '')}, {got}"
        )
    if kind in ("greater_than_equal", "greater_than", "less_than_equal", "less_than"):
        ops = (("ge", ">="), ("gt", ">"), ("le", "<="), ("lt", "<"))
        bounds = " ".join(f"{op} {context[k]}" for k, op in ops if k in context)
        return SettingError(field, f"expected a value {bounds}, {got}")
    if kind == "too_short":
        return SettingError(field, f"expected a non-empty {_container(value)}, {got}")
    if kind == "string_pattern_mismatch":
        return SettingError(
            field, f"expected a name ({_name_characters(context['pattern'])}), {got}"
        )
    if kind in _EXPECTED:
        return SettingError(field, f"expected {_EXPECTED[kind]}, {got}")
    return SettingError(field, f"{error['msg'][0].lower()}{error['msg'][1:]}, {got}")


def path(loc: tuple | list) -> str:
    """('envs', 'Hopper', 'budget') -> envs.Hopper.budget; list indices as [i]. Skips the
    parts pydantic adds for validator functions and union branches (they hold brackets)."""
    text = ""
    for part in loc:
        if isinstance(part, int):
            text += f"[{part}]"
        elif part and "[" not in part:
            text += f".{part}" if text else part
    return text


def show(value: Any) -> str:
    text = repr(value)  # repr escapes newlines, so messages stay on one line
    return text if len(text) <= 60 else text[:57] + "..."


def number_hint(value: Any) -> str:
    """PyYAML reads 1e5 and 1e-3 as strings (YAML 1.1 wants a dot and a sign); say so."""
    if not isinstance(value, str):
        return ""
    try:
        number = float(value)
    except ValueError:
        return ""
    plain = int(number) if number.is_integer() else number
    return f" (YAML reads {value} as a string; write {plain})"


def _name_characters(pattern: str) -> str:
    """What a name pattern like ^[A-Za-z0-9][A-Za-z0-9._-]*$ allows, in words."""
    allowed = pattern.split("][", 1)[-1].rsplit("]", 1)[0].replace("A-Za-z0-9", "")
    others = [c for c in allowed.replace("\\", "")]
    return ", ".join(["letters", "digits", " ".join(others)])


def _container(value: Any) -> str:
    return "mapping" if isinstance(value, dict) else "list"


_DURATION = re.compile(r"(?:(\d+(?:\.\d+)?)h)?(?:(\d+(?:\.\d+)?)m)?(?:(\d+(?:\.\d+)?)s)?")


def duration(text: str) -> float:
    """Seconds of a positive duration written like 90m, 2h, 1h30m or 45s; else ValueError."""
    match = _DURATION.fullmatch(text.strip())
    if not text.strip() or match is None:
        raise ValueError(f"not a duration like 90m, 2h or 1h30m: {text!r}")
    hours, minutes, seconds = (float(g or 0) for g in match.groups())
    total = hours * 3600 + minutes * 60 + seconds
    if total <= 0:
        raise ValueError(f"must be longer than 0, not {text!r}")
    return total


class Checked:
    """The root of the config dataclasses that check their fields: each one's `__post_init__`
    checks its own fields and first calls `super().__post_init__()`, so that a config of
    several bases (GAIfO's: TRPO's and the discriminator's) checks all of theirs, each once,
    along its MRO, with no base named by hand."""

    def __post_init__(self) -> None:
        pass
