import numpy as np
import pytest
import torch

from bench import envs
from bench.demos.experts import evaluate_policy
from bench.rl.networks import DeterministicPolicy, GaussianPolicy, RunningNorm, orthogonal_init
from bench.rl.rollout import VecCollector
from bench.rl.trpo import TRPOConfig, gae, train


def test_gae_bootstraps_on_truncation_not_termination():
    r = np.ones((1, 3), np.float32)
    v = np.zeros((1, 3), np.float32)
    nv = np.full((1, 3), 10.0, np.float32)
    term = np.array([[True, False, False]])
    trunc = np.array([[False, True, False]])
    adv, _ = gae(r, v, nv, term, trunc, gamma=0.5, lam=1.0)
    np.testing.assert_allclose(adv[0], [1.0, 6.0, 6.0])


def test_gae_does_not_leak_across_episode_end():
    r = np.array([[1.0], [100.0]], np.float32)
    z = np.zeros((2, 1), np.float32)
    ends = np.array([[True], [False]])
    adv, _ = gae(r, z, z, ends, np.zeros_like(ends), gamma=1.0, lam=1.0)
    assert adv[0, 0] == 1.0 and adv[1, 0] == 100.0


def test_running_norm_matches_numpy():
    rng = np.random.default_rng(0)
    x = rng.normal(3.0, 2.0, size=(1000, 4))
    norm = RunningNorm(4)
    for chunk in np.split(x, 10):
        norm.update(chunk)
    np.testing.assert_allclose(norm.mean.numpy(), x.mean(0), rtol=1e-6)
    np.testing.assert_allclose(norm.var.numpy(), x.var(0), rtol=1e-6)


def test_collector_keeps_true_final_observation(pendulum):
    """At an episode's last step next_obs is the terminal observation, not the reset one."""
    env = envs.make(pendulum, 0)
    collector = VecCollector([env], seed=0)
    policy = GaussianPolicy(5, 1, log_std=1.0)  # wild actions: short episodes
    batch = collector.collect(policy, 300)
    ends = np.flatnonzero(batch.terminated[:, 0] | batch.truncated[:, 0])
    assert len(ends) >= 2
    for t in ends[:-1]:
        assert not np.array_equal(batch.next_obs[t, 0], batch.obs[t + 1, 0])  # t+1 is a reset
        assert batch.timesteps[t + 1, 0] == 0
    inner = np.setdiff1d(np.arange(299), ends)
    np.testing.assert_array_equal(batch.next_obs[inner, 0], batch.obs[inner + 1, 0])
    collector.close()


def test_training_is_seeded(pendulum):
    def run():
        learner = train(
            lambda s: envs.make(pendulum, s),
            4096,
            seed=1,
            cfg=TRPOConfig(n_envs=2, steps_per_env=1024),
        )
        return torch.nn.utils.parameters_to_vector(learner.policy.parameters()).detach()

    torch.testing.assert_close(run(), run(), rtol=0, atol=0)


def test_custom_reward_replaces_env_reward(pendulum):
    seen = []

    def reward_fn(batch):
        seen.append(batch.obs.shape)
        return np.zeros_like(batch.rewards)

    train(
        lambda s: envs.make(pendulum, s),
        2048,
        0,
        TRPOConfig(n_envs=2, steps_per_env=512),
        reward_fn=reward_fn,
    )
    assert seen == [(512, 2, 5), (512, 2, 5)]


@pytest.mark.slow
def test_trpo_solves_inverted_pendulum_within_100k_steps(pendulum):
    steps = []
    learner = train(
        lambda s: envs.make(pendulum, s), 100_000, seed=1, callback=lambda n, *_: steps.append(n)
    )
    assert steps[-1] <= 100_000
    policy = DeterministicPolicy(learner.policy, np.array([-1.0]), np.array([1.0]))
    returns = evaluate_policy(policy, pendulum, episodes=10, seed=123)
    assert np.mean(returns) >= 950, returns


def test_orthogonal_init_scales_hidden_layers_by_root_two_and_the_last_by_its_gain():
    policy = GaussianPolicy(5, 3, (16, 8))
    orthogonal_init(policy.mean_net, last_gain=0.01)
    first, second, last = (m for m in policy.mean_net if isinstance(m, torch.nn.Linear))
    # (16, 5): orthonormal columns times the gain; (8, 16): orthonormal rows
    torch.testing.assert_close(first.weight.T @ first.weight, 2.0 * torch.eye(5))
    torch.testing.assert_close(second.weight @ second.weight.T, 2.0 * torch.eye(8))
    torch.testing.assert_close(last.weight @ last.weight.T, 1e-4 * torch.eye(3))
    assert all(not m.bias.any() for m in (first, second, last))
