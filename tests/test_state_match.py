"""bench.harness.state_match on hand-computed cases, and the distance a real trial records."""

from __future__ import annotations

import numpy as np
import pytest

from bench.harness import state_match, trial
from bench.harness.types import TrialSpec


def test_identical_samples_are_at_distance_zero():
    states = np.random.default_rng(0).normal(size=(5000, 3))
    assert state_match.state_distance(states, states) == pytest.approx(0.0, abs=1e-12)


def test_a_shift_counts_in_expert_standard_deviations():
    expert = np.random.default_rng(1).normal(size=(20_000, 2)) * [2.0, 0.5]
    # two expert stds along the first dimension, none along the second
    shifted = expert + [4.0, 0.0]
    per_dim = state_match.wasserstein_per_dim(shifted, expert)
    in_stds = 4.0 / expert[:, 0].std()  # ~2: the sample's std, not the generator's
    assert per_dim == pytest.approx([in_stds, 0.0], abs=1e-9)
    assert state_match.state_distance(shifted, expert) == pytest.approx(in_stds / 2, abs=1e-9)


def test_a_dimension_the_expert_holds_still_is_floored():
    expert = np.column_stack([np.linspace(-1, 1, 1001), np.zeros(1001)])
    scale = state_match.expert_scale(expert)
    assert scale[1] == pytest.approx(state_match.SCALE_FLOOR * expert[:, 0].std() / 2)
    moved = expert + [0.0, 1e-3]
    assert state_match.state_distance(moved, expert) < 0.05  # not 1e-3 / 0


def test_states_must_match_the_expert_dimensions():
    with pytest.raises(ValueError, match=r"\(N, O\) states"):
        state_match.state_distance(np.zeros((4, 3)), np.zeros((4, 2)))


@pytest.mark.parametrize("seeds", [(0, 1, 2), (3, 4, 5)])
def test_a_trial_records_how_far_its_states_lie_from_the_experts(seeds):
    """The expert's own evaluation states lie on its pool's; a random policy's do not."""

    def distances(algorithm: str) -> list[float]:
        out = []
        for seed in seeds:
            spec = TrialSpec("t", "InvertedPendulumBulletEnv-v0", algorithm, 0, seed, 1000, 5)
            record = trial.run_trial(spec, trial.plan(spec).inputs())
            assert record.status == "ok", record.traceback
            out.append(record.state_distance)
        return out

    expert, random = distances("expert"), distances("random")
    # measured on seeds 0-5: expert 0.02-0.32, random 5.75-7.67
    assert max(expert) < 1.0 < 3.0 < min(random)
