"""Learning claims, checked by running the learners through the runner (tiny but real budgets)."""

import pytest

from bench import normalize, store
from bench.runner import run_suite
from bench.suite import expand, load_suite

PENDULUM = "InvertedPendulumBulletEnv-v0"


@pytest.fixture(autouse=True)
def demo_cache(tmp_path, monkeypatch):
    monkeypatch.setattr("bench.paths.CACHE_DIR", tmp_path / "cache")


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
        "algorithms: [random, expert, gaifo]\nseeds: 2\neval_episodes: 10\n",
    )
    gaifo = df[df.algorithm == "gaifo"]
    assert len(gaifo) == 2
    assert (gaifo.normalized >= 0.9).all(), gaifo[["seed", "return", "normalized"]]
    assert (gaifo.env_steps <= 100_000).all()
    logs = store.load_logs(tmp_path / "res")
    assert {"disc_loss", "disc_acc_policy", "disc_acc_expert"} <= set(logs.key)
    curves = store.load_curves(tmp_path / "res")
    assert len(curves[curves.algorithm == "gaifo"]) >= 2 * 5
