"""One resumable-training wrapper: what a training loop hands over to survive an interruption.

A loop names what changes as it trains (its `parts`: modules, optimizers, random generators,
tensors, and mappings of them), what must be brought back by replaying (its env collectors),
and, when a snapshot is due, its own counters. `Resumable` saves all of it in one snapshot and,
where the trial resumes, puts it back and hands the counters to the loop, which goes on as if
it had never stopped::

    resume = Resumable(snapshots, parts={"learner": learner, "torch_rng": TORCH_RNG},
                       replayed={"collector": collector})
    steps = resumed["steps"] if (resumed := resume.restore()) else 0
    while steps < budget:
        ...
        resume.save_if_due(lambda: {"steps": steps})

On one machine a resumed trial returns the very learner an uninterrupted one does, provided
`parts` holds all that changes besides the counters. Where the snapshots are kept, how often
and until when is the runner's business (`Snapshots`): a loop outside the runner passes None
and `Resumable` does nothing.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from contextlib import AbstractContextManager
from typing import Any, Protocol

import numpy as np
import torch


class Snapshots(Protocol):
    """Where a trial keeps its snapshots: the runner's logger offers one as `logger.snapshots`.
    Loops use it through `Resumable`, never directly."""

    def due(self) -> bool:
        """Whether a snapshot should be saved now (every ~10 min of training)."""

    def save(self, state: dict[str, Any]) -> None:
        """Keep `state` (tensors, numbers, strings, and lists and dicts of them) to resume from.
        Past the run's time limit (`bench run --time-limit`), `due` is always true and `save`
        then ends the trial by raising `TrialPaused`: let it through, and the next run resumes
        the trial from this snapshot."""

    def load(self) -> dict[str, Any] | None:
        """The state last saved, where this trial resumes after an interruption; else None.
        The trial's env-step count is set back to what it was at that save."""

    def replaying(self) -> AbstractContextManager[None]:
        """Env steps taken inside do not count against the budget: an env being brought back to
        where it was when the snapshot was saved (`bench.rl.episodes.Episode`) gains no
        experience."""


class _TorchRNG:
    """The global torch generator, as a part (`TORCH_RNG`)."""

    def state_dict(self) -> torch.Tensor:
        return torch.get_rng_state()

    def load_state_dict(self, state: torch.Tensor) -> None:
        torch.set_rng_state(state)


TORCH_RNG = _TorchRNG()
"""Name it among a loop's parts when the loop draws from torch's global generator."""


def state_of(parts: Mapping[str, Any]) -> dict[str, Any]:
    """The state of each part: a generator's (torch or numpy), a tensor's values, a mapping's
    parts' states, else its `state_dict()`. Tensors and plain values only: weights_only-safe."""
    out: dict[str, Any] = {}
    for name, part in parts.items():
        if isinstance(part, torch.Generator):
            out[name] = part.get_state()
        elif isinstance(part, np.random.Generator):
            out[name] = part.bit_generator.state
        elif isinstance(part, torch.Tensor):
            out[name] = part.detach().cpu().clone()
        elif isinstance(part, Mapping):
            out[name] = state_of(part)
        else:
            out[name] = part.state_dict()
    return out


def load_into(parts: Mapping[str, Any], state: Mapping[str, Any]) -> None:
    """Put each part's state (from `state_of`) back into the part itself, so lists of
    parameters and optimizers that point at it stay valid."""
    for name, part in parts.items():
        if isinstance(part, torch.Generator):
            part.set_state(state[name])
        elif isinstance(part, np.random.Generator):
            part.bit_generator.state = state[name]
        elif isinstance(part, torch.Tensor):
            with torch.no_grad():
                part.copy_(state[name])
        elif isinstance(part, Mapping):
            load_into(part, state[name])
        else:
            part.load_state_dict(state[name])


class Resumable:
    """Saves a training loop's state when a snapshot is due, and restores it on resume."""

    def __init__(
        self,
        snapshots: Snapshots | None,
        parts: Mapping[str, Any],
        replayed: Mapping[str, Any] | None = None,
    ) -> None:
        """`parts`: name -> what changes as the loop trains (see `state_of`). `replayed`: name ->
        what is restored by stepping envs again (collectors: `state_dict`/`load_state_dict`),
        whose steps then do not count against the budget. Names are the snapshot's keys, shared
        with the loop's own counters."""
        self.snapshots = snapshots
        self.parts = parts
        self.replayed = replayed or {}

    def restore(self) -> dict[str, Any] | None:
        """Where the trial resumes: put every part back, replay the envs, and return the
        snapshot, from which the loop takes its counters. None: nothing to resume from."""
        state = self.snapshots.load() if self.snapshots is not None else None
        if state is None:
            return None
        load_into(self.parts, state)
        with self.snapshots.replaying():
            load_into(self.replayed, state)
        return state

    def save_if_due(self, counters: Callable[[], Mapping[str, Any]], room: bool = True) -> None:
        """Save a snapshot if one is due and `room` (False where the loop is about to end and
        a snapshot would only be thrown away): the parts, the replayed, and `counters()`,
        plain values the loop restarts from. Past the run's time limit this raises
        `TrialPaused`: let it through."""
        if self.snapshots is None or not room or not self.snapshots.due():
            return
        state = {**state_of(self.parts), **state_of(self.replayed), **counters()}
        self.snapshots.save(state)


class Stateful:
    """`state_dict` and `load_state_dict` of an object from its `parts()`, as `state_of` takes
    them: for a learner made of several modules, optimizers and generators."""

    def parts(self) -> dict[str, Any]:
        raise NotImplementedError

    def state_dict(self) -> dict[str, Any]:
        return state_of(self.parts())

    def load_state_dict(self, state: dict[str, Any]) -> None:
        load_into(self.parts(), state)
