"""What a stuck plugin, a plugin's leftover child or a killed worker can do to a run: each ends
that trial (or sends it back to pending), frees its worker and lets the run go on."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from bench.harness import isolate, trial
from bench.harness.isolate import Died, isolated
from benchmarks.kill_workers import workers_of  # the benchmark kills workers alike

PENDULUM = "InvertedPendulumBulletEnv-v0"


def sleep_forever() -> None:
    time.sleep(3600)


def leave_a_child_holding_the_pipe(marker: str) -> str:
    """Fork a grandchild that outlives this call (holding the result pipe), note its pid."""
    if os.fork() == 0:
        time.sleep(3600)
        os._exit(0)
    Path(marker).write_text(str(os.getpid()))
    return "done"


def alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    return Path(f"/proc/{pid}").exists() and "Z" not in _state(pid)


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except OSError:
        return "Z"


def test_a_call_past_its_timeout_is_stopped():
    start = time.monotonic()
    result = isolated(sleep_forever, timeout=1.5)
    assert isinstance(result, Died) and result.timed_out == 1.5
    assert time.monotonic() - start < 10 and "ran past its time limit" in str(result)


def test_a_child_left_behind_neither_blocks_the_call_nor_outlives_it(tmp_path):
    marker = tmp_path / "pid"
    start = time.monotonic()
    assert isolated(leave_a_child_holding_the_pipe, str(marker)) == "done"
    assert time.monotonic() - start < 10
    group = int(marker.read_text())
    time.sleep(0.2)
    leftovers = [p for p in os.listdir("/proc") if p.isdigit() and _pgid(int(p)) == group]
    assert not [p for p in leftovers if alive(int(p))]


def _pgid(pid: int) -> int | None:
    try:
        return os.getpgid(pid)
    except ProcessLookupError:
        return None


def test_a_child_dying_without_a_word_while_its_child_holds_the_pipe_is_died(tmp_path):
    def die_leaving_a_child() -> None:
        if os.fork() == 0:
            time.sleep(3600)
            os._exit(0)
        os._exit(3)

    start = time.monotonic()
    result = isolated(die_leaving_a_child)
    assert result == Died(exit_status=3) and time.monotonic() - start < isolate.POLL_S + 5


def write_suite(folder: Path, body: str) -> Path:
    path = folder / "s.yaml"
    path.write_text(body)
    return path


@pytest.mark.usefixtures("demo_cache")
def test_a_trial_past_the_suites_trial_timeout_is_failed_and_the_run_goes_on(tmp_path, cli):
    suite = write_suite(
        tmp_path,
        f"name: t\nenvs: {{{PENDULUM}: {{budget: 400000}}}}\ndemos: [1]\n"
        "algorithms: [random, survival]\nseeds: 1\neval_episodes: 2\n"
        "runner: {trial_timeout: 8s}\n",
    )
    out = cli("run", str(suite), "--results", str(tmp_path / "r"), "--jobs", "1")
    assert out.returncode == 1 and "TrialTimedOut" in out.stdout + out.stderr  # a trial failed
    records = [json.loads(p.read_text()) for p in (tmp_path / "r" / "trials").glob("*.json")]
    by_algorithm = {r["spec"]["algorithm"]: r for r in records}
    assert by_algorithm["random"]["status"] == "ok"
    assert by_algorithm["survival"]["status"] == "failed"
    assert "TrialTimedOut" in by_algorithm["survival"]["traceback"]
    assert "1 failed" in out.stdout


@pytest.mark.usefixtures("demo_cache")
def test_a_trial_that_does_not_pause_is_stopped_soon_after_the_time_limit(tmp_path, monkeypatch):
    from bench.harness.snapshots import SnapshotPlan
    from bench.harness.suite import load_suite

    monkeypatch.setattr(trial, "OVERRUN_S", 2.0)
    suite = load_suite(
        write_suite(
            tmp_path,
            f"name: t\nenvs: {{{PENDULUM}: {{budget: 400000}}}}\ndemos: [1]\n"
            "algorithms: [survival]\nseeds: 1\neval_episodes: 2\n",
        )
    )
    (spec,) = suite.trials
    inputs = trial.plan(spec).inputs()
    plan = SnapshotPlan.of(tmp_path / "r", every_s=10_000.0, stop_at=time.time() + 4.0)
    start = time.monotonic()
    result = trial.run_trial_apart(spec, inputs, snapshots=plan)  # saves and pauses itself
    assert result.status == "paused" and time.monotonic() - start < 4.0 + 2.0
    assert plan.read(spec.trial_id) is not None

    monkeypatch.setattr(trial, "run_trial", lambda *args: sleep_forever())  # never saves
    plan = SnapshotPlan.of(tmp_path / "r2", every_s=10_000.0, stop_at=time.time() + 4.0)
    start = time.monotonic()
    result = trial.run_trial_apart(spec, inputs, snapshots=plan)
    assert result.status == "paused" and 4.0 + 2.0 <= time.monotonic() - start < 4.0 + 2.0 + 5


@pytest.mark.slow
@pytest.mark.usefixtures("demo_cache")
def test_a_killed_worker_sends_its_trial_back_and_the_run_goes_on(tmp_path):
    suite = write_suite(
        tmp_path,
        f"name: k\nenvs: {{{PENDULUM}: {{budget: 12288}}}}\ndemos: [1]\n"
        "algorithms: [survival]\nseeds: 6\neval_episodes: 2\n",
    )
    results = tmp_path / "r"
    command = [sys.executable, "-m", "bench.cli", "run", str(suite), "--results", str(results)]
    proc = subprocess.Popen(
        [*command, "--jobs", "2"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    killed = 0
    deadline = time.time() + 240
    while killed < 2 and time.time() < deadline and proc.poll() is None:
        time.sleep(1.0)
        workers = workers_of(proc.pid)
        if len(workers) == 2 and list((results / "trials").glob("*.json")):
            os.kill(workers[killed % 2], signal.SIGKILL)
            killed += 1
    out, err = proc.communicate(timeout=600)
    assert proc.returncode == 0, err
    assert killed >= 1 and "a worker process died" in out + err
    records = [json.loads(p.read_text()) for p in (results / "trials").glob("*.json")]
    assert len(records) == 6 and all(r["status"] == "ok" for r in records)


def test_a_reader_that_leaves_fails_no_trial(tmp_path):
    """`bench run ... | head`: what a trial prints after the reader left goes nowhere; the
    call still returns its result."""
    code = (
        "import time\n"
        "from bench.harness.isolate import isolated\n"
        "def chatty():\n"
        "    time.sleep(1.0)\n"
        "    for i in range(10000):\n"
        "        print('line', i, flush=True)\n"
        "    return 'computed'\n"
        "import sys\n"
        "sys.stderr.write(repr(isolated(chatty)))\n"
    )
    reader, writer = os.pipe()
    proc = subprocess.Popen(
        [sys.executable, "-c", code], stdout=writer, stderr=subprocess.PIPE, text=True
    )
    os.close(writer)
    os.close(reader)  # the reader leaves before anything is printed
    _, err = proc.communicate(timeout=60)
    assert "'computed'" in err and "BrokenPipeError" not in err, err


def test_a_policies_file_where_the_folder_goes_is_refused_before_any_work(tmp_path, bench_here):
    (tmp_path / "r").mkdir()
    (tmp_path / "r" / "policies").write_text("not a folder")
    out = bench_here(
        "run", str(Path(__file__).parent.parent / "suites" / "quick.yaml"), "--results",
        str(tmp_path / "r"),
    )  # fmt: skip
    assert out.returncode == 2 and "is a file where a run keeps its policies" in out.stderr
    assert not (tmp_path / "r" / "trials").exists()


def test_a_policy_that_does_not_load_back_fails_its_trial(monkeypatch):
    from bench.harness import policies
    from bench.rl.networks import DeterministicPolicy, GaussianPolicy

    good = policies.to_bytes(DeterministicPolicy(GaussianPolicy(3, 1), [-1.0], [1.0]))
    assert policies.from_bytes(good)(__import__("numpy").zeros((2, 3))).shape == (2, 1)
    with pytest.raises(policies.PolicyError, match="the trained policy: not a policy file"):
        policies.from_bytes(good[: len(good) // 2])
