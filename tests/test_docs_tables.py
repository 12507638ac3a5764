"""The results tables quoted in the README and the docs agree with the committed report they
are copied from (`results/pybullet/report/per_env.csv`), so a redraw cannot leave them stale."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest

from bench import labels

ROOT = Path(__file__).resolve().parent.parent
PER_ENV = ROOT / "results" / "pybullet" / "report" / "per_env.csv"
ACROSS_COUNTS = "| 1 / 5 / 10 / 25 demos |"
COUNTS = (1, 5, 10, 25)
NAMES = {label.lower(): name for name, label in labels.LABELS.items()}


def _name(label: str) -> str:
    """'GAIL*' -> 'gail', 'Survival (floor)' -> 'survival'."""
    return NAMES[re.sub(r"\s*\(.*\)$", "", label).rstrip("*").lower()]


def _table(page: Path) -> tuple[list[str], list[list[str]]]:
    """The page's across-counts table: env labels and the rows below its header."""
    lines = page.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith(ACROSS_COUNTS))
    header = [cell.strip() for cell in lines[start].strip("|").split("|")]
    rows = []
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        rows.append([cell.strip() for cell in line.strip("|").split("|")])
    return header[1:], rows


@pytest.mark.parametrize("page", ["README.md", "docs/results/locomotion.md"])
def test_quoted_tables_match_the_committed_report(page):
    per_env = pd.read_csv(PER_ENV)
    env_ids = {labels.env_label(e): e for e in per_env.env_id.unique()}
    envs, rows = _table(ROOT / page)
    assert len(rows) >= 6
    for label, *cells in rows:
        if label.startswith("P("):  # 'P(GAIfO > GAIL*)': a probability of improvement
            algorithm, other = (_name(side) for side in label[2:-1].split(" > "))
            statistic = "p_improvement"
        else:
            algorithm, other, statistic = _name(label), None, "iqm"
        for env, cell in zip(envs, cells, strict=True):
            quoted = cell.split(" / ")
            counts = COUNTS if len(quoted) == len(COUNTS) else (COUNTS[1],)  # controls: one
            for n_demos, value in zip(counts, quoted, strict=True):
                row = per_env[
                    (per_env.env_id == env_ids[env])
                    & (per_env.n_demos == n_demos)
                    & (per_env.statistic == statistic)
                    & (per_env.algorithm == algorithm)
                    & (per_env.other.fillna("") == (other or ""))
                ]
                assert len(row) == 1, (page, label, env, n_demos)
                assert value == f"{row.estimate.iloc[0]:.2f}", (page, label, env, n_demos)
