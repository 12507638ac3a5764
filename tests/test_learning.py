"""Learning claims, checked by running the learners through the runner (tiny but real budgets).

Floats differ in their last bits between CPUs and training amplifies that, so a given seed can
pass on one machine and fail on another. The claims are therefore statistics over several
seeds with headroom, never "seed k passes"; each was checked on two disjoint seed sets."""

import pytest

from bench import normalize, store
from bench.runner import run_suite
from bench.suite import expand, load_suite

PENDULUM = "InvertedPendulumBulletEnv-v0"
SEEDS = [0, 1, 2, 3, 4, 5]


pytestmark = pytest.mark.usefixtures("demo_cache")


def run(tmp_path, body: str):
    (tmp_path / "s.yaml").write_text(body)
    specs = expand(load_suite(tmp_path / "s.yaml"))
    summary = run_suite(specs, tmp_path / "res", jobs=2, progress=False)
    assert summary.failed == 0
    return normalize.normalize(store.load(tmp_path / "res"))


def test_gaifo_imitates_inverted_pendulum_from_one_demonstration(tmp_path):
    df = run(
        tmp_path,
        f"name: learn\nenvs: {{{PENDULUM}: {{budget: 100000}}}}\ndemos: [1]\n"
        f"algorithms: [random, expert, gaifo]\nseeds: {SEEDS}\neval_episodes: 10\n",
    )
    gaifo = df[df.algorithm == "gaifo"]
    assert len(gaifo) == len(SEEDS)
    shown = gaifo[["seed", "return", "normalized"]]
    # Measured with the defaults: seeds 0-5 all 1.00; seeds 10-15 1.00 0.41 1.00 0.89 1.00 1.00.
    # About one seed in eight ends below 0.9 on one machine, and another CPU may move a seed
    # across, so two of six may miss 0.8; a third, or a median below 0.95, means it broke.
    assert gaifo.normalized.median() >= 0.95, shown
    assert (gaifo.normalized >= 0.8).sum() >= len(SEEDS) - 2, shown
    assert (gaifo.env_steps <= 100_000).all()
    logs = store.load_logs(tmp_path / "res")
    assert {
        "disc_loss",
        "disc_acc_policy",
        "disc_acc_expert",
        "reward_absorbing",
        "terminations",
    } <= set(logs.key)
    curves = store.load_curves(tmp_path / "res")
    assert len(curves[curves.algorithm == "gaifo"]) >= len(SEEDS) * 5
