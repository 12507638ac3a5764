"""Export of the expert pool as a Minari dataset: what Minari reads back is the pool."""

import warnings
from pathlib import Path

import minari
import numpy as np
import pytest
from minari.data_collector import EpisodeBuffer

from bench import cli
from bench.demos import minari_io, pools
from bench.harness import store
from bench.harness.suite import load_suite

PENDULUM = "InvertedPendulumBulletEnv-v0"


@pytest.fixture(scope="module")
def exported(module_cache, tmp_path_factory):
    """The pendulum's pool, recorded into a private cache and exported to a private folder."""
    mp = pytest.MonkeyPatch()
    root = tmp_path_factory.mktemp("minari")
    name = minari_io.export(PENDULUM, root, random_return=20.0, expert_return=1000.0)
    mp.setenv("MINARI_DATASETS_PATH", str(root))
    yield minari.load_dataset(name), pools.ensure_pool(PENDULUM)
    mp.undo()


def test_dataset_holds_the_pool(exported):
    dataset, pool_path = exported
    states = pools.load_demos(pool_path, PENDULUM)
    with_actions = pools.load_action_demos(pool_path, PENDULUM)
    episodes = list(dataset.iterate_episodes())
    assert len(episodes) == states.n_episodes == pools.POOL_SIZE
    for ep, obs, act, ended in zip(
        episodes, states.observations, with_actions.actions, states.terminated, strict=True
    ):
        np.testing.assert_array_equal(ep.observations, obs)  # final observation included
        np.testing.assert_array_equal(ep.actions, act)
        assert ep.terminations[-1] == ended and ep.truncations[-1] == (not ended)
        assert not ep.terminations[:-1].any() and not ep.truncations[:-1].any()
    assert dataset.spec.env_spec.id == PENDULUM


def test_minari_normalizes_like_bench(exported):
    dataset, _ = exported
    scores = minari.get_normalized_score(dataset, np.array([20.0, 510.0, 1000.0]))
    np.testing.assert_allclose(scores, [0.0, 0.5, 1.0])


def test_export_refuses_to_overwrite(exported, tmp_path):
    (tmp_path / minari_io.dataset_id(PENDULUM)).mkdir(parents=True)
    with pytest.raises(minari_io.DatasetError, match="already exists"):
        minari_io.export(PENDULUM, tmp_path, 20.0, 1000.0)


def test_cli_without_references_is_one_line_and_writes_nothing(tmp_path, capsys):
    out = tmp_path / "datasets"
    empty = tmp_path / "results"
    empty.mkdir()
    assert cli.main(["demos", "export", PENDULUM, str(out), "--references", str(empty)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "no random and expert trials" in err
    assert not out.exists()


# ---------------------------------------------------------------- import


def write_suite(folder, dataset, algorithms: str, env_id: str = PENDULUM):
    path = folder / "from-dataset.yaml"
    path.write_text(
        f"envs: {{{env_id}: {{budget: 2048, dataset: {dataset}}}}}\n"
        f"demos: [2]\nalgorithms: [{algorithms}]\nseeds: 1\neval_episodes: 2\n"
    )
    return path


def state_only_copy(dataset, root) -> str:
    """The dataset re-written without actions (NaN), as a state-only recording would be."""
    buffers = [
        EpisodeBuffer(
            id=ep.id,
            observations=list(ep.observations),
            actions=list(np.full_like(ep.actions, np.nan)),
            rewards=list(ep.rewards),
            terminations=list(ep.terminations),
            truncations=list(ep.truncations),
        )
        for ep in dataset.iterate_episodes()
    ]
    name = "someone/InvertedPendulumBulletEnv-v0/states-v0"
    with minari_io._datasets_root(root), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        minari.create_dataset_from_buffers(
            dataset_id=name,
            buffer=buffers,
            env=PENDULUM,
            observation_space=dataset.observation_space,
            action_space=dataset.action_space,
        )
    return str(root / name)


def test_import_gives_back_the_exported_demos(exported):
    dataset, pool_path = exported
    imported = minari_io.ensure_pool(dataset.id, PENDULUM)  # by id, from the local root
    for k, seed in ((1, 0), (5, 3)):
        a = pools.load_action_demos(imported, PENDULUM, k, seed)
        b = pools.load_action_demos(pool_path, PENDULUM, k, seed)
        assert a.demos.terminated == b.demos.terminated
        pairs = zip(a.demos.observations + a.actions, b.demos.observations + b.actions, strict=True)
        for x, y in pairs:
            np.testing.assert_array_equal(x, y)


def test_a_trial_runs_from_an_imported_dataset_without_a_shipped_expert(
    exported, tmp_path, monkeypatch
):
    dataset, _ = exported
    folder = str(minari.storage.get_dataset_path(dataset.id))
    monkeypatch.setattr(
        "bench.paths.EXPERTS_DIR", tmp_path / "no-experts"
    )  # the 1.0 is the dataset
    suite = write_suite(tmp_path, folder, "random, expert, gaifo")
    assert cli.main(["run", str(suite), "--results", str(tmp_path / "res"), "--jobs", "1"]) == 0
    records = {r.spec.algorithm: r for r in store.scan(tmp_path / "res")}
    assert {r.status for r in records.values()} == {"ok"}
    assert all(r.spec.dataset == folder for r in records.values())
    expert = records["expert"]
    assert expert.returns == [1000.0] and expert.reference == "dataset ref_max_score"
    assert records["gaifo"].env_steps == 2048


def test_state_only_dataset_serves_ifo_and_refuses_gail(exported, tmp_path, capsys):
    folder = state_only_copy(exported[0], tmp_path / "datasets")
    ok = load_suite(write_suite(tmp_path, folder, "random, expert, gaifo"))
    assert ok.envs[0].dataset == folder
    bad = write_suite(tmp_path, folder, "random, expert, gaifo, gail")
    assert cli.main(["run", str(bad), "--results", str(tmp_path / "res")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "records no actions (NaN), which gail needs" in err
    assert not (tmp_path / "res").exists()


def test_dataset_of_another_env_is_one_line(exported, tmp_path, capsys):
    folder = str(minari.storage.get_dataset_path(exported[0].id))
    suite = write_suite(tmp_path, folder, "random, gaifo", env_id="HopperBulletEnv-v0")
    assert cli.main(["run", str(suite), "--results", str(tmp_path / "res")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and f"was recorded in {PENDULUM}" in err
    assert not (tmp_path / "res").exists()


def test_a_dataset_rewritten_in_place_is_converted_again(exported, tmp_path):
    import shutil

    source = Path(minari.storage.get_dataset_path(exported[0].id))
    folder = tmp_path / "mine"
    shutil.copytree(source, folder)
    before = minari_io.ensure_pool(str(folder), PENDULUM)
    other = Path(state_only_copy(exported[0], tmp_path / "other"))
    shutil.rmtree(folder)
    shutil.copytree(other, folder)  # same place, same episode count, other content
    after = minari_io.ensure_pool(str(folder), PENDULUM)
    assert after != before
    assert (
        np.isnan(np.load(after)["actions"]).all() and not np.isnan(np.load(before)["actions"]).any()
    )


def test_a_truncated_dataset_is_one_line_before_any_trial(exported, tmp_path, capsys):
    import shutil

    folder = tmp_path / "broken"
    shutil.copytree(minari.storage.get_dataset_path(exported[0].id), folder)
    data = next(folder.rglob("*.hdf5"))
    data.write_bytes(data.read_bytes()[: data.stat().st_size // 2])
    suite = write_suite(tmp_path, str(folder), "random, expert, gaifo, gail")
    assert cli.main(["run", str(suite), "--results", str(tmp_path / "res")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and str(folder) in err and "Traceback" not in err
    assert "trials ->" not in err  # found before the run announces its trials
    assert not (tmp_path / "res").exists()  # and before anything is written


# ---------------------------------------------------------------- MuJoCo (gymnasium v5)

PENDULUM_V5 = "InvertedPendulum-v5"


@pytest.fixture(scope="module")
def exported_v5(module_cache, tmp_path_factory):
    """The v5 pendulum's pool (recorded from its shipped expert), exported as a Minari dataset."""
    mp = pytest.MonkeyPatch()
    root = tmp_path_factory.mktemp("minari-v5")
    name = minari_io.export(PENDULUM_V5, root, random_return=5.0, expert_return=1000.0)
    mp.setenv("MINARI_DATASETS_PATH", str(root))
    yield root, minari.load_dataset(name), pools.ensure_pool(PENDULUM_V5)
    mp.undo()


def test_a_mujoco_pool_round_trips_and_minari_normalizes_like_bench(exported_v5):
    _, dataset, pool_path = exported_v5
    assert dataset.spec.env_spec.id == PENDULUM_V5
    scores = minari.get_normalized_score(dataset, np.array([5.0, 502.5, 1000.0]))
    np.testing.assert_allclose(scores, [0.0, 0.5, 1.0])
    imported = minari_io.ensure_pool(dataset.id, PENDULUM_V5)
    a = pools.load_action_demos(imported, PENDULUM_V5, 3, 1)
    b = pools.load_action_demos(pool_path, PENDULUM_V5, 3, 1)
    for x, y in zip(
        a.demos.observations + a.actions, b.demos.observations + b.actions, strict=True
    ):
        np.testing.assert_array_equal(x, y)


def test_minaris_own_mujoco_datasets_load_as_demonstrations(exported_v5, tmp_path):
    """A dataset in the layout of Minari's `mujoco/<task>/expert-v0` (made here from the
    exported episodes: nothing is downloaded) serves a suite by its id, from the local root."""
    root, dataset, _ = exported_v5
    name = "mujoco/invertedpendulum/expert-v0"
    buffers = [
        EpisodeBuffer(
            id=ep.id,
            observations=list(ep.observations),
            actions=list(ep.actions),
            rewards=list(ep.rewards),
            terminations=list(ep.terminations),
            truncations=list(ep.truncations),
        )
        for ep in dataset.iterate_episodes()
    ]
    with minari_io._datasets_root(root), warnings.catch_warnings():
        warnings.simplefilter("ignore")
        minari.create_dataset_from_buffers(
            dataset_id=name,
            buffer=buffers,
            env=PENDULUM_V5,
            observation_space=dataset.observation_space,
            action_space=dataset.action_space,
            ref_min_score=5.0,
            ref_max_score=1000.0,
        )
    pool = minari_io.ensure_pool(name, PENDULUM_V5)
    states = pools.load_demos(pool, PENDULUM_V5, 5, 0)
    assert states.n_episodes == 5 and states.obs_dim == 4
    suite = load_suite(write_suite(tmp_path, name, "random, expert, gaifo", PENDULUM_V5))
    assert {s.dataset for s in suite.trials} == {name}


def test_an_export_cut_off_mid_write_leaves_no_dataset(module_cache, tmp_path, monkeypatch):
    """A dataset appears whole or not at all: an export that dies while Minari writes leaves
    nothing where the dataset goes, and the next export succeeds."""
    real = minari.create_dataset_from_buffers

    def dies_mid_write(*args, **kwargs):
        real(*args, **kwargs)  # everything written, then the process "dies" before it is done
        raise KeyboardInterrupt

    monkeypatch.setattr(minari, "create_dataset_from_buffers", dies_mid_write)
    with pytest.raises(KeyboardInterrupt):
        minari_io.export(PENDULUM, tmp_path, 20.0, 1000.0)
    assert not (tmp_path / minari_io.dataset_id(PENDULUM)).exists()
    assert not list(tmp_path.glob(".export-*"))
    monkeypatch.setattr(minari, "create_dataset_from_buffers", real)
    name = minari_io.export(PENDULUM, tmp_path, 20.0, 1000.0)
    monkeypatch.setenv("MINARI_DATASETS_PATH", str(tmp_path))
    assert minari.load_dataset(name).total_episodes == pools.POOL_SIZE
