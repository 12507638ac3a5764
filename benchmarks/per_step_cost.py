"""What each TRPO learner costs per env step beside GAIfO, trained with its suite's settings.

    python benchmarks/per_step_cost.py Walker2d-v5 --steps 16384 --rounds 2
    python benchmarks/per_step_cost.py InvertedPendulum-v5 --steps 32768 --algorithms gaifo pwil

Each algorithm's seed-0 trial at 5 demonstrations (from suites/mujoco.yaml and
suites/mujoco-since.yaml, so each runs with the settings its cells run with) is cut to
`--steps` env steps, one evaluation episode and one curve point, and run in this process, the
algorithms interleaved `--rounds` times; each row is its best round, in seconds per 1k env steps
(start and evaluation included), and its ratio to GAIfO's. Ratios are what to read: run it on
a quiet machine for seconds.
"""

from __future__ import annotations

import argparse
import dataclasses
import time

import torch

from bench.harness.suite import load_suite
from bench.harness.trial import plan, run_trial

SUITES = ("suites/mujoco.yaml", "suites/mujoco-since.yaml")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("env_id")
    parser.add_argument("--steps", type=int, default=16_384)
    parser.add_argument("--rounds", type=int, default=2)
    parser.add_argument("--algorithms", nargs="+", default=["gaifo", "airlfo", "wailfo", "pwil"])
    args = parser.parse_args()
    torch.set_num_threads(1)
    cut = dict(budget=args.steps, eval_episodes=1, curve_points=1)
    specs = {
        spec.algorithm: dataclasses.replace(spec, **cut)
        for suite in SUITES
        for spec in load_suite(suite).trials
        if (spec.env_id, spec.seed, spec.n_demos) == (args.env_id, 0, 5)
        and spec.algorithm in args.algorithms
    }
    seconds: dict[str, list[float]] = {name: [] for name in specs}
    for _ in range(args.rounds):
        for name, spec in specs.items():
            start = time.perf_counter()
            result = run_trial(spec, plan(spec).inputs())
            assert result.status == "ok", result.traceback
            seconds[name].append(time.perf_counter() - start)
    gaifo = min(seconds["gaifo"]) if "gaifo" in seconds else float("nan")
    for name, times in seconds.items():
        best = min(times)
        print(
            f"{args.env_id} {name:8s} {best / args.steps * 1e3:6.3f} s per 1k steps  x{best / gaifo:.2f} GAIfO"
        )


if __name__ == "__main__":
    main()
