import numpy as np
import pytest
import torch

from bench import envs
from bench.demos import pools
from bench.demos.experts import load_expert
from bench.envs.pixels import PixelConfig, VideoBeside
from bench.harness import runner, store, trial
from bench.harness.runner import run_suite
from bench.harness.suite import load_suite
from bench.imitation.data import Demos
from bench.rl.networks import GaussianPolicy
from bench.rl.rollout import VecCollector
from bench.rl.shared_trunk import SharedTrunkTRPO, make_trpo, mean_kl
from bench.rl.trpo import TRPO, TRPOConfig, policy_step

HOPPER = "HopperBulletEnv-v0"


def test_frames_are_stacked_small_uint8_images_oldest_first():
    cfg = PixelConfig(size=32, stack=3)
    env = envs.make(HOPPER, 0, cfg)
    flat, info = env.reset(seed=0)
    assert flat.shape == (3 * 32 * 32,) and flat.dtype == np.uint8
    assert env.observation_space.contains(flat)
    first = flat.reshape(cfg.shape)
    assert (first == first[:1]).all(), "a new episode's stack repeats its first frame"
    prev = first
    for _ in range(5):
        obs = env.step(env.action_space.sample())[0].reshape(cfg.shape)
        np.testing.assert_array_equal(obs[:-1], prev[1:])  # shifted by one frame
        prev = obs
    assert not np.array_equal(obs[-1], obs[0]), "the hopper moved, so the frames differ"
    assert first.min() < 200 < first.max(), "a rendered scene, not a blank frame"
    env.close()


def test_colour_frames_have_three_channels_each():
    cfg = PixelConfig(size=16, grayscale=False)
    assert cfg.shape == (12, 16, 16)
    env = envs.make("InvertedPendulumBulletEnv-v0", 0, cfg)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (12 * 16 * 16,)
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


PENDULUM = "InvertedPendulumBulletEnv-v0"


def test_pixel_demos_are_the_experts_video_as_the_imitator_sees_it(tmp_path):
    cfg = PixelConfig(size=16, stack=3)
    expert = load_expert(PENDULUM)
    video = pools.record(PENDULUM, expert, 2, 20_000, cfg)
    states = pools.record(PENDULUM, expert, 2, 20_000)
    for key in ("obs", "actions", "rewards", "terminated"):  # the same episodes, filmed
        np.testing.assert_array_equal(video[key], states[key])
    path = pools.save(tmp_path / "pool.npz", video)
    shown = pools.load_demos(path, PENDULUM, pixels=cfg)
    assert isinstance(shown, Demos) and not hasattr(shown, "actions")
    first = shown.observations[0]
    assert first.dtype == np.uint8 and first.shape == (len(video["obs"]) // 2, 3 * 16 * 16)
    env = envs.make(PENDULUM, 0, cfg)  # replay episode 0 with the imitator's camera
    seen, info = env.reset(seed=20_000)
    replay = [seen]
    for _ in range(40):
        seen, *_, info = env.step(expert(info["state"][None])[0])
        replay.append(seen)
    env.close()
    np.testing.assert_array_equal(first[:41], np.stack(replay))
    with pytest.raises(pools.DemoError, match="holds frames of shape"):
        pools.load_demos(path, PENDULUM, pixels=PixelConfig(size=32))
    plain = pools.save(tmp_path / "states.npz", states)
    with pytest.raises(pools.DemoError, match="holds no video"):
        pools.load_demos(plain, PENDULUM, pixels=cfg)


def tiny_suite(tmp_path, monkeypatch, observation: str) -> list:
    """The trials of a suite of two TRPO updates per learner on the pendulum, observed so
    (`observation` may carry more env settings: "pixels, frame_size: 32")."""
    monkeypatch.setattr(pools, "POOL_SIZE", 2)  # filming 25 episodes at 64x64 takes ~15 s
    tiny = "{n_envs: 2, steps_per_env: 64}"
    gaifo = "{n_envs: 2, steps_per_env: 64, disc_minibatch: 64}"  # D's draws: one batch at most
    (tmp_path / "s.yaml").write_text(
        f"name: tiny\nenvs: {{{PENDULUM}: {{budget: 256, observation: {observation}}}}}\n"
        f"demos: [1]\nalgorithms: [random, expert, gaifo: {gaifo}, airlfo: {gaifo}, survival: {tiny},"
        f" tcn: {{n_envs: 2, steps_per_env: 64, embed_steps: 5}}]\n"
        "seeds: [0]\neval_episodes: 2\n"
    )
    return list(load_suite(tmp_path / "s.yaml").trials)


@pytest.mark.usefixtures("demo_cache")
@pytest.mark.slow
def test_a_tiny_pixel_suite_runs_end_to_end(tmp_path, monkeypatch):
    specs = tiny_suite(tmp_path, monkeypatch, "pixels, frame_size: 32")
    assert {trial.plan(s).pixels.shape for s in specs if s.algorithm != "expert"} == {(4, 32, 32)}
    assert run_suite(specs, tmp_path / "res", jobs=2, progress=False).failed == 0
    records = {r.spec.algorithm: r for r in store.scan(tmp_path / "res")}
    assert set(records) == {"random", "expert", "gaifo", "airlfo", "survival", "tcn"}
    assert records["expert"].returns == [1000.0, 1000.0], "the expert still acts on states"
    for learner in ("gaifo", "airlfo", "survival", "tcn"):  # AIRLfO: its shaped D on frames
        assert records[learner].env_steps == 256 and len(records[learner].logs["kl"]) == 2
    assert {"disc_loss", "reward_absorbing"} <= set(records["gaifo"].logs)
    # a pixel learner is filmed from what it saw, beside the full view: two squares per panel
    from bench.analysis.video import compose, panels
    from bench.harness.film import film_episode

    chosen = panels(tmp_path / "res", algorithms=["gaifo"])
    films = [film_episode(p.policy, PENDULUM, 48, 5, 100_000, p.spec) for p in chosen]
    assert [f[0].shape for f in films] == [(48, 48, 3), (48, 96, 3)]  # expert, GAIfO
    frames = compose([p.title for p in chosen], films)
    assert len(frames) == 6 and frames[0].shape[1] == 48 + 96


@pytest.mark.usefixtures("demo_cache")
@pytest.mark.slow
def test_dask_workers_learn_from_the_video_the_driver_ships(tmp_path, monkeypatch, on_dask):
    specs = [
        s
        for s in tiny_suite(tmp_path, monkeypatch, "pixels, frame_size: 32")
        if s.algorithm == "gaifo"
    ]
    loky = run_suite(specs, tmp_path / "loky", jobs=1, progress=False)
    # The workers (other machines, in practice) start from an empty cache of their own.
    monkeypatch.setenv("IFO_BENCH_CACHE", str(tmp_path / "worker-cache"))
    dask = on_dask(specs, tmp_path / "dask", workers=1)
    assert loky.done == dask.done == 1
    (a,), (b,) = store.scan(tmp_path / "loky"), store.scan(tmp_path / "dask")
    assert a.returns == b.returns and a.logs["disc_loss"] == b.logs["disc_loss"]
    assert not (tmp_path / "worker-cache").exists(), "workers needed no video files"


def test_the_pendulum_fills_the_frame():
    cfg = PixelConfig(stack=1)
    env = envs.make(PENDULUM, 0, cfg)
    frame = env.reset(seed=0)[0].reshape(cfg.size, cfg.size)
    env.close()
    rows = np.flatnonzero((frame < 150).any(axis=1))  # the dark pole, cart and rail
    assert rows.max() - rows.min() >= cfg.size * 3 // 4, "the pole and cart do not span the frame"


@pytest.mark.usefixtures("demo_cache")
@pytest.mark.slow
def test_a_video_reward_suite_acts_on_states_and_judges_frames(tmp_path, monkeypatch):
    specs = tiny_suite(tmp_path, monkeypatch, "video-reward")
    gaifo = next(s for s in specs if s.algorithm == "gaifo")
    assert trial.plan(gaifo).pixels is None and trial.plan(gaifo).filmed == PixelConfig()
    env = trial.plan(gaifo).make_env(0)
    state, info = env.reset(seed=0)
    assert state.shape == (5,) and info["frames"].shape == (np.prod(PixelConfig().shape),)
    env.close()
    shown = trial.plan(gaifo).inputs()
    assert shown.observations[0].dtype == np.uint8, "the demonstrations are video"
    assert runner.run_suite(specs, tmp_path / "res", jobs=1, progress=False).failed == 0
    logs = {r.spec.algorithm: r.logs for r in store.scan(tmp_path / "res")}
    assert len(logs["gaifo"]["disc_loss"]) == 2 and len(logs["survival"]["kl"]) == 2
    assert len(logs["tcn"]["embed_dist2"]) == 2


def test_filmed_batches_carry_each_steps_frames():
    cfg = PixelConfig(size=16, stack=2)
    collector = VecCollector([VideoBeside(envs.make(PENDULUM, s, cfg)) for s in range(2)], 0)
    batch = collector.collect(GaussianPolicy(5, 1, log_std=1.0), 60)  # wild: episodes end
    collector.close()
    assert batch.obs.shape == (60, 2, 5) and batch.frames.shape == (60, 2, 2 * 16 * 16)
    ends = batch.terminated | batch.truncated
    assert ends[:-1].any(), "the test needs an episode boundary"
    for t in range(59):
        for i in range(2):
            if not ends[t, i]:  # within an episode s' of one step is s of the next
                np.testing.assert_array_equal(batch.next_frames[t, i], batch.frames[t + 1, i])
            else:  # a new episode starts from its own first frame, repeated
                first = batch.frames[t + 1, i].reshape(cfg.shape)
                assert (first == first[:1]).all()


def _unchanged(before: list[torch.Tensor], module: torch.nn.Module) -> bool:
    return all(torch.equal(a, b) for a, b in zip(before, module.parameters(), strict=True))


def test_from_frames_the_value_loss_trains_the_trunk_and_trpo_moves_the_head():
    cfg = PixelConfig(size=32, stack=2)
    collector = VecCollector([envs.make(PENDULUM, s, cfg) for s in range(2)], 0)
    learner = make_trpo(cfg.shape, 1, TRPOConfig(n_envs=2, steps_per_env=64, vf_epochs=1), seed=0)
    assert isinstance(learner, SharedTrunkTRPO)
    policy = learner.policy
    assert learner.value.net[0] is policy.trunk  # one trunk, two heads
    batch = collector.collect(policy, 64)
    collector.close()
    trunk = [p.detach().clone() for p in policy.trunk.parameters()]
    head = [p.detach().clone() for p in policy.mean_net.parameters()]
    grads: list[torch.Tensor] = []
    hooks = [p.register_hook(grads.append) for p in policy.trunk.parameters()]
    obs, actions = torch.from_numpy(batch.flat("obs")), torch.from_numpy(batch.flat("actions"))
    with torch.no_grad():
        features = policy.features(obs)
    info = policy_step(policy, features, actions, torch.randn(len(obs)), learner.cfg)
    assert info["step_frac"] > 0 and not grads  # the policy step never reaches the trunk
    assert _unchanged(trunk, policy.trunk) and not _unchanged(head, policy.mean_net)
    for hook in hooks:
        hook.remove()
    info = learner.update(batch, batch.rewards)  # ... and the value regression does,
    assert not _unchanged(trunk, policy.trunk)
    assert 0 <= info["trunk_kl"] < learner.cfg.max_kl  # paying for how far it moves the policy


def test_a_trunk_step_that_moves_the_policy_too_far_is_backtracked_into_the_trust_region():
    cfg = PixelConfig(size=32, stack=2)
    collector = VecCollector([envs.make(PENDULUM, s, cfg) for s in range(2)], 0)
    learner = SharedTrunkTRPO(cfg.shape, 1, TRPOConfig(n_envs=2, steps_per_env=64), seed=0)
    policy = learner.policy
    with torch.no_grad():  # a policy whose mean actions depend on the frames
        for p in policy.mean_net.parameters():
            p.normal_(0.0, 0.5)
    obs = torch.from_numpy(collector.collect(policy, 64).flat("obs"))
    collector.close()
    trunk = list(policy.trunk.parameters())
    before = torch.nn.utils.parameters_to_vector(trunk).detach().clone()
    with torch.no_grad():
        old_mean = policy(obs)
    small = before + 1e-6 * torch.randn_like(before)
    torch.nn.utils.vector_to_parameters(small, trunk)
    assert learner.hold_trunk(obs, old_mean, before)["trunk_step_frac"] == 1.0  # left alone
    assert torch.equal(torch.nn.utils.parameters_to_vector(trunk), small)

    torch.nn.utils.vector_to_parameters(before + 0.5 * torch.randn_like(before), trunk)
    with torch.no_grad():
        assert mean_kl(policy, old_mean, policy(obs)) > learner.cfg.max_kl
    held = learner.hold_trunk(obs, old_mean, before)
    assert held["trunk_kl_before_hold"] > learner.cfg.max_kl
    assert 0 <= held["trunk_step_frac"] < 1 and held["trunk_kl"] <= learner.cfg.max_kl
    with torch.no_grad():
        assert mean_kl(policy, old_mean, policy(obs)).item() == pytest.approx(held["trunk_kl"])


def test_plain_trpo_refuses_frames_it_would_not_train_the_trunk_of():
    with pytest.raises(ValueError, match="make_trpo"):
        TRPO(PixelConfig(size=32, stack=2).shape, 1, TRPOConfig(), seed=0)
    assert type(make_trpo(5, 1, TRPOConfig(), seed=0)) is TRPO
