"""The shipped TRPO expert, evaluated like any learner: the 1 of every normalized score."""

from __future__ import annotations

from dataclasses import dataclass

from bench.harness.registry import Logger, Policy, Task, register


@dataclass
class ExpertConfig:
    pass


@register(
    "expert",
    config=ExpertConfig,
    inputs="expert",
    description="the demonstrator itself (score 1)",
    role="expert",
    label="Expert",
)
def train(
    task: Task, demos: Policy, budget: int, seed: int, logger: Logger, config: ExpertConfig
) -> Policy:
    return demos  # the runner hands the expert policy itself to algorithms with inputs="expert"
