"""The tidy frames read from a results folder's records (`bench.harness.store`): one row per
trial, per learning-curve point, or per logged value, each with the trial's spec and what its
algorithm is (role, family, label), as the analysis reads them."""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from bench.harness.store import scan, status_of
from bench.harness.types import TrialResult

SPEC_COLUMNS = ["suite", "env_id", "algorithm", "n_demos", "seed", "budget", "observation"]
ROLE_COLUMNS = ["method", "role", "family", "label"]
"""What the shown algorithm (`algorithm`) is: the registered one it runs, its role, its
optimizer family and its display label, as its records say (`bench.harness.registry.Algorithm`)."""
TRIAL_COLUMNS = [
    *SPEC_COLUMNS,
    *ROLE_COLUMNS,
    "inputs",
    "trial_id",
    "setting",
    "status",
    "return",
    "return_std",
    "env_steps",
    "wall_time",
    "cpu_time",
    "failure",
    "state_distance",
    "software",
]
CURVE_COLUMNS = ["trial_id", *SPEC_COLUMNS, *ROLE_COLUMNS, "inputs", "env_steps", "return"]
LOG_COLUMNS = ["trial_id", *SPEC_COLUMNS, *ROLE_COLUMNS, "key", "index", "value"]


def load(results_dir: str | Path) -> pd.DataFrame:
    """One row per trial: TRIAL_COLUMNS; `return` is the mean evaluation return (NaN if failed)."""
    return _trials(scan(results_dir))


def load_curves(results_dir: str | Path) -> pd.DataFrame:
    """One row per evaluation point of every ok trial: CURVE_COLUMNS.

    Failed trials are left out: their curves stop early, and mixing them in
    would change the number of seeds behind each point along the curve.
    """
    return _curves(scan(results_dir))


def load_with_curves(results_dir: str | Path) -> tuple[pd.DataFrame, pd.DataFrame]:
    """`load` and `load_curves` from one reading of the records (a report needs both, and
    reading a large folder's records is most of what it costs before its statistics)."""
    records = list(scan(results_dir))
    return _trials(records), _curves(records)


def _trials(records: Iterable[TrialResult]) -> pd.DataFrame:
    rows = [_trial_row(r) for r in records]
    return _frame(rows, TRIAL_COLUMNS, ["env_id", "algorithm", "n_demos", "seed", "trial_id"])


def _curves(records: Iterable[TrialResult]) -> pd.DataFrame:
    rows = [
        {**_spec_row(r), "inputs": r.inputs, "env_steps": p.env_steps, "return": p.mean_return}
        for r in records
        if r.status == "ok"
        for p in r.curve
    ]
    return _frame(rows, CURVE_COLUMNS, ["env_id", "algorithm", "n_demos", "seed", "env_steps"])


def load_logs(results_dir: str | Path) -> pd.DataFrame:
    """Algorithm diagnostics, long format: LOG_COLUMNS; `index` counts entries per key."""
    rows = [
        {**_spec_row(r), "key": key, "index": i, "value": v}
        for r in scan(results_dir)
        for key, values in r.logs.items()
        for i, v in enumerate(values)
    ]
    return _frame(rows, LOG_COLUMNS, ["env_id", "algorithm", "n_demos", "seed", "key", "index"])


def _spec_row(r: TrialResult) -> dict[str, Any]:
    """The spec's columns and ROLE_COLUMNS; `algorithm` is the name shown (a labelled
    variant's label) and `method` the registered algorithm it runs."""
    row = {"trial_id": r.trial_id, "setting": r.spec.setting_id}
    row |= {c: getattr(r.spec, c) for c in SPEC_COLUMNS}
    shown = {"algorithm": r.spec.shown, "method": r.spec.algorithm}
    described = {"role": r.role or "learner", "family": r.family, "label": r.label or r.spec.shown}
    return row | shown | described | {"observation": r.spec.observation or "states"}


def _trial_row(r: TrialResult) -> dict[str, Any]:
    status = status_of(r)
    ok = status == "ok"
    returns = np.asarray(r.returns, dtype=float)
    return {
        **_spec_row(r),
        "inputs": r.inputs,
        "status": status,
        "return": float(returns.mean()) if ok else math.nan,
        "return_std": float(returns.std()) if ok else math.nan,
        "env_steps": r.env_steps,
        "wall_time": r.wall_time,
        "cpu_time": math.nan if r.cpu_time is None else r.cpu_time,
        "failure": None if ok or r.raised is None else r.raised[:FAILURE_CHARS],
        "state_distance": math.nan
        if r.state_distance is None or not ok
        else float(r.state_distance),
        "software": software(r.versions),
    }


FAILURE_CHARS = 200
"""The most of what a failed trial raised (`TrialResult.raised`) a frame keeps (the whole
traceback is in the record)."""


def software(versions: dict[str, str]) -> str:
    """The package versions a trial ran with, as one label: "gymnasium 1.4.0, pybullet ..."."""
    return ", ".join(f"{pkg} {v}" for pkg, v in sorted(versions.items()))


def _frame(rows: list[dict], columns: list[str], sort_by: list[str]) -> pd.DataFrame:
    frame = pd.DataFrame(rows, columns=columns)
    return frame.sort_values(sort_by, kind="stable", ignore_index=True)
