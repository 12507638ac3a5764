"""PWIL (Dadashi et al. 2021): primal Wasserstein imitation, state-only. No adversary: each
step's reward is what its state costs in a greedy coupling of the agent's episode with the
expert's states (`bench.imitation.coupling`), r = alpha exp(-sigma cost).

Followed from the paper and its code: expert atoms are the demonstrations' states, each
demonstration subsampled every `subsampling` steps (20) from a random offset, standardized by
the atoms' own mean and spread; each atom of mass 1/N, each agent step 1/T with T the horizon
(the env's time limit); sigma = beta T / sqrt(|S| + |A|) with alpha = beta = 5 (the code's
denominator counts the action's dimensions even state-only, and so does this). The coupling
starts afresh with each episode.

Departures: TRPO with the imitators' settings rather than D4PG, so that PWIL differs from GAIfO
in its reward alone; and the state coupled is the one each step reaches, s', where the authors'
code couples the one it starts from, s: then each step's reward depends on its own action
(TRPO's advantage credits it at once), and an episode's last state is paid too. The reward is positive, as the
paper's: a step alive is always worth more than the end of an episode, which the `survival`
control prices.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import torch

from bench.harness.learners import ImitationTRPOConfig, one_batch, trpo_on_reward
from bench.harness.registry import Logger, Policy, Task, register
from bench.imitation.coupling import couple, standardizer
from bench.imitation.data import Demos
from bench.rl.resume import Stateful
from bench.rl.rollout import Batch, Rewards
from bench.validate import above, at_least


@dataclass
class PWILConfig(ImitationTRPOConfig):
    """The imitators' TRPO settings and PWIL's reward."""

    alpha: float = 5.0
    """Scale of the reward: a step that costs nothing earns alpha."""
    beta: float = 5.0
    """Width of the reward's kernel: sigma = beta T / sqrt(|S| + |A|)."""
    subsampling: int = 20
    """Every this many states of each demonstration is an expert atom (from a random offset)."""
    horizon: int | None = None
    """T, the steps an episode's mass is spread over; None: the env's time limit."""

    def __post_init__(self) -> None:
        super().__post_init__()
        above(self, 0, "alpha", "beta")
        at_least(self, 1, "subsampling", "horizon")


def expert_atoms(demos: Demos, subsampling: int, rng: np.random.Generator) -> np.ndarray:
    """(N, O): the states each demonstration reaches, every `subsampling`-th from a random
    offset."""
    picked = []
    for obs in demos.observations:
        reached = obs[1:]
        offset = int(rng.integers(min(subsampling, len(reached))))
        picked.append(reached[offset::subsampling])
    return np.concatenate(picked).astype(np.float64)


class PWILReward(Stateful):
    """TRPO's reward hook: each env's episode coupled with the expert atoms step by step, the
    mass its atoms still hold carried from batch to batch until the episode ends."""

    def __init__(
        self, atoms: np.ndarray, n_envs: int, horizon: int, sigma: float, alpha: float
    ) -> None:
        """`atoms`: (N, O) expert states (`expert_atoms`), unscaled; `n_envs`: TRPO's envs;
        the reward alpha exp(-sigma cost)."""
        self.mean, self.scale = standardizer(atoms)
        self.atoms = (atoms - self.mean) / self.scale
        self.mass, self.sigma, self.alpha = 1.0 / horizon, sigma, alpha
        self.left = torch.zeros(n_envs, len(atoms), dtype=torch.float64)  # set at each reset

    def parts(self) -> dict[str, Any]:
        return {"left": self.left}

    def __call__(self, batch: Batch) -> Rewards:
        from scipy.spatial.distance import cdist  # here: every trial's worker imports plugins

        states = (batch.flat("next_obs").astype(np.float64) - self.mean) / self.scale
        # Where each state lies from each atom does not depend on what was spent: all at once.
        distances = cdist(states, self.atoms).reshape(*batch.rewards.shape, len(self.atoms))
        left = self.left.numpy()  # the tensor's memory: spent in place, saved with snapshots
        costs = np.empty(batch.rewards.shape)
        for t in range(len(costs)):
            left[batch.timesteps[t] == 0] = 1.0 / len(self.atoms)  # an episode starts
            costs[t] = couple(left, distances[t], self.mass)
        r = self.alpha * np.exp(-self.sigma * costs)
        logged = {"reward_mean": float(r.mean()), "coupling_cost": float(costs.mean())}
        return Rewards(r, logged=logged)


def horizon_on(task: Task, seed: int, horizon: int | None) -> int:
    """T on the task: `horizon`, or the env's time limit where it is None. A horizon shorter
    than the time limit is refused: an episode's steps past it would find every atom spent,
    cost nothing and earn PWIL's top reward."""
    env = task.make_env(seed)
    try:
        limit = env.spec.max_episode_steps if env.spec is not None else None
    finally:
        env.close()
    if horizon is None and limit is None:
        raise ValueError(f"{task.env_id} has no time limit: set PWIL's horizon")
    if horizon is not None and limit is not None and horizon < limit:
        raise ValueError(
            f"PWIL's horizon ({horizon}) is shorter than {task.env_id}'s episodes (up to {limit}"
            " steps): steps past it would couple to no atom"
        )
    return int(horizon or limit)


@register(
    "pwil",
    config=PWILConfig,
    inputs="states",
    resumable=True,
    description="PWIL: greedy Wasserstein coupling with the expert's states, no adversary",
    min_budget=one_batch,
    family="trpo",
    label="PWIL",
)
def train(
    task: Task, demos: Demos, budget: int, seed: int, logger: Logger, config: PWILConfig
) -> Policy:
    atoms = expert_atoms(demos, config.subsampling, np.random.default_rng(seed))
    horizon = horizon_on(task, seed, config.horizon)
    sigma = config.beta * horizon / np.sqrt(task.obs_dim + task.act_dim)
    reward = PWILReward(atoms, config.n_envs, horizon, sigma, config.alpha)
    return trpo_on_reward(task, budget, seed, logger, config, reward)
