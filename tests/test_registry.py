import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from bench.harness import frames, registry
from bench.harness.trial import plan, run_trial
from bench.harness.types import TrialSpec
from bench.imitation.data import ActionDemos, Demos

PENDULUM = "InvertedPendulumBulletEnv-v0"
README = Path(__file__).resolve().parent.parent / "README.md"


pytestmark = pytest.mark.usefixtures("demo_cache")


def spec(algorithm: str, budget: int = 4096, **hp) -> TrialSpec:
    return TrialSpec("t", PENDULUM, algorithm, 1, 0, budget, 2, hp)


def test_only_gail_is_handed_actions():
    algos = registry.all_algorithms()
    assert {"random", "expert", "gaifo", "gail", "survival"} <= set(algos)
    # GAIL, on either optimizer, is the one algorithm that sees the expert's actions
    assert sorted(name for name, a in algos.items() if a.uses_actions) == ["gail", "gail-sac"]
    for name, algo in algos.items():
        inputs = plan(spec(name)).inputs()
        if algo.inputs == "states":
            assert type(inputs) is Demos and not hasattr(inputs, "actions"), name
        elif algo.inputs == "actions":
            assert type(inputs) is ActionDemos, name


def test_unknown_algorithm_and_hyperparameter_are_named():
    with pytest.raises(registry.RegistryError, match="unknown algorithm 'gaifoo'"):
        registry.get("gaifoo")
    with pytest.raises(ValueError, match="no hyperparameter 'disc_lrr'"):
        registry.get("gaifo").make_config({"disc_lrr": 1.0})
    with pytest.raises(ValueError, match="reward must be one of"):
        registry.get("gaifo").make_config({"reward": "D"})


PLUGIN_PAGE = README.parent / "docs" / "guide" / "plugins.md"


@pytest.mark.slow
def test_the_plugin_page_installs_and_runs_as_written(tmp_path, cli):
    """The docs' plugin package, built from the page's own code blocks: pip installs it, bench
    lists it, and a suite trains it through the runner."""
    text = PLUGIN_PAGE.read_text()
    code = re.search(r"```python\n(.*?)```", text, re.S).group(1)
    toml = re.search(r"```toml\n(.*?)```", text, re.S).group(1)
    package = tmp_path / "my-ifo"
    (package / "my_ifo").mkdir(parents=True)
    (package / "my_ifo" / "__init__.py").write_text(code)
    (package / "pyproject.toml").write_text(toml)
    site = tmp_path / "site"
    install = [sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-build-isolation"]
    subprocess.run([*install, "--target", str(site), str(package)], check=True, capture_output=True)
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(site), *sys.path])}
    assert "nearest-state" in cli("list", env=env).stdout
    suite = tmp_path / "plug.yaml"
    suite.write_text(
        f"envs: {{{PENDULUM}: {{budget: 4096}}}}\ndemos: [1]\n"
        "algorithms: [random, expert, nearest-state]\nseeds: 1\neval_episodes: 2\n"
    )
    out = cli("run", str(suite), "--results", str(tmp_path / "res"), "--jobs", "1", env=env)
    assert out.returncode == 0, out.stderr

    runs = frames.load(tmp_path / "res")
    row = runs[runs.algorithm == "nearest-state"].iloc[0]
    assert row.status == "ok" and 0 < row.env_steps <= 4096 and np.isfinite(row["return"])


def test_trial_id_covers_resolved_defaults(tmp_path):
    from bench.harness.suite import load_suite

    def ids(algorithms: str) -> set[str]:
        path = tmp_path / "s.yaml"
        path.write_text(
            f"envs: {{{PENDULUM}: {{budget: 4096}}}}\ndemos: [1]\nalgorithms: {algorithms}\nseeds: 1\n"
        )
        return {s.trial_id for s in list(load_suite(path).trials) if s.algorithm == "gaifo"}

    plain = ids("[random, expert, gaifo]")
    assert plain == ids("[random, expert, {gaifo: {disc_lr: 0.0003}}]")  # the default, spelled out
    assert plain != ids("[random, expert, {gaifo: {disc_lr: 0.001}}]")
    spec = next(s for s in list(load_suite(tmp_path / "s.yaml").trials) if s.algorithm == "gaifo")
    assert spec.hyperparams["grad_penalty"] == 10.0  # defaults are in the hashed spec


def test_the_controls_run_the_imitators_trpo_settings(tmp_path):
    """survival and oracle differ from GAIfO and GAIL only in their reward: same config class as
    their TRPO part, and a suite env's trpo: and hyperparams: settings reach all four alike."""
    from bench.harness.learners import ImitationTRPOConfig
    from bench.harness.suite import load_suite

    algos = registry.all_algorithms()
    for control in ("survival", "oracle"):
        assert algos[control].config is ImitationTRPOConfig and algos[control].inputs == "none"
        assert issubclass(algos["gaifo"].config, ImitationTRPOConfig)
    suite = tmp_path / "matched.yaml"
    suite.write_text(
        f"envs: {{{PENDULUM}: {{budget: 4096, trpo: {{n_envs: 16}},"
        " hyperparams: {disc_steps: 25, steps_per_env: 128}}}\n"
        "demos: [1]\nalgorithms: [gaifo, gail, survival, oracle]\nseeds: 1\n"
    )
    settings = {s.algorithm: s.hyperparams for s in list(load_suite(suite).trials)}
    trpo_fields = set(settings["oracle"])
    assert settings["oracle"] == settings["survival"]
    assert settings["oracle"]["n_envs"] == 16 and settings["oracle"]["steps_per_env"] == 128
    for imitator in ("gaifo", "gail"):
        assert {k: settings[imitator][k] for k in trpo_fields} == settings["oracle"]


@pytest.mark.slow
def test_the_oracle_trains_on_the_envs_reward_where_survival_trains_on_one_per_step():
    """InvertedPendulum pays +1 per step alive, so there the two controls are the same learner
    and their records agree to the bit; Hopper pays for forward progress, so they part."""

    def returns(algorithm: str, env_id: str) -> list[float]:
        trial = TrialSpec("t", env_id, algorithm, 0, 0, 2048, 2, {"policy_average": 0.0})
        result = run_trial(trial, plan(trial).inputs())
        assert result.status == "ok", result.traceback
        return result.returns

    assert returns("oracle", PENDULUM) == returns("survival", PENDULUM)
    assert returns("oracle", "HopperBulletEnv-v0") != returns("survival", "HopperBulletEnv-v0")


@pytest.mark.slow
def test_a_broken_plugin_is_named_once_and_the_rest_works(tmp_path, cli, install_plugin):
    env = install_plugin(tmp_path, "broken", "broken-ifo = broken_ifo", {"broken_ifo": "1/0\n"})
    out = cli("list", env=env)
    assert out.returncode == 0, out.stderr
    warning = [line for line in out.stderr.splitlines() if "broken-ifo" in line]
    assert len(warning) == 1 and "ZeroDivisionError" in warning[0]
    assert "gaifo" in out.stdout and "broken-ifo" not in out.stdout
    # A run says it once too, not once per trial from its workers.
    suite = tmp_path / "s.yaml"
    suite.write_text(
        "envs: {InvertedPendulumBulletEnv-v0: {budget: 2048}}\ndemos: [1]\n"
        "algorithms: [random, expert]\nseeds: 3\neval_episodes: 1\n"
    )
    out = cli("run", str(suite), "--results", str(tmp_path / "res"), "--jobs", "2", env=env)
    assert out.returncode == 0, out.stderr
    assert sum("broken-ifo" in line for line in out.stderr.splitlines()) == 1, out.stderr


def test_a_plugin_that_takes_a_builtin_name_is_an_error_naming_both(tmp_path, cli, install_plugin):
    code = (
        "from dataclasses import dataclass\nfrom bench.harness.registry import register\n\n"
        "@dataclass\nclass C:\n    pass\n\n"
        "@register('gaifo', config=C, inputs='states')\n"
        "def train(task, demos, budget, seed, logger, config):\n    pass\n"
    )
    env = install_plugin(tmp_path, "clash", "my-gaifo = clash_ifo", {"clash_ifo": code})
    out = cli("list", env=env)
    assert out.returncode == 2 and len(out.stderr.strip().splitlines()) == 1, out.stderr
    assert "'gaifo' is registered twice" in out.stderr
    assert "algorithms.gaifo.train" in out.stderr and "clash_ifo.train" in out.stderr


def test_every_committed_record_is_still_a_trial_of_its_suite():
    """Validation only checks: every committed suite still loads, every committed record's
    settings pass the checks, and its trial id is one its suite expands to today (so no
    record went stale or changed id)."""
    from collections import defaultdict

    from bench.harness import store
    from bench.harness.suite import load_suite

    root = README.parent
    ids: dict[str, set[str]] = defaultdict(set)
    for path in sorted((root / "suites").glob("*.yaml")):
        suite = load_suite(path)
        ids[suite.name] |= {s.trial_id for s in suite.trials}
    for name, expected in ids.items():
        checked = 0
        for record in store.scan(root / "results" / name):
            assert record.trial_id in expected, f"{name}: {record.trial_id} is no trial of it"
            registry.get(record.spec.algorithm).make_config(record.spec.hyperparams)
            checked += 1
        assert checked == len(list(store.trials_dir(root / "results" / name).glob("*.json")))


PLUGIN_ROLES = '''
from dataclasses import dataclass

import numpy as np

from bench.harness.learners import ImitationTRPOConfig, one_batch, trpo_on_reward
from bench.harness.registry import register


@register("standing", config=ImitationTRPOConfig, inputs="none", min_budget=one_batch,
          role="floor", family="trpo", label="Standing")
def standing(task, demos, budget, seed, logger, config):
    """A floor of its own: TRPO paid 2 per step alive."""
    reward = lambda b: 2 * np.ones_like(b.rewards)
    return trpo_on_reward(task, budget, seed, logger, config, reward)


class MeanAction:
    """A policy class of the plugin's own: the demonstrations' mean state, mapped linearly."""

    def __init__(self, weights):
        self.weights = np.asarray(weights, dtype=np.float32)

    def __call__(self, obs):
        return np.tanh(obs @ self.weights)

    def state(self):
        import torch
        return {"weights": torch.from_numpy(self.weights)}

    @classmethod
    def from_state(cls, state):
        return cls(state["weights"].numpy())


@dataclass
class LinearConfig:
    pass


@register("linear", config=LinearConfig, inputs="states", family="trpo", label="Linear")
def linear(task, demos, budget, seed, logger, config):
    """Acts on a random projection of the state."""
    rng = np.random.default_rng(seed)
    return MeanAction(rng.normal(size=(task.obs_dim, task.act_dim)) * 0.1)
'''


@pytest.mark.slow
def test_a_plugin_control_is_drawn_and_reported_as_one_and_its_policy_is_kept(
    tmp_path, cli, install_plugin
):
    """Roles are declared, not guessed from names: a plugin registered as a floor control is
    drawn as a floor's line and every learner of its family is compared with it; a plugin's
    own policy class is kept like a built-in's and acts as it did when evaluated."""
    from bench.analysis import plot
    from bench.analysis.labels import Names
    from bench.analysis.normalize import normalize
    from bench.harness import policies

    env = install_plugin(
        tmp_path / "site",
        "roles",
        "standing = roles_ifo\nlinear = roles_ifo",
        {"roles_ifo": PLUGIN_ROLES},
    )
    suite = tmp_path / "roles.yaml"
    tiny = "{n_envs: 2, steps_per_env: 256}"
    suite.write_text(
        f"envs: {{{PENDULUM}: {{budget: 512}}}}\ndemos: [1]\nseeds: 2\neval_episodes: 2\n"
        f"algorithms: [random, expert, gaifo: {tiny}, standing: {tiny}, linear]\n"
    )
    results = tmp_path / "res"
    out = cli("run", str(suite), "--results", str(results), "--jobs", "1", env=env)
    assert out.returncode == 0, out.stderr
    out = cli("report", str(results), "--reps", "50", env=env)
    assert out.returncode == 0, out.stderr

    trials = frames.load(results)
    roles = dict(zip(trials["algorithm"], trials["role"], strict=False))
    assert roles["standing"] == "floor" and roles["linear"] == "learner"
    text = (results / "report" / "report.md").read_text()
    for pair in ("GAIfO > Standing", "Linear > Standing", "GAIfO > Linear"):
        assert pair in text, pair
    assert "**Standing** is a lower control (the floor)" in text  # the floor named as it is

    fig = plot.draw_figure2(normalize(trials))
    legend = [t.get_text() for t in fig.legends[0].get_texts()]
    assert "Standing (floor: paid to stay alive)" in legend and "Linear" in legend
    assert Names.of(trials).label("linear") == "Linear"

    for row in trials[trials["algorithm"] == "linear"].itertuples():
        file = policies.path(results, row.trial_id)
        assert file.is_file(), "a plugin's own policy class is kept"
    code = (
        "import sys, numpy as np\nfrom bench.harness import policies\n"
        "p = policies.load(sys.argv[1])\nprint(type(p).__name__, p(np.zeros((1, 5))).shape)\n"
    )
    loaded = subprocess.run(
        [sys.executable, "-c", code, str(file)], env=env, capture_output=True, text=True
    )
    assert loaded.stdout.split() == ["MeanAction", "(1,", "1)"], loaded.stderr


def test_a_field_added_later_keeps_old_ids_until_it_is_set(tmp_path):
    """A config field declared `added_later` stays out of a resolved config (what trial ids
    hash) while at its default, so adding it changed no recorded trial's id; set, it is in."""
    from algorithms.adversarial import AdversarialConfig
    from bench.harness.suite import load_suite as _load
    from bench.harness.suite.resolve import as_json

    assert "disc_noise" not in as_json(AdversarialConfig(n_envs=16))
    assert as_json(AdversarialConfig(n_envs=16, disc_noise=0.5))["disc_noise"] == 0.5
    body = f"envs: {{{PENDULUM}: {{budget: 4096, trpo: {{n_envs: 16}}}}}}\ndemos: [1]\nseeds: 1\n"
    plain = _load(write_text(tmp_path / "a.yaml", body + "algorithms: [gaifo]\n")).trials
    noisy = _load(
        write_text(
            tmp_path / "b.yaml", body + "algorithms: [{algorithm: gaifo, disc_noise: 0.5}]\n"
        )
    ).trials
    assert plain[0].hyperparams == {
        k: v for k, v in noisy[0].hyperparams.items() if k != "disc_noise"
    }
    assert plain[0].trial_id != noisy[0].trial_id


def write_text(path: Path, text: str) -> Path:
    path.write_text(text)
    return path
