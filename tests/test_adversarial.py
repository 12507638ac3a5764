import numpy as np
import pytest
import torch

from algorithms.adversarial import AdversarialConfig, disc_normalizer, floor_absorbing
from bench.envs.pixels import PixelConfig
from bench.harness import frames
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
    from algorithms.adversarial import DiscriminatorReward
    from bench.imitation.discriminator import Discriminator
    from bench.rl.absorbing import Transitions

    def transitions(loc: float) -> Transitions:
        obs = np.random.default_rng(0).normal(loc, 1.0, size=(64, 3)).astype(np.float32)
        return Transitions.real(obs, np.zeros((64, 1), np.float32), obs).map(torch.as_tensor)

    task = Task("X", 3, 1, np.array([-1.0]), np.array([1.0]), make_env=None)
    cfg = AdversarialConfig(disc_steps=3, disc_minibatch=16)
    disc = Discriminator(RunningNorm(3), lambda s, a, s2: torch.cat([s, s2], 1), 3, 1, (8,), True)
    reward = DiscriminatorReward(disc, transitions(3.0), task, cfg, seed=0)
    before = [p.detach().clone() for p in disc.parameters()]
    stats = reward.train_disc(transitions(0.0), pause=True)
    assert set(stats) == {"disc_loss", "disc_grad_penalty", "disc_acc_policy", "disc_acc_expert"}
    assert all(torch.equal(a, b) for a, b in zip(before, disc.parameters(), strict=True))
    reward.train_disc(transitions(0.0), pause=False)
    assert not all(torch.equal(a, b) for a, b in zip(before, disc.parameters(), strict=True))


def test_d_judges_only_the_state_entries_it_is_given():
    from bench.imitation.discriminator import Discriminator
    from bench.rl.absorbing import Transitions

    def judged(obs: np.ndarray, disc: Discriminator) -> torch.Tensor:
        x = Transitions.real(obs, np.zeros((len(obs), 1), np.float32), obs)
        return disc(x.map(torch.as_tensor))

    torch.manual_seed(0)
    pair = lambda s, a, s2: torch.cat([s, s2], 1)  # noqa: E731
    disc = Discriminator(RunningNorm(5), pair, 5, 1, (8,), True, obs_dims=3)
    assert disc.net[0].in_features == 2 * (3 + 1)  # s and s', each 3 entries and the flag
    obs = np.random.default_rng(0).normal(size=(16, 5)).astype(np.float32)
    tail_changed, head_changed = obs.copy(), obs.copy()
    tail_changed[:, 3:] += 100.0
    head_changed[:, :3] += 1.0
    assert torch.equal(judged(obs, disc), judged(tail_changed, disc))
    assert not torch.allclose(judged(obs, disc), judged(head_changed, disc))
    with pytest.raises(ValueError, match="disc_obs_dims \\(6\\) needs state vectors"):
        Discriminator(RunningNorm(5), pair, 5, 1, (8,), True, obs_dims=6)
    with pytest.raises(ValueError, match="disc_obs_dims must be >= 1"):
        AdversarialConfig(disc_obs_dims=0)


@pytest.mark.parametrize("share", [0.4, 1.01])
def test_a_pause_threshold_outside_half_to_one_is_refused(share):
    with pytest.raises(ValueError, match="disc_pause_above must be in"):
        AdversarialConfig(disc_pause_above=share)


def _trained_d(noise: float, seed: int = 0) -> tuple[torch.nn.Module, torch.Generator]:
    """D trained to tell two far-apart blobs of normalized rows apart: the policy's at x = 0,
    the expert's at x = 3 (std 0.1 each), no gradient penalty, with instance noise `noise`."""
    from bench.imitation.discriminator import DiscriminatorConfig, discriminator_loss
    from bench.rl.networks import mlp

    torch.manual_seed(seed)
    net = mlp([2, 64, 64, 1])
    opt = torch.optim.Adam(net.parameters(), lr=3e-3)
    gen = torch.Generator().manual_seed(seed)
    cfg = DiscriminatorConfig(grad_penalty=0.0, disc_noise=noise)
    for _ in range(600):
        policy = 0.1 * torch.randn(256, 2, generator=gen)
        expert = policy + torch.tensor([3.0, 0.0])
        loss, _ = discriminator_loss(net, policy, expert, cfg, gen)
        opt.zero_grad()
        loss.backward()
        opt.step()
    return net, gen


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_instance_noise_bounds_ds_certainty_at_the_blurred_optimum(seed):
    """Blurred by noise of std 1, the blobs overlap, and D's best logit is their log density
    ratio, (3x - 4.5) / 1.01 along x: -4.46 at the policy's states, rising 2.97 per unit
    towards the expert. D learns that; without noise it keeps growing more certain (below -8.1
    here, and further the longer it trains)."""
    along = torch.tensor([[x, 0.0] for x in (-0.2, 0.0, 0.2)])
    sharp, _ = _trained_d(0.0, seed)
    blurred, _ = _trained_d(1.0, seed)
    with torch.no_grad():
        hard, soft = sharp(along).squeeze(-1), blurred(along).squeeze(-1)
    assert hard[1] < -7, hard
    assert soft[1].item() == pytest.approx(-4.46, abs=1.0), soft
    assert (soft[2] - soft[0]).item() / 0.4 == pytest.approx(2.97, abs=1.0), soft


def test_no_instance_noise_draws_nothing_so_earlier_runs_stay_bit_identical():
    from bench.imitation.discriminator import DiscriminatorConfig, discriminator_loss
    from bench.rl.networks import mlp

    gen = torch.Generator().manual_seed(0)
    before = gen.get_state()
    cfg = DiscriminatorConfig(grad_penalty=0.0)
    net = mlp([2, 8, 1])
    rows = torch.zeros(4, 2)
    discriminator_loss(net, rows, rows, cfg, gen)
    assert torch.equal(gen.get_state(), before)
    with pytest.raises(ValueError, match="disc_noise must be"):
        DiscriminatorConfig(disc_noise=-0.1)


@pytest.mark.slow
@pytest.mark.usefixtures("demo_cache")
def test_instance_noise_trains_on_every_discriminator_learner(tmp_path, cli):
    """`disc_noise` reaches D's step in each adversarial loop: on-policy, SAC's and OPOLO's."""
    out = run_on_the_pendulum(
        tmp_path,
        cli,
        "{algorithm: gaifo, disc_noise: 0.3, n_envs: 2, steps_per_env: 256}",
        "{algorithm: gaifo-sac, disc_noise: 0.3, learning_starts: 768, batch_size: 32}",
        "{algorithm: opolo, disc_noise: 0.3, learning_starts: 768, batch_size: 32}",
    )
    assert "3 trials done, 0 failed" in out.stdout, out.stdout


def run_on_the_pendulum(tmp_path, cli, *entries: str):
    """`bench run` of one 1,024-step InvertedPendulum-v5 trial per algorithm entry (1 demo, one
    seed, one evaluation episode), records in tmp_path/res; asserts it succeeded."""
    suite = tmp_path / "pendulum.yaml"
    suite.write_text(
        "envs: {InvertedPendulum-v5: {budget: 1024}}\ndemos: [1]\nseeds: 1\neval_episodes: 1\n"
        "algorithms:\n" + "".join(f"  - {entry}\n" for entry in entries)
    )
    out = cli("run", str(suite), "--results", str(tmp_path / "res"), "--jobs", "1")
    assert out.returncode == 0, out.stderr
    return out


@pytest.mark.parametrize(("kind", "floor"), [("mean", 0.0), ("min", -1.0)])
def test_an_absorbing_floor_raises_the_absorbing_tails_rewards_only(kind, floor):
    real = np.array([-1.0, 0.5, 0.5], np.float32)
    tails = np.array([-3.0, 2.0, -0.5, -5.0], np.float32)  # two tails: entries, then loops
    r, got = floor_absorbing(np.concatenate([real, tails]), len(real), kind)
    assert got == floor
    np.testing.assert_array_equal(r[:3], real)
    np.testing.assert_array_equal(r[3:], np.maximum(tails, floor))


@pytest.mark.parametrize(
    ("settings", "says"),
    [
        ({"absorbing_floor": "median"}, "absorbing_floor must be one of 'none', 'mean', 'min'"),
        ({"absorbing_floor": "mean", "absorbing": False}, "absorbing_floor needs absorbing"),
    ],
)
def test_an_absorbing_floor_is_refused_unless_known_and_with_absorbing_states(settings, says):
    with pytest.raises(ValueError, match=says):
        AdversarialConfig(**settings)


@pytest.mark.slow
@pytest.mark.usefixtures("demo_cache")
def test_the_absorbing_floor_reaches_the_on_policy_loop(tmp_path, cli):
    """With `absorbing_floor: mean` every update logs the floor it used, the batch's mean reward."""
    run_on_the_pendulum(
        tmp_path, cli, "{algorithm: gaifo, absorbing_floor: mean, n_envs: 2, steps_per_env: 256}"
    )
    logs = frames.load_logs(tmp_path / "res").pivot(index="index", columns="key", values="value")
    assert len(logs) == 2
    np.testing.assert_allclose(logs["absorbing_floor"], logs["reward_mean"], rtol=1e-5)
