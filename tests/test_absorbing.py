"""Absorbing states: the tail's value, its bootstrap in GAE, and which episodes get a tail."""

import numpy as np
import pytest
import torch

from bench.imitation.discriminator import REWARDS, expert_transitions
from bench.rl import absorbing
from bench.rl.trpo import gae


def test_tail_value_by_hand_and_by_unrolling():
    # Into the absorbing state: -1; then -2 for ever. gamma 0.5: -1 + 0.5 * -2 / 0.5 = -3.
    assert absorbing.tail_value(np.array([[-1.0, -2.0]]), gamma=0.5) == pytest.approx([-3.0])
    gamma, r1, r2 = 0.99, 0.3, -0.7
    unrolled = r1 + sum(gamma**k * r2 for k in range(1, 5000))
    assert absorbing.tail_value(np.array([[r1, r2]]), gamma) == pytest.approx([unrolled], abs=1e-6)
    assert absorbing.tail_value(np.array([[5.0]]), 0.9) == pytest.approx([50.0])  # the loop alone


def test_gae_bootstraps_a_termination_from_its_tail_value():
    """T=3, one env, terminated at t=1, gamma 0.5, lambda 1; worked out by hand:
    delta_2 = 3 + 0.5 * 0.4 - 0.5 = 2.7  (batch end: bootstrap from V(s'))
    delta_1 = 2 + 0.5 * (-3) - 1.0 = -0.5  (terminated: bootstrap from the tail, -3)
    delta_0 = 1 + 0.5 * 0.4 - 0.5 = 0.7;  adv_0 = 0.7 + 0.5 * -0.5 = 0.45
    """
    r = np.array([[1.0], [2.0], [3.0]], np.float32)
    v = np.array([[0.5], [1.0], [0.5]], np.float32)
    nv = np.full((3, 1), 0.4, np.float32)
    term = np.array([[False], [True], [False]])
    trunc = np.zeros_like(term)
    after = np.zeros((3, 1), np.float32)
    after[1, 0] = absorbing.tail_value(np.array([[-1.0, -2.0]]), gamma=0.5)[0]
    adv, targets = gae(r, v, nv, term, trunc, gamma=0.5, lam=1.0, after_termination=after)
    np.testing.assert_allclose(adv[:, 0], [0.45, -0.5, 2.7], rtol=1e-6)
    np.testing.assert_allclose(targets[:, 0], adv[:, 0] + v[:, 0], rtol=1e-6)
    # Without a tail value a termination is worth 0, as before.
    adv0, _ = gae(r, v, nv, term, trunc, gamma=0.5, lam=1.0)
    np.testing.assert_allclose(adv0[1, 0], 2.0 - 1.0)


def test_truncation_ignores_tail_values():
    r = np.ones((1, 1), np.float32)
    z = np.zeros((1, 1), np.float32)
    nv = np.full((1, 1), 10.0, np.float32)
    adv, _ = gae(
        r, z, nv, np.array([[False]]), np.array([[True]]), 0.5, 1.0, np.full((1, 1), -99.0)
    )
    assert adv[0, 0] == pytest.approx(6.0)


def test_only_terminated_demonstrations_get_a_tail():
    fell = np.arange(12, dtype=np.float32).reshape(4, 3)  # 3 transitions, ends in a fall
    timed_out = np.ones((6, 3), np.float32)  # 5 transitions, cut by the time limit
    x = expert_transitions((fell, timed_out), (True, False), None, with_absorbing=True, gamma=0.99)
    assert len(x) == 3 + 5 + 2 and x.actions.shape == (10, 0)
    np.testing.assert_array_equal(x.obs[8], fell[-1])  # (s_T, s_a): from the terminal state
    assert not x.obs_absorbing[8] and x.next_absorbing[8]
    assert x.obs_absorbing[9] and x.next_absorbing[9]  # (s_a, s_a): the loop
    assert not x.obs_absorbing[:8].any() and not x.next_absorbing[:8].any()
    np.testing.assert_allclose(x.weight, [1.0] * 9 + [100.0], rtol=1e-5)  # 1 / (1 - 0.99)
    off = expert_transitions(
        (fell, timed_out), (True, False), None, with_absorbing=False, gamma=0.99
    )
    assert len(off) == 8


def test_tails_of_state_action_demonstrations_act_with_zeros():
    obs = np.ones((3, 2), np.float32)
    acts = np.full((2, 1), 0.5, np.float32)
    x = expert_transitions((obs,), (True,), (acts,), with_absorbing=True, gamma=0.99)
    np.testing.assert_array_equal(x.actions[:, 0], [0.5, 0.5, 0.0, 0.0])


def test_signed_reward_is_the_logit_and_odd():
    logit = torch.linspace(-5, 5, 11)
    signed = REWARDS["log D - log(1-D)"](logit)
    assert torch.equal(signed, logit)
    assert torch.allclose(signed, -signed.flip(0))  # D = 0.5 pays 0: no sign to exploit


@pytest.mark.slow
def test_discriminator_learns_that_falling_is_not_expert_like(tmp_path, monkeypatch, pendulum):
    """InvertedPendulum's expert never drops the pole; an untrained policy drops it every few
    dozen steps. Within a few updates D must judge the absorbing state as the policy's: the
    signed reward there turns negative, so falling costs for the rest of the horizon."""
    from bench import paths
    from bench.demos import pools
    from bench.harness.trial import run_trial
    from bench.harness.types import TrialSpec

    monkeypatch.setattr(paths, "CACHE_DIR", tmp_path / "cache")
    spec = TrialSpec(
        "t", pendulum, "gaifo", 1, 0, 8 * 2048, 2, {"absorbing": True, "reward": "log D - log(1-D)"}
    )
    pool = pools.ensure_pool(pendulum)
    result = run_trial(spec, pools.load_demos(pool, pendulum, 1, 0))
    assert result.status == "ok", result.traceback
    absorbing_reward = result.logs["reward_absorbing"]
    assert len(absorbing_reward) >= 4
    assert max(absorbing_reward[-3:]) < 0
