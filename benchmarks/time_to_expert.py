"""Env steps and wall time for an algorithm to first reach a normalized return.

    python benchmarks/time_to_expert.py [--algorithm gaifo] [--env InvertedPendulumBulletEnv-v0]
        [--demos 1] [--seeds 0 1] [--threshold 0.95] [--eval-every 2048] [--budget 200000]
        [--hyperparams '{"n_envs": 4}']

Seeds run side by side (one process each). The policy is evaluated (5
episodes) after every update once `--eval-every` steps have passed; wall time
counts training only, not these evaluations. Run it for `survival` too: on
tasks that end early, that is how much of the speed a positive reward buys
by paying for staying alive.
"""

from __future__ import annotations

import argparse
import json
import time

import joblib
import numpy as np
import torch
from references import reference_returns  # benchmarks/references.py, beside this script

from bench import envs
from bench.harness.trial import plan
from bench.harness.trial_log import StepTally
from bench.harness.types import TrialSpec
from bench.rl.rollout import evaluate


class Reached(Exception):
    pass


class ThresholdLogger:
    def __init__(self, env_id: str, lo: float, hi: float, threshold: float, every: int) -> None:
        self.eval_envs = [envs.make(env_id, 10_000 + i) for i in range(5)]
        self.lo, self.hi, self.threshold, self.every = lo, hi, threshold, every
        self.next, self.eval_time, self.start = 0, 0.0, time.perf_counter()

    def checkpoint(self, env_steps: int, policy) -> None:
        if env_steps < self.next:
            return
        self.next = env_steps + self.every
        t = time.perf_counter()
        score = (np.mean(evaluate(policy, self.eval_envs, 5, 10_000)) - self.lo) / (
            self.hi - self.lo
        )
        self.eval_time += time.perf_counter() - t
        if score >= self.threshold:
            raise Reached((env_steps, time.perf_counter() - self.start - self.eval_time, score))

    def log(self, env_steps: int, **scalars: float) -> None:
        pass


def run(spec: TrialSpec, lo: float, hi: float, threshold: float, every: int) -> tuple:
    torch.set_num_threads(1)
    trial = plan(spec)
    algo, task = trial.algorithm, trial.task(StepTally())
    logger = ThresholdLogger(spec.env_id, lo, hi, threshold, every)
    try:
        algo.train(
            task,
            trial.inputs(),
            spec.budget,
            spec.seed,
            logger,
            algo.make_config(spec.hyperparams),
        )
    except Reached as r:
        return r.args[0]
    return (None, None, None)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--algorithm", default="gaifo")
    parser.add_argument("--env", default="InvertedPendulumBulletEnv-v0")
    parser.add_argument("--demos", type=int, default=1)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--threshold", type=float, default=0.95)
    parser.add_argument("--eval-every", type=int, default=2048)
    parser.add_argument("--budget", type=int, default=200_000)
    parser.add_argument("--hyperparams", type=json.loads, default={}, help="JSON config overrides")
    args = parser.parse_args()
    lo, hi = reference_returns(args.env)
    specs = [
        TrialSpec(
            "speed", args.env, args.algorithm, args.demos, s, args.budget, 5, args.hyperparams
        )
        for s in args.seeds
    ]
    wall = time.perf_counter()
    results = joblib.Parallel(n_jobs=len(specs))(
        joblib.delayed(run)(s, lo, hi, args.threshold, args.eval_every) for s in specs
    )
    print(
        f"{args.algorithm} {args.hyperparams or ''} on {args.env}, {args.demos} demo(s): first normalized >= {args.threshold}"
    )
    for spec, (steps, seconds, score) in zip(specs, results, strict=True):
        if steps is None:
            print(f"  seed {spec.seed}: not reached within {args.budget} steps")
        else:
            print(
                f"  seed {spec.seed}: {steps:7,d} env steps, {seconds:5.1f} s training (score {score:.2f})"
            )
    print(
        f"  all seeds side by side: {time.perf_counter() - wall:.1f} s wall, evaluations and start-up included"
    )


if __name__ == "__main__":
    main()
