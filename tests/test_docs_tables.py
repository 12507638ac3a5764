"""The results tables quoted in the README and the docs agree with the committed report they
are copied from (`sections.env_by_count`'s table in a suite's `report/report.md`), so a redraw
cannot leave them stale."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
ACROSS_COUNTS = re.compile(r"\|\s*(at )?1 / 5 / 10 / 25 demos\s*\|")


def _cells(line: str) -> list[str]:
    return [cell.strip() for cell in line.strip().strip("|").split("|")]


def _table(page: Path, after: str = "") -> dict[str, dict[str, str]]:
    """The page's first across-counts table below the first line that mentions `after` (a page
    may quote two suites, each below its link to the report): row label -> env label -> cell.
    A row label loses what only the docs add: 'Survival (floor)' -> 'Survival',
    'P(GAIfO > GAIL*)' -> 'GAIfO > GAIL*'."""
    lines = page.read_text().splitlines()
    below = next(i for i, line in enumerate(lines) if after in line)
    start = next(i for i, line in enumerate(lines) if i >= below and ACROSS_COUNTS.match(line))
    envs = _cells(lines[start])[1:]
    rows = {}
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        label, *cells = _cells(line)
        label = re.sub(r"^P\((.*)\)$", r"\1", re.sub(r" \((floor|ceiling)\)$", "", label))
        rows[label] = dict(zip(envs, cells, strict=True))
    return rows


@pytest.mark.parametrize(
    ("page", "suite"),
    [
        ("README.md", "pybullet"),
        ("README.md", "mujoco"),
        ("docs/results/locomotion.md", "pybullet"),
    ],
)
def test_quoted_tables_match_the_committed_report(page, suite):
    report_md = f"{suite}/report/report.md"  # the docs site reaches results/ as records/
    report, quoted = _table(ROOT / "results" / report_md), _table(ROOT / page, after=report_md)
    assert len(quoted) >= 6
    for label, cells in quoted.items():
        for env, cell in cells.items():
            values = report[label][env].split(" / ")
            if " / " not in cell:  # a control, quoted once: it takes no demonstrations
                values = sorted(set(values))
            assert cell.split(" / ") == values, (page, label, env)
