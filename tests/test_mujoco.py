"""The paper's tasks on MuJoCo (gymnasium v5) work wherever a PyBullet id does: every
algorithm and control trains on one through the runner, its records say which simulator they
ran on, and `bench video` films it where MuJoCo can render."""

import numpy as np
import pytest

from bench import envs
from bench.envs.pixels import PixelConfig
from bench.harness import registry, store
from bench.harness.runner import run_suite
from bench.harness.suite import load_suite

PENDULUM_V5 = "InvertedPendulum-v5"
TINY_TRPO = "n_envs: 2, steps_per_env: 250"
TINY_SAC = "learning_starts: 1500, batch_size: 64, hidden: [32, 32]"  # 500 updates
SUITE = f"""
name: mujoco-tiny
envs:
  {PENDULUM_V5}: {{budget: 2000}}
demos: [2]
algorithms:
  - random
  - expert
  - {{algorithm: gaifo, {TINY_TRPO}, disc_minibatch: 64}}
  - {{algorithm: gail, {TINY_TRPO}, disc_minibatch: 64}}
  - {{algorithm: bco, pre_demo_steps: 1000, n_envs: 2, inverse_steps: 30, alpha: 0.5,
      inverse_refit_steps: 10, bc_steps: 20, minibatch: 64}}
  - {{algorithm: tcn, {TINY_TRPO}, embed_steps: 20, embed_minibatch: 32}}
  - {{algorithm: airlfo, {TINY_TRPO}, disc_minibatch: 64}}
  - {{algorithm: wailfo, {TINY_TRPO}, disc_minibatch: 64}}
  - {{algorithm: pwil, {TINY_TRPO}}}
  - {{algorithm: survival, {TINY_TRPO}}}
  - {{algorithm: oracle, {TINY_TRPO}}}
  - {{algorithm: gaifo-sac, {TINY_SAC}}}
  - {{algorithm: gail-sac, {TINY_SAC}}}
  - {{algorithm: survival-sac, {TINY_SAC}}}
  - {{algorithm: oracle-sac, {TINY_SAC}}}
  - {{algorithm: opolo, {TINY_SAC}, train_every: 200, inverse_pretrain: 50, disc_steps: 2}}
  - {{algorithm: survival-td3, {TINY_SAC}}}
  - {{algorithm: oracle-td3, {TINY_SAC}}}
seeds: [0]
eval_episodes: 2
curve_points: 3
"""


@pytest.fixture(scope="module")
def finished(tmp_path_factory, module_cache):
    root = tmp_path_factory.mktemp("mujoco")
    (root / "s.yaml").write_text(SUITE)
    specs = list(load_suite(root / "s.yaml").trials)
    summary = run_suite(specs, root / "res", jobs=2, progress=False)
    return specs, root / "res", summary


@pytest.mark.slow
def test_every_algorithm_and_control_trains_on_a_mujoco_task(finished):
    specs, results, summary = finished
    assert summary.failed == 0 and summary.done == len(specs)
    records = list(store.scan(results))
    built_in = {
        n
        for n, a in registry.all_algorithms().items()
        if a.train.__module__.startswith("algorithms.")
    }
    assert {r.spec.algorithm for r in records} == built_in
    for record in records:
        assert np.all(np.isfinite(record.returns)), record.spec.algorithm
        assert record.env_steps <= record.spec.budget
        assert "mujoco" in record.versions and "pybullet" not in record.versions
    expert = next(r for r in records if r.spec.algorithm == "expert")
    assert np.mean(expert.returns) == 1000  # the shipped expert balances to the time limit


def can_render(env_id: str) -> str | None:
    """Why MuJoCo cannot render here, or None where it can."""
    try:
        env = envs.make(env_id, 0, PixelConfig(size=16, stack=1))
        env.close()
    except Exception as e:  # no EGL, no OSMesa: whatever the GL stack raises
        return f"{type(e).__name__}: {e}"
    return None


@pytest.mark.slow
def test_a_video_of_a_mujoco_task(finished, tmp_path, cli):
    reason = can_render(PENDULUM_V5)
    if reason is not None:
        pytest.skip(f"MuJoCo cannot render here ({reason})")
    import imageio.v3 as iio

    _, results, _ = finished
    out = cli(
        "video",
        str(results),
        "--out",
        str(tmp_path / "v.gif"),
        "--steps",
        "10",
        "--size",
        "48",
        "--algorithm",
        "gaifo",
    )
    assert out.returncode == 0, out.stderr
    frames = iio.imread(tmp_path / "v.gif")
    assert frames.shape[0] == 11 and frames.shape[2] == 48 * 2  # the expert beside GAIfO
    assert frames.std() > 0


def test_pybullet_is_only_imported_for_a_pybullet_id(tmp_path):
    """A MuJoCo trial's process never imports PyBullet, so the package runs where PyBullet has
    no wheels; and MuJoCo's notes on gymnasium's models (Ant's) neither print nor leave a
    MUJOCO_LOG.TXT in the working folder."""
    import subprocess
    import sys

    code = (
        "import sys; from bench import envs; envs.check_env_id('Ant-v5');"
        " e = envs.make('Ant-v5', 0); e.step(e.action_space.sample());"
        " print('pybullet' in sys.modules, 'pybullet_envs_gymnasium' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["False", "False"]
    assert out.stderr == ""
    assert not list(tmp_path.iterdir())  # no MUJOCO_LOG.TXT
