"""`bench list`, `bench experts` and `bench demos`: the algorithms, the experts and their demonstrations."""

from __future__ import annotations

import argparse
import dataclasses
import json
import shlex
from pathlib import Path
from typing import TYPE_CHECKING

from bench.cli.args import at_least, folder

if TYPE_CHECKING:
    import pandas as pd


def _experts_train(args: argparse.Namespace) -> int:
    from bench import envs, paths, validate
    from bench.demos.experts import ExpertError, ExpertTraining, train_expert

    envs.check_env_id(args.env_id)
    batch = {"n_envs": args.n_envs, "steps_per_env": args.steps_per_env}
    settings = {**batch, **args.hyperparams}  # --hyperparams has the last word
    try:
        validate.check_types(ExpertTraining, settings)
        cfg = ExpertTraining(**settings)
    except (TypeError, ValueError) as e:
        raise ExpertError(f"experts train: bad TRPO settings: {e}") from None
    if args.steps < cfg.batch_size:
        raise ExpertError(
            f"experts train: --steps {args.steps} is less than one TRPO batch "
            f"({cfg.n_envs} x {cfg.steps_per_env} = {cfg.batch_size} steps): nothing would train"
        )
    out = Path(args.out or paths.expert_dir(args.env_id))
    own = paths.expert_dir(args.env_id)
    if out.resolve().is_relative_to(paths.EXPERTS_DIR.resolve()) and out.resolve() != own.resolve():
        raise ExpertError(
            f"experts train: {out} is in the shipped experts' folder but is not {args.env_id}'s"
            f" ({own}): an expert is saved only into its own env's folder"
        )
    if (out / "policy.pt").exists() and not args.replace:
        raise ExpertError(
            f"experts train: {out} already has an expert: pass --out DIR to train one"
            " elsewhere, or --replace to overwrite it"
        )
    # Rebuilt from the parsed arguments, without --out: where it was saved is not how it was trained.
    command = ["bench", "experts", "train", args.env_id, "--steps", str(args.steps)]
    command += ["--seed", str(args.seed), "--n-envs", str(args.n_envs)]
    command += ["--steps-per-env", str(args.steps_per_env)]
    if args.hyperparams:
        command += ["--hyperparams", json.dumps(args.hyperparams)]
    meta = train_expert(
        args.env_id, args.steps, args.seed, cfg, out_dir=args.out, command=shlex.join(command)
    )
    print(
        f"{meta['env_id']}: return {meta['return_mean']:.1f} +- {meta['return_std']:.1f} "
        f"over {meta['eval_episodes']} episodes ({meta['train_steps']} steps, {meta['wall_time_s']:.0f} s)"
    )
    return 0


def _trpo_overrides(text: str) -> dict:
    """argparse type: a JSON object of ExpertTraining fields, or an argparse error naming the problem."""
    from bench.demos.experts import ExpertTraining

    try:
        value = json.loads(text)
    except json.JSONDecodeError as err:
        raise argparse.ArgumentTypeError(f"not JSON: {err}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError("must be a JSON object, e.g. '{\"hidden\": [128, 128]}'")
    known = {f.name for f in dataclasses.fields(ExpertTraining)}
    unknown = sorted(set(value) - known)
    if unknown:
        raise argparse.ArgumentTypeError(
            f"ExpertTraining has no field {', '.join(map(repr, unknown))} (known: {', '.join(sorted(known))})"
        )
    return value


EXPERT_NUMBERS = ("return (mean +- std)", "train steps", "wall time")
"""The columns of `bench experts list --markdown` that hold numbers, right-aligned."""


def experts_cells(experts: list[dict]) -> pd.DataFrame:
    """The display strings of `bench experts list --markdown`, a row per expert's meta.json."""
    import pandas as pd

    rows = [
        [
            m["env_id"],
            f"{m['return_mean']:.1f} +- {m['return_std']:.1f}",
            f"{m['train_steps']:,}",
            f"{m['wall_time_s'] / 60:.1f} min",
        ]
        for m in experts
    ]
    return pd.DataFrame(rows, columns=["env", *EXPERT_NUMBERS])


def _experts_list(args: argparse.Namespace) -> int:
    from bench.analysis import markdown
    from bench.demos.experts import list_experts
    from bench.paths import EXPERTS_DIR

    rows = list_experts()
    if not rows:
        print(f"no experts in {EXPERTS_DIR}")
        return 0
    if getattr(args, "markdown", False):
        print(markdown.table(experts_cells(rows), right=EXPERT_NUMBERS))
        return 0
    print(
        f"{'env':36s} {'return (mean +- std)':>22s} {'episodes':>8s} {'train steps':>12s} {'wall':>7s}"
    )
    for m in rows:
        ret = f"{m['return_mean']:.1f} +- {m['return_std']:.1f}"
        print(
            f"{m['env_id']:36s} {ret:>22s} {m['eval_episodes']:>8d} "
            f"{m['train_steps']:>12,d} {m['wall_time_s']:>6.0f}s"
        )
    return 0


def _list(args: argparse.Namespace) -> int:
    from bench.harness import registry

    print("algorithms:")
    for name, algo in sorted(registry.all_algorithms().items()):
        flag = "  (uses expert actions)" if algo.uses_actions else ""
        print(f"  {name:12s} inputs={algo.inputs:8s} {algo.description}{flag}")
    print()
    return _experts_list(args)


def _demos_export(args: argparse.Namespace) -> int:
    from bench.analysis import normalize
    from bench.demos import minari_io
    from bench.harness import frames

    if not Path(args.references).is_dir():
        raise FileNotFoundError(f"{args.references}: no such results folder")
    refs = normalize.reference_returns(frames.load(args.references)).set_index("env_id")
    if args.env_id not in refs.index or refs.loc[args.env_id].isna().any():
        raise normalize.NormalizationError(
            f"{args.references} has no random and expert trials of {args.env_id} to take "
            "ref_min_score and ref_max_score from"
        )
    random, expert = (
        refs.loc[args.env_id, normalize.RANDOM],
        refs.loc[args.env_id, normalize.EXPERT],
    )
    name = minari_io.export(args.env_id, args.dir, random, expert)
    print(
        f"wrote {Path(args.dir) / name} (ref_min_score {random:.1f}, ref_max_score {expert:.1f}"
        f" from {args.references}); load it with MINARI_DATASETS_PATH={args.dir}"
        f" minari.load_dataset({name!r})"
    )
    return 0


def _demos_show(args: argparse.Namespace) -> int:
    from bench import envs
    from bench.demos import pools

    envs.check_env_id(args.env_id)
    if args.demos is not None and args.demos > pools.POOL_SIZE:
        raise pools.DemoError(
            f"demos show: --demos {args.demos}: the pool has {pools.POOL_SIZE} episodes"
        )
    episodes = pools.pool_episodes(pools.ensure_pool(args.env_id), args.env_id)
    falls = [e for e in episodes if e.terminated]
    print(
        f"{args.env_id}: {len(episodes)} expert episodes (env seeds {pools.POOL_SEED}-"
        f"{pools.POOL_SEED + len(episodes) - 1}), {len(falls)} ending in a terminal state"
    )
    drawn = {}
    header = f"{'episode':>7s} {'steps':>6s} {'return':>9s}  {'ends':12s}"
    if args.demos is not None:
        drawn = pools.drawn_by(len(episodes), args.demos, range(args.seeds))
        count = f"{args.demos} demo{'s' if args.demos > 1 else ''}"
        header += f"  seeds given it at {count} (of 0-{args.seeds - 1})"
    print(header)
    for e in episodes:
        ends = "terminal" if e.terminated else "time limit"
        seeds = ", ".join(map(str, drawn.get(e.index, [])))
        print(f"{e.index:7d} {e.steps:6d} {e.expert_return:9.1f}  {ends:12s}  {seeds}".rstrip())
    return 0


def add(sub: argparse._SubParsersAction) -> None:
    """The `list`, `experts` and `demos` commands."""
    lst = sub.add_parser("list", help="registered algorithms and available experts")
    lst.set_defaults(func=_list)

    experts = sub.add_parser("experts", help="train and list TRPO experts")
    esub = experts.add_subparsers(dest="experts_command", required=True, metavar="ACTION")
    tr = esub.add_parser("train", help="train a TRPO expert on the env reward and save it")
    tr.add_argument("env_id", help="gymnasium id, e.g. HopperBulletEnv-v0")
    tr.add_argument(
        "--steps", type=at_least(1), default=1_000_000, help="env steps of training (default 1e6)"
    )
    tr.add_argument("--seed", type=at_least(0), default=0, help="training seed (default 0)")
    tr.add_argument("--n-envs", type=at_least(1), default=8, help="envs per batch (default 8)")
    tr.add_argument(
        "--steps-per-env",
        type=at_least(1),
        default=256,
        help="steps per env per update (default 256)",
    )
    tr.add_argument(
        "--hyperparams",
        type=_trpo_overrides,
        default={},
        help='ExpertTraining (TRPOConfig) overrides as JSON, e.g. \'{"hidden": [128, 128], "init_log_std": -1.0}\'',
    )
    tr.add_argument(
        "--out",
        type=folder,
        default=None,
        help="save here instead of results/experts/ENV_ID (to compare before replacing the shipped one)",
    )
    tr.add_argument(
        "--replace",
        action="store_true",
        help="overwrite the expert in results/experts/ENV_ID (refused without this flag)",
    )
    tr.set_defaults(func=_experts_train)
    ls = esub.add_parser("list", help="show the available experts and their returns")
    ls.add_argument("--markdown", action="store_true", help="print a markdown table")
    ls.set_defaults(func=_experts_list)

    dem = sub.add_parser("demos", help="the expert demonstrations, in other formats")
    dsub = dem.add_subparsers(dest="demos_command", required=True, metavar="ACTION")
    exp = dsub.add_parser(
        "export",
        help="write an env's expert pool as a local Minari dataset",
        description="Write ENV_ID's expert demonstration pool (observations, actions, rewards,"
        " terminations) as a Minari dataset under DIR, with the random and expert mean returns"
        " of a results folder as ref_min_score / ref_max_score.",
    )
    exp.add_argument("env_id", help="gymnasium id, e.g. HopperBulletEnv-v0")
    exp.add_argument("dir", type=folder, help="Minari datasets folder (MINARI_DATASETS_PATH)")
    exp.add_argument(
        "--references",
        required=True,
        metavar="RESULTS",
        help="results folder whose random and expert trials define the scores, e.g. results/pybullet",
    )
    exp.set_defaults(func=_demos_export)
    show = dsub.add_parser(
        "show",
        help="list an env's expert pool: each episode's length, return and how it ended",
        description="List ENV_ID's expert demonstration pool (recorded first if not cached): each"
        " episode's steps, the expert's return and whether it ended in a terminal state (a fall)"
        " or at the time limit; with --demos N, which seeds' trials with N demonstrations are"
        " given each episode.",
    )
    show.add_argument("env_id", help="gymnasium id, e.g. Walker2DBulletEnv-v0")
    show.add_argument(
        "--demos", type=at_least(1), metavar="N", help="show which seeds draw each episode at N"
    )
    show.add_argument(
        "--seeds", type=at_least(1), default=10, help="seeds 0..K-1 to show (default 10)"
    )
    show.set_defaults(func=_demos_show)
