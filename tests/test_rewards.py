"""One reward signature for both optimizers: a function of transitions, handed to TRPO's loop
by `on_trpo` and to SAC's by `on_sac`, checked against values worked out by hand on a real
env's batch, and trained on by both optimizers through the runner."""

import dataclasses

import numpy as np
import pytest
import torch

from algorithms.offpolicy import OffPolicyConfig, sac_budget, train_on_reward
from bench import envs
from bench.harness import registry
from bench.harness.learners import ImitationTRPOConfig, one_batch, trpo_on_reward
from bench.harness.trial import plan, run_trial
from bench.harness.types import TrialSpec
from bench.imitation.rewards import on_sac, on_trpo
from bench.rl import replay
from bench.rl.absorbing import Transitions
from bench.rl.rollout import VecCollector

PENDULUM = "InvertedPendulumBulletEnv-v0"
GAMMA = 0.9


def first_coordinate(x: Transitions) -> torch.Tensor:
    """A reward anyone can check by hand: s'[0] where s' is real, -1 for the absorbing state."""
    return torch.where(x.next_absorbing, -1.0, x.next_obs[:, 0].float())


def test_on_trpo_pays_each_step_and_values_each_termination_by_hand():
    collector = VecCollector([envs.make(PENDULUM, i) for i in range(2)], 0)
    rng = np.random.default_rng(0)
    batch = collector.run(lambda obs: rng.uniform(-1, 1, (len(obs), 1)).astype(np.float32), 60)
    collector.close()
    assert batch.terminated.sum() >= 2  # random actions drop the pole within 60 steps
    low, high = collector.low, collector.high
    rewards = on_trpo(first_coordinate, low, high, GAMMA)(batch)
    assert np.array_equal(rewards.per_step, batch.next_obs[..., 0].astype(np.float32))
    # The tail of a terminated step: (s_T, 0, s_a) into the absorbing state once (-1), then the
    # loop (-1) for ever: -1 - GAMMA / (1 - GAMMA).
    ended = batch.terminated
    assert np.allclose(rewards.after_termination[ended], -1 - GAMMA / (1 - GAMMA))
    assert np.all(rewards.after_termination[~ended] == 0)


def test_on_sac_pays_each_replay_row_with_the_absorbing_state_flagged():
    obs = np.array([[0.5, 1.0], [0.25, 2.0]], np.float32)
    next_obs = np.array([[0.75, 1.0], [0.125, 2.0]], np.float32)
    actions = np.zeros((2, 1), np.float32)
    rows = replay.transitions_of_step(
        obs, actions, next_obs, np.zeros(2), np.array([False, True]), True
    )
    batch = replay.ReplayBatch(*(torch.from_numpy(x) for x in rows))
    got = on_sac(first_coordinate)(batch)
    # the live step, the terminated one (into the absorbing state), the absorbing loop
    assert got.tolist() == [0.75, -1.0, -1.0]


@dataclasses.dataclass
class OnTRPO(ImitationTRPOConfig):
    n_envs: int = 2
    steps_per_env: int = 128


@dataclasses.dataclass
class OnSAC(OffPolicyConfig):
    hidden: tuple[int, ...] = (16, 16)
    learning_starts: int = 200
    batch_size: int = 32


def one_reward_two_optimizers(monkeypatch) -> dict[str, list[type]]:
    """Two plugins, one reward (the distance to the nearest demonstrated state): one trains
    TRPO on it, one SAC. Returns what each reward call was handed, by plugin."""
    seen: dict[str, list[type]] = {"trpo": [], "sac": []}

    def nearest(demos, family):
        expert = torch.from_numpy(np.concatenate(demos.observations))

        def reward(x: Transitions) -> torch.Tensor:
            seen[family].append(type(x))
            dist = torch.cdist(x.next_obs.float(), expert).min(1).values
            return torch.where(x.next_absorbing, -dist.max(), -dist)

        return reward

    def on_trpo_plugin(task, demos, budget, seed, logger, config):
        reward = on_trpo(nearest(demos, "trpo"), task.action_low, task.action_high, config.gamma)
        return trpo_on_reward(task, budget, seed, logger, config, reward)

    def on_sac_plugin(task, demos, budget, seed, logger, config):
        return train_on_reward(task, budget, seed, logger, config, on_sac(nearest(demos, "sac")))

    monkeypatch.setattr(registry, "_ALGORITHMS", dict(registry.all_algorithms()))
    registry.register("near-trpo", config=OnTRPO, inputs="states", min_budget=one_batch)(
        on_trpo_plugin
    )
    registry.register("near-sac", config=OnSAC, inputs="states", min_budget=sac_budget)(
        on_sac_plugin
    )
    return seen


@pytest.mark.usefixtures("demo_cache")
def test_one_transition_reward_trains_both_optimizers_through_the_runner(monkeypatch):
    seen = one_reward_two_optimizers(monkeypatch)
    for name, budget in (("near-trpo", 1024), ("near-sac", 600)):
        spec = TrialSpec("t", PENDULUM, name, 1, 0, budget, 2)
        result = run_trial(spec, plan(spec).inputs())
        assert result.status == "ok", result.traceback
        assert result.env_steps == budget and np.all(np.isfinite(result.returns))
    assert seen["trpo"] and seen["sac"]
    assert set(seen["trpo"]) == set(seen["sac"]) == {Transitions}
