"""The harness trusts no learner: a policy's actions are checked (shape, finite values) and so
is what a learner spent (env steps within its budget); a violation is that trial's failure,
with a message that says which."""

import dataclasses

import numpy as np
import pytest

from bench.harness import registry
from bench.harness.trial import plan, run_trial
from bench.harness.types import TrialSpec

PENDULUM = "InvertedPendulumBulletEnv-v0"


@dataclasses.dataclass
class NoConfig:
    pass


def wrong_shape(task, demos, budget, seed, logger, config):
    return lambda obs: np.zeros((len(obs), task.act_dim + 1), np.float32)


def not_finite(task, demos, budget, seed, logger, config):
    return lambda obs: np.full((len(obs), task.act_dim), np.nan, np.float32)


def no_policy(task, demos, budget, seed, logger, config):
    pass  # trained, and forgot to return what it trained


def over_budget(task, demos, budget, seed, logger, config):
    env = task.make_env(seed)
    try:
        for _ in range(budget + 10):
            env.step(env.action_space.sample())
    except Exception:  # the budget's error, swallowed
        pass
    return lambda obs: np.zeros((len(obs), task.act_dim), np.float32)


@pytest.mark.parametrize(
    ("train", "message"),
    [
        (wrong_shape, "the policy returned actions of shape (2, 2) for 2 observations"),
        (not_finite, "the policy returned non-finite actions"),
        (no_policy, "rule-breaker's train returned NoneType, not a policy"),
        (over_budget, "more than its budget of 500"),
    ],
)
def test_a_policy_or_a_learner_that_breaks_the_rules_fails_its_trial(monkeypatch, train, message):
    monkeypatch.setattr(registry, "_ALGORITHMS", dict(registry.all_algorithms()))
    registry.register("rule-breaker", config=NoConfig, inputs="none")(train)
    spec = TrialSpec("t", PENDULUM, "rule-breaker", 0, 0, 500, 2)
    result = run_trial(spec, plan(spec).inputs())
    assert result.status == "failed" and message in result.traceback, result.traceback
