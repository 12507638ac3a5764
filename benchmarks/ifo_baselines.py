"""The IfO baselines side by side: BCO, TCN and GAIfO, normalized by random (0) and expert (1).

    python benchmarks/ifo_baselines.py [--envs InvertedPendulumBulletEnv-v0] [--seeds 3] [--jobs 2]

Runs InvertedPendulum (100k env steps per trial) and, when an expert is shipped for it, Hopper
(1M steps: ~10 min per trial per core) through bench.runner.run_suite, then prints the normalized
return of each algorithm and seed. The `survival` control (TRPO on +1 per step, no demos) runs
too: on tasks that end early, it is what an imitation reward earns for staying alive alone.
Records go to results/ifo-baselines/ (with the suite file); rerunning skips finished trials.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import pandas as pd

from bench import paths, store
from bench.normalize import normalize
from bench.runner import run_suite
from bench.suite import expand, load_suite

BUDGETS = {"InvertedPendulumBulletEnv-v0": 100_000, "HopperBulletEnv-v0": 1_000_000}
ALGORITHMS = ["random", "expert", "survival", "bco", "tcn", "gaifo"]
LEARNERS = ["bco", "tcn", "gaifo", "survival"]


def write_suite(folder: Path, env_ids: list[str], seeds: int, n_demos: int, episodes: int) -> Path:
    envs = ", ".join(f"{e}: {{budget: {BUDGETS[e]}}}" for e in env_ids)
    path = folder / "suite.yaml"
    folder.mkdir(parents=True, exist_ok=True)
    path.write_text(
        f"name: ifo-baselines\nenvs: {{{envs}}}\ndemos: [{n_demos}]\n"
        f"algorithms: [{', '.join(ALGORITHMS)}]\nseeds: {seeds}\neval_episodes: {episodes}\n"
    )
    return path


def report(df: pd.DataFrame) -> str:
    """Normalized return per env, algorithm and seed, then mean and std over seeds."""
    df = normalize(df)
    refs = df[df.algorithm.isin(["random", "expert"])].groupby(["env_id", "algorithm"])["return"]
    lines = ["reference returns (mean over seeds):", refs.mean().unstack().round(1).to_string(), ""]
    ok = df[df.algorithm.isin(LEARNERS)]
    table = ok.pivot_table(index=["env_id", "algorithm"], columns="seed", values="normalized")
    table["mean"], table["std"] = table.mean(axis=1), table.std(axis=1)
    lines += ["normalized return (0 = random, 1 = expert):", table.round(2).to_string()]
    failed = df[df.status != "ok"]
    if len(failed):
        lines += ["", f"{len(failed)} failed trials: {sorted(set(failed.algorithm))}"]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    default_envs = [e for e in BUDGETS if paths.has_expert(e)]
    parser.add_argument("--envs", nargs="+", default=default_envs, choices=list(BUDGETS))
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--demos", type=int, default=1, help="demonstrations per trial")
    parser.add_argument("--eval-episodes", type=int, default=10)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--results", type=Path, default=Path("results/ifo-baselines"))
    args = parser.parse_args()

    suite = load_suite(
        write_suite(args.results, args.envs, args.seeds, args.demos, args.eval_episodes)
    )
    specs = expand(suite)
    summary = run_suite(specs, args.results, jobs=args.jobs)
    print(f"{summary.done} done, {summary.failed} failed, {summary.skipped} already finished")
    df = store.load(args.results)  # only this suite's trials: the folder may hold earlier runs
    print(report(df[df.trial_id.isin({s.trial_id for s in specs})]))


if __name__ == "__main__":
    main()
