import numpy as np
import pytest
import torch

from algorithms.adversarial import AdversarialConfig, disc_normalizer
from bench.harness.pixels import PixelConfig
from bench.harness.registry import Task
from bench.imitation.data import Demos
from bench.imitation.discriminator import REWARDS
from bench.rl.networks import PixelScale, RunningNorm


def test_reward_forms_have_the_documented_signs():
    logit = torch.linspace(-5, 5, 11)
    assert (REWARDS["-log(1-D)"](logit) > 0).all()
    assert (REWARDS["log D"](logit) < 0).all()
    assert torch.equal(REWARDS["log D - log(1-D)"](logit), logit)


def test_d_scales_states_by_the_policy_or_by_the_demonstrations():
    task = Task("X", 3, 1, np.array([-1.0]), np.array([1.0]), make_env=None)
    rng = np.random.default_rng(0)
    episodes = tuple(rng.normal(5.0, 2.0, size=(50, 3)).astype(np.float32) for _ in range(2))
    demos = Demos("X", episodes)
    policy_norm = RunningNorm(3)
    assert disc_normalizer(task, policy_norm, demos, "policy") is policy_norm
    expert = disc_normalizer(task, policy_norm, demos, "expert")
    assert expert is not policy_norm  # fixed: the policy's updates do not move it
    states = np.concatenate(episodes)
    np.testing.assert_allclose(expert.mean.numpy(), states.mean(0), rtol=1e-5)
    np.testing.assert_allclose(expert.var.numpy(), states.var(0), rtol=1e-4)
    # frames keep their fixed scale whatever disc_norm says
    frames = PixelConfig(size=8)
    seen = Task("X", int(np.prod(frames.shape)), 1, task.action_low, task.action_high, None, frames)
    scale = PixelScale(frames.shape)
    assert disc_normalizer(seen, scale, demos, "expert") is scale


def test_an_unknown_d_scale_is_refused():
    with pytest.raises(ValueError, match="disc_norm must be one of 'policy', 'expert'"):
        AdversarialConfig(disc_norm="nope")


def test_a_paused_discriminator_takes_no_step_and_still_reports_its_losses():
    from algorithms.adversarial import discriminator_step
    from bench.imitation.discriminator import Discriminator
    from bench.rl.absorbing import Transitions

    def transitions(loc: float) -> Transitions:
        obs = np.random.default_rng(0).normal(loc, 1.0, size=(64, 3)).astype(np.float32)
        return Transitions.real(obs, np.zeros((64, 1), np.float32), obs).map(torch.as_tensor)

    cfg = AdversarialConfig(disc_steps=3, disc_minibatch=16)
    disc = Discriminator(RunningNorm(3), lambda s, a, s2: torch.cat([s, s2], 1), 3, 1, (8,), True)
    opt = torch.optim.Adam(disc.parameters(), lr=cfg.disc_lr)
    before = [p.detach().clone() for p in disc.parameters()]
    policy_x, expert_x = transitions(0.0), transitions(3.0)
    gen = torch.Generator().manual_seed(0)
    stats = discriminator_step(disc, opt, policy_x, expert_x, cfg, gen, pause=True)
    assert {"disc_loss", "disc_acc_policy", "disc_acc_expert"} <= set(stats)
    assert all(torch.equal(a, b) for a, b in zip(before, disc.parameters(), strict=True))
    discriminator_step(disc, opt, policy_x, expert_x, cfg, gen)
    assert not all(torch.equal(a, b) for a, b in zip(before, disc.parameters(), strict=True))


@pytest.mark.parametrize("share", [0.4, 1.01])
def test_a_pause_threshold_outside_half_to_one_is_refused(share):
    with pytest.raises(ValueError, match="disc_pause_above must be in"):
        AdversarialConfig(disc_pause_above=share)
