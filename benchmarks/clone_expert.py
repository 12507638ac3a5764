"""BCO's cloning step on the expert's own actions: the most BCO could score from its labels.

    python benchmarks/clone_expert.py --env InvertedDoublePendulum-v5 [--demos 5]
        [--seeds 0 1 2] [--input-norm none]

Each seed draws the demonstrations a Figure 2 trial of that seed draws, clones the expert's
true actions with BCO's `clone` (its config's defaults), and evaluates the cloned policy
on 10 episodes as the runner does. Where this scores low, BCO's shortfall is cloning's, not
its inverse model's. `--input-norm none` clones on raw inputs (BCO's `input_norm` setting)
instead of normalizing them by the demonstrations' states: where the expert's states span a
tiny region, normalizing by them magnifies a cloned policy's small drift into inputs it never
saw.
"""

from __future__ import annotations

import argparse

import numpy as np
import torch
from references import reference_returns  # benchmarks/references.py, beside this script

from algorithms.bco import INPUT_NORMS, BCOConfig, clone
from bench.harness.trial import EVAL_SEED, plan
from bench.harness.trial_log import StepTally
from bench.harness.types import TrialSpec
from bench.rl.networks import DeterministicPolicy
from bench.rl.rollout import evaluate


def cloned_return(env_id: str, n_demos: int, seed: int, input_norm: str) -> float:
    # A GAIL spec: the one learner given the expert's actions, the same draw of demonstrations.
    spec = TrialSpec("clone-expert", env_id, "gail", n_demos, seed, 1, 10, {})
    trial = plan(spec)
    states, actions = trial.inputs().state_actions()
    task = trial.task(StepTally())
    low, high = task.action_low, task.action_high
    torch.manual_seed(seed)
    labels = torch.from_numpy(np.clip(actions, low, high)).float()
    policy, _ = clone(
        torch.from_numpy(states).float(),
        labels,
        task,
        BCOConfig(input_norm=input_norm),
        torch.Generator().manual_seed(seed + 1),
    )
    eval_seed = EVAL_SEED + 1000 * seed
    eval_envs = [trial.make_env(eval_seed + i) for i in range(10)]
    return float(
        np.mean(evaluate(DeterministicPolicy(policy, low, high), eval_envs, 10, eval_seed))
    )


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--env", default="InvertedDoublePendulum-v5")
    parser.add_argument("--demos", type=int, default=5)
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    parser.add_argument("--input-norm", choices=INPUT_NORMS, default="demos")
    args = parser.parse_args()
    torch.set_num_threads(1)
    lo, hi = reference_returns(args.env)
    print(
        f"cloning the expert's actions on {args.env}, {args.demos} demo(s), input_norm {args.input_norm}:"
    )
    for seed in args.seeds:
        ret = cloned_return(args.env, args.demos, seed, args.input_norm)
        print(f"  seed {seed}: return {ret:9.1f}  normalized {(ret - lo) / (hi - lo):5.2f}")


if __name__ == "__main__":
    main()
