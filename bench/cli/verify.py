"""`bench verify FOLDER`: do its records reproduce here? Rerun a sample and compare."""

from __future__ import annotations

import argparse
import sys

from bench.cli.args import at_least


def _verify(args: argparse.Namespace) -> int:
    from bench.errors import BadInput
    from bench.harness import store, verify

    records = {r.trial_id: r for d in store.suite_dirs(args.results_dir) for r in store.scan(d)}
    if not records:
        raise FileNotFoundError(f"{args.results_dir}: no trial records")
    unknown = [t for t in args.trial or () if t not in records]
    if unknown:
        raise BadInput(f"{args.results_dir}: no record of trial {', '.join(unknown)}")
    chosen = [r for r in records.values() if _wanted(r, args)]
    if args.trial:
        chosen = [records[t] for t in args.trial]
    elif args.sample is not None:
        chosen = verify.sample(chosen, args.sample, seed=args.seed)
    if not chosen:
        raise BadInput(f"{args.results_dir}: no ok record matches --env/--algorithm/--demos")
    print(f"verifying {len(chosen)} records on {verify.where()}", file=sys.stderr)
    print("| trial | env | algorithm | demos | seed | verdict | compared |")
    print("|:--|:--|:--|--:|--:|:--|:--|")
    differing = 0
    for record in chosen:
        verdict = verify.verify(record, steps=args.steps)
        differing += not verdict.identical
        s = record.spec
        print(
            f"| {record.trial_id} | {s.env_id} | {s.shown} | {s.n_demos} | {s.seed} |"
            f" {'identical' if verdict.identical else '**differs**'} | {verdict.how} |",
            flush=True,
        )
    print(f"\n{len(chosen) - differing} of {len(chosen)} identical, {differing} differ")
    return 1 if differing else 0


def _wanted(record, args: argparse.Namespace) -> bool:
    s = record.spec
    return (
        record.status == "ok"
        and (not args.env or s.env_id in args.env)
        and (not args.algorithm or {s.algorithm, s.shown} & set(args.algorithm))
        and (not args.demos or s.n_demos in args.demos)
    )


def add(sub: argparse._SubParsersAction) -> None:
    """The `verify` command."""
    ver = sub.add_parser(
        "verify",
        help="rerun records of a results folder and say which reproduce here",
        description="Rerun records of RESULTS_DIR (a sample, or named ones) and say per record"
        " whether this machine computes it to the bit: a trial that trains is rerun for its"
        " first --steps env steps and its per-update logs compared; the references whole."
        " Nothing is written. Exit status 1 where any record differs.",
    )
    ver.add_argument("results_dir", help="e.g. results/mujoco")
    ver.add_argument("--trial", action="append", metavar="ID", help="a trial id (repeatable)")
    ver.add_argument("--env", action="append", metavar="ID", help="only this env (repeatable)")
    ver.add_argument(
        "--algorithm", action="append", metavar="NAME", help="only this algorithm (repeatable)"
    )
    ver.add_argument(
        "--demos", action="append", type=int, metavar="N", help="only N demonstrations"
    )
    ver.add_argument(
        "--sample",
        type=at_least(1),
        metavar="N",
        help="N records spread over envs and algorithms (default: every record that matches)",
    )
    ver.add_argument("--seed", type=int, default=0, help="the sample's seed (default 0)")
    ver.add_argument(
        "--steps",
        type=at_least(1),
        default=16_384,
        metavar="N",
        help="env steps a training trial is rerun for (default 16384: 4 TRPO updates)",
    )
    ver.set_defaults(func=_verify)
