"""The runner for real: loky and dask workers, SIGKILL and resume, plugins, failures."""

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from matplotlib.patches import Rectangle

from bench.analysis import normalize, plot
from bench.harness import frames, store
from bench.harness.costs import CostModel, TimeLimit, estimate
from bench.harness.runner import _jobs, run_suite
from bench.harness.snapshots import SnapshotPlan
from bench.harness.suite import load_suite
from bench.harness.types import TrialResult, TrialSpec

PENDULUM = "InvertedPendulumBulletEnv-v0"


def write_suite(folder: Path, name: str, body: str) -> Path:
    path = folder / f"{name}.yaml"
    path.write_text(f"name: {name}\n{body}")
    return path


def start_run(suite: Path, results: Path, jobs: str, **popen) -> subprocess.Popen:
    """`bench run SUITE --results RESULTS --jobs JOBS` started in a session of its own (so its
    whole process group can be signalled), its stdout discarded."""
    command = [sys.executable, "-m", "bench.cli", "run", str(suite), "--results", str(results)]
    return subprocess.Popen(
        [*command, "--jobs", jobs], stdout=subprocess.DEVNULL, start_new_session=True, **popen
    )


pytestmark = pytest.mark.usefixtures("demo_cache")


@pytest.mark.slow
def test_killed_run_resumes_without_losing_or_duplicating(tmp_path, cli):
    suite = write_suite(
        tmp_path,
        "kill",
        f"envs: {{{PENDULUM}: {{budget: 6144}}}}\ndemos: [1]\nalgorithms: [survival]\nseeds: 8\neval_episodes: 2\n",
    )
    results = tmp_path / "res"
    proc = start_run(suite, results, "2", stderr=subprocess.DEVNULL)
    deadline = time.time() + 120
    while len(list((results / "trials").glob("*.json"))) < 3 and time.time() < deadline:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGKILL)  # driver and workers, mid-run
    proc.wait()
    before = {p.name: p.read_bytes() for p in (results / "trials").glob("*.json")}
    assert 3 <= len(before) < 8, "the kill should land mid-run"
    for data in before.values():
        json.loads(data)  # every record on disk is whole

    out = cli("run", str(suite), "--results", str(results), "--jobs", "2")
    assert out.returncode == 0, out.stderr
    assert f"{len(before)} already finished" in out.stdout
    assert "core-minutes of CPU" in out.stdout  # what the trials run this time took
    after = {p.name: p.read_bytes() for p in (results / "trials").glob("*.json")}
    assert len(after) == 8 and not list((results / "trials").glob("*.tmp"))
    assert all(after[name] == data for name, data in before.items())  # finished trials untouched
    ids = {s.trial_id for s in list(load_suite(suite).trials)}
    assert {name.removesuffix(".json") for name in after} == ids


@pytest.mark.slow
def test_dask_backend_matches_loky(tmp_path, on_dask):
    suite = write_suite(
        tmp_path,
        "dask",
        f"envs: {{{PENDULUM}: {{budget: 4096}}}}\ndemos: [1]\nalgorithms: [random, gaifo]\nseeds: 2\neval_episodes: 2\n",
    )
    specs = list(load_suite(suite).trials)
    loky = run_suite(specs, tmp_path / "loky", jobs=2, progress=False)
    assert loky.done == len(specs) == 4
    spent = [r.cpu_time for r in store.scan(tmp_path / "loky")]  # measured in each trial's fork
    assert all(s > 0 for s in spent) and loky.cpu_s == pytest.approx(sum(spent))
    dask = on_dask(specs, tmp_path / "dask", workers=2)
    assert dask.done == 4
    a, b = frames.load(tmp_path / "loky"), frames.load(tmp_path / "dask")
    np.testing.assert_array_equal(a["return"].to_numpy(), b["return"].to_numpy())
    np.testing.assert_array_equal(a["env_steps"].to_numpy(), b["env_steps"].to_numpy())
    # Each record says what its algorithm was given, so figures need no registry.
    assert dict(zip(a["algorithm"], a["inputs"], strict=True)) == {
        "random": "none",
        "gaifo": "states",
    }


FLAKY = (
    "from dataclasses import dataclass\nfrom bench.harness.registry import register\n\n"
    "@dataclass\nclass C:\n    pass\n\n"
    "@register('flaky', config=C, inputs='none')\n"
    "def train(task, demos, budget, seed, logger, config):\n"
    "    raise RuntimeError('lost the simulator')\n"
)


DYING = (
    "import os, signal, sys\nfrom dataclasses import dataclass\n"
    "import numpy as np\nfrom bench.harness.registry import register\n\n"
    "@dataclass\nclass C:\n    pass\n\n"
    "@register('dying', config=C, inputs='none')\n"
    "def train(task, demos, budget, seed, logger, config):\n"
    "    if seed == 0:\n        os._exit(3)\n"
    "    if seed == 1:\n        os.kill(os.getpid(), signal.SIGSEGV)\n"
    "    if seed == 2:\n        sys.exit(4)\n"
    "    return lambda obs: np.zeros((len(obs), task.act_dim))\n"
)


@pytest.mark.parametrize("jobs", ["1", "2"])
@pytest.mark.slow
def test_a_trial_whose_process_dies_is_that_trials_failure(tmp_path, cli, install_plugin, jobs):
    """A learner that exits, or is killed by a signal, inside its trial fails that trial with how
    it died; the run goes on with the rest and a rerun does not try it again."""
    env = install_plugin(tmp_path / "site", "dying", "dying = dying_ifo", {"dying_ifo": DYING})
    suite = write_suite(
        tmp_path,
        "dying",
        f"envs: {{{PENDULUM}: {{budget: 1000}}}}\ndemos: [1]\nalgorithms: [random, dying]\n"
        "seeds: 4\neval_episodes: 1\n",
    )
    results = tmp_path / "res"
    run = ("run", str(suite), "--results", str(results), "--jobs", jobs)
    out = cli(*run, env=env)
    assert out.returncode == 1, out.stderr
    assert "5 trials done, 3 failed" in out.stdout
    records = {r.spec.seed: r for r in store.scan(results) if r.spec.algorithm == "dying"}
    assert records[3].status == "ok"
    assert "exited with status 3" in records[0].traceback
    assert "killed by signal 11 (SIGSEGV)" in records[1].traceback
    assert "exited with status 4" in records[2].traceback
    again = cli(*run, env=env)
    assert "0 trials done, 0 failed, 8 already finished" in again.stdout


BEATING = (
    "import os, time\nfrom dataclasses import dataclass\n"
    "from bench.harness.registry import register\n\n"
    "@dataclass\nclass C:\n    pass\n\n"
    "@register('beating', config=C, inputs='none')\n"
    "def train(task, demos, budget, seed, logger, config):\n"
    "    beat = os.path.join(os.environ['BEATS'], str(seed))\n"
    "    while True:  # trains forever, writing as a trial's snapshots are written\n"
    "        with open(beat, 'a') as f:\n            f.write('.')\n"
    "        time.sleep(0.02)\n"
)


def _lock_is_free(folder: Path) -> bool:
    import fcntl

    with open(folder / store.LOCK, "a") as handle:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return False
        fcntl.flock(handle, fcntl.LOCK_UN)
        return True


@pytest.mark.parametrize("jobs", ["1", "2"])
@pytest.mark.slow
def test_once_a_terminated_runs_lock_is_free_nothing_of_it_still_writes(
    tmp_path, install_plugin, jobs
):
    """SIGTERM to `bench run` (a scheduler's end of a job): the run says so and exits 143, and
    by the time its folder's lock can be taken, none of its trials is still writing; so a
    second run into the folder never shares it with orphans."""
    env = install_plugin(
        tmp_path / "site", "beating", "beating = beating_ifo", {"beating_ifo": BEATING}
    )
    beats = tmp_path / "beats"
    beats.mkdir()
    suite = write_suite(
        tmp_path,
        "beat",
        f"envs: {{{PENDULUM}: {{budget: 1000}}}}\ndemos: [1]\nalgorithms: [beating]\nseeds: 2\n",
    )
    results = tmp_path / "res"
    for _ in range(2):  # the race this guards against was intermittent
        proc = start_run(
            suite,
            results,
            jobs,
            stderr=subprocess.PIPE,
            text=True,
            env={**env, "BEATS": str(beats)},
        )
        deadline = time.time() + 120
        want = 2 if jobs == "2" else 1
        while len(list(beats.iterdir())) < want and time.time() < deadline:
            time.sleep(0.05)
        assert len(list(beats.iterdir())) == want, "the trials should be running"
        proc.send_signal(signal.SIGTERM)
        while not _lock_is_free(results):
            assert time.time() < deadline, "the run should end on SIGTERM"
            time.sleep(0.001)
        sizes = {p: p.stat().st_size for p in beats.iterdir()}
        time.sleep(0.3)
        assert {p: p.stat().st_size for p in beats.iterdir()} == sizes, "an orphan still writes"
        assert proc.wait(timeout=30) == 143
        assert "terminated" in proc.stderr.read()
        for p in beats.iterdir():
            p.unlink()


@pytest.mark.slow
def test_failing_trial_is_recorded_and_retried(tmp_path, cli, install_plugin):
    env = install_plugin(tmp_path / "site", "flaky", "flaky = flaky_ifo", {"flaky_ifo": FLAKY})
    suite = write_suite(
        tmp_path,
        "fail",
        f"envs: {{{PENDULUM}: {{budget: 1000}}}}\ndemos: [1]\nalgorithms: [random, flaky]\nseeds: 1\neval_episodes: 1\n",
    )
    results = tmp_path / "res"
    run = ("run", str(suite), "--results", str(results), "--jobs", "1")
    out = cli(*run, env=env)
    assert out.returncode == 1
    assert "1 trials done, 1 failed" in out.stdout
    df = frames.load(results)
    failed = df[df.status == "failed"]
    assert list(failed.algorithm) == ["flaky"]
    record = store.read(store.record_path(results, failed.trial_id.iloc[0]))
    assert "lost the simulator" in record.traceback
    out = cli(*run, env=env)
    assert "0 trials done, 0 failed, 2 already finished" in out.stdout
    out = cli(*run, "--retry-failed", env=env)
    assert "0 trials done, 1 failed, 1 already finished" in out.stdout


def finished(spec: TrialSpec, seconds: float) -> TrialResult:
    """A record of `spec` that trained its whole budget in `seconds`."""
    return TrialResult(spec, "ok", [1.0], [], spec.budget, seconds, {})


def test_dispatch_runs_unseen_kinds_then_the_costliest_first():
    def spec(env: str, algorithm: str, seed: int, budget: int = 1000) -> TrialSpec:
        return TrialSpec("t", env, algorithm, 0, seed, budget, 1)

    cheap, dear = spec(PENDULUM, "oracle", 1), spec(PENDULUM, "survival", 1)
    unseen = spec(PENDULUM, "oracle-sac", 0, budget=10)
    timed = [
        finished(spec(PENDULUM, "oracle", 0), 0.1),
        finished(spec(PENDULUM, "survival", 0), 10.0),
    ]
    jobs = _jobs([cheap, dear, unseen], CostModel.of(timed))
    assert next(jobs)[1][0] == unseen  # its cost is unknown: learn it early
    assert next(jobs)[1][0] == dear  # then the costliest; the cheap one fills the tail

    costs = CostModel.of(timed)
    jobs = _jobs([cheap, dear, spec(PENDULUM, "survival", 2)], costs)
    assert next(jobs)[1][0] == dear
    costs.observe(finished(spec(PENDULUM, "oracle", 2), 100.0))  # a slow one finished meanwhile
    assert next(jobs)[1][0] == cheap  # the order follows what was learned

    # The suite's `runner.first` algorithms go before every other, dearest first among them.
    sac = [spec(PENDULUM, "survival-sac", s, budget=b) for s, b in ((0, 100), (1, 200))]
    costs.observe(finished(spec(PENDULUM, "survival-sac", 9), 0.01))  # known to be the cheapest
    assert [job[1][0] for job in _jobs([dear, *sac], costs)][0] == dear
    jobs = _jobs([dear, unseen, *sac, cheap], costs, first={"survival-sac"})
    order = [job[1][0] for job in jobs]
    assert order[:2] == sac[::-1] and set(order[2:]) == {dear, unseen, cheap}

    # Before them all, the references every score is normalized against: they cost an
    # evaluation, and a run cut short without them leaves nothing that can be read.
    random, expert = spec(PENDULUM, "random", 0), spec(PENDULUM, "expert", 0)
    costs.observe(finished(spec(PENDULUM, "random", 9), 0.001))
    jobs = _jobs([*sac, dear, random, expert], costs, first={"survival-sac"})
    order = [job[1][0] for job in jobs]
    assert set(order[:2]) == {random, expert} and order[2:4] == sac[::-1]


def test_trials_resuming_from_a_snapshot_run_before_new_ones():
    def spec(algorithm: str, seed: int, budget: int = 1000) -> TrialSpec:
        return TrialSpec("t", PENDULUM, algorithm, 0, seed, budget, 1)

    dear, resumed, unseen = spec("survival", 1), spec("oracle", 1), spec("oracle-sac", 0)
    costs = CostModel.of([finished(spec("survival", 0), 10.0), finished(spec("oracle", 0), 1.0)])
    costs.done_before = {resumed.trial_id: 0.9}  # 0.1 s left: the cheapest, yet it goes first
    assert [job[1][0] for job in _jobs([dear, unseen, resumed], costs)] == [resumed, unseen, dear]
    # The suite's `runner.first` algorithms still go before any other.
    order = [job[1][0] for job in _jobs([dear, resumed], costs, first={"survival"})]
    assert order == [dear, resumed]


def test_a_labelled_variant_is_priced_by_its_own_records_once_it_has_some():
    """Wider networks cost otherwise: a variant goes by its algorithm only until it has run."""
    plain = TrialSpec("t", PENDULUM, "oracle", 0, 0, 1000, 1)
    wide = dataclasses.replace(plain, label="oracle-wide", hyperparams={"hidden": [256, 256]})
    costs = CostModel.of([finished(plain, 10.0)])
    seconds, basis = costs.price(dataclasses.replace(wide, seed=1))
    assert seconds == pytest.approx(10.0) and "oracle's: no oracle-wide trial yet" in basis
    costs.observe(finished(wide, 80.0))
    seconds, basis = costs.price(dataclasses.replace(wide, seed=1))
    assert seconds == pytest.approx(80.0) and basis == "median of 1 trials"
    assert costs.price(dataclasses.replace(plain, seed=1))[0] == pytest.approx(10.0)


def test_a_time_limit_starts_the_dearest_trial_that_still_fits_and_then_stops():
    # Survival at 0.01 s per step: 50, 30 and 20 s; gaifo never timed.
    specs = [
        TrialSpec("t", PENDULUM, "survival", 1, seed, budget, 1)
        for seed, budget in enumerate((5000, 3000, 2000))
    ]
    unpriced = TrialSpec("t", PENDULUM, "gaifo", 1, 0, 1000, 1)
    costs = CostModel.of([finished(TrialSpec("t", PENDULUM, "survival", 1, 9, 1000, 1), 10.0)])
    now = [0.0]
    limit = TimeLimit.starting_now(60.0, clock=lambda: now[0])
    jobs = _jobs([*specs, unpriced], costs, limit=limit)
    assert next(jobs)[1][0] == specs[0]  # 50 s of 60 fits
    now[0] = 35.0  # 25 s left: the 30-s trial no longer fits, the 20-s one does
    assert next(jobs)[1][0] == specs[2]
    assert next(jobs, None) is None  # 30 s and unpriced: neither fits, so the run ends

    # The dearest that fits goes first, whatever the suite's order, after the references,
    # which cost their evaluation (1 s here) at any budget.
    reference = TrialSpec("t", PENDULUM, "random", 1, 0, 1000, 1)
    costs.observe(TrialResult(reference, "ok", [1.0], [], 0, 1.0, {}))
    limit = TimeLimit.starting_now(60.0, clock=lambda: 0.0)
    order = [job[1][0] for job in _jobs([*specs[::-1], reference], costs, limit=limit)]
    assert order == [reference, *specs]


def test_once_none_fits_a_time_limit_starts_trials_that_can_pause_while_worth_it(tmp_path):
    # Survival takes snapshots and can pause at the limit; random cannot. At 0.01 s per step,
    # survival's 1,000 steps fit in the 40 s left and its 5,000 do not; random is unpriced.
    dear = TrialSpec("t", PENDULUM, "survival", 1, 0, 5000, 1)
    cheap = dataclasses.replace(dear, seed=1, budget=1000)
    unpriced = TrialSpec("t", PENDULUM, "random", 1, 0, 1000, 1)
    costs = CostModel.of([finished(dataclasses.replace(dear, seed=9, budget=1000), 10.0)])
    now = [10.0]
    limit = TimeLimit.starting_now(40.0, clock=lambda: now[0], pause_floor_s=20.0)
    plan = SnapshotPlan.of(tmp_path)
    jobs = _jobs([unpriced, cheap, dear], costs, limit=limit, snapshot_plan=plan)
    assert next(jobs)[1][0] == cheap  # 10 s: fits
    assert next(jobs)[1][0] == dear  # 50 s does not, but it can pause, with 40 s left
    assert next(jobs, None) is None  # random cannot pause
    now[0] = 30.0  # 20 s left: still worth starting one that pauses, 19.9 s not
    assert next(_jobs([dear], costs, limit=limit, snapshot_plan=plan))[1][0] == dear
    now[0] = 30.1
    assert next(_jobs([dear], costs, limit=limit, snapshot_plan=plan), None) is None
    # Without snapshots nothing can pause: only what fits starts.
    now[0] = 10.0
    assert [job[1][0] for job in _jobs([dear, cheap], costs, limit=limit)] == [cheap]
    # Nor where pausing is off (`--no-pause`: a disk that does not outlive the run).
    no_pause = dataclasses.replace(limit, pause=False)
    assert [
        job[1][0] for job in _jobs([dear, cheap], costs, limit=no_pause, snapshot_plan=plan)
    ] == [cheap]


def test_a_time_limit_fits_trials_at_this_runs_pace():
    """Prices are CPU seconds; a core shared with other work takes longer on the clock. Once
    this run's first trial took twice its price, a trial priced at 30 s of the 40 s left no
    longer fits (60 s at that pace), and one priced at 20 s still does."""
    spec = TrialSpec("t", PENDULUM, "survival", 1, 0, 1000, 1)
    costs = CostModel.of([finished(dataclasses.replace(spec, seed=s), 10.0) for s in (7, 8, 9)])
    priced_30, priced_20 = (
        dataclasses.replace(spec, seed=s, budget=b) for s, b in ((1, 3000), (2, 2000))
    )
    limit = TimeLimit.starting_now(40.0, clock=lambda: 0.0)
    assert next(_jobs([priced_30], costs, limit=limit))[1][0] == priced_30
    costs.finished(finished(dataclasses.replace(spec, seed=3), 20.0))  # priced 10 s: took 20
    assert costs.pace_factor() == pytest.approx(2.0)
    assert [job[1][0] for job in _jobs([priced_30, priced_20], costs, limit=limit)] == [priced_20]


@pytest.mark.slow
def test_time_limit_leaves_the_trials_that_would_not_fit(tmp_path, cli):
    # Prices come from the records beside the results folder: here, records that say a
    # survival trial takes an hour per 2,048 steps and a random one two seconds.
    results = tmp_path / "results"
    for algorithm, env_steps, seconds in (("survival", 2048, 3600.0), ("random", 0, 2.0)):
        spec = TrialSpec("priced", PENDULUM, algorithm, 1, 0, 2048, 2)
        store.write(results / "priced", TrialResult(spec, "ok", [1.0], [], env_steps, seconds, {}))
    suite = write_suite(
        tmp_path,
        "limited",
        f"envs: {{{PENDULUM}: {{budget: 2048}}}}\ndemos: [1]\nseeds: 1\neval_episodes: 2\n"
        "algorithms: [random, survival]\n",
    )
    run = ("run", str(suite), "--results", str(results / "limited"), "--jobs", "2")
    # Under 5 min, not even a trial that could pause at the limit is worth starting.
    out = cli(*run, "--time-limit", "4m")
    assert out.returncode == 0, out.stderr
    assert "1 trials done, 0 failed" in out.stdout and "1 trials not started" in out.stdout
    assert {r.spec.algorithm for r in store.scan(results / "limited")} == {"random"}
    # The progress bar prices by the same records: the hour-long trial left over 2 workers,
    # none unpriced.
    assert "left=~30 min]" in out.stderr.replace("\r", "\n").splitlines()[-1]
    assert "1 of 2 trials pending" in cli(*run, "--estimate").stdout
    # With 10 min left the survival trial would start and pause at the limit; not under
    # --no-pause, where its snapshot would not outlive the run.
    out = cli(*run, "--time-limit", "10m", "--no-pause")
    assert "0 trials done" in out.stdout and "1 trials not started" in out.stdout, out.stdout
    assert not (results / "limited" / ".partial").exists()


def test_an_estimate_with_nothing_pending_prints_no_table(tmp_path, cli):
    body = f"envs: {{{PENDULUM}: {{budget: 2048}}}}\ndemos: [1]\nseeds: 1\neval_episodes: 2\n"
    suite = write_suite(tmp_path, "done", body + "algorithms: [random]\n")
    run = ("run", str(suite), "--results", str(tmp_path / "done"))
    assert cli(*run, "--jobs", "1").returncode == 0
    out = cli(*run, "--estimate")
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines()[1:] == ["nothing to run: every trial has its record"]
    assert out.stdout.startswith("0 of 1 trials pending")


def test_time_left_is_the_expected_seconds_over_the_workers():
    def spec(algorithm: str, seed: int, budget: int = 1000) -> TrialSpec:
        return TrialSpec("t", PENDULUM, algorithm, 0, seed, budget, 1)

    costs = CostModel.of([finished(spec("gaifo", 0), 1800.0)])  # half an hour per 1,000 steps
    # a learner of no known family and never timed: nothing to price it by
    todo = [spec("gaifo", 1), spec("gaifo", 2, budget=2000), spec("not-installed", 1)]
    assert costs.time_left(todo[:2], workers=1) == "~1.5 h"
    assert costs.time_left(todo, workers=2) == "~45 min +1 unpriced"
    assert costs.time_left(todo[2:], workers=1) == "unknown (1 trials of kinds never timed)"


def test_time_left_corrects_itself_by_this_runs_pace():
    """Records made on a faster machine: once this run's first trial takes twice what they
    predicted, the time left doubles."""

    def spec(seed: int) -> TrialSpec:
        return TrialSpec("t", PENDULUM, "gaifo", 0, seed, 1000, 1)

    costs = CostModel.of([finished(spec(0), 600.0)])
    todo = [spec(seed) for seed in range(2, 8)]
    assert costs.time_left(todo, workers=1) == "~1.0 h"
    costs.finished(finished(spec(1), 1200.0))  # this machine: twice as slow as expected
    assert costs.pace_factor() == pytest.approx(2.0)
    # 6 trials at the records' mean now (900 s), at this run's pace (x2): 3 hours
    assert costs.time_left(todo, workers=1) == "~3.0 h"


def test_a_price_from_wall_times_does_not_set_the_pace_of_a_cpu_timed_trial():
    """Wall times made on a loaded machine price a trial high; one that took less on the clock
    says nothing of this machine's pace until its kind is priced by CPU time."""

    def spec(seed: int) -> TrialSpec:
        return TrialSpec("t", PENDULUM, "oracle", 0, seed, 1000, 1)

    costs = CostModel.of([finished(spec(0), 1800.0)])  # wall time, on a shared core
    timed = dataclasses.replace(finished(spec(1), 1200.0), cpu_time=1100.0)
    costs.finished(timed)
    assert costs.pace_factor() == 1.0
    # Priced by its CPU time from now on (1,100 s): the next such trial sets the pace.
    costs.finished(dataclasses.replace(finished(spec(2), 1650.0), cpu_time=1100.0))
    assert costs.pace_factor() == pytest.approx(1.5)


@pytest.mark.slow
def test_two_variants_of_one_algorithm_run_and_plot_side_by_side(tmp_path, cli):
    suite = write_suite(
        tmp_path,
        "ablation",
        f"envs: {{{PENDULUM}: {{budget: 2048}}}}\ndemos: [1]\nseeds: 2\neval_episodes: 2\n"
        "algorithms:\n  - random\n  - expert\n  - gaifo\n"
        "  - {algorithm: gaifo, label: gaifo-no-absorbing, absorbing: false}\n",
    )
    out = cli("run", str(suite), "--results", str(tmp_path / "res"), "--jobs", "2")
    assert out.returncode == 0, out.stderr
    records = list(store.scan(tmp_path / "res"))
    variant = [r for r in records if r.spec.label == "gaifo-no-absorbing"]
    assert len(variant) == 2 and all(r.spec.hyperparams["absorbing"] is False for r in variant)
    df = normalize.normalize(frames.load(tmp_path / "res"))
    fig = plot.draw_figure2(df)
    assert len([p for p in fig.axes[0].patches if isinstance(p, Rectangle)]) == 2
    assert [t.get_text() for t in fig.legends[0].get_texts()][:2] == ["GAIfO", "gaifo-no-absorbing"]
    out = cli("compare", str(tmp_path / "res"), str(tmp_path / "res"))
    assert out.returncode == 0 and "gaifo-no-absorbing" in out.stdout


def test_estimate_from_seconds_per_step_here_or_at_most_the_slowest_env():
    def done(env_id: str, algorithm: str, seconds: float, budget: int = 1000) -> TrialResult:
        spec = TrialSpec("s", env_id, algorithm, 5, 0, budget, 10)
        return TrialResult(spec, "ok", [1.0], [], budget, seconds, {})

    records = [done("A", "gaifo", 10.0), done("A", "gaifo", 30.0), done("B", "gaifo", 100.0)]
    todo = [
        TrialSpec("s", env, algo, 5, seed, 2000, 10)
        for env, algo in [("A", "gaifo"), ("C", "gaifo"), ("C", "bco")]
        for seed in (1, 2)
    ]
    rows = {(r.env_id, r.algorithm): r for r in estimate(todo, records)}
    assert rows["A", "gaifo"].seconds == pytest.approx(40.0) and rows["A", "gaifo"].trials == 2
    assert rows["C", "gaifo"].seconds == pytest.approx(200.0)  # B's 0.1 s per step, the slowest
    assert "B" in rows["C", "gaifo"].basis
    assert rows["C", "bco"].seconds is None


def test_one_record_of_a_swamped_machine_does_not_set_the_price():
    """A survival trial that took 30x its like ones (paused for hours, or a core shared five
    ways) among four ordinary ones: the price is theirs, not a mean four times over."""

    def done(seconds: float) -> TrialResult:
        spec = TrialSpec("s", "A", "survival", 5, 0, 1000, 10)
        return TrialResult(spec, "ok", [1.0], [], 1000, seconds, {})

    records = [done(s) for s in (9.0, 10.0, 11.0, 12.0, 300.0)]
    (row,) = estimate([TrialSpec("s", "A", "survival", 5, 1, 2000, 10)], records)
    assert row.seconds == pytest.approx(22.0) and "median of 5" in row.basis


def test_records_that_measured_their_cpu_time_price_by_it_not_by_their_wall_time():
    """Two trials that shared a core took twice their cost in wall time; their CPU time is the
    cost. Where a kind has records of both, the ones that measured CPU time price it."""

    def done(wall: float, cpu: float | None) -> TrialResult:
        spec = TrialSpec("s", "A", "gaifo", 5, 0, 1000, 10)
        return TrialResult(spec, "ok", [1.0], [], 1000, wall, {}, cpu_time=cpu)

    todo = [TrialSpec("s", "A", "gaifo", 5, 1, 2000, 10)]
    (row,) = estimate(todo, [done(20.0, None), done(22.0, None)])
    assert row.seconds == pytest.approx(42.0)  # wall times, the only measure there is
    (row,) = estimate(todo, [done(20.0, None), done(22.0, 10.0), done(19.0, 11.0)])
    assert row.seconds == pytest.approx(21.0) and "median of 2" in row.basis


def test_a_kind_timed_only_by_the_wall_here_is_scaled_from_the_cpu_timed_kinds_here():
    """GAIL's records on A are wall times of trials that shared a core (4x their cost); GAIfO's
    there measured CPU time. GAIL on A is then priced as GAIfO on A, times GAIL's CPU rate over
    GAIfO's where both measured it (B), not by its own swollen wall times."""

    def done(env_id: str, algorithm: str, wall: float, cpu: float | None) -> TrialResult:
        spec = TrialSpec("s", env_id, algorithm, 5, 0, 1000, 10)
        return TrialResult(spec, "ok", [1.0], [], 1000, wall, {}, cpu_time=cpu)

    records = [
        done("A", "gail", 40.0, None),
        done("A", "gaifo", 12.0, 10.0),
        done("B", "gaifo", 25.0, 20.0),
        done("B", "gail", 26.0, 22.0),
    ]
    todo = [TrialSpec("s", "A", "gail", 5, 1, 2000, 10)]
    (row,) = estimate(todo, records)
    assert row.seconds == pytest.approx(10.0 * 22.0 / 20.0 * 2)
    assert "gaifo" in row.basis and "CPU" in row.basis
    (row,) = estimate(todo, records[:2])  # nothing measured GAIL's CPU time: its wall times
    assert row.seconds == pytest.approx(80.0) and "median of 1" in row.basis


def test_a_kind_new_to_an_env_is_scaled_from_the_algorithms_measured_there():
    """GAIfO on a new env, where only the oracle has run: the oracle's rate here times GAIfO's
    rate over the oracle's on the envs where both ran (a geometric mean over them)."""

    def done(env_id: str, algorithm: str, seconds: float) -> TrialResult:
        spec = TrialSpec("s", env_id, algorithm, 5, 0, 1000, 10)
        return TrialResult(spec, "ok", [1.0], [], 1000, seconds, {})

    records = [
        *(done(env, "gaifo", s) for env, s in [("A", 20.0), ("B", 300.0), ("D", 900.0)]),
        *(done(env, "oracle", s) for env, s in [("A", 10.0), ("B", 100.0), ("C", 50.0)]),
    ]
    todo = [TrialSpec("s", "C", "gaifo", 5, 1, 2000, 10)]
    (row,) = estimate(todo, records)
    # GAIfO/oracle: 2x on A, 3x on B (D has no oracle): sqrt(6) x the oracle's 0.05 s per step
    assert row.seconds == pytest.approx(0.05 * 6**0.5 * 2000)
    assert "oracle" in row.basis and "scaled" in row.basis


def test_a_reference_costs_its_evaluation_at_any_budget():
    # A tiny-budget expert record (no env step of training) must not scale to 200 minutes at 2M.
    spec = TrialSpec("s", "A", "expert", 5, 0, 256, 10)
    records = [TrialResult(spec, "ok", [1.0], [], 0, 5.0, {})]
    todo = [TrialSpec("s", env, "expert", 5, 1, 2_000_000, 10) for env in ("A", "B")]
    rows = {r.env_id: r for r in estimate(todo, records)}
    assert rows["A"].seconds == rows["B"].seconds == pytest.approx(5.0)


def test_a_state_trials_estimate_never_goes_by_a_pixel_trials_cost():
    def done(env_id: str, observation: str | None, seconds: float) -> TrialResult:
        spec = TrialSpec("s", env_id, "gaifo", 5, 0, 1000, 10, observation=observation)
        return TrialResult(spec, "ok", [1.0], [], 1000, seconds, {})

    records = [done("A", None, 10.0), done("B", "pixels", 500.0)]
    todo = [TrialSpec("s", "C", "gaifo", 5, 1, 1000, 10)]
    (row,) = estimate(todo, records)
    assert row.seconds == pytest.approx(10.0) and "A" in row.basis
    (row,) = estimate([dataclasses.replace(todo[0], observation="pixels")], records)
    assert row.seconds == pytest.approx(500.0) and "B (pixels)" in row.basis


@pytest.mark.slow
def test_two_suites_that_ask_for_the_same_trial_share_one_record(tmp_path):
    """A trial is identified by what decides it, not by its suite or label: a labelled variant
    in a screen and the plain entry of a suite whose env sets the same settings are one trial,
    run once and linked into the second suite's folder, where it reads as that suite's."""
    tiny = f"envs: {{{PENDULUM}: {{budget: 2048, trpo: {{n_envs: 2}}}}}}\ndemos: [1]\n"
    screen = write_suite(
        tmp_path,
        "screen",
        f"envs: {{{PENDULUM}: {{budget: 2048}}}}\ndemos: [1]\nalgorithms: [random, expert,"
        " {algorithm: survival, label: survival-e2, n_envs: 2}]\nseeds: 2\neval_episodes: 2\n",
    )
    suite = write_suite(
        tmp_path,
        "figure",
        tiny + "algorithms: [random, expert, survival]\nseeds: 2\neval_episodes: 2\n",
    )
    results = tmp_path / "results"
    first = run_suite(list(load_suite(screen).trials), results / "screen", jobs=1, progress=False)
    assert first.failed == 0 and first.done == 6
    specs = list(load_suite(suite).trials)
    second = run_suite(specs, results / "figure", jobs=1, progress=False, priced_by=results)
    assert (second.done, second.linked, second.skipped) == (0, 6, 6)
    files = sorted(store.trials_dir(results / "figure").glob("*.json"))
    assert len(files) == 6 and all(store.LINK in json.loads(f.read_text()) for f in files)
    linked = {r.spec.algorithm: r for r in store.scan(results / "figure") if r.spec.seed == 0}
    assert linked["survival"].spec.label is None and linked["survival"].spec.suite == "figure"
    assert linked["survival"].label == "Survival"
    assert linked["survival"].stored_in == str(results / "screen")
    source = {r.spec.shown: r for r in store.scan(results / "screen") if r.spec.seed == 0}
    assert linked["survival"].returns == source["survival-e2"].returns
    assert linked["survival"].trial_id == source["survival-e2"].trial_id
    again = run_suite(specs, results / "figure", jobs=1, progress=False, priced_by=results)
    assert (again.done, again.linked, again.skipped) == (0, 0, 6)  # linked once, found after


@pytest.mark.slow
def test_a_run_links_what_another_suite_finished_and_runs_the_rest(tmp_path, cli, install_plugin):
    env = install_plugin(tmp_path / "site", "flaky", "flaky = flaky_ifo", {"flaky_ifo": FLAKY})
    body = f"envs: {{{PENDULUM}: {{budget: 1000}}}}\ndemos: [1]\nalgorithms: [random, flaky]\n"
    first = write_suite(tmp_path, "first", body + "seeds: 2\neval_episodes: 2\n")
    # flaky fails: failed records are never linked
    a = ("run", str(first), "--results", str(tmp_path / "res" / "a"), "--jobs", "1")
    assert cli(*a, env=env).returncode == 1
    second = write_suite(tmp_path, "second", body + "seeds: 3\neval_episodes: 2\n")
    other = write_suite(tmp_path, "other", body + "seeds: 3\neval_episodes: 3\n")
    for suite, linked in ((second, 2), (other, 0)):  # other evaluates differently: not the same
        results = tmp_path / "res" / suite.stem
        estimate = cli("run", str(suite), "--results", str(results), "--estimate", env=env)
        assert f"{6 - linked} of 6 trials pending" in estimate.stdout
        out = cli("run", str(suite), "--results", str(results), "--jobs", "1", env=env)
        assert f"{3 - linked} trials done, 3 failed" in out.stdout
        assert (f"{linked} of them by other suites (linked)" in out.stdout) == bool(linked)
    old = {(r.spec.seed, r.spec.algorithm): r for r in store.scan(tmp_path / "res" / "a")}
    new = {(r.spec.seed, r.spec.algorithm): r for r in store.scan(tmp_path / "res" / "second")}
    for seed in (0, 1):
        link, source = new[seed, "random"], old[seed, "random"]
        assert link.spec == dataclasses.replace(source.spec, suite="second")
        assert link.returns == source.returns and link.stored_in.endswith("a")
    assert new[2, "random"].stored_in is None  # no such trial there: it ran
    assert sorted(new) == [(s, a) for s in range(3) for a in ("flaky", "random")]  # all, once
    assert {r.spec.suite for r in new.values()} == {"second"}


def test_a_learner_never_timed_is_priced_as_its_optimizers_learners_on_the_env():
    """A plugin's first run (AIRLfO here, a reward on TRPO): as the TRPO learners that trained
    on this env, by their median seconds per step; not as the controls, which train no reward,
    and never for a name of no family."""

    def done(algorithm: str, seconds: float) -> TrialResult:
        spec = TrialSpec("s", "A", algorithm, 5, 0, 1000, 10)
        return TrialResult(spec, "ok", [1.0], [], 1000, seconds, {})

    records = [done("gaifo", 10.0), done("gail", 30.0), done("oracle", 2.0)]
    todo = [TrialSpec("s", "A", name, 5, 1, 2000, 10) for name in ("airlfo", "not-registered")]
    rows = {r.algorithm: r for r in estimate(todo, records)}
    assert rows["airlfo"].seconds == pytest.approx(0.02 * 2000)
    assert rows["airlfo"].basis == "rough: as the trpo learners here (gaifo, gail)"
    assert rows["not-registered"].seconds is None
