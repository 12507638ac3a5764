"""Export of the expert pool as a Minari dataset: what Minari reads back is the pool."""

import minari
import numpy as np
import pytest

from bench import cli, demos, minari_io

PENDULUM = "InvertedPendulumBulletEnv-v0"


@pytest.fixture(scope="module")
def exported(module_cache, tmp_path_factory):
    """The pendulum's pool, recorded into a private cache and exported to a private folder."""
    mp = pytest.MonkeyPatch()
    root = tmp_path_factory.mktemp("minari")
    name = minari_io.export(PENDULUM, root, random_return=20.0, expert_return=1000.0)
    mp.setenv("MINARI_DATASETS_PATH", str(root))
    yield minari.load_dataset(name), demos.ensure_pool(PENDULUM)
    mp.undo()


def test_dataset_holds_the_pool(exported):
    dataset, pool_path = exported
    states = demos.load_demos(pool_path, PENDULUM)
    with_actions = demos.load_action_demos(pool_path, PENDULUM)
    episodes = list(dataset.iterate_episodes())
    assert len(episodes) == states.n_episodes == demos.POOL_SIZE
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
