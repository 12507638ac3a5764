"""`bench`: run suites, plot and report results, train and list experts."""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import shlex
import sys
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from bench.envs import EnvError

if TYPE_CHECKING:
    import pandas as pd


class UsageError(ValueError):
    """A command-line argument that cannot work; the message is one line."""


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a bad argument is one line on stderr (no usage block), exit status 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message}\n")


def at_least(low: int) -> Callable[[str], int]:
    """argparse type: an int >= `low`."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"not an integer: {text!r}") from None
        if value < low:
            raise argparse.ArgumentTypeError(f"must be >= {low}, not {value}")
        return value

    return parse


def jobs_count(text: str) -> int:
    """argparse type: parallel jobs, >= 1, or -1 for every core."""
    value = at_least(-1)(text)
    if value == 0:
        raise argparse.ArgumentTypeError("must be >= 1, or -1 for every core, not 0")
    return value


def folder(text: str) -> Path:
    """argparse type: a folder to write into, which may not exist yet but is no file."""
    path = Path(text)
    if path.exists() and not path.is_dir():
        raise argparse.ArgumentTypeError(f"{text} is a file, not a folder")
    return path


def _experts_train(args: argparse.Namespace) -> int:
    from bench import envs, paths, validate
    from bench.experts import ExpertConfig, ExpertError, train_expert

    envs.check_env_id(args.env_id)
    batch = {"n_envs": args.n_envs, "steps_per_env": args.steps_per_env}
    settings = {**batch, **args.hyperparams}  # --hyperparams has the last word
    try:
        validate.check_types(ExpertConfig, settings)
        cfg = ExpertConfig(**settings)
    except (TypeError, ValueError) as e:
        raise ExpertError(f"experts train: bad TRPO settings: {e}") from None
    if args.steps < cfg.batch_size:
        raise ExpertError(
            f"experts train: --steps {args.steps} is less than one TRPO batch "
            f"({cfg.n_envs} x {cfg.steps_per_env} = {cfg.batch_size} steps): nothing would train"
        )
    out = args.out or paths.expert_dir(args.env_id)
    if args.out is None and paths.has_expert(args.env_id) and not args.replace:
        raise ExpertError(
            f"experts train: {args.env_id} already has an expert in {out}: pass --out DIR to "
            "train one beside it, or --replace to overwrite the shipped one"
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
    """argparse type: a JSON object of ExpertConfig fields, or an argparse error naming the problem."""
    from bench.experts import ExpertConfig

    try:
        value = json.loads(text)
    except json.JSONDecodeError as err:
        raise argparse.ArgumentTypeError(f"not JSON: {err}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError("must be a JSON object, e.g. '{\"hidden\": [128, 128]}'")
    known = {f.name for f in dataclasses.fields(ExpertConfig)}
    unknown = sorted(set(value) - known)
    if unknown:
        raise argparse.ArgumentTypeError(
            f"ExpertConfig has no field {', '.join(map(repr, unknown))} (known: {', '.join(sorted(known))})"
        )
    return value


def _experts_list(args: argparse.Namespace) -> int:
    from bench.experts import list_experts
    from bench.paths import EXPERTS_DIR

    rows = list_experts()
    if not rows:
        print(f"no experts in {EXPERTS_DIR}")
        return 0
    if getattr(args, "markdown", False):
        print("| env | return (mean +- std) | train steps | wall time |")
        print("|---|---:|---:|---:|")
        for m in rows:
            print(
                f"| {m['env_id']} | {m['return_mean']:.1f} +- {m['return_std']:.1f} "
                f"| {m['train_steps']:,} | {m['wall_time_s'] / 60:.1f} min |"
            )
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


def _run(args: argparse.Namespace) -> int:
    from bench import store
    from bench.runner import run_suite
    from bench.suite import expand, load_suite, select

    suite = load_suite(args.suite)
    specs = select(expand(suite), args.suite, env=args.env, algorithm=args.algorithm)
    results = Path(args.results) if args.results else Path("results") / suite.name
    backend = args.backend or suite.runner.backend
    jobs = args.jobs if args.jobs is not None else suite.runner.jobs
    if args.estimate:
        return _estimate(specs, results, jobs)
    with store.claim(results):
        print(f"suite {suite.name}: {len(specs)} trials -> {results}/", file=sys.stderr)
        if args.reuse:
            from bench.reuse import reuse

            copied = reuse(specs, results, args.reuse)
            print(f"{copied} finished trials copied from {', '.join(args.reuse)}", file=sys.stderr)
        summary = run_suite(
            specs,
            results,
            jobs=jobs,
            backend=backend,
            scheduler=args.scheduler,
            retry_failed=args.retry_failed,
            device=args.device,
            tensorboard=args.tensorboard,
        )
    print(
        f"{summary.done} trials done, {summary.failed} failed, "
        f"{summary.skipped} already finished (records in {results}/trials)"
    )
    if summary.failed:
        print("rerun with --retry-failed to try the failed trials again", file=sys.stderr)
    return 1 if summary.failed else 0


def _estimate(specs: list, results: Path, jobs: int) -> int:
    """Print what the pending trials would cost, from every record under results/'s parent."""
    from bench import store
    from bench.costs import estimate
    from bench.runner import pending

    finished = {r.trial_id: r.status for r in store.scan(results)}
    todo = pending(specs, finished, retry_failed=False)
    records = [r for d in store.find_result_dirs(results.parent) for r in store.scan(d)]
    rows = estimate(todo, records)
    print(f"{len(todo)} of {len(specs)} trials pending -> {results}/")
    width = max([36, *(len(r.env_id) for r in rows)])
    print(
        f"{'env':{width}s} {'algorithm':14s} {'trials':>6s} {'per trial':>10s} {'core-h':>7s}  basis"
    )
    known = 0.0
    for r in sorted(rows, key=lambda r: (r.env_id, r.algorithm)):
        each = "?" if r.seconds is None else f"{r.seconds / 60:.1f} min"
        hours = "?" if r.seconds is None else f"{r.seconds * r.trials / 3600:.2f}"
        known += 0.0 if r.seconds is None else r.seconds * r.trials
        print(
            f"{r.env_id:{width}s} {r.algorithm:14s} {r.trials:6d} {each:>10s} {hours:>7s}  {r.basis}"
        )
    cores = jobs if jobs > 0 else os.cpu_count() or 1
    unknown = sum(r.trials for r in rows if r.seconds is None)
    print(
        f"total {known / 3600:.1f} core-hours, ~{known / 3600 / cores:.1f} h wall on {cores} cores"
        + (f"; {unknown} trials with nothing to go by" if unknown else "")
    )
    return 0


def _plot(args: argparse.Namespace) -> int:
    from bench import labels, normalize, plot, store

    dirs = store.suite_dirs(args.results_dir)
    for d in dirs:
        trials = store.load(d)
        if trials.empty:
            raise FileNotFoundError(f"{store.trials_dir(d)}: no readable trial record")
        df = normalize.normalize(trials)
        left_out = df[df["status"] != "ok"]
        if len(left_out):
            kinds = ", ".join(f"{n} {s}" for s, n in left_out["status"].value_counts().items())
            print(f"{d}: {len(left_out)} records left out ({kinds})", file=sys.stderr)
        written = []
        if labels.algorithm_order(df["algorithm"].unique()):
            out = Path(args.out) if args.out and len(dirs) == 1 else d / "figure2.png"
            written = plot.figure2(df, out)
        else:
            print(f"{d}: no learner's records, only references: no figure", file=sys.stderr)
        plot.write_summary_csv(df, d / "summary.csv")
        print(f"## {d}\n\n{plot.summary_table(df)}\n")
        print("wrote " + ", ".join(str(p) for p in [*written, d / "summary.csv"]) + "\n")
    return 0


def _report(args: argparse.Namespace) -> int:
    from bench import report

    for written in report.write_reports(args.results_dir, args.out, args.reps):
        tables = report.tables(written.aggregates, written.improvements, written.action_users)
        print(f"## {written.path}\n\n{tables}")
        print(f"wrote {written.path} (figures and aggregates.csv beside it)\n")
    return 0


def _compare(args: argparse.Namespace) -> int:
    from bench import labels, normalize, report, stats

    run, ref = (_one_suite(args.run), _one_suite(args.reference))
    run_df, ref_df = normalize.normalized_alike(run, ref)
    comparison = stats.compare(run_df, ref_df, reps=args.reps)
    starred = labels.action_users(run_df) | labels.action_users(ref_df)
    print(report.compare_table(comparison, str(args.run), str(args.reference), starred))
    return 0


def _one_suite(folder: str) -> pd.DataFrame:
    """The trial records of the one suite in `folder`."""
    from bench import store

    dirs = store.suite_dirs(folder)
    if len(dirs) > 1:
        raise FileNotFoundError(
            f"{folder} holds {len(dirs)} suites' records ({', '.join(map(str, dirs))}); name one"
        )
    return store.load(dirs[0])


def _demos_export(args: argparse.Namespace) -> int:
    from bench import minari_io, normalize, store

    if not Path(args.references).is_dir():
        raise FileNotFoundError(f"{args.references}: no such results folder")
    refs = normalize.reference_returns(store.load(args.references)).set_index("env_id")
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


def _video(args: argparse.Namespace) -> int:
    from bench import store
    from bench.video import VideoError, video

    if not store.trials_dir(args.results).is_dir():
        raise FileNotFoundError(f"{args.results}: no trial records (no trials/ folder)")
    if args.out.suffix not in (".gif", ".mp4"):
        raise VideoError(f"video: --out must end in .gif or .mp4, not {args.out.name!r}")
    if args.out.is_dir():
        raise VideoError(f"video: --out {args.out} is a folder")
    out, titles = video(
        args.results,
        args.out,
        env_id=args.env,
        algorithms=args.algorithm,
        n_demos=args.demos,
        seed=args.seed,
        steps=args.steps,
        size=args.size,
        fps=args.fps,
    )
    print(f"wrote {out}: {', '.join(titles)}")
    return 0


def _list(args: argparse.Namespace) -> int:
    from bench import registry

    print("algorithms:")
    for name, algo in sorted(registry.all_algorithms().items()):
        flag = "  (uses expert actions)" if algo.uses_actions else ""
        print(f"  {name:12s} inputs={algo.inputs:8s} {algo.description}{flag}")
    print()
    return _experts_list(args)


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="bench",
        description="ifo-bench: compare imitation-from-observation algorithms on PyBullet.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run = sub.add_parser(
        "run",
        help="run a YAML suite (resumable: finished trials are skipped)",
        description="Expand SUITE to env x demos x algorithm x seed trials and run the unfinished ones.",
    )
    run.add_argument("suite", help="path of a suite file, e.g. suites/quick.yaml")
    run.add_argument(
        "--results",
        metavar="DIR",
        type=folder,
        help="where records go (default results/<suite name>)",
    )
    run.add_argument(
        "--env",
        action="append",
        metavar="ID",
        help="run only this env's trials (repeatable); records stay those of the whole suite",
    )
    run.add_argument(
        "--algorithm",
        action="append",
        metavar="NAME",
        help="run only this algorithm's trials (repeatable)",
    )
    run.add_argument(
        "--jobs", type=jobs_count, help="parallel trials (default: the suite's, else all cores)"
    )
    run.add_argument("--retry-failed", action="store_true", help="rerun trials recorded as failed")
    run.add_argument(
        "--reuse",
        action="append",
        metavar="DIR",
        help="copy finished records of the same trials (all alike but the suite's name) from"
        " another results folder instead of running them (repeatable)",
    )
    run.add_argument(
        "--estimate",
        action="store_true",
        help="run nothing: print the pending trials' expected core-hours, from the records"
        " under the results folder's parent",
    )
    run.add_argument(
        "--backend",
        choices=["loky", "dask"],
        help="joblib backend (default: the suite's, else loky)",
    )
    run.add_argument(
        "--scheduler",
        metavar="ADDRESS",
        help="dask scheduler, e.g. tcp://10.0.0.1:8786 (dask backend)",
    )
    run.add_argument(
        "--tensorboard",
        metavar="DIR",
        type=folder,
        help="also write every trial's logged scalars there as TensorBoard events, live"
        " (tensorboard --logdir DIR)",
    )
    run.add_argument(
        "--device", default="cpu", help="torch device for networks, e.g. cuda (default cpu)"
    )
    run.set_defaults(func=_run)

    plot = sub.add_parser(
        "plot",
        help="draw Figure 2, write summary.csv and print a table for each suite's results",
        description="Find every suite's records under RESULTS_DIR (experts skipped) and draw each.",
    )
    plot.add_argument("results_dir", help="e.g. results/ or results/quick")
    plot.add_argument(
        "--out", metavar="FILE", help="figure path (.png; a .pdf is written beside it)"
    )
    plot.set_defaults(func=_plot)

    rep = sub.add_parser(
        "report",
        help="aggregate statistics (IQM, CIs, probability of improvement) and a markdown report",
        description="Find every suite's records under RESULTS_DIR and write report.md with its figures.",
    )
    rep.add_argument("results_dir", help="e.g. results/ or results/quick")
    rep.add_argument(
        "--out",
        metavar="DIR",
        type=folder,
        help="report folder (default <suite dir>/report; one per suite)",
    )
    rep.add_argument(
        "--reps",
        type=at_least(1),
        default=2000,
        metavar="N",
        help="bootstrap resamples per interval (default 2000)",
    )
    rep.set_defaults(func=_report)

    cmp = sub.add_parser(
        "compare",
        help="compare two results folders' IQMs per env, algorithm and demo count",
        description="Per env, algorithm and demo count in both folders: each folder's IQM over"
        " seeds with a 95%% CI, and whether they differ (the CI of the difference excludes 0).",
    )
    cmp.add_argument("run", help="a suite's results folder, e.g. runs/quick")
    cmp.add_argument("reference", help="the folder to compare against, e.g. results/quick")
    cmp.add_argument(
        "--reps",
        type=at_least(1),
        default=2000,
        metavar="N",
        help="bootstrap resamples (default 2000)",
    )
    cmp.set_defaults(func=_compare)

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
        help='ExpertConfig (TRPOConfig) overrides as JSON, e.g. \'{"hidden": [128, 128], "init_log_std": -1.0}\'',
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

    vid = sub.add_parser(
        "video",
        help="the expert and learned policies side by side, as a GIF or MP4",
        description="Roll out the expert and each learner's kept policy (one seed, one demo"
        " count) from the same start state and film them side by side, each titled with the"
        " normalized return its record scored.",
    )
    vid.add_argument("results", type=Path, help="a results folder, e.g. results/locomotion")
    vid.add_argument("--out", type=Path, required=True, help="FILE.gif or FILE.mp4")
    vid.add_argument("--env", metavar="ID", help="the env (needed where the folder has several)")
    vid.add_argument(
        "--algorithm",
        action="append",
        metavar="NAME",
        help="a learner or label (repeatable; default all)",
    )
    vid.add_argument("--demos", type=int, help="demonstration count (default the largest run)")
    vid.add_argument("--seed", type=at_least(0), default=0, help="which trials (default 0)")
    vid.add_argument(
        "--steps", type=at_least(1), default=300, help="env steps filmed (default 300)"
    )
    vid.add_argument(
        "--size", type=at_least(16), default=200, help="panel side in pixels (default 200)"
    )
    vid.add_argument("--fps", type=at_least(1), default=30, help="frames per second (default 30)")
    vid.set_defaults(func=_video)

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
    return parser


def _user_errors() -> tuple[type[Exception], ...]:
    """Exceptions that mean bad input: printed as one line, exit status 2."""
    from bench.demos import DemoError
    from bench.experts import ExpertError
    from bench.minari_io import DatasetError
    from bench.normalize import NormalizationError
    from bench.registry import RegistryError
    from bench.stats import ComparisonError
    from bench.store import FolderBusy
    from bench.suite import SuiteError
    from bench.video import VideoError

    return (
        UsageError,
        FolderBusy,
        VideoError,
        EnvError,
        SuiteError,
        RegistryError,
        ExpertError,
        DemoError,
        NormalizationError,
        ComparisonError,
        DatasetError,
        FileNotFoundError,
    )


def _one_line_warning(message, category, filename, lineno, line=None) -> str:
    return f"bench: warning: {message}\n"


def main(argv: list[str] | None = None) -> int:
    warnings.formatwarning = _one_line_warning  # a line each, not the source line under it
    args = build_parser().parse_args(argv)
    func: Callable[[argparse.Namespace], int] = args.func
    try:
        return func(args)
    except _user_errors() as e:
        print(f"bench: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("bench: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
