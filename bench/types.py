"""Data types that cross module boundaries. Frozen; shapes checked on construction.

Shapes use T for steps in an episode, B for a batch, O for the observation
size and A for the action size.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np


@dataclass(frozen=True)
class Demos:
    """State-only demonstrations: what an imitation-from-observation algorithm gets.

    There is deliberately no `actions` field anywhere on this type.
    """

    env_id: str
    observations: tuple[np.ndarray, ...]
    """One (T_i + 1, O) float32 array per episode; row T_i is the episode's true final observation.
    From pixels, (T_i + 1, C*H*W) uint8 flat stacks of frames (`bench.pixels`)."""
    terminated: tuple[bool, ...] | None = None
    """Per episode: True if it ended in a terminal state (the agent fell), False if a time limit
    cut it. None means no episode terminated."""

    def __post_init__(self) -> None:
        if not self.observations:
            raise ValueError("Demos needs at least one episode")
        dims = {o.shape[1] for o in self.observations if o.ndim == 2}
        if len(dims) != 1 or any(o.ndim != 2 or len(o) < 2 for o in self.observations):
            raise ValueError("each episode must be a (T+1, O) array with T >= 1 and one O for all")
        terminated = (False,) * self.n_episodes if self.terminated is None else self.terminated
        if len(terminated) != self.n_episodes:
            raise ValueError("one terminated flag per episode")
        object.__setattr__(self, "terminated", tuple(bool(t) for t in terminated))

    @property
    def obs_dim(self) -> int:
        return self.observations[0].shape[1]

    @property
    def n_episodes(self) -> int:
        return len(self.observations)

    def transitions(self) -> tuple[np.ndarray, np.ndarray]:
        """All (s, s') pairs: two (sum T_i, O) arrays."""
        obs = np.concatenate([o[:-1] for o in self.observations])
        next_obs = np.concatenate([o[1:] for o in self.observations])
        return obs, next_obs


@dataclass(frozen=True)
class ActionDemos:
    """Demonstrations with the expert's actions. Only GAIL (and tests) may receive these."""

    demos: Demos
    actions: tuple[np.ndarray, ...]
    """One (T_i, A) float32 array per episode, aligned with `demos.observations[i][:-1]`."""

    def __post_init__(self) -> None:
        if len(self.actions) != self.demos.n_episodes:
            raise ValueError("one action array per episode")
        for o, a in zip(self.demos.observations, self.actions, strict=True):
            if a.ndim != 2 or len(a) != len(o) - 1:
                raise ValueError("actions of episode i must be (T_i, A) with T_i = len(obs_i) - 1")

    @property
    def env_id(self) -> str:
        return self.demos.env_id

    def state_actions(self) -> tuple[np.ndarray, np.ndarray]:
        """All (s, a) pairs: (sum T_i, O) and (sum T_i, A)."""
        obs = np.concatenate([o[:-1] for o in self.demos.observations])
        return obs, np.concatenate(self.actions)


CURVE_POINTS = 10
"""Learning-curve evaluations per trial unless its suite asks otherwise (at most; when the
algorithm offers checkpoints)."""


@dataclass(frozen=True)
class TrialSpec:
    """Everything that determines one trial, and the suite that asked for it. Its id hashes
    what decides its outcome (`identity`): everything but the suite's name and label, so the
    same trial asked for by two suites is one record."""

    suite: str
    env_id: str
    algorithm: str
    n_demos: int
    seed: int
    budget: int
    """Env steps the algorithm may take while training."""
    eval_episodes: int
    hyperparams: dict[str, Any] = field(default_factory=dict)
    """Overrides of the algorithm's config dataclass; JSON-serializable."""
    label: str | None = None
    """A variant's name in a suite with several of one algorithm (None: `algorithm`)."""
    dataset: str | None = None
    """A Minari dataset (folder or id) the demonstrations come from (None: the shipped
    expert's pool)."""
    observation: str | None = None
    """What the learner observes: None for the env's state vector, "pixels" for stacked
    rendered frames (`bench.pixels`), "video-reward" for states while its reward judges
    frames; demonstrations are then the expert's video."""
    frame_size: int | None = None
    """Side in pixels of the frames of a pixel or video-reward trial (None: PixelConfig's 64)."""
    curve_points: int = CURVE_POINTS
    """Learning-curve evaluations during training."""

    def identity(self) -> str:
        """What decides the trial's outcome, as canonical JSON: every field but `suite` and
        `label`, which only say who asked for it and what it is called there."""
        spec = asdict(self)
        del spec["suite"], spec["label"]
        return json.dumps(spec, sort_keys=True, separators=(",", ":"))

    @property
    def shown(self) -> str:
        """The name records are grouped, plotted and compared by."""
        return self.label or self.algorithm

    @property
    def trial_id(self) -> str:
        return hashlib.sha256(self.identity().encode()).hexdigest()[:16]

    def __hash__(self) -> int:
        return hash(self.identity())


@dataclass(frozen=True)
class CurvePoint:
    env_steps: int
    mean_return: float


@dataclass(frozen=True)
class TrialResult:
    """One finished trial, as written to disk."""

    spec: TrialSpec
    status: str
    """"ok" or "failed"; "paused" for a trial stopped at its run's time limit, which the
    runner does not write (its snapshot is what is kept)."""
    returns: list[float]
    """Undiscounted return of each evaluation episode (empty when failed)."""
    curve: list[CurvePoint]
    """Evaluation return against env steps used so far."""
    env_steps: int
    wall_time: float
    """Seconds from start of training to end of final evaluation."""
    versions: dict[str, str]
    traceback: str | None = None
    logs: dict[str, list[float]] = field(default_factory=dict)
    """Algorithm diagnostics over training, e.g. discriminator loss and accuracy."""
    inputs: str | None = None
    """What the algorithm was given: "none", "states", "actions" or "expert" (its registry
    entry's `inputs`), so figures can mark action users from the records alone."""
    reference: str | None = None
    """Where an expert record's returns come from when no shipped expert was run (a dataset's
    demonstrator: its ref_max_score or its episodes' returns)."""
    state_distance: float | None = None
    """How far the evaluation episodes' states lie from the expert's pool
    (`bench.state_match.state_distance`: 0 = distributed alike); None from pixels, for a
    dataset's demonstrator, and in records written before it was measured."""
    stored_in: str | None = None
    """Where a trial another suite ran is recorded, for a suite that asks for it too: that
    suite's results folder, which holds its record and policy (`bench.store.link`); None where
    the record is this folder's own. Said by the reader, never written into a record."""
    role: str | None = None
    """What its algorithm is in a comparison (`bench.registry.Role`), as registered when it ran."""
    family: str | None = None
    """The optimizer family whose controls it is read against (`bench.registry.Algorithm`)."""
    label: str | None = None
    """Its name in figures and reports: a variant's own (`TrialSpec.label`), else its
    algorithm's registered label ("GAIfO")."""
    resumed_at: list[int] = field(default_factory=list)
    """Env steps at which the trial was resumed from a snapshot (`bench.snapshots`) after an
    interruption; empty where it trained in one go."""
    policy: bytes | None = field(default=None, repr=False)
    """The final policy's file (`bench.policies`), on its way from the worker to the driver,
    which writes it beside the record; never part of the record itself."""

    @property
    def trial_id(self) -> str:
        return self.spec.trial_id
