"""Parallel efficiency of the runner: trials per hour with N jobs over 1 job.

    python benchmarks/parallel_efficiency.py [--suite suites/quick.yaml] [--env ID]
                                             [--algorithm NAME] [--trials 16]
                                             [--jobs 2] [--repeats 3]

Runs `--trials` trials of a real suite (spread evenly over its trial list, so
every algorithm is in the sample) into fresh temporary folders, once with
1 job and once with N jobs, exactly as `bench run --jobs` would: the N-job run
starts its own worker processes inside the timed run. With the defaults that
is 16 quick-suite trials of ~7 s each, about 3 minutes per repeat.

Efficiency is (trials/h with N jobs) / (N x trials/h with 1 job). It splits
into two factors, printed for each repeat:
- busy: the share of the N cores' time spent inside trials. The rest is
  worker start-up (~1.5 s per worker: starting Python and importing torch and
  PyBullet) and the
  tail, when the last trial runs alone.
- slowdown: the trials' summed wall time with N jobs over that with 1 job:
  trials running side by side on shared hardware (and, on a VM, neighbours).
A shared VM's speed drifts by 20% from minute to minute, so the summary is the
median over `--repeats`, 1-job and N-job runs alternating.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

from joblib.externals.loky import get_reusable_executor

from bench.harness import store
from bench.harness.runner import run_suite
from bench.harness.suite import load_suite, select
from bench.harness.types import TrialSpec


@dataclass(frozen=True)
class Timing:
    elapsed: float
    """Wall time of the whole run, seconds."""
    trial_seconds: float
    """Sum of the trials' own wall times."""


def timed_run(specs: list[TrialSpec], jobs: int) -> Timing:
    get_reusable_executor().shutdown(wait=True)  # fresh workers, as a new `bench run` has
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        summary = run_suite(specs, Path(tmp), jobs=jobs, progress=False)
        elapsed = time.perf_counter() - start
        trial_seconds = sum(r.wall_time for r in store.scan(tmp))
    if summary.failed or summary.done != len(specs):
        raise SystemExit(f"benchmark run failed: {summary}")
    return Timing(elapsed, trial_seconds)


def spread(specs: list[TrialSpec], n: int) -> list[TrialSpec]:
    """`n` trials evenly spaced over the suite's list (all of them if it has fewer)."""
    if n >= len(specs):
        return specs
    return [specs[round(i * len(specs) / n)] for i in range(n)]


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--suite", default="suites/quick.yaml")
    parser.add_argument("--env", action="append", help="only this env of the suite (repeatable)")
    parser.add_argument(
        "--algorithm", action="append", help="only this algorithm of the suite (repeatable)"
    )
    parser.add_argument("--trials", type=int, default=16)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    specs = select(list(load_suite(args.suite).trials), args.suite, args.env, args.algorithm)
    specs = spread(specs, args.trials)
    print(f"{len(specs)} trials of {args.suite}, 1 job vs {args.jobs} jobs", flush=True)

    effs, busies, slowdowns = [], [], []
    for k in range(args.repeats):
        one, many = timed_run(specs, 1), timed_run(specs, args.jobs)
        eff = one.elapsed / (args.jobs * many.elapsed)
        busy = many.trial_seconds / (args.jobs * many.elapsed)
        slowdown = many.trial_seconds / one.trial_seconds
        effs.append(eff)
        busies.append(busy)
        slowdowns.append(slowdown)
        print(
            f"repeat {k + 1}: 1 job {one.elapsed:6.1f} s   {args.jobs} jobs {many.elapsed:6.1f} s   "
            f"efficiency {eff:.2f}   busy {busy:.2f}   slowdown {slowdown:.2f}",
            flush=True,
        )
    print(
        f"median: efficiency {statistics.median(effs):.2f}   busy {statistics.median(busies):.2f}"
        f"   slowdown {statistics.median(slowdowns):.2f}"
    )


if __name__ == "__main__":
    main()
