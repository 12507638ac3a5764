"""The results tables quoted in the README and the docs agree with the committed report they
are copied from (`markdown.env_by_count`'s table in `results/pybullet/report/report.md`), so a
redraw cannot leave them stale."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
REPORT = ROOT / "results" / "pybullet" / "report" / "report.md"
ACROSS_COUNTS = re.compile(r"\|\s*(at )?1 / 5 / 10 / 25 demos\s*\|")


def _cells(line: str) -> list[str]:
    return [cell.strip() for cell in line.strip().strip("|").split("|")]


def _table(page: Path) -> dict[str, dict[str, str]]:
    """The page's across-counts table: row label -> env label -> cell. A row label loses what
    only the docs add: 'Survival (floor)' -> 'Survival', 'P(GAIfO > GAIL*)' -> 'GAIfO > GAIL*'."""
    lines = page.read_text().splitlines()
    start = next(i for i, line in enumerate(lines) if ACROSS_COUNTS.match(line))
    envs = _cells(lines[start])[1:]
    rows = {}
    for line in lines[start + 2 :]:
        if not line.startswith("|"):
            break
        label, *cells = _cells(line)
        label = re.sub(r"^P\((.*)\)$", r"\1", re.sub(r" \((floor|ceiling)\)$", "", label))
        rows[label] = dict(zip(envs, cells, strict=True))
    return rows


@pytest.mark.parametrize("page", ["README.md", "docs/results/locomotion.md"])
def test_quoted_tables_match_the_committed_report(page):
    report, quoted = _table(REPORT), _table(ROOT / page)
    assert len(quoted) >= 6
    for label, cells in quoted.items():
        for env, cell in cells.items():
            values = report[label][env].split(" / ")
            if " / " not in cell:  # a control, quoted once: it takes no demonstrations
                values = sorted(set(values))
            assert cell.split(" / ") == values, (page, label, env)
