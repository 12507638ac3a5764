import numpy as np
import pytest

from bench import envs
from bench.pixels import PixelConfig

HOPPER = "HopperBulletEnv-v0"


def test_frames_are_stacked_small_uint8_images_oldest_first():
    env = envs.make(HOPPER, 0, PixelConfig(size=32, stack=3))
    first, info = env.reset(seed=0)
    assert first.shape == (3, 32, 32) and first.dtype == np.uint8
    assert env.observation_space.contains(first)
    assert (first == first[:1]).all(), "a new episode's stack repeats its first frame"
    prev = first
    for _ in range(5):
        obs, *_ = env.step(env.action_space.sample())
        np.testing.assert_array_equal(obs[:-1], prev[1:])  # shifted by one frame
        prev = obs
    assert not np.array_equal(obs[-1], obs[0]), "the hopper moved, so the frames differ"
    assert first.min() < 200 < first.max(), "a rendered scene, not a blank frame"
    env.close()


def test_colour_frames_have_three_channels_each():
    env = envs.make("InvertedPendulumBulletEnv-v0", 0, PixelConfig(size=16, grayscale=False))
    obs, _ = env.reset(seed=0)
    assert obs.shape == (12, 16, 16)
    env.close()


def test_rendering_leaves_the_physics_and_its_seeding_alone():
    actions = np.random.default_rng(0).uniform(-1, 1, (30, 3)).astype(np.float32)
    plain, framed = envs.make(HOPPER, 7), envs.make(HOPPER, 7, PixelConfig(size=16))
    state, _ = plain.reset(seed=7)
    _, info = framed.reset(seed=7)
    np.testing.assert_array_equal(info["state"], state)
    for action in actions:
        state, reward, *_ = plain.step(action)
        _, framed_reward, _, _, info = framed.step(action)
        np.testing.assert_array_equal(info["state"], state)
        assert framed_reward == reward
    plain.close()
    framed.close()


def test_unusable_frame_settings_are_refused():
    with pytest.raises(ValueError, match="size >= 8"):
        PixelConfig(size=4)
