"""Parallel efficiency of the runner: trials per hour with N jobs over 1 job.

    python benchmarks/parallel_efficiency.py [--jobs 2] [--trials 8] [--budget 40960] [--repeats 3]

Runs the same small suite (GAIfO on InvertedPendulum, one demonstration) into
fresh temporary folders with 1 job and with N jobs, twice:

- cold: worker processes start inside the timed run. Each pays ~3 s once
  (importing torch and PyBullet, and torch.optim's first use of torch._dynamo),
  which short suites feel and long ones do not.
- warm: one tiny trial per worker runs first, untimed, so the timed run sees
  what the trials of a long suite see.

It prints trials/hour for each and their ratio divided by N. A shared VM's
speed drifts by 20% from minute to minute, so each figure is the median of
`--repeats` runs, the 1-job and N-job runs alternating.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

from joblib.externals.loky import get_reusable_executor

from bench.runner import run_suite
from bench.types import TrialSpec

ENV = "InvertedPendulumBulletEnv-v0"


def trials_per_hour(specs: list[TrialSpec], jobs: int) -> float:
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        summary = run_suite(specs, Path(tmp), jobs=jobs, progress=False)
        elapsed = time.perf_counter() - start
    assert summary.failed == 0 and summary.done == len(specs)
    return len(specs) / elapsed * 3600


def warm_up(jobs: int) -> None:
    """One smallest-budget trial per worker; loky keeps the workers for the next run."""
    specs = [TrialSpec("warm-up", ENV, "gaifo", 1, 1000 + i, 2048, 1) for i in range(jobs)]
    trials_per_hour(specs, jobs)


def efficiency(specs: list[TrialSpec], jobs: int, warm: bool, repeats: int) -> str:
    ones, manys = [], []
    for _ in range(repeats):
        if warm:
            warm_up(1)
        ones.append(trials_per_hour(specs, 1))
        if warm:
            warm_up(jobs)
        else:
            get_reusable_executor().shutdown(wait=True)  # fresh workers for a cold run
        manys.append(trials_per_hour(specs, jobs))
    one, many = statistics.median(ones), statistics.median(manys)
    label = "warm" if warm else "cold"
    return (
        f"{label}: 1 job {one:,.0f} trials/h   {jobs} jobs {many:,.0f} trials/h   "
        f"efficiency {many / one / jobs:.2f}"
    )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--trials", type=int, default=8)
    parser.add_argument("--budget", type=int, default=40960)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    specs = [
        TrialSpec("parallel", ENV, "gaifo", 1, seed, args.budget, 5) for seed in range(args.trials)
    ]
    print(efficiency(specs, args.jobs, warm=False, repeats=args.repeats), flush=True)
    print(efficiency(specs, args.jobs, warm=True, repeats=args.repeats))


if __name__ == "__main__":
    main()
