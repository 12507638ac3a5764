"""The harness trusts no learner: a policy's actions are checked (shape, finite values) and so
is what a learner spent (env steps within its budget); a violation is that trial's failure,
with a message that says which."""

import dataclasses

import numpy as np
import pytest

from bench.harness import registry, trial_log
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


def chatty(task, demos, budget, seed, logger, config):
    env = task.make_env(seed)
    env.reset(seed=seed)
    for step in range(1, budget + 1):  # a scalar logged every env step
        env.step(env.action_space.sample())
        logger.log(step, reward=0.5, other=1.0)
    return lambda obs: np.zeros((len(obs), task.act_dim), np.float32)


def test_a_learner_that_logs_every_step_leaves_a_record_of_bounded_size(monkeypatch):
    """Kept whole, a log call per env step of a long trial writes a record too large to read
    back; past 2 x MAX_LOGGED calls every other one is kept, evenly over the trial."""
    monkeypatch.setattr(registry, "_ALGORITHMS", dict(registry.all_algorithms()))
    monkeypatch.setattr(trial_log, "MAX_LOGGED", 20)
    registry.register("chatty", config=NoConfig, inputs="none")(chatty)
    spec = TrialSpec("t", PENDULUM, "chatty", 0, 0, 500, 2)
    result = run_trial(spec, plan(spec).inputs())
    assert result.status == "ok", result.traceback
    steps = result.logs["env_steps"]
    assert 20 <= len(steps) < 40 and len(result.logs["reward"]) == len(steps)
    assert steps[0] == 1 and len(set(np.diff(steps))) == 1 and steps[-1] > 500 - 32  # even


def test_thinned_logs_go_on_alike_from_the_state_a_snapshot_keeps(monkeypatch):
    monkeypatch.setattr(trial_log, "MAX_LOGGED", 5)
    one_go, first = (trial_log.TrialLogger([], 0, 1) for _ in range(2))
    for step in range(100):
        one_go.log(step, x=step)
        if step < 57:
            first.log(step, x=step)
    resumed = trial_log.TrialLogger([], 0, 1)  # what a snapshot's load sets
    resumed.logs, resumed.log_calls, resumed.log_stride = (
        first.logs,
        first.log_calls,
        first.log_stride,
    )
    for step in range(57, 100):
        resumed.log(step, x=step)
    assert resumed.logs == one_go.logs and len(one_go.logs["x"]) < 10


@pytest.mark.parametrize("name", ["", "my method", "a/b", "-x", "név"])
def test_a_name_a_suite_could_not_name_or_a_folder_not_hold_is_refused(monkeypatch, name):
    monkeypatch.setattr(registry, "_ALGORITHMS", dict(registry.all_algorithms()))
    with pytest.raises(ValueError, match="letters, digits and"):
        registry.register(name, config=NoConfig, inputs="none")(wrong_shape)
