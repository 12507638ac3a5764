"""How a number, an interval or a table is written in markdown: the formatting every table
and section of a report shares (`bench.analysis.tables`, `bench.analysis.sections`), and the
command line's. Pure text: nothing here computes a statistic or draws."""

from __future__ import annotations

import math
from collections.abc import Collection

import pandas as pd

from bench.analysis import labels
from bench.analysis.labels import Names


def steps(n: float) -> str:
    """Env steps, short: 420k, 1.25M; never for inf."""
    if math.isinf(n):
        return "never"
    return f"{n / 1e6:.2f}M" if n >= 1e6 else f"{n / 1e3:.0f}k"


def interval(estimate: float, lo: float, hi: float) -> str:
    """`estimate [lo, hi]`; the estimate alone for a point statistic (no interval)."""
    if pd.isna(lo) and pd.isna(hi):
        return f"{estimate:.2f}"
    return f"{estimate:.2f} [{lo:.2f}, {hi:.2f}]"


def mean_std(mean: float, std: float) -> str:
    """`mean ± std`; the mean alone where there is no spread (one seed)."""
    return f"{mean:.2f}" if pd.isna(std) else f"{mean:.2f} ± {std:.2f}"


def table(cells: pd.DataFrame, right: Collection[str] = ()) -> str:
    """`cells`, a frame of display strings, as a markdown table; the columns named in `right`
    (numbers) right-aligned, the rest left-aligned."""
    align = ["right" if c in right else "left" for c in cells.columns]
    # No number parsing: the cells are already formatted ("0.010" must not become "0.01").
    return cells.to_markdown(index=False, colalign=align, disable_numparse=True)


def demos_title(n: int) -> str:
    """ "5 demonstrations", "No demonstrations": a count's heading."""
    return labels.demos_label(n, "demonstration").capitalize()


def range_text(values: pd.Series) -> str:
    """ "3" or "3–5": the least and the most of `values` (counts)."""
    lo, hi = int(values.min()), int(values.max())
    return str(lo) if lo == hi else f"{lo}–{hi}"


def duration(seconds: float) -> str:
    """A wall time in the unit that reads best: "45 s", "12 min", "3.5 h"."""
    if not math.isfinite(seconds) or seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 2 * 3600:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def pair_label(a: str, b: str, names: Names) -> str:
    """ "GAIfO > GAIL*": the pair (a, b) of a probability of improvement, as labelled."""
    return f"{names.label(a)} > {names.label(b)}"
