"""SIGKILL to a run's worker processes (never its driver) at random moments: the run goes on,
each trial in flight starts again (from its snapshot), and every trial ends with a record.

    python benchmarks/kill_workers.py [--kills 20] [--seed 0]

Runs a suite of short `survival` trials on InvertedPendulum with `--jobs 2` and
`--snapshot-every 2s`, kills one of its loky workers at a random moment 0.5-8 s after each
trial that lands, until `--kills` kills, then prints what the run
said and checks its records: all trials there, each exactly once, each ok, none
half-written, no snapshot left over, and each computing what an uninterrupted run computes.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

SUITE = """name: kill-workers
envs: {InvertedPendulumBulletEnv-v0: {budget: 30720}}
demos: [1]
algorithms: [survival]
seeds: 24
eval_episodes: 2
"""


def workers_of(driver: int) -> list[int]:
    """The pids of the driver's loky worker processes."""
    found = []
    for entry in Path("/proc").iterdir():
        try:
            stat = (entry / "stat").read_text()
            command = (entry / "cmdline").read_bytes()
        except OSError:
            continue
        if int(stat.rsplit(")", 1)[1].split()[1]) == driver and b"LokyProcess" in command:
            found.append(int(entry.name))
    return sorted(found)


def _outcome(record: Path) -> tuple:
    """What a trial computed (not when or how often it was resumed)."""
    r = json.loads(record.read_text())
    return r["status"], r["returns"], r["curve"], r["env_steps"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kills", type=int, default=20)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = random.Random(args.seed)
    folder = Path(tempfile.mkdtemp(prefix="kill-workers-"))
    (folder / "suite.yaml").write_text(SUITE)
    results = folder / "results"
    command = [sys.executable, "-m", "bench.cli", "run", str(folder / "suite.yaml")]
    command += ["--results", str(results), "--jobs", "2", "--snapshot-every", "2s"]
    log = open(folder / "run.log", "w")  # noqa: SIM115 - the run writes it while we watch
    run = subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
    kills, landed = 0, 0
    while kills < args.kills and run.poll() is None:
        # after each trial that lands, a kill at a random moment 0.5-8 s later: a run whose
        # workers die faster than any trial can land stops by design (runner.WORKER_DEATHS)
        while run.poll() is None and len(list((results / "trials").glob("*.json"))) <= landed:
            time.sleep(0.2)
        landed = len(list((results / "trials").glob("*.json")))
        time.sleep(rng.uniform(0.5, 8.0))
        workers = workers_of(run.pid)
        if workers and run.poll() is None:
            os.kill(rng.choice(workers), signal.SIGKILL)
            kills += 1
    run.wait()
    log.close()
    said = (folder / "run.log").read_text().replace("\r", "\n")
    records = [json.loads(p.read_text()) for p in (results / "trials").glob("*.json")]
    statuses = [r["status"] for r in records]
    print(f"{kills} workers killed; run exit status {run.returncode}")
    print(f"'a worker process died' said {said.count('a worker process died')} times")
    print(
        f"records: {len(records)} of 24, {statuses.count('ok')} ok, {statuses.count('failed')} failed"
    )
    seeds = sorted(r["spec"]["seed"] for r in records)
    leftovers = list((results / "trials").glob("*.tmp")) + list((results / ".partial").glob("*"))
    print(f"each seed once: {seeds == list(range(24))}; leftovers: {len(leftovers)}")
    quiet = Path(tempfile.mkdtemp(prefix="kill-workers-quiet-")) / "results"  # not beside: no reuse
    uninterrupted = [*command[:-6], "--results", str(quiet), "--jobs", "2"]
    subprocess.run(uninterrupted, capture_output=True, check=False)
    same = sum(
        _outcome(p) == _outcome(quiet / "trials" / p.name)
        for p in (results / "trials").glob("*.json")
    )
    print(f"returns and curves as an uninterrupted run's: {same} of {len(records)}")
    print(f"(run folder: {folder})")


if __name__ == "__main__":
    main()
