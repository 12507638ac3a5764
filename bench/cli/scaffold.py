"""`bench new-algorithm NAME DIR`: an installable plugin package to start one's own method from.

What it writes learns as written: TRPO (the imitators' own, with their settings) on a
state-only reward learned as it goes, a judge of (s, s') transitions that tells the
demonstrated ones from the policy's and sees the absorbing state an ended episode leads into,
so the reward never teaches the agent to fall. Replace the judge's features or loss with your
own idea; everything else is the harness's.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from bench.errors import BadInput

NAME_PATTERN = re.compile(r"^[a-z][a-z0-9-]{0,39}$")

MODULE = '''"""{name}: TRPO on a reward learned from state-only demonstrations.

The reward is a judge's: a classifier of transitions (s, s') that tells the demonstrated ones
from the policy's, trained a few steps on each new batch, and each step's reward is
-log(1 - D(s, s')), more the more the step looks demonstrated. Where an episode ends, the judge
sees the absorbing state it leads into (`bench.rl.absorbing`) like any other input and learns
that the expert never goes there, so an ended episode earns about 0 for ever while every step
alive earns more: the reward never teaches the agent to fall (a reward negative at every step
would teach just that). Replace `features` or the judge's loss with your own idea.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
import torch.nn.functional as F
from bench.harness.learners import ImitationTRPOConfig, one_batch, trpo_on_reward
from bench.harness.registry import Logger, Policy, Task, register
from bench.imitation.data import Demos
from bench.imitation.discriminator import expert_transitions
from bench.imitation.rewards import batch_rewards, batch_transitions
from bench.rl.absorbing import FLAG, Transitions
from bench.rl.networks import mlp
from bench.rl.resume import Stateful
from bench.rl.rollout import Batch, Rewards


@dataclass
class {config}(ImitationTRPOConfig):
    """The imitators' TRPO settings (so the built-in controls are its floor and ceiling),
    and the judge's own."""

    judge_hidden: tuple[int, ...] = (64, 64)
    """Hidden layer sizes of the judge's network."""
    judge_lr: float = 3e-4
    """Adam learning rate of the judge."""
    judge_steps: int = 5
    """Judge minibatch steps per policy update."""
    judge_minibatch: int = 256
    """Transitions of each side per judge step."""


def features(x: Transitions, centre: torch.Tensor, spread: torch.Tensor) -> torch.Tensor:
    """What the judge sees of a transition: s and s', scaled by the demonstrations' statistics,
    each with its absorbing flag (the absorbing state is all zeros and the flag)."""

    def state(obs: torch.Tensor, absorbing: torch.Tensor) -> torch.Tensor:
        flag = absorbing.float()[:, None]
        return torch.cat([(obs.float() - centre) / spread * (1 - flag), FLAG * flag], dim=1)

    return torch.cat([state(x.obs, x.obs_absorbing), state(x.next_obs, x.next_absorbing)], 1)


class Judge(Stateful):
    """The learned reward: TRPO calls it on each batch (it trains, then rewards). Its state is
    saved with the learner's (`Stateful`), so a trial on it can pause and resume."""

    def __init__(self, task: Task, demos: Demos, config: {config}, seed: int) -> None:
        self.task, self.config = task, config
        expert = expert_transitions(demos.observations, demos.terminated, None, True, config.gamma)
        self.expert = expert.map(torch.as_tensor)
        states = np.concatenate(demos.observations)
        self.centre = torch.as_tensor(states.mean(0))
        self.spread = torch.as_tensor(states.std(0) + 1e-3)
        self.net = mlp([2 * (task.obs_dim + 1), *config.judge_hidden, 1])
        self.optimizer = torch.optim.Adam(self.net.parameters(), lr=config.judge_lr)
        self.rng = torch.Generator().manual_seed(seed)

    def parts(self) -> dict:
        return {{"net": self.net, "optimizer": self.optimizer, "rng": self.rng}}

    def logit(self, x: Transitions) -> torch.Tensor:
        return self.net(features(x, self.centre, self.spread)).squeeze(-1)

    def draw(self, x: Transitions) -> Transitions:
        """A minibatch, each row drawn as often as the steps it stands for (`weight`)."""
        n = self.config.judge_minibatch
        rows = torch.multinomial(x.weight.float(), n, replacement=True, generator=self.rng)
        return x.map(lambda field: field[rows])

    def __call__(self, batch: Batch) -> Rewards:
        x, terminated = batch_transitions(
            batch, self.task.action_low, self.task.action_high, self.config.gamma
        )
        x = x.map(torch.as_tensor)
        for _ in range(self.config.judge_steps):  # demonstrated: 1, the policy's: 0
            policy, expert = self.logit(self.draw(x)), self.logit(self.draw(self.expert))
            loss = F.binary_cross_entropy_with_logits(policy, torch.zeros_like(policy))
            loss = loss + F.binary_cross_entropy_with_logits(expert, torch.ones_like(expert))
            self.optimizer.zero_grad()
            loss.backward()
            self.optimizer.step()
        with torch.no_grad():
            reward = F.softplus(self.logit(x))  # -log(1 - D): above 0, more where it looks expert
        logged = {{"judge_loss": loss.item()}}
        return batch_rewards(reward.numpy(), batch, terminated, self.config.gamma, logged=logged)


@register(
    "{name}",
    config={config},
    inputs="states",  # state-only demonstrations: `Demos` has no actions at all
    min_budget=one_batch,
    resumable=True,  # its judge's state is saved with the learner's
    label="{label}",
)
def train(
    task: Task, demos: Demos, budget: int, seed: int, logger: Logger, config: {config}
) -> Policy:
    """TRPO on a judge's reward: how demonstrated each step's (s, s') looks."""
    torch.manual_seed(seed)
    return trpo_on_reward(task, budget, seed, logger, config, Judge(task, demos, config, seed))
'''

PYPROJECT = """[build-system]
requires = ["setuptools>=68"]
build-backend = "setuptools.build_meta"

[project]
name = "{dist}"
version = "0.1.0"
description = "{name}: an imitation-from-observation method for ifo-bench"
dependencies = ["ifo-bench"]

# How ifo-bench finds the algorithm: no edit of the harness.
[project.entry-points."ifo_bench.algorithms"]
{name} = "{module}"

[tool.ruff]
line-length = 100
"""

SUITE = """# {name} beside the committed GAIfO, GAIL, BCO, TCN and controls on Hopper-v5, Figure 2's
# settings and budget at 5 demonstrations: only {name}'s trials run, the others are linked
# from the checkout's results/mujoco.
#   bench run suite.yaml --results runs/{name} --estimate
#   bench run suite.yaml --results runs/{name} && bench report runs/{name} --focus {name}
name: {name}
settings: settings/mujoco.yaml
envs:
  Hopper-v5: {{budget: 1000000, seeds: {{bco: 5, tcn: 5, {name}: 3}}}}
demos: [5]
algorithms: [random, expert, gaifo, gail, bco, tcn, survival, oracle, {name}]
seeds: 10
eval_episodes: 10
"""

README = """# {name}

An imitation-from-observation method for [ifo-bench](https://github.com/), as
`bench new-algorithm` wrote it: TRPO on a state-only reward (`{module}/__init__.py`).

    pip install -e .          # bench list now shows {name}
    bench run suite.yaml --results runs/{name} --estimate
    bench run suite.yaml --results runs/{name}
    bench report runs/{name} --focus {name}

Change the reward in `{module}/__init__.py`: a changed source makes its trials new ones (the
old records are set aside, not reused). The harness's page "Evaluate your method" walks
through the rest.
"""


def write_plugin(name: str, folder: Path) -> list[Path]:
    """Write the plugin package `name` into `folder` (new, or empty); return its files."""
    if not NAME_PATTERN.match(name):
        raise BadInput(
            f"algorithm name {name!r}: use lower-case letters, digits and '-', starting with a"
            " letter (at most 40)"
        )
    if folder.exists() and (not folder.is_dir() or any(folder.iterdir())):
        raise BadInput(f"{folder} exists and is not an empty folder; name a new one")
    module = name.replace("-", "_")
    words = {
        "name": name,
        "module": module,
        "dist": f"{name}-ifo",
        "label": name,
        "config": "".join(w.capitalize() for w in name.split("-")) + "Config",
    }
    files = {
        folder / module / "__init__.py": MODULE,
        folder / "pyproject.toml": PYPROJECT,
        folder / "suite.yaml": SUITE,
        folder / "README.md": README,
    }
    for path, template in files.items():
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(template.format(**words))
    return list(files)


def _new_algorithm(args: argparse.Namespace) -> int:
    written = write_plugin(args.name, Path(args.folder))
    print("wrote " + ", ".join(str(p) for p in written))
    folder = args.folder if Path(args.folder).is_absolute() else f"./{Path(args.folder)}"
    print(f"next: pip install -e {folder} && bench list")  # ./: a path, not a package name
    return 0


def add(sub: argparse._SubParsersAction) -> None:
    """The `new-algorithm` command."""
    new = sub.add_parser(
        "new-algorithm",
        help="write an installable plugin package for a method of your own",
        description="Write a plugin package into DIR: a module registering NAME (TRPO on a"
        " state-only reward that learns as written), its pyproject.toml with the entry point,"
        " a suite that runs it beside the committed baselines, and a README.",
    )
    new.add_argument("name", metavar="NAME", help="the algorithm's name, e.g. my-ifo")
    new.add_argument("folder", metavar="DIR", help="a new (or empty) folder for the package")
    new.set_defaults(func=_new_algorithm)
