"""BCO(alpha) (Torabi et al. 2018): behavioral cloning from observation.

1. Pre-demonstration: act uniformly at random for `pre_demo_steps` env steps and fit an
   inverse dynamics model a = M(s, s') on the agent's own transitions (MSE, normalized inputs).
2. Label the demonstrations' (s, s') pairs with M's actions and clone them: a Gaussian MLP
   policy trained by maximum likelihood.
3. alpha > 0: run the policy for alpha * pre_demo_steps more env steps, add them to M's data,
   refit M, relabel, re-clone; repeat while budget (or `max_iterations`) remains.
   alpha = 0 is plain BCO and stops after step 2, using only `pre_demo_steps` of the budget.

Every env step, random ones included, goes through `task.make_env` and counts against the
trial's budget, so BCO's sample use compares with the RL-based learners'. The policy is offered
to the runner after every fit (a learning curve), and M's held-out error is logged.

Measured on InvertedPendulum (100k steps, 10 seeds, results/pybullet): M's held-out R^2 is above
0.98 from the first fit, so cloning is the limit, not labelling: 0.62 normalized from 1 demo
(cloning the expert's true actions scores ~0.6 as well), 0.87 from 5, 0.98 from 10.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import torch

from bench.fields import added_later
from bench.harness.registry import Logger, Policy, Task, register, snapshots_of
from bench.imitation.data import Demos
from bench.imitation.inverse_dynamics import (
    InverseModel,
    TransitionRows,
    fit_inverse,
    inverse_error,
)
from bench.rl import flat_adam
from bench.rl.networks import DeterministicPolicy, GaussianPolicy
from bench.rl.resume import TORCH_RNG, Resumable
from bench.rl.rollout import VecCollector
from bench.validate import above, at_least, layers, one_of

INPUT_NORMS = ("demos", "none")


@dataclass
class BCOConfig:
    pre_demo_steps: int = 20_000
    """Env steps of the uniform random policy before the first fit."""
    alpha: float = 0.25
    """Each post-demonstration iteration runs the policy for alpha * pre_demo_steps env steps."""
    max_iterations: int | None = None
    """Post-demonstration iterations at most; None: until the budget runs out."""
    n_envs: int = 8
    """Envs stepped side by side, so the policy runs one batched forward per step. Collection
    goes in whole rounds of n_envs steps, so a phase's steps round down to a multiple of it."""
    inverse_hidden: tuple[int, ...] = (64, 64)
    """Hidden layer sizes of the inverse dynamics MLP (ReLU)."""
    inverse_lr: float = 1e-3
    """Adam learning rate of the inverse model."""
    inverse_steps: int = 2000
    """Adam minibatch steps of the inverse model's first fit."""
    inverse_refit_steps: int = 500
    """Adam minibatch steps of each later refit; they warm-start, and the data grows by alpha."""
    val_fraction: float = 0.1
    """Share of the agent's transitions held out to measure the inverse model's error."""
    policy_hidden: tuple[int, ...] = (64, 64)
    """Hidden layer sizes of the policy MLP (tanh), as in the TRPO learners."""
    bc_lr: float = 1e-3
    """Adam learning rate of behavioral cloning."""
    bc_steps: int = 1000
    """Adam minibatch steps per cloning; every iteration clones a fresh policy."""
    minibatch: int = 256
    """Minibatch size of both the inverse model and cloning."""
    init_log_std: float = -0.5
    """Initial log std of the policy; cloning then fits it by maximum likelihood."""
    input_norm: str = added_later("demos")
    """What the policy's input normalizer is fitted to: "demos" (the demonstrations' states) or
    "none" (raw inputs; docs/design/settings.md)."""

    def __post_init__(self) -> None:
        layers(self, "inverse_hidden", "policy_hidden")
        if self.n_envs < 1 or self.pre_demo_steps < self.n_envs:
            raise ValueError("need n_envs >= 1 and pre_demo_steps >= n_envs")
        if self.alpha < 0 or not 0 < self.val_fraction < 1:
            raise ValueError("need alpha >= 0 and 0 < val_fraction < 1")
        at_least(self, 1, "inverse_steps", "inverse_refit_steps", "bc_steps", "minibatch")
        at_least(self, 0, "max_iterations")
        above(self, 0, "inverse_lr", "bc_lr")
        one_of(self, "input_norm", INPUT_NORMS)


def clone(
    s: torch.Tensor, a: torch.Tensor, task: Task, cfg: BCOConfig, gen: torch.Generator
) -> tuple[GaussianPolicy, float]:
    """A fresh policy fit to actions `a` at states `s` by maximum likelihood; (policy, last NLL).

    Fresh each iteration: only the labels change between iterations, and a fixed number of steps
    from scratch also fits the log std (hence the rollouts' exploration noise) the same way each time.
    """
    policy = GaussianPolicy(task.obs_dim, task.act_dim, cfg.policy_hidden, cfg.init_log_std)
    if cfg.input_norm == "demos":
        policy.norm.update(s.numpy())  # its inputs are demonstration states
    opt = flat_adam.adam(
        [p for n, p in policy.named_parameters() if not n.startswith("norm.")], lr=cfg.bc_lr
    )
    loss = torch.zeros(())
    for _ in range(cfg.bc_steps):
        idx = torch.randint(len(s), (cfg.minibatch,), generator=gen)
        loss = -policy.log_prob(policy(s[idx]), a[idx]).mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    return policy, loss.item()


class AgentData:
    """The agent's own transitions (s, a, s') that M learns from, split at random as they come
    into a training part and a held-out part (to measure M's error); M's input normalizers
    follow every transition added."""

    def __init__(self, model: InverseModel, val_fraction: float, rng: np.random.Generator):
        self.model, self.val_fraction, self.rng = model, val_fraction, rng
        self.train, self.held_out = TransitionRows(), TransitionRows()

    def add(self, s: np.ndarray, a: np.ndarray, s_next: np.ndarray) -> None:
        held = self.rng.random(len(s)) < self.val_fraction
        self.train.append(s[~held], a[~held], s_next[~held])
        self.held_out.append(s[held], a[held], s_next[held])
        self.model.update_norms(s, s_next)

    def state(self) -> list[list[torch.Tensor]]:
        return [list(rows.tensors()) for rows in (self.train, self.held_out)]

    def load(self, state: list[list[torch.Tensor]]) -> None:
        for rows, saved in zip((self.train, self.held_out), state, strict=True):
            rows.append(*(x.numpy() for x in saved))


Act = Callable[[np.ndarray], np.ndarray]
"""act(observations (E, O)) -> actions (E, A)."""


def uniform_actions(low: np.ndarray, high: np.ndarray, rng: np.random.Generator) -> Act:
    """The pre-demonstration policy: actions uniform between the bounds."""
    return lambda obs: rng.uniform(low, high, size=(len(obs), len(low))).astype(np.float32)


def sampler(policy: GaussianPolicy, rng: np.random.Generator) -> Act:
    """The cloned policy as it explores: its mean plus its Gaussian noise."""

    @torch.no_grad()
    def sample(obs: np.ndarray) -> np.ndarray:
        mean = policy(torch.from_numpy(obs)).numpy()
        return mean + np.exp(policy.log_std.numpy()) * rng.standard_normal(mean.shape)

    return sample


def collect(rollouts: VecCollector, act: Act, n: int, data: AgentData, task: Task) -> int:
    """Step the envs with `act` for n steps, rounded down to whole rounds of one step each, and
    add them (actions as the envs applied them) to M's data; the steps taken."""
    batch = rollouts.run(act, n // len(rollouts.envs))
    applied = np.clip(batch.flat("actions"), task.action_low, task.action_high)
    data.add(batch.flat("obs"), applied, batch.flat("next_obs"))
    return batch.n_steps


def label_and_clone(
    model: InverseModel,
    demos: tuple[torch.Tensor, torch.Tensor],
    task: Task,
    cfg: BCOConfig,
    gen: torch.Generator,
) -> tuple[GaussianPolicy, float]:
    """The demonstrations' (s, s') labelled with M's best guess of the action, clipped to the
    bounds, and cloned (`clone`): the policy, and its last NLL."""
    demo_s, demo_next = demos
    low, high = torch.from_numpy(task.action_low), torch.from_numpy(task.action_high)
    with torch.no_grad():
        labels = model(demo_s, demo_next).clamp(low, high)
    return clone(demo_s, labels, task, cfg, gen)


@register(
    "bco",
    config=BCOConfig,
    inputs="states",
    resumable=True,
    description="BCO(alpha): inverse dynamics labels the demos, then behavioral cloning",
    min_budget=lambda config: config.pre_demo_steps,
    family="trpo",
    label="BCO",
)
def train(
    task: Task, demos: Demos, budget: int, seed: int, logger: Logger, config: BCOConfig
) -> Policy:
    cfg = config
    if cfg.pre_demo_steps > budget:
        raise ValueError(
            f"pre_demo_steps ({cfg.pre_demo_steps}) exceed the budget of {budget} env steps"
        )
    torch.manual_seed(seed)
    rng = np.random.default_rng(seed)
    gen = torch.Generator().manual_seed(seed + 1)
    low, high = task.action_low, task.action_high
    demo_pairs = tuple(torch.from_numpy(x) for x in demos.transitions())
    model = InverseModel(task.obs_dim, task.act_dim, cfg.inverse_hidden)
    model_opt = flat_adam.adam(model.net.parameters(), lr=cfg.inverse_lr)
    data = AgentData(model, cfg.val_fraction, rng)
    chunk = round(cfg.alpha * cfg.pre_demo_steps)
    rollouts = VecCollector(
        [task.make_env(seed * 1000 + i) for i in range(cfg.n_envs)], seed * 1000
    )
    # All that carries from one iteration to the next; the policy does not (each iteration
    # clones a fresh one).
    resume = Resumable(
        snapshots_of(logger),
        parts={
            "inverse": {"model": model, "opt": model_opt, "gen": gen},
            "rng": rng,
            "torch_rng": TORCH_RNG,
        },
        replayed={"rollouts": rollouts},
    )

    def counters() -> dict:
        """The loop's counters, and M's data."""
        return {"steps": steps, "iteration": iteration, "data": data.state()}

    try:
        if (resumed := resume.restore()) is None:  # the pre-demonstration phase
            uniform = uniform_actions(low, high, rng)
            steps, iteration = collect(rollouts, uniform, cfg.pre_demo_steps, data, task), 0
        else:
            steps, iteration = resumed["steps"], resumed["iteration"]
            data.load(resumed["data"])
        while True:
            resume.save_if_due(counters)
            fit_steps = cfg.inverse_steps if iteration == 0 else cfg.inverse_refit_steps
            train_mse = fit_inverse(
                model, model_opt, data.train.tensors(), fit_steps, cfg.minibatch, gen
            )
            policy, bc_nll = label_and_clone(model, demo_pairs, task, cfg, gen)
            held_out = inverse_error(model, data.held_out.tensors())
            logger.log(steps, inverse_train_mse=train_mse, bc_nll=bc_nll, **held_out)
            logger.checkpoint(steps, DeterministicPolicy(policy, low, high))
            n = min(chunk, budget - steps)  # never past the budget: the last chunk may be short
            if n < cfg.n_envs or iteration == cfg.max_iterations:
                break
            steps += collect(rollouts, sampler(policy, rng), n, data, task)  # post-demonstration
            iteration += 1
    finally:
        rollouts.close()
    return DeterministicPolicy(policy, low, high)
