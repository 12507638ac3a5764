"""Parallel efficiency of the runner: trials per hour with N jobs over 1 job.

    python benchmarks/parallel_efficiency.py [--jobs 2] [--trials 8] [--budget 40960]

Runs the same small suite (GAIfO on InvertedPendulum, one demonstration) into
fresh temporary folders with 1 job and with N jobs, worker start-up included,
and prints trials/hour for each and their ratio divided by N.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from bench.runner import run_suite
from bench.types import TrialSpec


def trials_per_hour(specs: list[TrialSpec], jobs: int) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        summary = run_suite(specs, Path(tmp), jobs=jobs, progress=False)
        elapsed = time.perf_counter() - start
    assert summary.failed == 0 and summary.done == len(specs)
    return len(specs) / elapsed * 3600


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--trials", type=int, default=8)
    parser.add_argument("--budget", type=int, default=40960)
    args = parser.parse_args()
    specs = [
        TrialSpec("parallel", "InvertedPendulumBulletEnv-v0", "gaifo", 1, seed, args.budget, 5)
        for seed in range(args.trials)
    ]
    one = trials_per_hour(specs, 1)
    many = trials_per_hour(specs, args.jobs)
    print(
        f"1 job: {one:,.0f} trials/h   {args.jobs} jobs: {many:,.0f} trials/h   "
        f"efficiency: {many / one / args.jobs:.2f}"
    )


if __name__ == "__main__":
    main()
