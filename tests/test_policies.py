"""Each trial's final policy is kept beside its record and acts as it did when evaluated."""

import pytest
import torch

from bench.harness import policies, store
from bench.harness.runner import run_suite
from bench.harness.suite import load_suite
from bench.harness.trial import EVAL_SEED, plan
from bench.rl.rollout import evaluate

PENDULUM = "InvertedPendulumBulletEnv-v0"

pytestmark = [pytest.mark.usefixtures("demo_cache"), pytest.mark.slow]


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    root = tmp_path_factory.mktemp("policies")
    tiny = "{n_envs: 2, steps_per_env: 512}"
    (root / "s.yaml").write_text(
        f"name: keep\nenvs: {{{PENDULUM}: {{budget: 2048}}}}\ndemos: [1]\n"
        f"algorithms: [random, expert, gaifo: {tiny}, survival: {tiny}, bco: {{pre_demo_steps: 512,"
        " inverse_steps: 20, inverse_refit_steps: 10, bc_steps: 20}]\nseeds: 2\neval_episodes: 3\n"
    )
    specs = list(load_suite(root / "s.yaml").trials)
    summary = run_suite(specs, root / "res", jobs=2, progress=False, tensorboard=root / "tb")
    assert summary.failed == 0
    return specs, root


def test_a_saved_policy_reproduces_its_records_evaluation(finished):
    specs, root = finished
    learners = [s for s in specs if s.algorithm not in ("random", "expert")]
    assert not any(
        policies.path(root / "res", s.trial_id).exists() for s in specs if s not in learners
    )
    for spec in learners:
        record = store.read(store.record_path(root / "res", spec.trial_id))
        file = policies.path(root / "res", spec.trial_id)
        assert torch.load(file, weights_only=True)["obs_shape"] == [5]
        policy = policies.load(file)
        seed = EVAL_SEED + 1000 * spec.seed
        envs = [plan(spec).make_env(seed + i, training=False) for i in range(spec.eval_episodes)]
        assert evaluate(policy, envs, spec.eval_episodes, seed) == record.returns, spec.algorithm
        for env in envs:
            env.close()


def test_a_linked_record_finds_its_policy_where_it_ran(finished):
    specs, root = finished
    (root / "t.yaml").write_text((root / "s.yaml").read_text().replace("name: keep", "name: other"))
    others = list(load_suite(root / "t.yaml").trials)
    summary = run_suite(others, root / "copy", jobs=1, progress=False, priced_by=root)
    assert summary.linked == len(others) and summary.done == 0
    for theirs in others:
        record = store.read(store.record_path(root / "copy", theirs.trial_id))
        assert record.stored_in == str(root / "res") and record.spec.suite == "other"
        saved = policies.path(record.stored_in, theirs.trial_id)
        assert saved.exists() == (theirs.algorithm not in ("random", "expert"))
        assert not policies.path(root / "copy", theirs.trial_id).exists()  # one file, not two


def test_a_video_has_a_panel_per_policy_and_a_frame_per_step(finished, tmp_path, cli):
    import imageio.v3 as iio

    _, root = finished
    out = cli(
        "video",
        str(root / "res"),
        "--out",
        str(tmp_path / "v.gif"),
        "--steps",
        "20",
        "--size",
        "64",
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.split(": ", 1)[1].split(", ")[0] == "Expert 1.00"
    frames = iio.imread(tmp_path / "v.gif")
    panels = ["Expert", "GAIfO", "BCO", "Survival"]
    assert [t.split()[0] for t in out.stdout.strip().split(": ", 1)[1].split(", ")] == panels
    assert frames.shape[:3] == (21, 64 + 22, 64 * len(panels))  # start state + 20 steps
    assert not (frames[0] == frames[-1]).all()  # the poles moved


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--algorithm", "gail"], "no gail with seed 0"),
        (["--demos", "7"], "no trials with 7 demos"),
        (["--seed", "99"], "no learner's trial of seed 99"),  # not a film of the expert alone
        (["--env", "HopperBulletEnv-v0"], "no trials of HopperBulletEnv-v0"),
        (["--out", "v.png"], "must end in .gif or .mp4"),
        (["--steps", "100000", "--size", "400"], "GiB of frames in memory"),
    ],
)
def test_a_video_of_nothing_is_one_line(finished, tmp_path, bench_here, args, message):
    _, root = finished
    out = bench_here("video", str(root / "res"), "--out", str(tmp_path / "v.gif"), *args)
    assert out.returncode == 2 and message in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1


def test_every_logged_scalar_is_a_tensorboard_event(finished):
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    from bench.harness.trial_log import event_dir

    specs, root = finished
    for spec in specs:
        record = store.read(store.record_path(root / "res", spec.trial_id))
        events = EventAccumulator(str(event_dir(root / "tb", spec)))
        events.Reload()
        tags = set(events.Tags()["scalars"])
        assert {f"train/{k}" for k in record.logs if k != "env_steps"} <= tags, spec.algorithm
        assert "eval/final_return" in tags
        if spec.algorithm == "gaifo":
            assert {"train/disc_acc_expert", "train/kl", "train/vf_loss", "eval/return"} <= tags
            kl = [e.value for e in events.Scalars("train/kl")]
            assert kl == pytest.approx(record.logs["kl"])
