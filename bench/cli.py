"""`bench`: run suites, plot and report results, train and list experts."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable

from bench.envs import EnvError


def _experts_train(args: argparse.Namespace) -> int:
    from bench import envs
    from bench.experts import train_expert
    from bench.rl.trpo import TRPOConfig

    envs.check_env_id(args.env_id)
    cfg = TRPOConfig(n_envs=args.n_envs, steps_per_env=args.steps_per_env)
    meta = train_expert(args.env_id, args.steps, args.seed, cfg)
    print(
        f"{meta['env_id']}: return {meta['return_mean']:.1f} +- {meta['return_std']:.1f} "
        f"over {meta['eval_episodes']} episodes ({meta['train_steps']} steps, {meta['wall_time_s']:.0f} s)"
    )
    return 0


def _experts_list(args: argparse.Namespace) -> int:
    from bench.experts import list_experts
    from bench.paths import EXPERTS_DIR

    rows = list_experts()
    if not rows:
        print(f"no experts in {EXPERTS_DIR}")
        return 0
    print(f"{'env':36s} {'return (mean +- std)':>22s} {'episodes':>8s} {'train steps':>12s} {'wall':>7s}")
    for m in rows:
        ret = f"{m['return_mean']:.1f} +- {m['return_std']:.1f}"
        print(f"{m['env_id']:36s} {ret:>22s} {m['eval_episodes']:>8d} {m['train_steps']:>12,d} {m['wall_time_s']:>6.0f}s")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="bench",
        description="ifo-bench: compare imitation-from-observation algorithms on PyBullet.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    experts = sub.add_parser("experts", help="train and list TRPO experts")
    esub = experts.add_subparsers(dest="experts_command", required=True, metavar="ACTION")
    tr = esub.add_parser("train", help="train a TRPO expert on the env reward and save it")
    tr.add_argument("env_id", help="gymnasium id, e.g. HopperBulletEnv-v0")
    tr.add_argument("--steps", type=int, default=1_000_000, help="env steps of training (default 1e6)")
    tr.add_argument("--seed", type=int, default=0, help="training seed (default 0)")
    tr.add_argument("--n-envs", type=int, default=8, help="envs per batch (default 8)")
    tr.add_argument("--steps-per-env", type=int, default=256, help="steps per env per update (default 256)")
    tr.set_defaults(func=_experts_train)
    ls = esub.add_parser("list", help="show the available experts and their returns")
    ls.set_defaults(func=_experts_list)
    return parser


USER_ERRORS: tuple[type[Exception], ...] = (EnvError,)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except USER_ERRORS as e:
        print(f"bench: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("bench: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
