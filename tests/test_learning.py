"""Learning claims, checked by running the learners through the runner (tiny but real budgets).

Floats differ in their last bits between CPUs and training amplifies that, so a given seed can
pass on one machine and fail on another. The claims are therefore statistics over several
seeds with headroom, never "seed k passes"; each was checked on two disjoint seed sets."""

import pytest

from bench.analysis import normalize
from bench.harness import frames
from bench.harness.runner import run_suite
from bench.harness.suite import load_suite

PENDULUM = "InvertedPendulumBulletEnv-v0"
SEEDS = [0, 1, 2, 3]


pytestmark = [pytest.mark.usefixtures("demo_cache"), pytest.mark.slow]


def run(tmp_path, body: str):
    (tmp_path / "s.yaml").write_text(body)
    specs = list(load_suite(tmp_path / "s.yaml").trials)
    summary = run_suite(specs, tmp_path / "res", jobs=2, progress=False)
    assert summary.failed == 0
    return normalize.normalize(frames.load(tmp_path / "res"))


@pytest.mark.parametrize("learner", ["gaifo", "gail"])
def test_adversarial_learners_imitate_inverted_pendulum_from_one_demonstration(tmp_path, learner):
    # The suites' setting for this task: a 4,096-step TRPO batch (README, "Batch size per task")
    # and 25 discriminator steps per update (README, "D's pace"), at 70k steps, not the suite's
    # 100k: in results/pybullet's learning curves (1 demo, seeds 0-9) every seed of both is at
    # 1,000 from 65,536 steps on, one TRPO update before the end here.
    df = run(
        tmp_path,
        f"name: learn\nenvs: {{{PENDULUM}: {{budget: 70000, trpo: {{n_envs: 16}},"
        " hyperparams: {disc_steps: 25}}}\n"
        f"demos: [1]\nalgorithms: [random, expert, {learner}]\nseeds: {SEEDS}\n"
        "eval_episodes: 10\ncurve_points: 4\n",  # each point is 5 episodes of up to 1,000 steps
    )
    runs = df[df.algorithm == learner]
    assert len(runs) == len(SEEDS)
    shown = runs[["seed", "return", "normalized"]]
    # Measured with this setting, 1 demo, at 100k: seeds 0-29 all >= 0.95 for both on two
    # machines (all 1.00 on the second, and seeds 0-9 at 5, 10 and 25 demos too); at 70k: seeds
    # 0-3 and 10-13 all 1.00 for both. Another CPU may still move a seed across, so one of four
    # may miss 0.95; a second, or a median below 0.95, means it broke.
    assert runs.normalized.median() >= 0.95, shown
    assert (runs.normalized >= 0.95).sum() >= len(SEEDS) - 1, shown
    assert (runs.env_steps <= 70_000).all()
    logs = frames.load_logs(tmp_path / "res")
    assert {
        "disc_loss",
        "disc_acc_policy",
        "disc_acc_expert",
        "reward_absorbing",
        "terminations",
    } <= set(logs.key)
    curves = frames.load_curves(tmp_path / "res")
    points = curves[curves.algorithm == learner].groupby("seed").size()
    assert len(points) == len(SEEDS) and points.between(4, 5).all(), points  # curve_points: 4


def test_sac_swings_up_the_pendulum():
    """The off-policy optimizer on its field's first check: gymnasium's Pendulum-v1 (random
    -1,200 to -1,500; solved about -150). Measured at 8k steps, 64 x 64: -142, -546, -142 on
    seeds 0-2 and -144, -144, -146 on 3-5 (the slow seed is still swinging up), and on the
    disjoint seeds 6-11 -176, -140, -169, -148, -143, -146: a median above -300 with room to
    spare, and no more than one slow seed. (At 10k, seeds 0-11 were as good, no better.)"""
    import joblib
    import numpy as np

    scores = joblib.Parallel(n_jobs=2)(joblib.delayed(_sac_pendulum)(seed) for seed in (0, 1, 2))
    assert np.median(scores) > -300 and sum(s > -400 for s in scores) >= 2, scores


def _sac_pendulum(seed: int) -> float:
    """Mean return of 5 episodes of SAC's deterministic actor after 8k steps on Pendulum-v1."""
    import gymnasium as gym
    import numpy as np

    from bench.rl import sac
    from bench.rl.rollout import evaluate

    cfg = sac.SACConfig(hidden=(64, 64), learning_starts=1000)
    learner = sac.train(lambda s: gym.make("Pendulum-v1"), 8_000, seed, cfg)
    envs = [gym.make("Pendulum-v1") for _ in range(5)]
    return float(np.mean(evaluate(sac.DeterministicActor(learner.actor), envs, 5, 1000)))


SWINGUP = "InvertedPendulumSwingupBulletEnv-v0"


def test_the_methods_since_the_paper_swing_up_where_survival_cannot(tmp_path):
    """The swing-up starts hanging and pays cos(angle) per step, so hanging still earns about
    -1,000 (random actions -930, the expert 870). It never ends early, so the survival control
    is paid the same whatever it does and stays there: the floor. At 80k, 1 demonstration, the
    quick suite's settings (docs/guide/since-the-paper.md, "On the pendulum"):
    - AIRLfO and WAILfO swing up on every seed measured, 0-3 and the disjoint 10-13 (returns
      -25 to 151 at 70-80k): the claim is a median above survival's best by 300, and at most
      one seed of three not above it by 50.
    - PWIL swings up on about half the seeds (at 80k: -83 and -814 of seeds 0-3, 12 and -737
      of 10-13; the rest hang): its kernel is narrow where the pendulum hangs. The claim is that
      one of five seeds beats survival's best by 150; a CPU that draws five hanging seeds
      (about 3% of the time, at one in two) fails it."""
    df = run(
        tmp_path,
        f"name: since\nsettings: settings/pybullet.yaml\nenvs: {{{SWINGUP}: {{budget: 80000,"
        " seeds: {survival: [0, 1], pwil: [0, 1, 2, 3, 4]}}}\n"
        "demos: [1]\nalgorithms: [random, expert, survival, airlfo, wailfo, pwil]\n"
        "seeds: [0, 1, 2]\neval_episodes: 3\ncurve_points: 1\n",
    )
    floor = df[df.algorithm == "survival"]["return"].max()
    for learner in ("airlfo", "wailfo"):
        runs = df[df.algorithm == learner]
        shown = runs[["seed", "return"]].to_string()
        assert len(runs) == 3, shown
        assert runs["return"].median() >= floor + 300, (learner, floor, shown)
        assert (runs["return"] >= floor + 50).sum() >= 2, (learner, floor, shown)
    pwil = df[df.algorithm == "pwil"]
    assert len(pwil) == 5 and pwil["return"].max() >= floor + 150, (floor, pwil)
