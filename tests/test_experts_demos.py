import dataclasses
import json
import subprocess
import sys
import time

import numpy as np
import pytest
import torch

from bench import cli, paths
from bench.demos import experts, pools
from bench.imitation.data import ActionDemos, Demos
from bench.rl.trpo import TRPOConfig


@pytest.fixture(scope="module")
def tiny_expert(tmp_path_factory, pendulum="InvertedPendulumBulletEnv-v0"):
    """A barely trained pendulum expert in a throwaway experts folder."""
    root = tmp_path_factory.mktemp("experts")
    mp = pytest.MonkeyPatch()
    mp.setattr(paths, "EXPERTS_DIR", root)
    mp.setattr(paths, "CACHE_DIR", root / "cache")
    meta = experts.train_expert(
        pendulum, 8192, seed=0, cfg=TRPOConfig(n_envs=4, steps_per_env=512), progress=False
    )
    yield pendulum, meta
    mp.undo()


def test_expert_round_trip_reproduces_its_recorded_return(tiny_expert):
    env_id, meta = tiny_expert
    assert (paths.expert_dir(env_id) / "policy.pt").is_file()
    for key in (
        "env_id",
        "train_steps",
        "wall_time_s",
        "seed",
        "package_version",
        "return_mean",
        "return_std",
    ):
        assert key in meta
    policy = experts.load_expert(env_id)  # torch.load(weights_only=True) inside
    returns = experts.evaluate_policy(policy, env_id, experts.EVAL_EPISODES, seed=10_000)
    assert np.mean(returns) == pytest.approx(meta["return_mean"], abs=0.01)
    assert [m["env_id"] for m in experts.list_experts()] == [env_id]


def test_missing_expert_is_a_clear_error(tiny_expert):
    with pytest.raises(experts.ExpertError, match="no expert for HopperBulletEnv-v0"):
        experts.load_expert("HopperBulletEnv-v0")


def test_experts_list_markdown(tmp_path, monkeypatch, capsys, table_rows, table_rule):
    """A row per expert's meta.json, its numbers right-aligned; no policy is loaded."""
    monkeypatch.setattr(paths, "EXPERTS_DIR", tmp_path)
    folder = tmp_path / "HopperBulletEnv-v0"
    folder.mkdir()
    (folder / "policy.pt").write_bytes(b"")
    meta = {"env_id": folder.name, "return_mean": 2597.84, "return_std": 64.4}
    meta |= {"train_steps": 1_500_000, "wall_time_s": 582.0, "eval_episodes": 50}
    (folder / "meta.json").write_text(json.dumps(meta))
    assert cli.main(["experts", "list", "--markdown"]) == 0
    out = capsys.readouterr().out
    header = ["env", "return (mean +- std)", "train steps", "wall time"]
    assert table_rows(out) == [header, [folder.name, "2597.8 +- 64.4", "1,500,000", "9.7 min"]]
    assert [cell.endswith(":") for cell in table_rule(out, header)] == [False, True, True, True]


def test_demos_keep_final_observation_and_hide_actions(tiny_expert):
    env_id, _ = tiny_expert
    path = pools.ensure_pool(env_id)
    state_only = pools.load_demos(path, env_id, k=3, seed=0)
    assert isinstance(state_only, Demos) and state_only.n_episodes == 3
    assert "actions" not in {f.name for f in dataclasses.fields(Demos)}
    assert not hasattr(state_only, "actions")
    with_actions = pools.load_action_demos(path, env_id, k=3, seed=0)
    assert isinstance(with_actions, ActionDemos)
    for obs, acts in zip(with_actions.demos.observations, with_actions.actions, strict=True):
        assert len(obs) == len(acts) + 1  # T actions, T + 1 observations
    for a, b in zip(state_only.observations, with_actions.demos.observations, strict=True):
        np.testing.assert_array_equal(a, b)
    s, s_next = state_only.transitions()
    assert s.shape == s_next.shape and len(s) == sum(len(o) - 1 for o in state_only.observations)


def test_demo_draw_is_deterministic_and_seed_dependent(tiny_expert):
    env_id, _ = tiny_expert
    path = pools.ensure_pool(env_id)
    first = pools.load_demos(path, env_id, k=5, seed=1).observations
    again = pools.load_demos(path, env_id, k=5, seed=1).observations
    other = pools.load_demos(path, env_id, k=5, seed=2).observations
    assert all(np.array_equal(a, b) for a, b in zip(first, again, strict=True))
    assert not all(
        len(a) == len(b) and np.array_equal(a, b) for a, b in zip(first, other, strict=True)
    )


def test_demo_file_from_another_env_is_rejected(tiny_expert, tmp_path):
    env_id, _ = tiny_expert
    path = pools.ensure_pool(env_id)
    with pytest.raises(
        pools.DemoError, match=f"holds demonstrations of {env_id}, not HopperBulletEnv-v0"
    ):
        pools.load_demos(path, "HopperBulletEnv-v0")
    junk = tmp_path / "junk.npz"
    junk.write_text("not a zip")
    with pytest.raises(pools.DemoError, match="is not a demo file"):
        pools.load_demos(junk, env_id)
    with pytest.raises(pools.DemoError, match="does not exist"):
        pools.load_demos(tmp_path / "missing.npz", env_id)
    with pytest.raises(pools.DemoError, match="asked for 26 demonstrations"):
        pools.load_demos(path, env_id, k=26)


def test_demos_say_which_episodes_terminated(tiny_expert):
    """A barely trained expert drops the pole (terminated) well before the 1000-step time limit."""
    env_id, _ = tiny_expert
    pool = pools.load_demos(pools.ensure_pool(env_id), env_id)
    lengths = [len(o) - 1 for o in pool.observations]
    assert pool.terminated == tuple(n < 1000 for n in lengths)
    assert any(pool.terminated)
    drawn = pools.load_demos(pools.ensure_pool(env_id), env_id, k=5, seed=3)
    assert drawn.terminated == tuple(len(o) - 1 < 1000 for o in drawn.observations)


def test_demos_show_lists_each_episode_and_the_seeds_given_it(tiny_expert, bench_here):
    env_id, _ = tiny_expert
    path = pools.ensure_pool(env_id)
    pool = pools.load_demos(path, env_id)
    out = bench_here("demos", "show", env_id, "--demos", "3", "--seeds", "4")
    assert out.returncode == 0, out.stderr
    head, _, *lines = out.stdout.splitlines()
    assert f"{sum(pool.terminated)} ending in a terminal state" in head
    assert len(lines) == pools.POOL_SIZE
    given: dict[int, list[int]] = {seed: [] for seed in range(4)}
    for i, line in enumerate(lines):
        index, steps, _, *rest = line.split()
        ends = rest.pop(0) if rest[0] == "terminal" else " ".join(rest.pop(0) for _ in "ab")
        assert (int(index), int(steps)) == (i, len(pool.observations[i]) - 1)
        assert ends == ("terminal" if pool.terminated[i] else "time limit")
        for seed in rest:
            given[int(seed.rstrip(","))].append(i)
    for seed, episodes in given.items():  # what a trial of that seed is handed
        drawn = pools.load_demos(path, env_id, k=3, seed=seed).observations
        assert len(episodes) == 3
        assert all(
            np.array_equal(a, pool.observations[i]) for a, i in zip(drawn, episodes, strict=True)
        )

    out = bench_here("demos", "show", env_id, "--demos", str(pools.POOL_SIZE + 1))
    assert out.returncode == 2 and "the pool has 25 episodes" in out.stderr
    assert out.stdout == "" and len(out.stderr.strip().splitlines()) == 1


def test_demos_without_flags_never_terminated():
    episode = np.zeros((3, 2), np.float32)
    assert Demos("x", (episode, episode)).terminated == (False, False)
    with pytest.raises(ValueError, match="one terminated flag per episode"):
        Demos("x", (episode,), (True, False))


@pytest.mark.slow
def test_killed_expert_training_resumes_from_its_checkpoint(tmp_path):
    """A training run killed midway resumes from its last checkpoint, not from step 0."""
    env_id, out = "InvertedPendulumBulletEnv-v0", tmp_path / "expert"
    budget, cfg = 16384, TRPOConfig(n_envs=4, steps_per_env=256)
    settings = f"{env_id!r}, {budget}, seed=0, cfg={cfg!r}"
    script = (
        "from pathlib import Path\nfrom bench.demos import experts\nfrom bench.rl.trpo import TRPOConfig\n"
        f"experts.train_expert({settings}, out_dir=Path({str(out)!r}), progress=False,"
        " checkpoint_every=0.0)\n"
    )
    proc = subprocess.Popen([sys.executable, "-c", script])
    checkpoint = out / experts.CHECKPOINT
    try:
        deadline = time.time() + 120
        while not checkpoint.exists() and proc.poll() is None and time.time() < deadline:
            time.sleep(0.05)
    finally:
        proc.kill()
        proc.wait()
    assert checkpoint.exists() and not (out / "meta.json").exists(), "not killed midway"
    with pytest.raises(experts.ExpertError, match="other settings"):
        experts.train_expert(env_id, budget // 2, 0, cfg, out)
    resumed_at = torch.load(checkpoint, weights_only=True)["state"]["steps"]
    assert 0 < resumed_at < budget
    meta = experts.train_expert(env_id, budget, 0, cfg, out, progress=False)
    assert meta["resumes"] == 1 and meta["train_steps"] == budget
    assert not checkpoint.exists()
    policy = experts.GaussianPolicy(meta["obs_dim"], meta["act_dim"], tuple(meta["hidden"]))
    policy.load_state_dict(torch.load(out / "policy.pt", weights_only=True))
    # It resumed as if it had never stopped: the expert a run in one go ships, to the bit.
    in_one_go = experts.train_expert(env_id, budget, 0, cfg, tmp_path / "one-go", progress=False)
    assert in_one_go["return_mean"] == meta["return_mean"]
    assert in_one_go["snapshot"] == meta["snapshot"]
    one_go = torch.load(tmp_path / "one-go" / "policy.pt", weights_only=True)
    for name, value in torch.load(out / "policy.pt", weights_only=True).items():
        assert torch.equal(value, one_go[name]), name


def test_kept_snapshots_are_chosen_on_episodes_of_their_own(tmp_path):
    """With `kept_snapshots`, evenly spaced snapshots join best-seen and final; the one shipped
    scored highest on the selection episodes, and its return is measured on the usual ones."""
    env_id, out = "InvertedPendulum-v5", tmp_path / "expert"
    cfg = experts.ExpertTraining(n_envs=2, steps_per_env=512, kept_snapshots=3)
    meta = experts.train_expert(env_id, 6144, 0, cfg, out, progress=False)
    kept = [name for name in meta["selection"] if name.startswith("kept at")]
    assert kept == ["kept at 2048", "kept at 4096", "kept at 6144"]
    assert "final" in meta["selection"]
    assert meta["selection"][meta["snapshot"]] == max(meta["selection"].values())
    policy = experts.GaussianPolicy(meta["obs_dim"], meta["act_dim"], tuple(meta["hidden"]))
    policy.load_state_dict(torch.load(out / "policy.pt", weights_only=True))
    deterministic = experts.DeterministicPolicy(
        policy, np.array(meta["action_low"]), np.array(meta["action_high"])
    )
    returns = experts.evaluate_policy(deterministic, env_id, experts.EVAL_EPISODES, seed=10_000)
    assert np.mean(returns) == pytest.approx(meta["return_mean"], abs=0.01)
    with pytest.raises(ValueError, match="kept_snapshots"):
        experts.ExpertTraining(kept_snapshots=-1)
