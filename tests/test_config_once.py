"""Each algorithm's config is built once per (algorithm entry, env): at load, carried by the
trial specs to the trial, which trains with that one (a copy, never a rebuild)."""

from collections import Counter

from bench.harness import registry
from bench.harness.suite import load_suite
from bench.harness.trial import plan, run_trial

PENDULUM = "InvertedPendulumBulletEnv-v0"
HOPPER = "HopperBulletEnv-v0"


def count_constructions(monkeypatch) -> Counter:
    """Constructions of every registered algorithm's config class, by class."""
    built: Counter = Counter()
    for config in {a.config for a in registry.all_algorithms().values()}:
        init = config.__init__

        def counted(self, *args, __init=init, **kwargs):
            built[type(self).__name__] += 1
            __init(self, *args, **kwargs)

        monkeypatch.setattr(config, "__init__", counted)
    return built


def test_each_config_is_built_once_per_entry_and_env(tmp_path, monkeypatch):
    built = count_constructions(monkeypatch)
    suite = tmp_path / "once.yaml"
    suite.write_text(
        f"envs:\n  {PENDULUM}: {{budget: 2048, trpo: {{n_envs: 2}},"
        " hyperparams: {disc_steps: 3, steps_per_env: 512}}\n"
        f"  {HOPPER}: {{budget: 4096}}\n"
        "demos: [1, 2]\n"
        "algorithms:\n"
        "  - random\n"
        "  - {algorithm: survival, n_envs: 2, steps_per_env: 512}\n"
        "  - {algorithm: gaifo, label: gaifo-lr, disc_lr: [0.001, 0.0003]}\n"
        "  - {bco: {pre_demo_steps: 1000}}\n"
        "seeds: 3\n"
    )
    loaded = load_suite(suite)
    entries, envs = len(loaded.algorithms), len(loaded.envs)
    assert entries == 5  # the sweep is two entries
    assert sum(built.values()) == entries * envs, built
    assert len(loaded.trials) > entries * envs  # seeds and demo counts share their config

    survival = next(s for s in loaded.trials if s.algorithm == "survival")
    before = sum(built.values())
    result = run_trial(survival, plan(survival).inputs())
    assert result.status == "ok", result.traceback
    assert sum(built.values()) == before  # the trial trained with the spec's config
    assert survival.config.n_envs == 2 and survival.hyperparams["n_envs"] == 2
