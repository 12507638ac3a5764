"""Does a committed record reproduce? Rerun its spec and compare, record by record.

A whole trial costs what it cost; its first updates cost seconds and say as much. A trial
that trains is rerun for its first `steps` env steps (past its algorithm's least budget: BCO's
pre-demonstration phase), and every series it logs once per
update (losses, KL, the reward's mean: all but timings) is compared with the record's, value
for value: two runs that agree on every value of their first updates computed the same floats,
and two that part, part there (training amplifies the last bit; they do not meet again). A
record without such a series (the references, which only evaluate) or whose budget is no more
than `steps` is rerun whole and its returns, curve and logs are compared. Nothing is written.
"""

from __future__ import annotations

import dataclasses
import random
from collections import defaultdict
from collections.abc import Iterable
from dataclasses import dataclass

from bench import kernels
from bench.harness import registry
from bench.harness.trial import plan, run_trial
from bench.harness.types import TrialResult

PREFIX_STEPS = 16_384
"""Env steps a verification trains a record's trial for: four TRPO updates of 4,096 steps."""


@dataclass(frozen=True)
class Verdict:
    record: TrialResult
    identical: bool
    how: str
    """What was compared ("first 4 updates", "whole trial"), and where it parted if it did."""


def _series(result: TrialResult) -> dict[str, list[float]]:
    """The record's logged series but timings (which no two runs share)."""
    return {k: v for k, v in result.logs.items() if not k.endswith("_s")}


def verify(record: TrialResult, steps: int = PREFIX_STEPS) -> Verdict:
    """Rerun `record`'s trial (its first `steps` env steps where it trains for more and logs
    per update) and say whether it computes what the record holds."""
    logged = _series(record)
    algorithm = registry.get(record.spec.algorithm)
    floor = 0
    if algorithm.min_budget is not None:  # BCO's first phase takes its pre-demonstration steps
        floor = algorithm.min_budget(registry.config_of(record.spec))
    steps = steps if steps > floor else floor + steps
    whole = not logged or record.spec.budget <= steps
    spec = record.spec if whole else dataclasses.replace(record.spec, budget=steps)
    rerun = run_trial(spec, plan(spec).inputs())
    if rerun.status != "ok":
        return Verdict(record, False, f"the rerun failed: {rerun.raised or '?'}")
    if whole:
        again = _series(rerun)
        parts = [
            ("returns", record.returns, rerun.returns),
            ("curve", record.curve, rerun.curve),
            *((k, v, again.get(k)) for k, v in logged.items()),
        ]
        parted = [name for name, a, b in parts if a != b]
        how = "whole trial" + (f": {', '.join(parted)} differ" if parted else "")
        return Verdict(record, not parted, how)
    # The last update of a shortened run may be cut by its budget (BCO's iterations are):
    # compared are the ones before it.
    again = {k: v[:-1] if len(v) > 1 else v for k, v in _series(rerun).items()}
    first: tuple[int, str] | None = None  # (index, what) of the earliest value that differs
    for key, values in logged.items():
        theirs = again.get(key, [])
        if not theirs:
            return Verdict(record, False, f"the rerun logs no {key}")
        part = next(
            (i for i, (a, b) in enumerate(zip(values, theirs, strict=False)) if a != b), None
        )
        if part is not None and (first is None or part < first[0]):
            first = (part, f"{key} {theirs[part]:.6g} against {values[part]:.6g}")
    updates = len(again.get("env_steps", []))
    if first is not None:
        return Verdict(record, False, f"parts at update {first[0] + 1} of {updates}: {first[1]}")
    return Verdict(record, True, f"first {updates} updates")


def sample(records: Iterable[TrialResult], n: int, seed: int = 0) -> list[TrialResult]:
    """`n` ok records spread over envs and algorithms: one of each (env, algorithm) in turn,
    the cells in a random order (so a sample smaller than the cells still spans every env and
    algorithm), drawn at random within each (seeded), until `n`."""
    cells: dict[tuple, list[TrialResult]] = defaultdict(list)
    for r in records:
        if r.status == "ok":
            cells[(r.spec.env_id, r.spec.shown)].append(r)
    rng = random.Random(seed)
    for rows in cells.values():
        rng.shuffle(rows)
    order = sorted(cells)
    rng.shuffle(order)
    chosen: list[TrialResult] = []
    while len(chosen) < n and any(cells.values()):
        for key in order:
            if cells[key] and len(chosen) < n:
                chosen.append(cells[key].pop())
    return chosen


def where() -> str:
    """What this machine computes with, as a verification says it: its CPU and kernels."""
    import platform
    from pathlib import Path

    cpu = platform.machine()
    info = Path("/proc/cpuinfo")
    if info.is_file():
        names = [
            line.split(":", 1)[1].strip()
            for line in info.read_text().splitlines()
            if line.startswith("model name")
        ]
        cpu = names[0] if names else cpu
    return f"{cpu}, kernels {kernels.describe()}"
