"""Suite files: what loads, what expands to which trials, and one-line errors for the rest."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pytest
import yaml

from bench import paths
from bench.harness import registry
from bench.harness.suite import (
    DEMO_POOL_SIZE,
    RunnerSettings,
    SuiteError,
    load_suite,
    select,
)
from bench.harness.types import CURVE_POINTS
from bench.rl.trpo import TRPOConfig

PENDULUM = "InvertedPendulumBulletEnv-v0"
HOPPER = "HopperBulletEnv-v0"
NO_EXPERT = "InvertedDoublePendulumBulletEnv-v0"


@dataclass
class IfoConfig:
    lr: float = 1e-3
    steps: int = 10
    normalize: bool = True


@dataclass
class NoConfig:
    pass


@dataclass
class TrpoLearnerConfig(TRPOConfig):
    disc_lr: float = 1e-3


def _train(task, demos, budget, seed, logger, config):
    raise NotImplementedError  # suites never train


@pytest.fixture(autouse=True)
def algorithms(monkeypatch):
    """A private registry with two references and two learners; the real one is left alone."""
    monkeypatch.setattr(registry, "_loaded", True)
    monkeypatch.setattr(registry, "_ALGORITHMS", {})
    registry.register("random", config=NoConfig, inputs="none", pixels=True)(_train)
    registry.register("expert", config=NoConfig, inputs="expert")(_train)
    registry.register("ifo", config=IfoConfig, inputs="states")(_train)
    registry.register("with-actions", config=NoConfig, inputs="actions")(_train)
    registry.register("trpo-ifo", config=TrpoLearnerConfig, inputs="states")(_train)


@pytest.fixture(autouse=True)
def experts(monkeypatch, tmp_path):
    root = tmp_path / "experts"
    for env_id in (PENDULUM, HOPPER):
        (root / env_id).mkdir(parents=True)
        (root / env_id / "policy.pt").write_bytes(b"")
        (root / env_id / "meta.json").write_text("{}")
    monkeypatch.setattr(paths, "EXPERTS_DIR", root)


def base() -> dict:
    return {
        "envs": {PENDULUM: {"budget": 1000}, HOPPER: {"budget": 2000}},
        "demos": [1, 5],
        "algorithms": ["random", "expert", {"ifo": {"lr": 0.01}}, "with-actions"],
        "seeds": 3,
    }


def write(tmp_path: Path, content: dict | str, name: str = "x.yaml") -> Path:
    path = tmp_path / name
    path.write_text(
        content if isinstance(content, str) else yaml.safe_dump(content, sort_keys=False)
    )
    return path


def test_loads_with_defaults(tmp_path):
    suite = load_suite(write(tmp_path, base(), "quick.yaml"))
    assert suite.name == "quick"
    assert [(e.env_id, e.budget) for e in suite.envs] == [(PENDULUM, 1000), (HOPPER, 2000)]
    assert suite.demos == (1, 5)
    assert suite.seeds == (0, 1, 2)
    assert suite.eval_episodes == 10
    assert suite.runner == RunnerSettings(jobs=-1, backend="loky")
    assert [(a.name, a.uses_demos) for a in suite.algorithms] == [
        ("random", False),
        ("expert", False),
        ("ifo", True),
        ("with-actions", True),
    ]
    resolved = {s.algorithm: s.hyperparams for s in suite.trials}
    assert resolved["ifo"] == {"lr": 0.01, "steps": 10, "normalize": True}  # defaults resolved
    assert resolved["with-actions"] == {}


def test_explicit_name_seeds_and_runner(tmp_path):
    raw = base() | {
        "name": "mine",
        "seeds": [7, 3],
        "eval_episodes": 4,
        "runner": {"jobs": 2, "backend": "dask", "first": ["ifo"]},
    }
    suite = load_suite(write(tmp_path, raw))
    assert suite.name == "mine"
    assert suite.seeds == (7, 3)
    assert suite.eval_episodes == 4
    assert suite.runner == RunnerSettings(jobs=2, backend="dask", first=("ifo",))
    raw["runner"]["first"] = ["ifoo"]
    with pytest.raises(SuiteError, match=r"runner\.first: 'ifoo' is no algorithm or label"):
        load_suite(write(tmp_path, raw, "typo.yaml"))


def test_yaml_text_as_documented(tmp_path):
    text = f"""
name: quick
envs:
  {PENDULUM}: {{budget: 100_000}}
demos: [1, {DEMO_POOL_SIZE}]
algorithms:
  - random
  - ifo: {{lr: 1.0e-3, steps: 5}}
  - ifo-less-entry-is-fine-too:
seeds: 2
"""
    registry.register("ifo-less-entry-is-fine-too", config=NoConfig, inputs="states")(_train)
    suite = load_suite(write(tmp_path, text))
    assert suite.envs[0].budget == 100_000
    resolved = {s.algorithm: s.hyperparams for s in suite.trials}
    assert resolved["ifo"] == {"lr": 1e-3, "steps": 5, "normalize": True}
    assert resolved["ifo-less-entry-is-fine-too"] == {}


def test_expand_counts_order_and_references(tmp_path):
    suite = load_suite(write(tmp_path, base()))
    specs = list(suite.trials)  # expanded once, at load
    # per env: 2 references x 3 seeds + 2 demo counts x 2 learners x 3 seeds
    assert len(specs) == 2 * (2 * 3 + 2 * 2 * 3)
    assert len({s.trial_id for s in specs}) == len(specs)
    assert list(load_suite(write(tmp_path, base())).trials) == specs  # deterministic

    first = [(s.env_id, s.algorithm, s.n_demos, s.seed) for s in specs[:9]]
    assert first == [
        (PENDULUM, "random", 0, 0),
        (PENDULUM, "random", 0, 1),
        (PENDULUM, "random", 0, 2),
        (PENDULUM, "expert", 0, 0),
        (PENDULUM, "expert", 0, 1),
        (PENDULUM, "expert", 0, 2),
        (PENDULUM, "ifo", 1, 0),
        (PENDULUM, "ifo", 1, 1),
        (PENDULUM, "ifo", 1, 2),
    ]
    refs = [s for s in specs if s.algorithm in ("random", "expert")]
    assert {s.n_demos for s in refs} == {0}
    learners = [s for s in specs if s.algorithm not in ("random", "expert")]
    assert {s.n_demos for s in learners} == {1, 5}
    hopper = [s for s in specs if s.env_id == HOPPER]
    assert {s.budget for s in hopper} == {2000}
    assert all(s.suite == "x" and s.eval_episodes == 10 for s in specs)
    assert {s.algorithm: s.hyperparams for s in specs}["ifo"] == {
        "lr": 0.01,
        "steps": 10,
        "normalize": True,
    }


def test_select_keeps_a_slice_with_the_same_ids(tmp_path):
    path = write(tmp_path, base())
    specs = list(load_suite(path).trials)
    hopper = select(specs, path, env=[HOPPER])
    assert hopper == [s for s in specs if s.env_id == HOPPER]  # same specs, so the same ids
    ifo = select(specs, path, env=[HOPPER, PENDULUM], algorithm=["ifo"])
    assert len(ifo) == 2 * 2 * 3 and {s.algorithm for s in ifo} == {"ifo"}
    assert select(specs, path) == specs


def test_select_by_demo_count_keeps_the_trials_without_demonstrations(tmp_path):
    path = write(tmp_path, base())
    specs = list(load_suite(path).trials)
    counts = sorted({s.n_demos for s in specs if s.n_demos})
    assert len(counts) > 1, "the test suite needs several demo counts"
    chosen = select(specs, path, demos=[counts[0]])
    assert {s.n_demos for s in chosen} == {0, counts[0]}
    assert chosen == [s for s in specs if s.n_demos in (0, counts[0])]
    with pytest.raises(SuiteError, match=r"x\.yaml: 7777 is not one of the suite's demo counts"):
        select(specs, path, demos=[7777])
    only_random = select(specs, path, algorithm=["random"], demos=[counts[0]])
    assert only_random == [s for s in specs if s.algorithm == "random"]  # checked against all


def test_a_selection_with_no_trial_fails(tmp_path):
    raw = base()
    raw["envs"][HOPPER]["seeds"] = {"ifo": 0}  # ifo runs on the pendulum only
    path = write(tmp_path, raw)
    with pytest.raises(SuiteError, match=r"x\.yaml: no trial of the suite has all of: envs \["):
        select(list(load_suite(path).trials), path, env=[HOPPER], algorithm=["ifo"])


@pytest.mark.parametrize("key", ["env", "algorithm"])
def test_select_of_a_name_not_in_the_suite_fails(tmp_path, key):
    path = write(tmp_path, base())
    with pytest.raises(SuiteError, match=rf"x\.yaml: 'Nope' is not one of the suite's {key}s"):
        select(list(load_suite(path).trials), path, **{key: ["Nope"]})


def _set(raw: dict, keys: tuple, value) -> dict:
    node = raw
    for k in keys[:-1]:
        node = node[k]
    node[keys[-1]] = value
    return raw


def _drop(raw: dict, key: str) -> dict:
    del raw[key]
    return raw


BAD = [
    # (change to the valid base suite, expected message after "x.yaml: ")
    (lambda r: r | {"sedes": 3}, "sedes: unknown key (expected one of name, envs, demos"),
    (lambda r: _drop(r, "envs"), "envs: missing (required)"),
    (lambda r: r | {"curve_points": 0}, "curve_points: expected a value >= 1, got 0"),
    (lambda r: _set(r, ("envs", PENDULUM, "steps"), 5), f"envs.{PENDULUM}.steps: unknown key"),
    (
        lambda r: _set(r, ("envs", PENDULUM, "budget"), "lots"),
        f"envs.{PENDULUM}.budget: expected an integer, got 'lots'",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "budget"), True),
        f"envs.{PENDULUM}.budget: expected an integer, got True",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "budget"), 0),
        f"envs.{PENDULUM}.budget: expected a value >= 1, got 0",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "budget"), "1e5"),
        "got '1e5' (YAML reads 1e5 as a string; write 100000)",
    ),
    (lambda r: _set(r, ("envs", PENDULUM), {}), f"envs.{PENDULUM}.budget: missing"),
    (lambda r: _set(r, ("envs",), {}), "envs: expected a non-empty mapping"),
    (lambda r: _set(r, ("envs",), [PENDULUM]), "envs: expected a mapping, got ["),
    (lambda r: _set(r, ("demos",), []), "demos: expected a non-empty list, got []"),
    (lambda r: _set(r, ("demos",), 5), "demos: expected a list, got 5"),
    (
        lambda r: _set(r, ("demos",), [1, 26]),
        "demos[1]: expected at most 25 (the shipped demonstrations), got 26",
    ),
    (lambda r: _set(r, ("demos",), [0]), "demos[0]: expected a value >= 1, got 0"),
    (lambda r: _set(r, ("demos",), [5, 5]), "demos: expected distinct values, got [5, 5]"),
    (lambda r: _set(r, ("seeds",), True), "seeds: expected a seed count or a list of seeds"),
    (lambda r: _set(r, ("seeds",), 0), "seeds: expected a seed count or a list of seeds, got 0"),
    (lambda r: _set(r, ("seeds",), [0, -1]), "seeds[1]: expected a value >= 0, got -1"),
    (lambda r: _set(r, ("seeds",), []), "seeds: expected a non-empty list"),
    (lambda r: _set(r, ("eval_episodes",), 2.5), "eval_episodes: expected an integer, got 2.5"),
    (
        lambda r: _set(r, ("name",), "a/b"),
        "name: expected a name (letters, digits, . _ -), got 'a/b'",
    ),
    (lambda r: _set(r, ("runner",), {"jobs": 0}), "runner.jobs: expected a positive integer or -1"),
    (
        lambda r: _set(r, ("runner",), {"jobs": False}),
        "runner.jobs: expected an integer, got False",
    ),
    (
        lambda r: _set(r, ("runner",), {"backend": "ray"}),
        "runner.backend: expected one of loky or dask, got 'ray'",
    ),
    (lambda r: _set(r, ("runner",), {"workers": 2}), "runner.workers: unknown key"),
    (lambda r: _set(r, ("algorithms",), []), "algorithms: expected a non-empty list"),
    (lambda r: _set(r, ("algorithms", 1), "gaifoo"), "algorithms[1]: unknown algorithm 'gaifoo'"),
    (lambda r: _set(r, ("algorithms", 1), 3), "algorithms[1]: expected a name or"),
    (lambda r: _set(r, ("algorithms", 1), "random"), "algorithms[1]: 'random' appears twice"),
    (
        lambda r: _set(r, ("algorithms", 2), {"ifo": {"lrr": 0.1}}),
        "algorithms[2].ifo: algorithm 'ifo' has no hyperparameter 'lrr' (known: lr, normalize, steps)",
    ),
    (
        lambda r: _set(r, ("algorithms", 2), {"ifo": {"lr": "1e-3"}}),
        "algorithms[2].ifo.lr: expected a number, got '1e-3' (YAML reads 1e-3 as a string; write 0.001)",
    ),
    (
        lambda r: _set(r, ("algorithms", 2), {"ifo": {"steps": 1.5}}),
        "algorithms[2].ifo.steps: expected an integer, got 1.5",
    ),
    (
        lambda r: _set(r, ("algorithms", 2), {"ifo": {"normalize": 1}}),
        "algorithms[2].ifo.normalize: expected true or false, got 1",
    ),
    (lambda r: _set(r, ("algorithms", 2), {"ifo": [1]}), "algorithms[2].ifo: expected a mapping"),
    (
        lambda r: _set(r, ("envs",), {"HoperBulletEnv-v0": {"budget": 5}}),
        "envs.HoperBulletEnv-v0: unknown env id 'HoperBulletEnv-v0'",
    ),
    (
        lambda r: _set(r, ("envs",), {NO_EXPERT: {"budget": 5}}),
        f"envs.{NO_EXPERT}: no trained expert in",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "observation"), "video"),
        f"envs.{PENDULUM}.observation: expected one of states, pixels or video-reward, got 'video'",
    ),
    (
        lambda r: _set(
            r, ("envs", PENDULUM), {"budget": 5, "observation": "pixels", "dataset": "d"}
        ),
        f"envs.{PENDULUM}.observation: pixels needs video demonstrations; a dataset holds states",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "observation"), "pixels"),
        f"envs.{PENDULUM}.observation: ifo, with-actions cannot learn from pixels"
        " (those that can: random)",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "observation"), "video-reward"),
        f"envs.{PENDULUM}.observation: ifo, with-actions cannot imitate video"
        " (those that can: none)",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "frame_size"), 32),
        f"envs.{PENDULUM}.frame_size: only with observation: pixels or video-reward",
    ),
    (
        lambda r: _set(
            r, ("envs", PENDULUM), {"budget": 5, "observation": "pixels", "frame_size": 16}
        ),
        f"envs.{PENDULUM}.frame_size: expected a value >= 24, got 16",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "trpo"), {"nenvs": 16}),
        f"envs.{PENDULUM}.trpo.nenvs: not a TRPO setting (known: cg_damping,",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "trpo"), {"n_envs": 0}),
        f"envs.{PENDULUM}.trpo: n_envs must be >= 1, not 0",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "trpo"), {"n_envs": 1.5}),
        f"envs.{PENDULUM}.trpo.n_envs: expected an integer, got 1.5",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "trpo"), 16),
        f"envs.{PENDULUM}.trpo: expected a mapping, got 16",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "hyperparams"), {"lrr": 0.1}),
        f"envs.{PENDULUM}.hyperparams.lrr: no algorithm of the suite has this setting"
        " (expert, ifo, random, with-actions)",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "hyperparams"), {"steps": "many"}),
        f"envs.{PENDULUM}.hyperparams.steps: expected an integer, got 'many'",
    ),
    (
        lambda r: _set(r, ("envs", PENDULUM, "hyperparams"), [25]),
        f"envs.{PENDULUM}.hyperparams: expected a mapping, got [25]",
    ),
]


@pytest.mark.parametrize("change, expected", BAD, ids=[b[1].split(":")[0] for b in BAD])
def test_bad_suites_fail_with_one_line(tmp_path, change, expected):
    path = write(tmp_path, change(base()))
    with pytest.raises(SuiteError) as info:
        load_suite(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: ")
    assert expected in message, message


@pytest.mark.parametrize(
    "text, expected",
    [
        ("envs: [unclosed\n", "line 2, column 1: invalid YAML"),
        ("envs:\n  a: 1\n  a: 2\n", "line 3, column 3: invalid YAML: duplicate key 'a'"),
        ("", "expected a mapping with keys envs, demos, algorithms, got None"),
        ("- 1\n- 2\n", "expected a mapping with keys envs, demos, algorithms, got [1, 2]"),
        ("envs: " + "[" * 5000 + "]" * 5000 + "\n", "invalid YAML: nested too deeply"),
    ],
)
def test_bad_yaml_fails_with_one_line(tmp_path, text, expected):
    path = write(tmp_path, text)
    with pytest.raises(SuiteError) as info:
        load_suite(path)
    assert "\n" not in str(info.value)
    assert str(info.value).startswith(f"{path}: ")
    assert expected in str(info.value)


def test_missing_file_names_the_neighbours(tmp_path):
    write(tmp_path, base(), "quick.yaml")
    with pytest.raises(SuiteError, match=r"nope.yaml: no such suite file \(suites there: quick\)"):
        load_suite(tmp_path / "nope.yaml")


def test_suite_error_is_a_value_error():
    assert issubclass(SuiteError, ValueError)


# ---------------------------------------------------------------- variants and sweeps


def test_labelled_variants_of_one_algorithm(tmp_path):
    raw = base() | {
        "algorithms": [
            "ifo",
            {"algorithm": "ifo", "label": "ifo-unnormalized", "normalize": False},
        ]
    }
    specs = list(load_suite(write(tmp_path, raw)).trials)
    shown = {s.shown for s in specs}
    assert shown == {"ifo", "ifo-unnormalized"}
    variant = next(s for s in specs if s.label == "ifo-unnormalized")
    assert variant.algorithm == "ifo" and variant.hyperparams["normalize"] is False
    plain = next(s for s in specs if s.label is None)
    assert '"label"' not in plain.identity()  # a label names a trial; it does not decide it
    assert len({s.trial_id for s in specs}) == len(specs)
    assert {s.shown for s in select(specs, "x", algorithm=["ifo-unnormalized"])} == {
        "ifo-unnormalized"
    }
    assert {s.shown for s in select(specs, "x", algorithm=["ifo"])} == shown  # all variants


def test_a_list_sweeps_and_labels_say_the_values(tmp_path, monkeypatch):
    @dataclass
    class NetConfig:
        hidden: tuple = (64, 64)
        lr: float = 1e-3

    registry.register("net", config=NetConfig, inputs="states")(_train)
    raw = base() | {
        "algorithms": [
            {"net": {"hidden": [32, 32]}},  # one value of a list-valued field
            {"algorithm": "net", "label": "grid", "lr": [0.001, 0.01], "hidden": [[8], [16]]},
        ]
    }
    suite = load_suite(write(tmp_path, raw))
    entries = suite.algorithms
    assert [e.shown for e in entries] == [
        "net",
        "grid-lr=0.001-hidden=[8]",
        "grid-lr=0.001-hidden=[16]",
        "grid-lr=0.01-hidden=[8]",
        "grid-lr=0.01-hidden=[16]",
    ]
    resolved = {s.shown: s.hyperparams for s in suite.trials}
    assert resolved["net"]["hidden"] == [32, 32]
    assert resolved["grid-lr=0.01-hidden=[16]"] == {"hidden": [16], "lr": 0.01}


@pytest.mark.parametrize(
    "entries, message",
    [
        (["ifo", {"ifo": {"lr": 0.1}}], "'ifo' appears twice; give each variant its own label"),
        (
            [{"algorithm": "ifo", "label": "a", "lr": [0.1, 0.1]}],
            "algorithms[0].lr: expected distinct values to sweep",
        ),
        (
            [{"algorithm": "ifo", "label": "ifo-lr=0.1"}, {"ifo": {"lr": [0.1, 0.2]}}],
            "'ifo-lr=0.1' appears twice",
        ),
        (
            [{"algorithm": "ifo", "label": "random"}],
            "algorithms[0].label: 'random' is an algorithm",
        ),
        ([{"algorithm": "ifo", "label": "a b"}], "algorithms[0].label: expected a name"),
        ([{"algorithm": "nope", "label": "a"}], "algorithms[0]: unknown algorithm"),
        (
            [{"algorithm": "ifo", "label": "a", "lr": ["x"]}],
            "algorithms[0].ifo.lr: expected a number",
        ),
    ],
)
def test_bad_variants_are_one_line_errors(tmp_path, entries, message):
    with pytest.raises(SuiteError) as err:
        load_suite(write(tmp_path, base() | {"algorithms": entries}))
    assert message in str(err.value) and "\n" not in str(err.value)


def test_an_entry_may_run_fewer_seeds(tmp_path):
    raw = base() | {"algorithms": ["random", {"algorithm": "ifo", "seeds": 2}, "with-actions"]}
    specs = list(load_suite(write(tmp_path, raw)).trials)
    seeds = {a: sorted({s.seed for s in specs if s.algorithm == a}) for a in ("ifo", "random")}
    assert seeds == {"ifo": [0, 1], "random": [0, 1, 2]}
    bad = base() | {"algorithms": [{"algorithm": "ifo", "seeds": 0}]}
    with pytest.raises(SuiteError, match=r"algorithms\[0\]\.seeds: expected a seed count"):
        load_suite(write(tmp_path, bad))


def test_an_env_may_run_other_seeds_per_algorithm(tmp_path):
    entries = ["random", {"algorithm": "ifo", "seeds": 2}, "with-actions"]
    raw = base() | {"name": "t", "algorithms": entries}
    plain = {s.trial_id for s in list(load_suite(write(tmp_path, raw)).trials)}
    raw["envs"][HOPPER]["seeds"] = {"ifo": 1, "random": [4, 7]}
    specs = list(load_suite(write(tmp_path, raw, "s.yaml")).trials)
    seeds = {
        (s.env_id, s.algorithm): sorted(
            {t.seed for t in specs if (t.env_id, t.algorithm) == (s.env_id, s.algorithm)}
        )
        for s in specs
    }
    assert seeds[HOPPER, "ifo"] == [0] and seeds[HOPPER, "random"] == [4, 7]
    assert seeds[HOPPER, "with-actions"] == [0, 1, 2]  # the suite's, as before
    assert seeds[PENDULUM, "ifo"] == [0, 1] and seeds[PENDULUM, "random"] == [0, 1, 2]
    assert {s.trial_id for s in specs if s.seed in (0, 1)} <= plain  # the same trials keep ids
    raw["envs"][HOPPER]["seeds"] = {"ifo": 0}  # not on this env
    specs = list(load_suite(write(tmp_path, raw, "n.yaml")).trials)
    assert {s.env_id for s in specs if s.algorithm == "ifo"} == {PENDULUM}
    raw["envs"][HOPPER]["seeds"] = {"ifo": -1}
    with pytest.raises(SuiteError, match=r"envs\.HopperBulletEnv-v0\.seeds\.ifo: expected"):
        load_suite(write(tmp_path, raw, "neg.yaml"))
    raw["envs"][HOPPER]["seeds"] = {"ifoo": 1}
    with pytest.raises(
        SuiteError, match=r"envs\.HopperBulletEnv-v0\.seeds: 'ifoo' is no algorithm"
    ):
        load_suite(write(tmp_path, raw, "bad.yaml"))


def test_a_pixel_env_marks_its_trials_and_keeps_state_trial_ids(tmp_path):
    raw = base() | {"name": "s", "algorithms": ["random", "expert"]}
    states = list(load_suite(write(tmp_path, raw)).trials)
    _set(raw, ("envs", PENDULUM, "observation"), "pixels")  # the expert acts on states there too
    pixels = list(load_suite(write(tmp_path, raw, "p.yaml")).trials)
    seen = {(s.env_id, s.observation) for s in pixels}
    assert seen == {(PENDULUM, "pixels"), (HOPPER, None)}
    state_ids = {s.trial_id for s in states}
    assert all((s.trial_id in state_ids) == (s.env_id == HOPPER) for s in pixels)
    _set(raw, ("envs", PENDULUM, "frame_size"), 32)  # another kind of trial: other ids
    small = list(load_suite(write(tmp_path, raw, "q.yaml")).trials)
    assert {s.frame_size for s in small if s.env_id == PENDULUM} == {32}
    assert not {s.trial_id for s in small if s.env_id == PENDULUM} & {s.trial_id for s in pixels}


def _learners_with_an_own_variant(**own) -> dict:
    """A suite of a reference, two learners, and a TRPO learner's variant labelled "own" with
    its own settings."""
    variant = {"algorithm": "trpo-ifo", "label": "own", **own}
    return base() | {"name": "s", "algorithms": ["random", "ifo", "trpo-ifo", variant]}


def test_an_envs_trpo_settings_reach_every_trpo_learner_there_and_no_other(tmp_path):
    raw = _learners_with_an_own_variant(n_envs=4)
    plain = {s.trial_id for s in list(load_suite(write(tmp_path, raw)).trials)}
    _set(raw, ("envs", PENDULUM, "trpo"), {"n_envs": 16, "gamma": 0.995})
    specs = list(load_suite(write(tmp_path, raw, "t.yaml")).trials)
    for spec in specs:
        changed = spec.env_id == PENDULUM and spec.algorithm == "trpo-ifo"
        assert (spec.trial_id not in plain) == changed  # everything else keeps its id
        if changed:  # the env's settings go under the entry's own, and the rest stay resolved
            want = (4 if spec.label == "own" else 16, 0.995, 1e-3)
            got = (
                spec.hyperparams["n_envs"],
                spec.hyperparams["gamma"],
                spec.hyperparams["disc_lr"],
            )
            assert got == want


def test_an_envs_hyperparams_reach_every_algorithm_that_has_them_there_and_no_other(tmp_path):
    raw = _learners_with_an_own_variant(disc_lr=4e-4)
    plain = {s.trial_id for s in list(load_suite(write(tmp_path, raw)).trials)}
    _set(raw, ("envs", PENDULUM, "trpo"), {"n_envs": 16})
    _set(raw, ("envs", PENDULUM, "hyperparams"), {"disc_lr": 0.01, "steps": 3})
    specs = list(load_suite(write(tmp_path, raw, "h.yaml")).trials)
    for spec in specs:
        changed = spec.env_id == PENDULUM and spec.algorithm in ("ifo", "trpo-ifo")
        assert (spec.trial_id not in plain) == changed  # everything else keeps its id
        if not changed:
            continue
        if spec.algorithm == "ifo":  # its own setting; disc_lr is not one of ifo's
            assert (spec.hyperparams["steps"], spec.hyperparams["lr"]) == (3, 1e-3)
            assert "disc_lr" not in spec.hyperparams
        else:  # the env's hyperparams over its trpo settings, under the entry's own
            want = (4e-4 if spec.label == "own" else 0.01, 16)
            assert (spec.hyperparams["disc_lr"], spec.hyperparams["n_envs"]) == want


def test_a_trials_id_is_what_decides_it_not_the_suite_or_label_that_asks_for_it(tmp_path):
    raw = base() | {"name": "one"}
    one = list(load_suite(write(tmp_path, raw)).trials)
    mine = {"algorithm": "ifo", "label": "mine", "lr": 0.01}
    renamed = raw | {"name": "two", "algorithms": ["random", "expert", mine, "with-actions"]}
    two = list(load_suite(write(tmp_path, renamed, "two.yaml")).trials)
    assert [s.trial_id for s in one] == [s.trial_id for s in two]
    assert {s.suite for s in two} == {"two"} and "mine" in {s.label for s in two}
    raw["algorithms"][2] = {"ifo": {"lr": 0.02}}
    changed = list(load_suite(write(tmp_path, raw, "three.yaml")).trials)
    ids = {s.trial_id for s in one}
    assert [s.trial_id in ids for s in changed] == [s.algorithm != "ifo" for s in changed]


def test_curve_points_sets_the_curves_resolution(tmp_path):
    raw = base() | {"name": "s"}
    plain = list(load_suite(write(tmp_path, raw)).trials)
    assert {s.curve_points for s in plain} == {CURVE_POINTS}
    spelled = list(
        load_suite(write(tmp_path, raw | {"curve_points": CURVE_POINTS}, "d.yaml")).trials
    )
    assert [s.trial_id for s in spelled] == [s.trial_id for s in plain]
    fewer = list(load_suite(write(tmp_path, raw | {"curve_points": 3}, "f.yaml")).trials)
    assert {s.curve_points for s in fewer} == {3}
    assert not {s.trial_id for s in fewer} & {s.trial_id for s in plain}  # other records


def test_a_settings_file_is_shared_and_a_suites_own_settings_win(tmp_path):
    """Tuned settings live in one file that suites name: each env it lists gets them, under the
    suite's own; the trials are those the settings written into the suite would give."""
    (tmp_path / "settings").mkdir()
    tuned = {PENDULUM: {"trpo": {"n_envs": 16}, "hyperparams": {"steps": 3}}, "Other-v0": {}}
    (tmp_path / "settings" / "tuned.yaml").write_text(yaml.safe_dump(tuned))
    inline = _learners_with_an_own_variant(n_envs=4)
    _set(inline, ("envs", PENDULUM, "trpo"), {"n_envs": 16, "gamma": 0.995})
    _set(inline, ("envs", PENDULUM, "hyperparams"), {"steps": 3})
    shared = _learners_with_an_own_variant(n_envs=4) | {"settings": "settings/tuned.yaml"}
    _set(shared, ("envs", PENDULUM, "trpo"), {"gamma": 0.995})
    one = load_suite(write(tmp_path, inline, "inline.yaml")).trials
    two = load_suite(write(tmp_path, shared, "shared.yaml")).trials
    assert [s.trial_id for s in one] == [s.trial_id for s in two]
    by_label = {s.shown: s.hyperparams for s in two if s.env_id == PENDULUM}
    assert by_label["own"]["n_envs"] == 4 and by_label["trpo-ifo"]["n_envs"] == 16
    assert by_label["ifo"]["steps"] == 3


def test_a_settings_files_setting_no_learner_of_the_suite_has_goes_unused(tmp_path):
    """A settings file serves many suites: a screen of the controls alone runs on a task whose
    entry also tunes the discriminator. The suite's own setting no algorithm has is refused."""
    (tmp_path / "tuned.yaml").write_text(yaml.safe_dump({PENDULUM: {"hyperparams": {"steps": 3}}}))
    controls = base() | {"algorithms": ["random", "expert", "trpo-ifo"]}
    plain = load_suite(write(tmp_path, controls, "plain.yaml")).trials
    tuned = load_suite(write(tmp_path, controls | {"settings": "tuned.yaml"}, "t.yaml")).trials
    assert [s.trial_id for s in tuned] == [s.trial_id for s in plain]
    _set(controls, ("envs", PENDULUM, "hyperparams"), {"steps": 3})
    with pytest.raises(SuiteError, match="no algorithm of the suite has this setting"):
        load_suite(write(tmp_path, controls, "own.yaml"))


@pytest.mark.parametrize(
    ("tuned", "expected"),
    [
        (None, "no such settings file"),
        ("[1, 2]", "expected a mapping of env ids"),
        (f"{PENDULUM}: {{trpo: {{n_env: 16}}}}", f"{PENDULUM}.trpo.n_env: not a TRPO setting"),
        (f"{PENDULUM}: {{budget: 5}}", f"{PENDULUM}.budget: unknown key"),
        (f"{PENDULUM}: {{trpo: {{gamma: 2.0}}}}", f"{PENDULUM}.trpo"),
        (
            f"{PENDULUM}: {{hyperparams: {{stepz: 3}}}}",
            f"{PENDULUM}.hyperparams.stepz: no registered algorithm has this setting",
        ),
    ],
)
def test_a_bad_settings_file_is_one_line(tmp_path, tuned, expected):
    if tuned is not None:
        (tmp_path / "tuned.yaml").write_text(tuned)
    path = write(tmp_path, base() | {"settings": "tuned.yaml"}, "s.yaml")
    with pytest.raises(SuiteError) as error:
        load_suite(path)
    message = str(error.value)
    assert expected in message and "\n" not in message, message


def test_yaml_merge_keys_share_settings_and_a_key_beside_one_overrides_it(tmp_path):
    text = (
        f"envs:\n  {PENDULUM}: &base {{budget: 1000}}\n  {HOPPER}: {{<<: *base, budget: 2000}}\n"
        "demos: [1]\nalgorithms: [random]\nseeds: 1\n"
    )
    suite = load_suite(write(tmp_path, text))
    assert [(e.env_id, e.budget) for e in suite.envs] == [(PENDULUM, 1000), (HOPPER, 2000)]
