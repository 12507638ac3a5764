"""Run a suite's trials in parallel: `run_suite` hands each pending trial (`bench.harness.trial`) to
a joblib worker (loky here, dask on a cluster): the references (random, expert) first, then the
suite's `runner.first` algorithms, then the rest; within each, trials resuming from a snapshot
first, then the longest (`bench.harness.costs`).

The driver prepares each trial's inputs (demonstrations, or the expert) and
ships them with it, so workers need no files: that is what lets the dask
backend run trials on other machines. Only the driver writes records, one
atomic file per finished trial, as results stream back.
"""

from __future__ import annotations

import contextlib
import functools
import itertools
import os
import socket
import sys
import warnings
from collections.abc import Callable, Collection, Iterator, Sequence
from contextlib import closing, contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import joblib
from joblib.externals.loky.process_executor import TerminatedWorkerError
from tqdm import tqdm

from bench.errors import BadInput
from bench.harness import policies, registry, snapshots, store
from bench.harness.costs import CostModel, TimeLimit
from bench.harness.snapshots import SnapshotPlan
from bench.harness.trial import demo_pool, plan, run_trial_apart
from bench.harness.types import TrialResult, TrialSpec

if TYPE_CHECKING:
    from distributed import Client


@dataclass(frozen=True)
class RunSummary:
    done: int
    failed: int
    skipped: int
    """Trials this folder had finished, or found finished in another suite's (`linked`)."""
    left: int = 0
    """Pending trials not started: under a time limit, those that would not have fit."""
    paused: int = 0
    """Trials stopped at the time limit, each kept as a snapshot to resume from."""
    linked: int = 0
    """Of the skipped, trials another suite's folder had finished: linked, not rerun."""
    set_aside: int = 0
    """Records of these trials' cells made with other settings or another version of a
    plugin's code, moved out of the folder's trials (`store.superseded`)."""
    cpu_s: float = 0.0
    """CPU seconds of the trials this run recorded (runs before a resume included): the bill,
    whatever else loaded the machine."""


def link_finished(
    specs: list[TrialSpec], results_dir: Path, roots: Path | Sequence[Path] | None
) -> list[TrialSpec]:
    """Link into `results_dir` the trials of `specs` that a folder under `roots` has finished
    (the same trial, asked for by another suite: `store.link`); return the others."""
    if roots is None or not specs:
        return specs
    found = store.find(roots, {s.trial_id for s in specs}, besides=results_dir)
    for spec in specs:
        if spec.trial_id in found:
            label = registry.shown_as(spec.algorithm, spec.label)
            store.link(results_dir, spec, label, found[spec.trial_id])
    return [s for s in specs if s.trial_id not in found]


def pending(specs: list[TrialSpec], have: dict[str, str], retry_failed: bool) -> list[TrialSpec]:
    """Trials without a record in `have` (trial id -> status), and failed ones when `retry_failed`."""
    keep = []
    for spec in specs:
        status = have.get(spec.trial_id)
        if status is None or (status != "ok" and retry_failed):
            keep.append(spec)
    return keep


def _jobs(
    specs: list[TrialSpec],
    costs: CostModel,
    tensorboard: str | Path | None = None,
    first: Collection[str] = (),
    limit: TimeLimit | None = None,
    snapshot_plan: SnapshotPlan | None = None,
    in_workers: bool = False,
    trial_timeout: float | None = None,
) -> Iterator:
    """The trials as joblib calls: the references every score is normalized against first (they
    cost an evaluation, and a run cut short without them leaves no trial that can be read),
    then those of the algorithms `first` (names or labels), then the others; within each
    group, trials resuming from a snapshot first, then kinds with nothing to go by (to learn
    their cost), then the dearest, so the last to finish are short. Under a time `limit`,
    those that still fit as each starts, at this run's pace (`CostModel.wall_seconds`), the
    dearest first (never an unpriced one); once none does, those that can pause at the limit
    (`registry.Algorithm.resumable`, with a `snapshot_plan`) while that is worth it
    (`TimeLimit.worth_pausing`); then none."""

    first = set(first)

    def order(spec: TrialSpec) -> tuple:
        reference = registry.get(spec.algorithm).role in registry.REFERENCE_ROLES
        return (reference, bool({spec.algorithm, spec.shown} & first), *costs.priority(spec))

    def pausable(spec: TrialSpec) -> bool:
        return snapshot_plan is not None and registry.get(spec.algorithm).resumable

    remaining = list(specs)
    while remaining:  # a generator: the next trial is chosen (and loaded) as a worker frees up
        if limit is None:
            startable = remaining
        else:
            startable = [s for s in remaining if limit.fits(costs.wall_seconds(s))]
            if not startable and limit.worth_pausing():
                startable = [s for s in remaining if pausable(s)]
        if not startable:
            return
        spec = max(startable, key=order)  # first of equals: suite order
        remaining.remove(spec)
        inputs = plan(spec).inputs()
        yield joblib.delayed(run_trial_apart)(
            spec, inputs, tensorboard, snapshot_plan, in_workers, trial_timeout
        )


WORKER_DEATHS = 10
"""Worker processes that may die in a row, with no trial landing in between, before the run
stops (something keeps killing them: the same command resumes once it is gone)."""


class WorkersDying(BadInput, RuntimeError):
    """Worker processes keep dying and no trial lands: the run stops (one line, exit 2)."""


def run_suite(
    specs: list[TrialSpec],
    results_dir: Path,
    jobs: int = -1,
    backend: str = "loky",
    scheduler: str | None = None,
    retry_failed: bool = False,
    progress: bool = True,
    tensorboard: str | Path | None = None,
    first: Collection[str] = (),
    limit: TimeLimit | None = None,
    priced_by: Path | None = None,
    linked_from: Sequence[Path] | None = None,
    snapshot_every: float | None = snapshots.EVERY_S,
    trial_timeout: float | None = None,
) -> RunSummary:
    """Run every pending trial in parallel, writing each record as it finishes; with
    `tensorboard`, each trial's scalars go there live as TensorBoard events. The trials of
    the algorithms `first` (names or labels) start before the others'. A trial that a folder
    under `priced_by` has finished (another suite's: the same trial) is linked, not rerun
    (`store.link`); with `linked_from`, from the folders under those (the checkout's committed
    results, say) instead. Trials are priced by the records of every results folder under
    `priced_by` (default: `results_dir`'s own), read only when something is pending, and by
    each trial as it finishes. Trials whose algorithm takes snapshots save one every
    `snapshot_every` seconds under `<results_dir>/.partial/` (None: never) and resume from it
    after an interruption. Under a time `limit`, a trial starts if it is expected to finish in
    time or, with snapshots, if it can pause at the limit (see `_jobs`); at the limit every
    trial in flight that takes snapshots saves one and stops, and the rest are left pending. A
    trial still running `trial_timeout` seconds after it started is stopped and recorded as
    failed. Records of these trials' cells made with other settings or another version of a
    plugin's code are moved aside first (`store.superseded`)."""
    # A named scheduler is reached first: one that cannot be is refused before anything is touched.
    with _scheduler(backend, scheduler) as client:
        records = list(store.scan(results_dir))
        stale = store.superseded(records, specs)
        if stale:
            store.set_aside(results_dir, stale)
            records = [r for r in records if r.trial_id not in stale]
        have = {r.trial_id: store.status_of(r) for r in records}
        todo = pending(specs, have, retry_failed)
        unlinked = link_finished(
            todo, results_dir, priced_by if linked_from is None else linked_from
        )
        linked, todo = len(todo) - len(unlinked), unlinked
        skipped = len(specs) - len(todo)
        snapshot_plan = _snapshot_plan(results_dir, snapshot_every, limit, have)
        if not todo:
            return RunSummary(0, 0, skipped, linked=linked, set_aside=len(stale))
        others = [] if priced_by is None else store.scan_under(priced_by, besides=results_dir)
        costs = CostModel.of(itertools.chain(records, others))
        if snapshot_plan is not None:
            costs.done_before = snapshot_plan.done_before(todo)
        make_demo_pools(todo)
        with _workers(backend, jobs, client) as workers:
            landing = _Landing(results_dir, costs, snapshot_plan, workers, todo, progress)
            with closing(landing.bar):
                # Each trial runs in a process of its own, forked by the worker (`run_trial_apart`);
                # loky's workers also die with this driver, so an interrupted run leaves no orphans.
                in_workers = backend == "loky" and workers > 1
                dispatch = functools.partial(
                    _jobs,
                    costs=costs,
                    tensorboard=tensorboard,
                    first=first,
                    limit=limit,
                    snapshot_plan=snapshot_plan,
                    in_workers=in_workers,
                    trial_timeout=trial_timeout,
                )
                _run_all(todo, jobs, dispatch, landing)
        return landing.summary(skipped, linked=linked, set_aside=len(stale))


def _snapshot_plan(
    results_dir: Path, every: float | None, limit: TimeLimit | None, have: dict[str, str]
) -> SnapshotPlan | None:
    """Where and how often trials save snapshots (None: `every` is None, never), stopping at
    the time limit; snapshots of trials already recorded go (a run killed as a record landed)."""
    if every is None:
        return None
    plan = SnapshotPlan.of(results_dir, every, None if limit is None else limit.wall_deadline())
    finished = {trial_id for trial_id, status in have.items() if status == "ok"}
    for trial_id in plan.saved() & finished:
        plan.discard(trial_id)
    return plan


def make_demo_pools(specs: list[TrialSpec]) -> None:
    """Record the demonstration pools the trials read, once each, before workers fork (each
    would otherwise record its own)."""
    plans = [plan(s) for s in specs]
    sources = {
        (p.spec.env_id, p.spec.dataset or "", p.filmed)
        for p in plans
        if p.algorithm.inputs in ("states", "actions")
    }
    for env_id, dataset, filmed in sources:
        demo_pool(env_id, dataset or None, filmed)


@contextmanager
def _scheduler(backend: str, scheduler: str | None) -> Iterator[Client | None]:
    """A client of the dask scheduler at `scheduler` for the block; None where there is none to
    reach (another backend, or dask on a local cluster)."""
    if backend != "dask" or scheduler is None:
        yield None
        return
    from distributed import Client

    try:
        _refused_at_once(scheduler)
        client = Client(scheduler, timeout="20s")
    except OSError as e:  # no scheduler there, or one that does not answer
        raise BadInput(f"cannot reach the dask scheduler at {scheduler}: {e}") from None
    try:
        yield client
    finally:
        client.close()


@contextmanager
def _workers(backend: str, jobs: int, client: Client | None) -> Iterator[int]:
    """joblib set to run on `backend` (loky here; dask: `client`'s cluster, or a local one
    started for the block where it is None) for the block, which gets the number of workers."""
    local = None
    try:
        if backend == "dask":
            if client is None:
                from distributed import Client

                client = local = Client(processes=True)
            ctx = joblib.parallel_config(backend="dask")
            workers = sum(client.nthreads().values())
        else:
            ctx = joblib.parallel_config(backend=backend, n_jobs=jobs)
            workers = jobs if jobs > 0 else os.cpu_count() or 1
        with ctx, warnings.catch_warnings():
            # loky replaces workers that grew in memory and says so; no trial is lost by it.
            warnings.filterwarnings("ignore", message="A worker stopped while some jobs were given")
            yield workers
    finally:
        if local is not None:
            local.close()


def _refused_at_once(scheduler: str) -> None:
    """Raise OSError (refused, unreachable network) where a TCP scheduler's address answers
    at once that nothing can connect: dask would keep trying for its whole timeout. A slow or
    unknown host, or another protocol, is left to dask's own attempts."""
    from distributed.comm import parse_address, parse_host_port

    try:
        scheme, location = parse_address(scheduler)
        host, port = parse_host_port(location)
    except ValueError:
        return
    if scheme == "tcp":
        with contextlib.suppress(socket.timeout, socket.gaierror):
            socket.create_connection((host, port), timeout=5).close()


class _Landing:
    """Where finished trials land: their policy and record written, their snapshot dropped,
    their cost learned, the counts and the progress bar (with its estimate of the time left)
    brought up to date."""

    def __init__(
        self,
        results_dir: Path,
        costs: CostModel,
        snapshot_plan: SnapshotPlan | None,
        workers: int,
        todo: list[TrialSpec],
        progress: bool,
    ) -> None:
        self.results_dir, self.costs, self.snapshot_plan = results_dir, costs, snapshot_plan
        self.workers = workers
        self.unfinished = {spec.trial_id: spec for spec in todo}
        self.done = self.failed = self.paused = 0
        self.cpu_s = 0.0
        self.bar = tqdm(
            total=len(todo), desc="trials", unit="trial", disable=not progress, dynamic_ncols=True
        )
        self.bar.set_postfix(left=costs.time_left(self.unfinished.values(), workers))

    def land(self, result: TrialResult) -> None:
        del self.unfinished[result.trial_id]
        if result.status == "paused":  # no record: its snapshot is what is kept
            self.paused += 1
        else:
            if result.policy is not None:  # before the record: it implies its policy
                policies.write(self.results_dir, result.trial_id, result.policy)
            store.write(self.results_dir, result)
            self.cpu_s += result.cpu_time or 0.0
            if self.snapshot_plan is not None:  # a record (ok or failed) ends the trial
                self.snapshot_plan.discard(result.trial_id)
            self.costs.finished(result)
        if result.status == "ok":
            self.done += 1
        elif result.status == "failed":
            self.failed += 1
            spec = result.spec
            self.say(f"failed: {spec.env_id} {spec.shown} seed {spec.seed}: {result.raised or '?'}")
        self.bar.update(1)
        # "left" counts the trials in flight in full: an upper bound.
        left = self.costs.time_left(self.unfinished.values(), self.workers)
        counts = {"done": self.done, "failed": self.failed}
        self.bar.set_postfix(
            **counts, **({"paused": self.paused} if self.paused else {}), left=left
        )

    def summary(self, skipped: int, linked: int, set_aside: int) -> RunSummary:
        """What the run did, once every trial has landed (or been left for later)."""
        left = len(self.unfinished)  # never started, under a time limit
        return RunSummary(
            self.done,
            self.failed,
            skipped,
            left=left,
            paused=self.paused,
            linked=linked,
            set_aside=set_aside,
            cpu_s=self.cpu_s,
        )

    def say(self, line: str) -> None:
        """A line above the progress bar, on stdout; where its reader has left (`| head`), the
        run goes on without it (stdout goes nowhere from then on)."""
        try:
            self.bar.write(line)
        except BrokenPipeError:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())


def _run_all(
    todo: list[TrialSpec],
    jobs: int,
    dispatch: Callable[[list[TrialSpec]], Iterator],
    landing: _Landing,
) -> None:
    """Run the trials (`dispatch` makes the joblib calls of those not yet landed) and land each
    as it finishes. A worker killed from outside (by a user, the out-of-memory killer) takes
    the pool's other workers with it: each trial in flight goes back to pending and starts
    again from its snapshot, and nothing is failed for it; only if workers keep dying with no
    trial landing does the run stop (`WorkersDying`)."""
    deaths_in_a_row = 0
    while True:
        parallel = joblib.Parallel(
            n_jobs=jobs, return_as="generator_unordered", pre_dispatch="n_jobs"
        )
        try:
            for result in parallel(dispatch([s for s in todo if s.trial_id in landing.unfinished])):
                landing.land(result)
                deaths_in_a_row = 0
            return
        except TerminatedWorkerError:
            deaths_in_a_row += 1
            if deaths_in_a_row >= WORKER_DEATHS:
                raise WorkersDying(
                    f"{deaths_in_a_row} worker processes died in a row and no trial"
                    " landed in between (something keeps killing them?): stopped;"
                    " the same command resumes where this run stopped"
                ) from None
            landing.say(
                "a worker process died (killed from outside the run?): the trials in"
                " flight start again, from their snapshots; the run goes on"
            )
