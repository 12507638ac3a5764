"""Results folders for tests: copies of committed ones, made readable anywhere."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from pathlib import Path

from bench.harness.store import scan, write
from bench.harness.types import TrialResult


def copy_folder(
    results_dir: str | Path, to: str | Path, keep: Callable[[TrialResult], bool] | None = None
) -> Path:
    """Copy the records of `results_dir` (those `keep` keeps, where given) into `to` (a new
    folder), each a record of its own: a link is replaced by the record it names, as this
    suite's. Links name their records relative to their folder, so a folder taken out of its
    parent (a copy elsewhere, an archive) must be copied this way to stay readable."""
    to = Path(to)
    if to.exists():
        raise FileExistsError(f"{to} exists already")
    for result in scan(results_dir):
        if keep is None or keep(result):
            write(to, dataclasses.replace(result, stored_in=None))
    return to
