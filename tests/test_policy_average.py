"""PolicyAverage: the exponential moving average of policy weights the imitators return."""

import numpy as np
import torch

from bench.harness.learners import PolicyAverage
from bench.rl.networks import GaussianPolicy


def policy_with(value: float, obs_mean: float) -> GaussianPolicy:
    policy = GaussianPolicy(obs_shape=3, act_dim=2, hidden=(4,))
    with torch.no_grad():
        for p in policy.parameters():
            p.fill_(value)
        policy.norm.mean.fill_(obs_mean)
    return policy


def test_average_follows_the_hand_computed_recurrence():
    average = PolicyAverage(decay=0.5)
    for value in (0.0, 2.0, 4.0):  # 0, then 0.5*0 + 0.5*2 = 1, then 0.5*1 + 0.5*4 = 2.5
        average.update(policy_with(value, obs_mean=value))
    for p in average.weights.parameters():
        assert torch.allclose(p, torch.full_like(p, 2.5))
    # Observation statistics are not averaged: the latest ones normalize the latest data.
    assert torch.all(average.weights.norm.mean == 4.0)


def test_decay_zero_is_the_latest_policy_exactly():
    average = PolicyAverage(decay=0.0)
    latest = GaussianPolicy(obs_shape=3, act_dim=2)
    average.update(GaussianPolicy(obs_shape=3, act_dim=2))
    average.update(latest)
    obs = torch.randn(5, 3)
    assert torch.equal(average.weights(obs), latest(obs))


def test_updates_after_a_snapshot_leave_the_snapshot_alone():
    class Learner:
        policy = policy_with(1.0, 0.0)

    class Task:
        action_low, action_high = np.full(2, -10.0), np.full(2, 10.0)

    average = PolicyAverage(decay=0.5)
    average.update(policy_with(1.0, 0.0))
    snapshot = average.policy(Learner(), Task())
    before = snapshot(np.zeros(3))
    average.update(policy_with(3.0, 0.0))
    assert np.array_equal(snapshot(np.zeros(3)), before)
