import subprocess
import sys

import numpy as np
import pytest

from bench import envs


def rollout(env_id: str, seed: int, steps: int = 200) -> np.ndarray:
    return trajectory(env_id, seed, steps)[0]


def trajectory(env_id: str, seed: int, steps: int = 200) -> tuple[np.ndarray, np.ndarray]:
    """Random actions from `seed`: the observations, and per step (reward, terminated)."""
    env = envs.make(env_id, seed)
    obs, steps_taken = [env.reset(seed=seed)[0]], []
    for _ in range(steps):
        o, reward, term, trunc, _ = env.step(env.action_space.sample())
        obs.append(o)
        steps_taken.append((reward, term))
        if term or trunc:
            obs.append(env.reset()[0])
    env.close()
    return np.array(obs), np.array(steps_taken, np.float64)


@pytest.mark.parametrize("env_id", ["HopperBulletEnv-v0", "Pendulum-v1"])
def test_same_seed_same_rollout(env_id):
    a, b = rollout(env_id, 3), rollout(env_id, 3)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, rollout(env_id, 4))


@pytest.mark.parametrize(
    "env_id",
    ["HopperBulletEnv-v0", "Walker2DBulletEnv-v0", "HalfCheetahBulletEnv-v0", "AntBulletEnv-v0"],
)
def test_the_speed_patches_step_like_the_library(env_id):
    """bench.envs.bullet_speed reads the same simulator state with fewer calls: a speed-up only, so
    the same seed gives the same trajectory and rewards, bit for bit, through falls and resets."""
    from bench.envs import bullet_speed

    fast = trajectory(env_id, 5, steps=400)
    bullet_speed.restore()
    try:
        library = trajectory(env_id, 5, steps=400)
    finally:
        bullet_speed.apply_again()
    np.testing.assert_array_equal(fast[0], library[0])
    np.testing.assert_array_equal(fast[1], library[1])


def steps_of(env, actions: np.ndarray, seed: int) -> list:
    """Every reset observation and step result (infos included) of `actions`, resetting at ends."""
    out = [env.reset(seed=seed)[0]]
    for a in actions:
        o, reward, term, trunc, info = env.step(a)
        out += [o, reward, type(reward), term, trunc, info]
        if term or trunc:
            out.append(env.reset()[0])
    return out


def assert_bit_equal(a, b) -> None:
    assert type(a) is type(b)
    if isinstance(a, dict):
        assert list(a) == list(b)
        for key in a:
            assert_bit_equal(a[key], b[key])
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype
        np.testing.assert_array_equal(a, b)
    else:
        assert a == b


@pytest.mark.parametrize("env_id", ["Hopper-v5", "Walker2d-v5", "HalfCheetah-v5", "Ant-v5"])
def test_the_mujoco_speed_up_steps_like_the_library(env_id):
    """bench.envs.mujoco_speed computes each step's values once instead of twice: the same
    observations, rewards (and their types), ends and infos as gymnasium's own step, to the bit,
    through falls and resets, at full and at gentle random actions."""
    import gymnasium as gym

    fast = envs.make(env_id, 0)
    library = gym.make(env_id, disable_env_checker=True)
    assert "step" in vars(fast.unwrapped) and "step" not in vars(library.unwrapped)
    rng = np.random.default_rng(5)
    actions = rng.uniform(-1, 1, size=(1500, fast.action_space.shape[0])).astype(np.float32)
    for scale in (1.0, 0.3):
        got, want = steps_of(fast, actions * scale, 5), steps_of(library, actions * scale, 5)
        assert len(got) == len(want)
        for a, b in zip(got, want, strict=True):
            assert_bit_equal(a, b)
    assert sum(isinstance(x, bool) and x for x in want) > 0 or env_id == "HalfCheetah-v5"
    fast.close()
    library.close()


def test_the_mujoco_speed_up_leaves_other_options_to_the_library(tmp_path, monkeypatch):
    import gymnasium as gym

    monkeypatch.chdir(tmp_path)  # MuJoCo's notes on Ant's model file land in MUJOCO_LOG.TXT here

    from bench.envs import mujoco_speed

    ant = mujoco_speed.speed_up(gym.make("Ant-v5", include_cfrc_ext_in_observation=False))
    hopper = mujoco_speed.speed_up(
        gym.make("Hopper-v5", exclude_current_positions_from_observation=False)
    )
    assert "step" not in vars(ant.unwrapped) and "step" not in vars(hopper.unwrapped)


def test_unknown_env_is_one_clear_error():
    with pytest.raises(envs.EnvError, match="unknown env id 'NoSuchEnv-v0'"):
        envs.make("NoSuchEnv-v0", 0)


def test_discrete_actions_rejected():
    with pytest.raises(envs.EnvError, match="Discrete action space"):
        envs.make("CartPole-v1", 0)


def test_spaces_of_a_plain_gymnasium_env():
    obs_dim, act_dim, low, high = envs.spaces("Pendulum-v1")
    assert (obs_dim, act_dim) == (3, 1)
    assert low[0] == -2.0 and high[0] == 2.0


def test_pybullet_noise_does_not_reach_stdout():
    code = "from bench import envs; e = envs.make('HopperBulletEnv-v0', 0); e.step(e.action_space.sample()); print('ok')"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout == "ok\n"
    assert "argv[0]" not in out.stderr and "build time" not in out.stderr


def test_cli_unknown_env_exits_2_with_one_line():
    out = subprocess.run(
        [sys.executable, "-m", "bench.cli", "experts", "train", "NoSuchEnv-v0"],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 2
    assert out.stderr.strip() == "bench: error: unknown env id 'NoSuchEnv-v0'"
