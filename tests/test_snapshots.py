"""Snapshots for real: a trial killed mid-run, or paused at a time limit, resumes from its last
snapshot and ends exactly where it would have ended in one go (same machine, same seed),
off-policy and on."""

import dataclasses
import json
import os
import signal
import subprocess
import sys
import time

import pytest

from bench.harness import policies, store
from bench.harness.costs import TimeLimit, estimate
from bench.harness.runner import run_suite
from bench.harness.snapshots import FOLDER, SnapshotPlan
from bench.harness.suite import load_suite
from bench.harness.types import TrialResult, TrialSpec

PENDULUM = "InvertedPendulumBulletEnv-v0"

pytestmark = pytest.mark.usefixtures("demo_cache")


def learning(folder) -> list:
    """Snapshots saved past 300 env steps: after the learners' first updates."""
    saved = [json.loads(p.read_text()) for p in folder.glob("*.json")]
    return [p for p in saved if p["env_steps"] > 300]


def untimed(logs: dict) -> dict:
    """Logs but for the seconds spent (`collect_s`, `update_s`), which no two runs share."""
    return {k: v for k, v in logs.items() if not k.endswith("_s")}


OFF_POLICY = "hidden: [16, 16], learning_starts: 300, batch_size: 32"
ON_POLICY = "hidden: [16, 16], n_envs: 2, steps_per_env: 128"
LEARNERS = {
    # gaifo-sac: a reward (D) with a state of its own; opolo: a learner of its own (TD3, M, D)
    "off-policy": (
        1000,
        f"[{{gaifo-sac: {{{OFF_POLICY}}}}}, {{opolo: {{{OFF_POLICY}, disc_hidden: [16, 16],"
        " inverse_pretrain: 20, train_every: 100}}]",
    ),
    # gaifo: D and the policy average beside TRPO; tcn: an embedding trained before TRPO
    "on-policy": (
        10240,
        f"[{{gaifo: {{{ON_POLICY}, disc_hidden: [16, 16]}}}},"
        f" {{tcn: {{{ON_POLICY}, embed_steps: 50}}}}]",
    ),
    # pwil: a reward whose state, each env's coupling, runs on across TRPO's batches and
    # episodes cut by the snapshot
    "on-policy reward state": (10240, f"[{{pwil: {{{ON_POLICY}}}}}]"),
    # bco: an inverse model and the agent's own data, grown each iteration; float64 actions
    "bco": (
        6000,
        "[{bco: {pre_demo_steps: 1000, alpha: 0.25, n_envs: 2, inverse_steps: 50,"
        " inverse_refit_steps: 20, bc_steps: 50, inverse_hidden: [16, 16],"
        " policy_hidden: [16, 16]}}]",
    ),
}


@pytest.mark.parametrize("optimizer", sorted(LEARNERS))
@pytest.mark.slow
def test_a_killed_then_paused_trial_resumes_and_ends_as_if_never_stopped(
    optimizer, tmp_path, bench_here
):
    budget, algorithms = LEARNERS[optimizer]
    suite = tmp_path / "s.yaml"
    suite.write_text(
        f"name: snap\nenvs: {{{PENDULUM}: {{budget: {budget}}}}}\ndemos: [1]\n"
        f"algorithms: {algorithms}\nseeds: 1\neval_episodes: 2\n"
    )
    specs = list(load_suite(suite).trials)
    # Under parents of their own: a run links what a folder beside it has finished.
    whole = tmp_path / "a" / "whole"
    assert run_suite(specs, whole, jobs=2, progress=False, snapshot_every=None).failed == 0

    cut = tmp_path / "b" / "cut"
    run = [sys.executable, "-m", "bench.cli", "run", str(suite), "--results", str(cut)]
    proc = subprocess.Popen(
        [*run, "--jobs", "2", "--snapshot-every", "0.2s"],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.time() + 120
    while len(learning(cut / FOLDER)) < len(specs) and time.time() < deadline:
        time.sleep(0.05)
    time.sleep(0.3)  # work past the snapshots, lost with the kill
    os.killpg(proc.pid, signal.SIGKILL)  # driver and workers, mid-trial
    proc.wait()
    assert not list((cut / "trials").glob("*.json")), "the kill should land mid-trial"
    assert len(list((cut / FOLDER).glob("*.pt"))) == len(specs)

    out = bench_here("run", str(suite), "--results", str(cut), "--estimate")
    assert f"{len(specs)} of them resume from a snapshot" in out.stdout, out.stdout
    # Resumed under a time limit that ends in half a second: each trial still in flight then
    # saves and stops at its next chance (one that finished first has its record).
    limit = TimeLimit.starting_now(0.5, pause_floor_s=0.0)
    stopped = run_suite(specs, cut, jobs=2, progress=False, limit=limit)
    assert stopped.failed == 0 and stopped.paused >= 1, stopped
    assert stopped.done + stopped.paused == len(specs)
    paused = SnapshotPlan.of(cut).saved() - {r.trial_id for r in store.scan(cut)}
    assert len(paused) == stopped.paused
    out = bench_here("run", str(suite), "--results", str(cut), "--jobs", "2")
    assert out.returncode == 0, out.stderr
    assert not list((cut / FOLDER).iterdir())  # a written record ends its snapshot, leftovers too
    left = SnapshotPlan.of(cut)  # as if a run were killed between a record and its removal
    left.write(specs[0].trial_id, {"stale": True}, env_steps=500, budget=1000)
    (cut / FOLDER / f"{specs[0].trial_id}.pt.x1y2.tmp").write_bytes(b"cut off mid-write")
    assert run_suite(specs, cut, progress=False).skipped == len(specs) and not left.saved()
    assert not list((cut / FOLDER).iterdir())
    resumed = {r.trial_id: r for r in store.scan(cut)}
    for one_go in store.scan(whole):
        again = resumed[one_go.trial_id]
        assert again.resumed_at and 300 < again.resumed_at[0] < budget  # updates under way
        assert len(again.resumed_at) == (2 if again.trial_id in paused else 1)
        assert again.resumed_at == sorted(again.resumed_at)
        assert again.env_steps == one_go.env_steps == budget
        assert again.cpu_time > 0 and one_go.cpu_time > 0  # its runs' CPU seconds, summed
        assert again.returns == one_go.returns
        assert again.curve == one_go.curve
        assert untimed(again.logs) == untimed(one_go.logs)
        kept = [policies.path(folder, one_go.trial_id).read_bytes() for folder in (whole, cut)]
        assert kept[0] == kept[1]


def test_a_cut_off_trial_is_priced_at_what_its_snapshot_leaves(tmp_path):
    spec = TrialSpec("s", "A", "gaifo-sac", 5, 0, 1000, 10)
    records = [TrialResult(spec, "ok", [1.0], [], 1000, 100.0, {})]
    todo = [dataclasses.replace(spec, seed=seed) for seed in (1, 2)]
    plan = SnapshotPlan.of(tmp_path)
    plan.write(todo[0].trial_id, {"anything": 1}, env_steps=750, budget=1000)
    done_before = plan.done_before(todo)
    assert done_before == {todo[0].trial_id: 0.75, todo[1].trial_id: 0.0}
    (row,) = estimate(todo, records, done_before)
    assert row.seconds == pytest.approx((25.0 + 100.0) / 2)
    assert plan.read(todo[0].trial_id) == {"anything": 1}
    plan.discard(todo[0].trial_id)
    assert plan.read(todo[0].trial_id) is None and plan.done_fraction(todo[0].trial_id) == 0.0


PLUGIN_LOOP = '''
from dataclasses import dataclass

import numpy as np
import torch

from bench.harness.registry import register, snapshots_of
from bench.rl.resume import Resumable
from bench.rl.rollout import VecCollector


@dataclass
class SearchConfig:
    step: float = 0.1
    """Std of each random perturbation of the weights."""


class Linear:
    def __init__(self, weights):
        self.weights = weights

    def __call__(self, obs):
        return np.tanh(obs @ self.weights.numpy()).astype(np.float32)


@register("search", config=SearchConfig, inputs="none", resumable=True, family="trpo")
def search(task, demos, budget, seed, logger, config):
    """Random search on the env's reward, in a loop of the plugin's own."""
    rng = np.random.default_rng(seed)
    best = torch.zeros(task.obs_dim, task.act_dim)
    envs = VecCollector([task.make_env(seed * 1000 + i) for i in range(2)], seed * 1000)
    resume = Resumable(snapshots_of(logger), {"best": best, "rng": rng}, {"envs": envs})
    resumed = resume.restore()
    steps, score = (resumed["steps"], resumed["score"]) if resumed else (0, -np.inf)
    while steps + 100 <= budget:
        trial = best + torch.from_numpy(rng.normal(0, config.step, best.shape)).float()
        batch = envs.run(Linear(trial), 50)
        steps += batch.n_steps
        if batch.rewards.mean() > score:
            best.copy_(trial)
            score = float(batch.rewards.mean())
        logger.log(steps, score=score)
        logger.checkpoint(steps, Linear(best.clone()))
        resume.save_if_due(lambda: {"steps": steps, "score": score})
    return Linear(best.clone())
'''


@pytest.mark.slow
def test_a_plugin_loop_resumes_through_the_wrapper(tmp_path, cli, install_plugin):
    """A loop of a plugin's own names its parts to `Resumable`, and a trial of it killed
    mid-run resumes and ends where a run in one go ends."""
    env = install_plugin(
        tmp_path / "plugin",
        "search-plugin",
        "search = search_plugin",
        {"search_plugin": PLUGIN_LOOP},
    )
    env["IFO_BENCH_CACHE"] = str(tmp_path / "cache")
    suite = tmp_path / "s.yaml"
    suite.write_text(
        f"name: loop\nenvs: {{{PENDULUM}: {{budget: 30000}}}}\ndemos: [1]\nalgorithms: [search]\n"
        "seeds: 1\neval_episodes: 2\n"
    )
    whole, cut = tmp_path / "a" / "whole", tmp_path / "b" / "cut"
    out = cli("run", str(suite), "--results", str(whole), env=env)
    assert out.returncode == 0, out.stderr
    run = [sys.executable, "-m", "bench.cli", "run", str(suite), "--results", str(cut)]
    proc = subprocess.Popen(
        [*run, "--snapshot-every", "0.2s"],
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    deadline = time.time() + 120
    while not learning(cut / FOLDER) and time.time() < deadline:
        time.sleep(0.05)
    time.sleep(0.3)
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    assert not list((cut / "trials").glob("*.json")), "the kill should land mid-trial"
    out = cli("run", str(suite), "--results", str(cut), env=env)
    assert out.returncode == 0, out.stderr
    (one_go,), (again,) = store.scan(whole), store.scan(cut)
    assert again.resumed_at and 300 < again.resumed_at[0] < 30000
    assert (again.returns, again.curve) == (one_go.returns, one_go.curve)
    assert untimed(again.logs) == untimed(one_go.logs)
