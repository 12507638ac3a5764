"""The off-policy family (SAC with absorbing states; GAIfO, GAIL and the controls on it), for
real at tiny budgets."""

import numpy as np
import pytest
import torch

from algorithms import offpolicy
from bench.harness import registry, store
from bench.harness.runner import run_suite
from bench.harness.suite import load_suite
from bench.imitation.rewards import replay_transitions
from bench.rl import replay, sac
from bench.rl.absorbing import FLAG

PENDULUM = "InvertedPendulumBulletEnv-v0"
TINY = {"hidden": [16, 16], "learning_starts": 300, "batch_size": 32}

pytestmark = pytest.mark.usefixtures("demo_cache")


def test_a_termination_leads_into_the_absorbing_loop_and_a_truncation_does_not():
    obs, next_obs = np.ones((3, 2), np.float32), np.full((3, 2), 2.0, np.float32)
    actions = np.full((3, 1), 0.5, np.float32)
    terminated = np.array([False, True, False])  # env 2 may have been truncated: not an end
    s, a, s_next, r, not_done = replay.transitions_of_step(
        obs, actions, next_obs, np.array([1.0, 1.0, 1.0]), terminated, absorbing=True
    )
    assert len(s) == 4  # three steps, and the loop once for the one termination
    assert s_next[1].tolist() == [0.0, 0.0, FLAG] and s_next[0].tolist() == [2.0, 2.0, 0.0]
    assert s[3].tolist() == s_next[3].tolist() == [0.0, 0.0, FLAG]
    assert a[3].tolist() == [0.0] and r.tolist() == [1.0, 1.0, 1.0, 0.0]
    assert not_done.tolist() == [1.0] * 4  # nothing masked: the loop's reward decides
    _, _, _, _, masked = replay.transitions_of_step(
        obs, actions, next_obs, np.ones(3), terminated, absorbing=False
    )
    assert masked.tolist() == [1.0, 0.0, 1.0]


def test_every_termination_reaches_the_buffer_as_an_absorbing_transition(pendulum):
    from bench import envs

    episodes = []

    def count(steps, learner, info):
        episodes.append(steps)

    cfg = sac.SACConfig(**TINY)
    learner = sac.train(lambda s: envs.make(pendulum, s), 600, 0, cfg, callback=count)
    buffer = learner.buffer
    rows = slice(0, buffer.count)
    into = (buffer.next_obs[rows, -1] == FLAG) & (buffer.obs[rows, -1] == 0)
    loop = (buffer.obs[rows, -1] == FLAG) & (buffer.next_obs[rows, -1] == FLAG)
    assert into.sum() == loop.sum() > 10  # a random pendulum falls every ~25 steps
    assert buffer.count == 600 + loop.sum()
    assert (buffer.actions[rows][loop] == 0).all() and (buffer.env_rewards[rows][loop] == 0).all()
    assert (buffer.not_done[rows] == 1).all()


def test_rewards_come_from_the_current_discriminator(pendulum):
    from bench import envs
    from bench.demos import pools as demo_pool
    from bench.harness.trial import demo_pool as pool_of

    demos = demo_pool.load_demos(pool_of(pendulum, None), pendulum, 2, 0)
    obs_dim = envs.spaces(pendulum)[0]
    cfg = offpolicy.OffPolicyAdversarialConfig(**TINY)
    expert = offpolicy.expert_replay(demos, None, 1, absorbing=True)
    norm = offpolicy.RunningNorm(obs_dim)
    norm.update(np.concatenate(demos.observations))
    disc = offpolicy.Discriminator(norm, offpolicy.state_transition, obs_dim, 1, (16, 16), True)
    reward_fn = offpolicy.CurrentDReward(disc, expert, cfg, 0)
    batch = replay.ReplayBatch(*(x[:32] for x in vars(expert).values()))  # any transitions
    out = reward_fn(batch)
    first = out.rewards
    with torch.no_grad():
        now = disc.net(disc.inputs(replay_transitions(batch))).squeeze(-1)
    assert torch.equal(first, now)  # D after its step on this very minibatch
    assert not torch.equal(reward_fn(batch).rewards, first)  # and D moves on every minibatch
    assert {"disc_loss", "disc_acc_policy", "disc_acc_expert"} <= set(out.logged)


@pytest.mark.slow
def test_the_controls_are_matched_and_every_off_policy_learner_runs(tmp_path):
    algos = registry.all_algorithms()
    for name in ("survival-sac", "oracle-sac"):
        assert algos[name].config is offpolicy.OffPolicyConfig
    for name in ("gaifo-sac", "gail-sac"):
        assert issubclass(algos[name].config, offpolicy.OffPolicyConfig)
    tiny = "{hidden: [16, 16], learning_starts: 300, batch_size: 32}"
    opolo = (
        "{hidden: [16, 16], disc_hidden: [16, 16], learning_starts: 300, batch_size: 32,"
        " inverse_pretrain: 20, train_every: 100}"
    )
    (tmp_path / "s.yaml").write_text(
        f"name: sac\nenvs: {{{PENDULUM}: {{budget: 800}}}}\ndemos: [1]\nalgorithms: [random,"
        f" expert, gaifo-sac: {tiny}, gail-sac: {tiny}, survival-sac: {tiny},"
        f" oracle-sac: {tiny}, opolo: {opolo}]\nseeds: 1\neval_episodes: 2\n"
    )
    specs = list(load_suite(tmp_path / "s.yaml").trials)
    assert run_suite(specs, tmp_path / "res", jobs=2, progress=False).failed == 0
    records = {r.spec.algorithm: r for r in store.scan(tmp_path / "res")}
    learners = ("gaifo-sac", "gail-sac", "survival-sac", "oracle-sac", "opolo")
    assert all(records[name].env_steps == 800 for name in learners)
    assert "disc_acc_expert" in records["gaifo-sac"].logs
    assert {"disc_acc_expert", "inverse_loss", "inverse_gap"} <= set(records["opolo"].logs)
    # InvertedPendulum pays +1 per step alive: there the two controls are one learner
    assert records["oracle-sac"].returns == records["survival-sac"].returns
    from bench.harness import policies
    from bench.harness.trial import EVAL_SEED, plan
    from bench.rl.rollout import evaluate

    spec = records["gaifo-sac"].spec  # its kept policy acts as it did when scored
    policy = policies.load(policies.path(tmp_path / "res", spec.trial_id))
    envs = [plan(spec).make_env(EVAL_SEED + i, training=False) for i in range(2)]
    assert evaluate(policy, envs, 2, EVAL_SEED) == records["gaifo-sac"].returns


@pytest.mark.slow
def test_opolo_rewards_come_from_the_current_discriminator_and_its_dual_term_lowers_q(pendulum):
    """OPOLO's reward is -log(1 - D) of D as it is now (D's training changes it), and the
    critic's dual term pushes Q down at the policy's actions: with alpha > 0, Q there ends
    lower than with alpha = 0, on the same data."""
    from algorithms.opolo import OPOLO, OPOLOConfig
    from bench import envs
    from bench.demos import pools as demo_pool
    from bench.harness.registry import Task
    from bench.harness.trial import demo_pool as pool_of

    demos = demo_pool.load_demos(pool_of(pendulum, None), pendulum, 2, 0)
    obs_dim, act_dim, low, high = envs.spaces(pendulum)
    task = Task(pendulum, obs_dim, act_dim, low, high, lambda s: envs.make(pendulum, s))
    cfg = OPOLOConfig(hidden=(16, 16), disc_hidden=(16, 16), batch_size=64, train_every=10**6)
    learner = OPOLO(task, demos, cfg, seed=0)
    rng = np.random.default_rng(0)
    n = 512
    obs = rng.normal(size=(n, task.obs_dim)).astype(np.float32)
    acts = rng.uniform(-1, 1, size=(n, task.act_dim)).astype(np.float32)
    steps = replay.transitions_of_step(obs, acts, obs + 0.1, np.zeros(n), np.zeros(n, bool), False)
    learner.buffer.add(*steps)
    batch = learner.buffer.sample(64)
    before = learner.reward(batch)
    learner.train_disc()
    after = learner.reward(batch)
    assert (before >= 0).all() and not torch.allclose(before, after)

    def q_at_policy(alpha: float) -> float:
        run = OPOLO(task, demos, OPOLOConfig(**{**vars(cfg), "alpha": alpha}), seed=0)
        run.buffer = learner.buffer
        for _ in range(50):
            b = run.buffer.sample(64)
            run.update(b, torch.zeros(64))
        with torch.no_grad():
            return torch.min(*run.critic(b.obs, run.actor.act(b.obs))).mean().item()

    assert q_at_policy(10.0) < q_at_policy(0.0)


@pytest.mark.parametrize("name", ["gaifo-sac", "opolo"])
def test_device_setting_runs_the_learner_there_and_keeps_a_cpu_policy(name, pendulum):
    """`device` moves the networks and updates; the kept policy is a CPU one either way. On a
    machine without a GPU, asking for one fails at the trial's start, in one line."""
    from bench import envs
    from bench.demos import pools as demo_pool
    from bench.harness.registry import Task
    from bench.harness.trial import demo_pool as pool_of

    demos = demo_pool.load_demos(pool_of(pendulum, None), pendulum, 1, 0)
    obs_dim, act_dim, low, high = envs.spaces(pendulum)
    task = Task(pendulum, obs_dim, act_dim, low, high, lambda s: envs.make(pendulum, s))
    algo = registry.get(name)
    tiny = {**TINY, "learning_starts": 100}
    if name == "opolo":
        tiny.update(disc_hidden=[16, 16], inverse_pretrain=5, train_every=50)

    class Quiet:
        def checkpoint(self, env_steps, policy): ...

        def log(self, env_steps, **scalars): ...

    if not torch.cuda.is_available():
        with pytest.raises(RuntimeError, match="torch sees no GPU"):
            algo.train(task, demos, 200, 0, Quiet(), algo.config(**tiny, device="cuda"))
        return
    policy = algo.train(task, demos, 200, 0, Quiet(), algo.config(**tiny, device="cuda"))
    assert all(t.device.type == "cpu" for t in policy.state()["weights"].values())
    assert policy(np.zeros((3, obs_dim), np.float32)).shape == (3, act_dim)
