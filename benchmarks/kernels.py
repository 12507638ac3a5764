"""What portable kernels cost: a trial's training with each library's own kernels against the
same trial with them pinned (`kernels: portable`), env steps per second on one core.

    python benchmarks/kernels.py [--steps 50000] [--envs HalfCheetah-v5 Hopper-v5] [--algorithm gaifo]

Each measurement runs in a fresh process (the libraries read their kernel switches once), one
after the other, native and portable interleaved `--repeats` times; prints the median of each
and their ratio. Time it on a quiet machine: nothing else may load the cores.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys

from bench import kernels

CHILD = """
import json, sys, time
import torch
from bench.harness.trial import plan, run_trial
from bench.harness.types import TrialSpec
env_id, algorithm, steps = sys.argv[1], sys.argv[2], int(sys.argv[3])
spec = TrialSpec("kernels", env_id, algorithm, 5 if algorithm != "oracle" else 0, 0, steps, 1,
                 curve_points=1)
inputs = plan(spec).inputs()
start = time.perf_counter()
result = run_trial(spec, inputs)
assert result.status == "ok", result.traceback
print(json.dumps({"steps_per_s": steps / (time.perf_counter() - start)}))
"""


def measure(env_id: str, algorithm: str, steps: int, kind: str) -> float:
    env = {**os.environ, **kernels.pins(kind)}
    for name in kernels.PORTABLE if kind == "native" else ():
        env.pop(name, None)
    out = subprocess.run(
        [sys.executable, "-c", CHILD, env_id, algorithm, str(steps)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])["steps_per_s"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--envs", nargs="+", default=["HalfCheetah-v5", "Hopper-v5"])
    parser.add_argument("--algorithm", default="gaifo")
    parser.add_argument("--steps", type=int, default=50_000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    print(f"{'env':18s} {'algorithm':10s} {'native/s':>9s} {'portable/s':>11s} {'ratio':>6s}")
    for env_id in args.envs:
        runs: dict[str, list[float]] = {"native": [], "portable": []}
        for _ in range(args.repeats):
            for kind in runs:
                runs[kind].append(measure(env_id, args.algorithm, args.steps, kind))
        native, portable = (statistics.median(runs[k]) for k in ("native", "portable"))
        print(
            f"{env_id:18s} {args.algorithm:10s} {native:9.0f} {portable:11.0f}"
            f" {portable / native:6.2f}",
            flush=True,
        )


if __name__ == "__main__":
    main()
