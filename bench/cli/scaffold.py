"""`bench new-algorithm NAME DIR`: an installable plugin package to start one's own method from.

What it writes learns as written: TRPO (the imitators' own, with their settings) on a
state-only reward, how closely each step tracks the demonstrated states at the same time of
the episode. Every step alive earns more than an ended episode (0), so the reward never
teaches the agent to fall. Replace the reward with your own; everything else is the
harness's.
"""

from __future__ import annotations

import argparse
import re
from pathlib import Path

from bench.errors import BadInput

NAME_PATTERN = re.compile(r"^[a-z][a-z0-9-]{0,39}$")

MODULE = '''"""{name}: TRPO on how closely each step tracks the demonstrations at the same time.

The reward of a step that reaches state s' at time t of its episode is 1 / (1 + d / bandwidth),
d the distance from s' to the nearest state the demonstrations reached within `window` steps of
t (in units of the demonstrations' spread): 1 on the expert's path at the expert's pace, less
away from it. Matched in time, standing still is far from an expert that has long since left:
a reward of nearest states alone pays standing, since every demonstration starts by standing.
Every step alive earns more than an ended episode (0, what TRPO values after a termination),
so the agent is never taught to fall; a reward negative at every step would teach just that.
Replace `reward` with your own idea; the harness does the rest.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

from bench.harness.learners import ImitationTRPOConfig, one_batch, trpo_on_reward
from bench.harness.registry import Logger, Policy, Task, register
from bench.imitation.data import Demos
from bench.rl.rollout import Batch


@dataclass
class {config}(ImitationTRPOConfig):
    """The imitators' TRPO settings (so the built-in controls are its floor and ceiling),
    and the reward's own."""

    bandwidth: float = 1.0
    """How fast the reward falls with the distance to the demonstrations (in spreads)."""
    window: int = 10
    """Steps either side of a step's time whose demonstrated states it is matched against."""


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
    """TRPO on tracking the demonstrated states at the same time of the episode."""
    states = np.concatenate(demos.observations)
    centre = torch.as_tensor(states.mean(0))
    spread = torch.as_tensor(states.std(0))
    # A dimension the expert holds still (a balanced pole) would make every other state look
    # infinitely far: no dimension counts for more than ten times the average one.
    spread = torch.clamp(spread, min=0.1 * float(spread.mean()) + 1e-8)
    # (episodes, longest, O), each episode padded with its last state; `reached` masks the pad
    longest = max(len(o) for o in demos.observations)
    track = torch.stack([torch.as_tensor(np.pad(o, ((0, longest - len(o)), (0, 0)), "edge"))
                         for o in demos.observations])
    track = (track - centre) / spread
    reached = torch.stack([torch.arange(longest) < len(o) for o in demos.observations])
    offsets = torch.arange(-config.window, config.window + 1)
    scale = config.bandwidth * np.sqrt(track.shape[-1])

    def reward(batch: Batch) -> np.ndarray:  # (T, E) steps -> (T, E) rewards
        s_next = (torch.as_tensor(batch.flat("next_obs")) - centre) / spread  # (N, O)
        t = torch.as_tensor(batch.flat("timesteps")) + 1  # s' is the state at time t + 1
        at = (t[:, None] + offsets).clamp(0, longest - 1)  # (N, 2w + 1) times matched against
        near = track[:, at]  # (episodes, N, 2w + 1, O)
        d = (near - s_next[None, :, None]).norm(dim=-1)
        d = torch.where(reached[:, at], d, torch.inf).amin(dim=(0, 2))  # (N,)
        close = 1.0 / (1.0 + d / scale)
        return close.reshape(batch.rewards.shape).numpy()

    return trpo_on_reward(task, budget, seed, logger, config, reward)
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
