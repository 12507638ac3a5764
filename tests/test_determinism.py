"""One machine, one record: a trial of each optimizer family on both simulators computes the
same record to the bit whatever path runs it: beside another trial in two loky workers, or on
dask's. (Paused and resumed trials: test_snapshots; one job and two: test_runner.)"""

import pytest

from bench.harness import store
from bench.harness.runner import run_suite
from bench.harness.suite import load_suite

pytestmark = pytest.mark.usefixtures("demo_cache")

OFF_POLICY = "hidden: [16, 16], learning_starts: 300, batch_size: 32"
ALGORITHMS = (
    "[{gaifo: {hidden: [16, 16], n_envs: 2, steps_per_env: 128, disc_hidden: [16, 16]}},"
    f" {{gaifo-sac: {{{OFF_POLICY}}}}},"
    f" {{opolo: {{{OFF_POLICY}, disc_hidden: [16, 16], inverse_pretrain: 20, train_every: 100}}}},"
    " {bco: {pre_demo_steps: 500, alpha: 0.5, n_envs: 2, inverse_steps: 20,"
    " inverse_refit_steps: 10, bc_steps: 20, inverse_hidden: [16, 16], policy_hidden: [16, 16]}}]"
)


def _records(folder) -> dict:
    """Each record as the trial computed it: all but the seconds it took."""
    return {
        r.trial_id: (
            r.returns,
            r.curve,
            r.env_steps,
            {k: v for k, v in r.logs.items() if not k.endswith("_s")},
        )
        for r in store.scan(folder)
    }


@pytest.mark.slow
def test_every_path_computes_the_same_records(tmp_path, on_dask):
    suite = tmp_path / "d.yaml"
    suite.write_text(
        "name: d\nenvs:\n  InvertedPendulum-v5: {budget: 800}\n"
        "  InvertedPendulumBulletEnv-v0: {budget: 800}\n"
        f"demos: [1]\nalgorithms: {ALGORITHMS}\nseeds: 1\neval_episodes: 2\ncurve_points: 2\n"
    )
    specs = list(load_suite(suite).trials)
    assert {s.algorithm for s in specs} == {"gaifo", "gaifo-sac", "opolo", "bco"} and len(
        specs
    ) == 8
    # Under parents of their own: a run links what a folder beside it has finished.
    summary = run_suite(specs, tmp_path / "loky" / "r", jobs=2, progress=False)
    assert summary.done == len(specs), summary
    assert on_dask(specs, tmp_path / "dask" / "r", workers=2).done == len(specs)
    loky = _records(tmp_path / "loky" / "r")
    assert len(loky) == len(specs)
    assert _records(tmp_path / "dask" / "r") == loky
