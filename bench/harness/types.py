"""The harness's data types: a trial's spec and its record. Frozen.

Demonstrations, which algorithms get, are `bench.imitation.data`'s.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field, replace
from typing import Any

CURVE_POINTS = 10
"""Learning-curve evaluations per trial unless its suite asks otherwise (at most; when the
algorithm offers checkpoints)."""


OPTIONAL_FIELDS = ("code", "kernels")
"""Spec fields added after records were committed: left out of a trial's identity (and of its
record) where unset, so the ids of the trials that do not set them stay what they were."""


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
    rendered frames (`bench.envs.pixels`), "video-reward" for states while its reward judges
    frames; demonstrations are then the expert's video."""
    frame_size: int | None = None
    """Side in pixels of the frames of a pixel or video-reward trial (None: PixelConfig's 64)."""
    curve_points: int = CURVE_POINTS
    """Learning-curve evaluations during training."""
    kernels: str | None = None
    """"portable" where its floats must be the same on any x86-64 CPU
    (`bench.kernels`); None: the CPU's own kernels, as every committed record's."""
    code: str | None = None
    """The identity of the code that trains it (`bench.harness.registry.code_identity`): a
    plugin's source hash, so that a changed plugin's trials are new trials; None for the
    built-ins."""
    config: Any = field(default=None, compare=False, repr=False)
    """The algorithm's config dataclass, built from `hyperparams` when the suite was loaded
    and carried to the trial, so that it is built once (None for a spec read from a record:
    `config_of` builds it). What it holds is `hyperparams`: no part of the trial's identity,
    never written into a record."""

    def plain(self) -> dict[str, Any]:
        """Its fields as plain values, as a record holds them: all but `config`, which
        `hyperparams` says."""
        spec = asdict(replace(self, config=None))
        del spec["config"]
        return spec

    def decisive(self) -> dict[str, Any]:
        """Every field but `suite` and `label`, which only say who asked for the trial and what
        it is called there; `OPTIONAL_FIELDS` only where they are set."""
        spec = self.plain()
        del spec["suite"], spec["label"]
        for optional in OPTIONAL_FIELDS:
            if spec[optional] is None:
                del spec[optional]
        return spec

    def identity(self) -> str:
        """What decides the trial's outcome (`decisive`), as canonical JSON."""
        return _canonical(self.decisive())

    @property
    def shown(self) -> str:
        """The name records are grouped, plotted and compared by."""
        return self.label or self.algorithm

    @property
    def setting_id(self) -> str:
        """What decides the trial but its seed, hashed: trials that differ only in their seed
        share it, so seeds of one setting are compared only with seeds of the same setting.
        The CPU kernels it ran on are no part of it: a record made with portable kernels is a
        draw of the same setting as one made with the CPU's own (what `bench compare` asks)."""
        spec = self.decisive()
        del spec["seed"]
        spec.pop("kernels", None)
        return hashlib.sha256(_canonical(spec).encode()).hexdigest()[:12]

    @property
    def trial_id(self) -> str:
        return hashlib.sha256(self.identity().encode()).hexdigest()[:16]

    def __hash__(self) -> int:
        return hash(self.identity())


def _canonical(value: Any) -> str:
    """JSON that two equal values always write alike: keys sorted, no spaces."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"))


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
    (`bench.harness.state_match.state_distance`: 0 = distributed alike); None from pixels, for a
    dataset's demonstrator, and in records written before it was measured."""
    stored_in: str | None = None
    """Where a trial another suite ran is recorded, for a suite that asks for it too: that
    suite's results folder, which holds its record and policy (`bench.harness.store.link`); None where
    the record is this folder's own. Said by the reader, never written into a record."""
    role: str | None = None
    """What its algorithm is in a comparison (`bench.harness.registry.Role`), as registered when it ran."""
    family: str | None = None
    """The optimizer family whose controls it is read against (`bench.harness.registry.Algorithm`)."""
    label: str | None = None
    """Its name in figures and reports: a variant's own (`TrialSpec.label`), else its
    algorithm's registered label ("GAIfO")."""
    resumed_at: list[int] = field(default_factory=list)
    """Env steps at which the trial was resumed from a snapshot (`bench.harness.snapshots`) after an
    interruption; empty where it trained in one go."""
    cpu_time: float | None = None
    """CPU seconds (user and system) of the trial's own process, runs before a resume
    included: what it cost a core whatever else loaded the machine, where `wall_time` grows
    with the load. None in records written before it was measured, and where a trial resumed
    from a snapshot that did not keep it."""
    policy: bytes | None = field(default=None, repr=False)
    """The final policy's file (`bench.harness.policies`), on its way from the worker to the driver,
    which writes it beside the record; never part of the record itself."""

    @property
    def trial_id(self) -> str:
        return self.spec.trial_id

    @property
    def raised(self) -> str | None:
        """What a failed trial raised: its traceback's last line (exception and message), or
        None where there is no traceback."""
        lines = (self.traceback or "").strip().splitlines()
        return lines[-1] if lines else None
