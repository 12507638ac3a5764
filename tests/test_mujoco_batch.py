"""The MuJoCo locomotion tasks stepped E at a time (`bench.envs.mujoco_batch`) give what
gymnasium's own envs give stepped one by one, to the bit, through falls, time limits and resets;
and a trial's collector gives the same batches either way."""

import gymnasium as gym
import numpy as np
import pytest
import torch

from bench import envs
from bench.rl.networks import GaussianPolicy
from bench.rl.rollout import VecCollector, evaluate, step_together

TASKS = ["Hopper-v5", "Walker2d-v5", "HalfCheetah-v5", "Ant-v5"]
E = 4


def ends_of(results: list) -> int:
    return sum(int(term or trunc) for _, _, term, trunc in results)


def library_steps(env_id: str, actions: np.ndarray, limit: int) -> list:
    """gymnasium's envs as it ships them, stepped one by one: per step (obs, reward, term, trunc)
    of each env, resetting at ends (seeds 0..E-1 first, then unseeded)."""
    lib = [gym.make(env_id, disable_env_checker=True, max_episode_steps=limit) for _ in range(E)]
    for i, env in enumerate(lib):
        env.reset(seed=i)
    out = []
    for row in actions:
        step = []
        for env, a in zip(lib, row, strict=True):
            o, r, term, trunc, _ = env.step(a)
            step.append((o, r, term, trunc))
            if term or trunc:
                env.reset()
        out.append(step)
    return out


def batched_steps(env_id: str, actions: np.ndarray, limit: int) -> list:
    made = [envs.make(env_id, i) for i in range(E)]
    for env in made:
        env._max_episode_steps = limit
    together = step_together(made)
    assert together is not None
    out = []
    for row in actions:
        o, r, term, trunc = together(made, row)
        out.append(list(zip(o, r, term, trunc, strict=True)))
        for i in np.flatnonzero(term | trunc):
            made[i].reset()
    return out


@pytest.mark.parametrize("env_id", TASKS)
def test_a_batched_step_is_the_library_step(env_id):
    rng = np.random.default_rng(3)
    act_dim = gym.make(env_id).action_space.shape[0]
    for scale, limit in ((1.0, 1000), (0.3, 60)):  # falls at full actions; time limits at 60
        actions = (rng.uniform(-1, 1, (700, E, act_dim)) * scale).astype(np.float32)
        want = library_steps(env_id, actions, limit)
        got = batched_steps(env_id, actions, limit)
        for step_got, step_want in zip(got, want, strict=True):
            for (o, r, term, trunc), (o2, r2, term2, trunc2) in zip(
                step_got, step_want, strict=True
            ):
                assert o.dtype == o2.dtype and np.array_equal(o, o2)
                assert r == r2 and np.float64(r).tobytes() == np.float64(r2).tobytes()
                assert (bool(term), bool(trunc)) == (term2, trunc2)
        ended = sum(bool(term or trunc) for step in want for _, _, term, trunc in step)
        assert ended > 0 or (env_id == "HalfCheetah-v5" and limit == 1000)


def test_only_the_plain_tasks_step_together(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # MuJoCo's notes on Ant's model file land here
    from bench.envs import mujoco_speed

    plain = envs.make("Hopper-v5", 0)
    assert step_together([plain, envs.make("Hopper-v5", 1)]) is not None
    assert step_together([plain, envs.make("Walker2d-v5", 1)]) is None  # two tasks: one by one
    wrapped = mujoco_speed.speed_up(gym.wrappers.ClipAction(gym.make("Hopper-v5")))
    assert step_together([wrapped]) is None
    other = mujoco_speed.speed_up(gym.make("Ant-v5", include_cfrc_ext_in_observation=False))
    assert step_together([other]) is None
    assert step_together([envs.make("InvertedPendulum-v5", 0)]) is None


@pytest.mark.parametrize("env_id", ["Hopper-v5", "Ant-v5"])
def test_a_collector_gathers_the_same_batches_either_way(env_id):
    obs_dim, act_dim, _, _ = envs.spaces(env_id)
    policy = GaussianPolicy(obs_dim, act_dim, log_std=0.5)
    batches = []
    for batched in (True, False):
        torch.manual_seed(0)
        collector = VecCollector([envs.make(env_id, 10 + i) for i in range(E)], seed=10)
        assert collector.together is not None
        if not batched:
            collector.together = None
        batches.append([collector.collect(policy, 128) for _ in range(3)])
        state = collector.state_dict()
        batches[-1].append(state["episodes"])
    for a, b in zip(batches[0][:3], batches[1][:3], strict=True):
        for name in (
            "obs",
            "actions",
            "next_obs",
            "rewards",
            "terminated",
            "truncated",
            "timesteps",
        ):
            assert np.array_equal(getattr(a, name), getattr(b, name)), name
        assert a.episode_returns == b.episode_returns
    assert sum(len(b.episode_returns) for b in batches[0][:3]) > 0
    for x, y in zip(batches[0][3], batches[1][3], strict=True):
        assert x["start"] == y["start"] and torch.equal(x["actions"], y["actions"])


def test_a_frozen_mean_is_the_policy_forward():
    policy = GaussianPolicy(11, 3, hidden=(32, 16))
    policy.norm.update(np.random.default_rng(0).normal(2.0, 3.0, (500, 11)))
    obs = torch.from_numpy(np.random.default_rng(1).normal(2.0, 9.0, (8, 11)).astype(np.float32))
    with torch.no_grad():
        assert torch.equal(policy.frozen_mean()(obs), policy(obs))


@pytest.mark.parametrize("env_id", ["Walker2d-v5", "HalfCheetah-v5"])
def test_evaluation_returns_the_same_either_way(env_id, monkeypatch):
    from bench.envs import mujoco_batch

    obs_dim, act_dim, _, _ = envs.spaces(env_id)
    weights = np.random.default_rng(0).normal(0, 0.3, (obs_dim, act_dim))

    def policy(obs: np.ndarray) -> np.ndarray:
        return np.tanh(obs @ weights)  # float64 actions: the envs take them as they are

    returns = []
    for enabled in (True, False):
        monkeypatch.setattr(mujoco_batch, "_enabled", enabled)
        made = [envs.make(env_id, 0) for _ in range(3)]
        assert (step_together(made) is not None) == enabled
        returns.append(evaluate(policy, made, episodes=5, seed=7))
    assert returns[0] == returns[1] and all(np.isfinite(returns[0]))
