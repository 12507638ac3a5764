"""`bench new-algorithm NAME DIR`: an installable plugin package to start one's own method from.

What it writes learns as written: TRPO (the imitators' own, with their settings) on a
state-only reward, how close each step's (s, s') lies to a demonstrated one, handed to TRPO
through `bench.imitation.rewards.on_trpo` and judged at the absorbing state like any other
input, so that ending an episode is worth the least a step can be and the reward never
teaches the agent to fall. Replace the reward with your own; everything else is the harness's.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from bench.errors import BadInput

NAME_PATTERN = re.compile(r"^[a-z][a-z0-9-]{0,39}$")

MODULE = '''"""{name}: TRPO on how close each step's (s, s') lies to a demonstrated one.

The reward is 1 / (1 + d / bandwidth), d the distance from the step's (s, s') to the nearest
demonstrated pair, in units of the demonstrations' spread: 1 on the expert's path, less
further from it, and 0 at the absorbing state an episode ends in. Every step alive is worth more
than ending the episode, so the agent is never taught to fall (a reward negative at every step
would teach it just that). Replace `reward` with your own idea; the harness does the rest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from bench.harness.learners import ImitationTRPOConfig, one_batch, trpo_on_reward
from bench.harness.registry import Logger, Policy, Task, register
from bench.imitation.data import Demos
from bench.imitation.rewards import on_trpo
from bench.rl.absorbing import Transitions


@dataclass
class {config}(ImitationTRPOConfig):
    """The imitators' TRPO settings (so the built-in controls are its floor and ceiling),
    and the reward's own."""

    bandwidth: float = 1.0
    """How fast the reward falls with the distance to the demonstrations (in spreads)."""
    max_pairs: int = 10_000
    """Demonstrated (s, s') pairs kept to compare against (drawn evenly where there are more)."""


@register(
    "{name}",
    config={config},
    inputs="states",  # state-only demonstrations: `Demos` has no actions at all
    min_budget=one_batch,
    resumable=True,  # the reward is fixed, so a trial can pause and resume
    label="{label}",
)
def train(
    task: Task, demos: Demos, budget: int, seed: int, logger: Logger, config: {config}
) -> Policy:
    """TRPO on the closeness of each step's (s, s') to the demonstrated ones."""
    obs, next_obs = demos.transitions()  # (N, O) each: every demonstrated step
    pairs = np.concatenate([obs, next_obs], axis=1)
    keep = np.linspace(0, len(pairs) - 1, min(len(pairs), config.max_pairs)).astype(int)
    pairs = torch.as_tensor(pairs[keep], dtype=torch.float32)
    centre, spread = pairs.mean(0), pairs.std(0)
    # A dimension the expert holds still (a balanced pole) would make every other state look
    # infinitely far: no dimension counts for more than ten times the average one.
    spread = torch.clamp(spread, min=0.1 * float(spread.mean()) + 1e-8)
    expert = (pairs - centre) / spread
    scale = config.bandwidth * np.sqrt(pairs.shape[1])

    def reward(x: Transitions) -> torch.Tensor:
        seen = (torch.cat([x.obs, x.next_obs], dim=1).float() - centre) / spread
        distance = torch.cdist(seen, expert).min(dim=1).values
        # 1 on the expert's path, falling slowly with the distance and never to 0, so that a
        # step alive anywhere still beats the end of the episode (0) the absorbing state gets
        close = 1.0 / (1.0 + distance / scale)
        return torch.where(x.obs_absorbing | x.next_absorbing, 0.0, close)

    shaped = on_trpo(reward, task.action_low, task.action_high, config.gamma)
    return trpo_on_reward(task, budget, seed, logger, config, shaped)
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
