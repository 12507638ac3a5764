"""`bench run`: run a suite's pending trials, or price them (`--estimate`)."""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from collections import Counter
from pathlib import Path
from typing import TYPE_CHECKING

from bench import paths
from bench.cli.args import duration, existing_folder, folder, jobs_count, output_folder
from bench.errors import BadInput

if TYPE_CHECKING:
    from bench.harness.runner import RunSummary


def _run(args: argparse.Namespace) -> int:
    from bench.harness.suite import load_suite, select

    if args.no_pause and args.time_limit is None:
        raise BadInput("--no-pause says which trials to start before a --time-limit: give one")
    suite = load_suite(args.suite)
    if suite.kernels == "portable" and not args.estimate:
        restarted = _with_portable_kernels(args)
        if restarted is not None:
            return restarted
    specs = select(
        list(suite.trials), args.suite, env=args.env, algorithm=args.algorithm, demos=args.demos
    )
    # The runner (torch, pandas) after the suite's checks: a suite refused before its checks
    # reach the algorithms (an unknown env, say) is refused ~0.5 s sooner.
    from bench.harness import store
    from bench.harness.costs import TimeLimit
    from bench.harness.runner import run_suite

    results = _results_folder(args, suite.name)
    jobs = args.jobs if args.jobs is not None else suite.runner.jobs
    # Finished trials are looked for beside the results folder, in the checkout's committed
    # results (whatever --results says) and in every folder named by --reuse.
    reuse = [results.parent, paths.RESULTS_DIR, *map(Path, args.reuse or ())]
    if args.no_reuse:
        reuse = []
    if args.estimate:
        return _estimate(specs, results, jobs, reuse)
    from bench.demos import minari_io

    for env_id, dataset in sorted({(s.env_id, s.dataset) for s in specs if s.dataset}):
        minari_io.ensure_pool(dataset, env_id)  # read whole now: a broken one fails before any run
    with store.claim(results):
        print(f"suite {suite.name}: {len(specs)} trials -> {results}/", file=sys.stderr)
        # Priced as --estimate prices them; a time limit counts from now on.
        limit = None
        if args.time_limit is not None:
            limit = TimeLimit.starting_now(args.time_limit, pause=not args.no_pause)
        summary = run_suite(
            specs,
            results,
            jobs=jobs,
            backend=args.backend or suite.runner.backend,
            scheduler=args.scheduler,
            retry_failed=args.retry_failed,
            tensorboard=args.tensorboard,
            first=suite.runner.first,
            limit=limit,
            priced_by=results.parent,
            linked_from=reuse,
            snapshot_every=args.snapshot_every,
            trial_timeout=args.trial_timeout or suite.runner.trial_timeout,
        )
    _say_what_ran(summary, results)
    return 1 if summary.failed else 0


def _with_portable_kernels(args: argparse.Namespace) -> int | None:
    """Run the command again in a process started with the portable kernels pinned, and return
    its exit status; None where this process has them already. The libraries read their kernel
    switches once, when they first compute: the run must have them from its start (and so
    must its workers, which inherit them)."""
    from bench import kernels

    if kernels.active() == "portable":
        return None
    env = {**os.environ, **kernels.pins("portable")}
    command = [sys.executable, "-m", "bench.cli", *args.argv]
    return subprocess.run(command, env=env, check=False).returncode


def _results_folder(args: argparse.Namespace, suite_name: str) -> Path:
    """Where the run writes: --results, else results/<suite name>; refused (BadInput) where
    that would write into the shipped experts, or where the demonstration cache cannot be."""
    results = Path(args.results) if args.results else Path("results") / suite_name
    cache = paths.CACHE_DIR  # demonstration pools are recorded there before any trial
    existing = next((p for p in (cache, *cache.parents) if p.exists()), cache)
    if not existing.is_dir():
        raise BadInput(f"the demonstration cache {cache} (IFO_BENCH_CACHE) is under a file")
    shipped = paths.shipped_folder(results)
    if shipped is not None:
        raise BadInput(
            f"{results}: results would be written into {shipped}, which holds the shipped"
            " experts; name another folder (--results DIR, or another suite name)"
        )
    return results


def _say_what_ran(summary: RunSummary, results: Path) -> None:
    """The run's `RunSummary` in words, and what to do next."""
    from bench.harness import store
    from bench.harness.snapshots import FOLDER

    if summary.set_aside:
        print(
            f"{summary.set_aside} records of these cells were made with other settings or another"
            f" version of their plugin's code: moved to {results}/{store.SET_ASIDE}/ (kept, never"
            " reused)"
        )
    linked = f", {summary.linked} of them by other suites (linked)" if summary.linked else ""
    cpu = f"; {_core_time(summary.cpu_s)} of CPU" if summary.cpu_s else ""
    print(
        f"{summary.done} trials done, {summary.failed} failed, "
        f"{summary.skipped} already finished{linked} (records in {results}/trials){cpu}"
    )
    if summary.paused:
        print(
            f"{summary.paused} trials paused at the time limit, each kept as a snapshot in"
            f" {results}/{FOLDER}/ (run again to resume them)"
        )
    if summary.left:
        print(
            f"{summary.left} trials not started: not expected to finish within --time-limit"
            " (--estimate prices them; run again to go on)"
        )
    if summary.failed:
        print("rerun with --retry-failed to try the failed trials again", file=sys.stderr)


def _estimate(specs: list, results: Path, jobs: int, reuse: list[Path]) -> int:
    """Print what the pending trials would cost, from every record under results/'s parent,
    less what the snapshots of cut-off trials have behind them. Trials a folder under `reuse`
    has finished are not pending: a run links them (said per folder)."""
    from bench.harness import store
    from bench.harness.costs import estimate
    from bench.harness.runner import pending
    from bench.harness.snapshots import SnapshotPlan

    records = list(store.scan(results))
    stale = store.superseded(records, specs)
    finished = {r.trial_id: store.status_of(r) for r in records if r.trial_id not in stale}
    todo = pending(specs, finished, retry_failed=False)
    elsewhere = store.find(reuse, {s.trial_id for s in todo}, besides=results)
    todo = [s for s in todo if s.trial_id not in elsewhere]
    print(f"{len(todo)} of {len(specs)} trials pending -> {results}/")
    if stale:
        print(
            f"{len(stale)} records there were made with other settings or another version of"
            f" their plugin's code: a run moves them to {results}/{store.SET_ASIDE}/ and runs"
            " their cells again"
        )
    if elsewhere:
        where = Counter(str(_shown_path(p.parent.parent)) for p in elsewhere.values())
        print(
            f"{len(elsewhere)} more finished by other runs, linked, not run again: "
            + ", ".join(f"{n} from {folder}/" for folder, n in sorted(where.items()))
        )
    if not todo:
        print("nothing to run: every trial has its record")
        return 0
    done_before = SnapshotPlan.of(results).done_before(todo)
    rows = estimate(todo, store.scan_under(results.parent), done_before)
    width = max([36, *(len(r.env_id) for r in rows)])
    named = max([14, *(len(r.algorithm) for r in rows)])
    print(
        f"{'env':{width}s} {'algorithm':{named}s} {'trials':>6s} {'per trial':>10s} {'core-h':>7s}  basis"
    )
    known = 0.0
    for r in sorted(rows, key=lambda r: (r.env_id, r.algorithm)):
        each = "?" if r.seconds is None else f"{r.seconds / 60:.1f} min"
        hours = "?" if r.seconds is None else f"{r.seconds * r.trials / 3600:.2f}"
        known += 0.0 if r.seconds is None else r.seconds * r.trials
        print(
            f"{r.env_id:{width}s} {r.algorithm:{named}s} {r.trials:6d} {each:>10s} {hours:>7s}  {r.basis}"
        )
    cut_off = [f for f in done_before.values() if f > 0]
    if cut_off:
        print(
            f"{len(cut_off)} of them resume from a snapshot, {100 * sum(cut_off) / len(cut_off):.0f}%"
            " of their budget done on average (priced at what they have left)"
        )
    cores = jobs if jobs > 0 else os.cpu_count() or 1
    unknown = sum(r.trials for r in rows if r.seconds is None)
    print(
        f"total {known / 3600:.1f} core-hours, ~{known / 3600 / cores:.1f} h wall on {cores} cores"
        + (f"; {unknown} trials with nothing to go by" if unknown else "")
    )
    return 0


def _shown_path(path: Path) -> Path:
    """`path` relative to the working folder where it lies below it, else absolute."""
    try:
        return path.resolve().relative_to(Path.cwd().resolve())
    except ValueError:
        return path.resolve()


def add(sub: argparse._SubParsersAction) -> None:
    """The `run` command."""
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
    _add_selection(run)
    _add_run_control(run)
    _add_backend(run)
    run.set_defaults(func=_run)


def _add_selection(run: argparse.ArgumentParser) -> None:
    """Which of the suite's trials to run."""
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
        "--demos",
        action="append",
        type=int,
        metavar="N",
        help="run only the trials with N demonstrations (repeatable), and those that take none",
    )


def _add_run_control(run: argparse.ArgumentParser) -> None:
    """How many at once, what to reuse, rerun or price, and when to stop."""
    run.add_argument(
        "--jobs", type=jobs_count, help="parallel trials (default: the suite's, else all cores)"
    )
    reuse = run.add_mutually_exclusive_group()
    reuse.add_argument(
        "--reuse",
        action="append",
        metavar="DIR",
        type=existing_folder,
        help="also link trials finished in results folders under DIR instead of running them"
        " (repeatable; the results folder's parent and the checkout's results/ always are)",
    )
    reuse.add_argument(
        "--no-reuse",
        action="store_true",
        help="link nothing finished elsewhere: train every trial this folder lacks (a rerun that"
        " checks committed records, as `make run` does)",
    )
    run.add_argument("--retry-failed", action="store_true", help="rerun trials recorded as failed")
    run.add_argument(
        "--estimate",
        action="store_true",
        help="run nothing: print the pending trials' expected core-hours, from the records"
        " under the results folder's parent",
    )
    run.add_argument(
        "--time-limit",
        type=duration,
        metavar="DURATION",
        help="end the run DURATION from now (e.g. 2h30m): start the trials expected to finish"
        " by then (priced as --estimate prices them), dearest first, then those that can pause"
        " (every built-in algorithm's); at the limit, those in flight save a snapshot and stop,"
        " to resume next run; one that has not stopped a minute later is stopped and left"
        " pending",
    )
    run.add_argument(
        "--no-pause",
        action="store_true",
        help="with --time-limit: start only the trials expected to finish by then, none to"
        " pause at the limit (where the disk does not outlive the run, a paused trial's"
        " snapshot is lost with it)",
    )
    run.add_argument(
        "--trial-timeout",
        type=duration,
        metavar="DURATION",
        help="stop a trial still running DURATION after it started and record it as failed"
        " (default: the suite's runner.trial_timeout, else none)",
    )
    run.add_argument(
        "--snapshot-every",
        type=duration,
        default=10 * 60,
        metavar="DURATION",
        help="how often a trial (of any built-in algorithm) saves its state under"
        " RESULTS/.partial/, to resume from if the run is cut off (default 10m)",
    )


def _add_backend(run: argparse.ArgumentParser) -> None:
    """Where the trials run, and where their scalars go besides the records."""
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
        type=output_folder,
        help="also write every trial's logged scalars there as TensorBoard events, live"
        " (tensorboard --logdir DIR)",
    )


def _core_time(seconds: float) -> str:
    """CPU seconds as core-hours, or core-minutes under an hour: "2.4 core-hours"."""
    if seconds >= 3600:
        return f"{seconds / 3600:.1f} core-hours"
    return f"{seconds / 60:.1f} core-minutes"
