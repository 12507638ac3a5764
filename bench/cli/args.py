"""Argument types and the one-line parser every `bench` command shares."""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable
from pathlib import Path

from bench import validate


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a bad argument is one line on stderr (no usage block), exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message}\n")


def at_least(low: int) -> Callable[[str], int]:
    """argparse type: an int >= `low`."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be >= {low}, not {value}")
        return value

    return parse


def level(text: str) -> float:
    """A significance level: a number strictly between 0 and 1."""
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not 0 < value < 1:
        raise argparse.ArgumentTypeError(f"{text!r} is not a level between 0 and 1, e.g. 0.01")
    return value


def jobs_count(text: str) -> int:
    """argparse type: parallel jobs, >= 1, or -1 for every core."""
    value = at_least(-1)(text)
    if value == 0:
        raise argparse.ArgumentTypeError("must be >= 1, or -1 for every core, not 0")
    return value


def folder(text: str) -> Path:
    """argparse type: a folder to write into, which may not exist yet but is no file, and
    which this user can write (checked before any work, without creating anything)."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a file, not a folder")
    _writable(path, text)
    return path


def output_folder(text: str) -> Path:
    """argparse type: `folder`, and none that holds (or lies in) the shipped experts."""
    path = folder(text)
    _not_shipped(path, text)
    return path


def existing_folder(text: str) -> Path:
    """argparse type: a folder that exists (read, never written)."""
    path = Path(text)
    if not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is not a folder")
    return path


def _not_shipped(path: Path, text: str) -> None:
    from bench import paths

    shipped = paths.inside_shipped(path)
    if shipped is not None:
        raise argparse.ArgumentTypeError(
            f"{text} would write into {shipped}, which holds the shipped experts; name another"
        )


def out_file(text: str) -> Path:
    """argparse type: a file to write, whose folder this user can write (or create)."""
    path = Path(text)
    if path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a folder, not a file")
    _writable(path.parent, text)
    _not_shipped(path.parent, text)
    return path


def _writable(path: Path, text: str) -> None:
    """Raise ArgumentTypeError unless `path`, or the nearest folder above it that exists (where
    it would be created), is a folder this user may write into."""
    existing = path
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if not existing.is_dir():
        raise argparse.ArgumentTypeError(f"{text}: {existing} is a file, not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise argparse.ArgumentTypeError(f"{text}: {existing} is not writable")


def duration(text: str) -> float:
    """argparse type: a positive duration in seconds, written like 90m, 2h, 1h30m or 45s."""
    try:
        return validate.duration(text)
    except ValueError as e:
        raise argparse.ArgumentTypeError(str(e)) from None
