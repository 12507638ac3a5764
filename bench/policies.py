"""Each trial's final policy, kept beside its record: `<results>/policies/<trial id>.pt`.

A policy file is a plain dict of tensors and numbers (`DeterministicPolicy.state`), so it
loads with `torch.load(..., weights_only=True)` and needs no class of a given version to be
read: the networks are rebuilt from the sizes it holds, the normalizer's statistics included.
Workers send the bytes back with the result; the driver writes them, atomically, before the
record, so every ok record of a learner has its policy. The references have none: random
holds no weights, and the expert is `results/experts/<env>/policy.pt`.
"""

from __future__ import annotations

import io
from pathlib import Path

import torch

from bench import atomic
from bench.rl.networks import DeterministicPolicy
from bench.rl.sac import DeterministicActor

FOLDER = "policies"


def path(results_dir: str | Path, trial_id: str) -> Path:
    return Path(results_dir) / FOLDER / f"{trial_id}.pt"


KINDS = {"gaussian-mean": DeterministicPolicy, "sac-actor": DeterministicActor}
"""What a file's `kind` rebuilds: the TRPO learners' mean policy, SAC's squashed-mean actor."""


def to_bytes(policy: object) -> bytes | None:
    """The file's bytes for a network policy; None for one without weights (random)."""
    if not isinstance(policy, tuple(KINDS.values())):
        return None
    buffer = io.BytesIO()
    torch.save(policy.state(), buffer)
    return buffer.getvalue()


def write(results_dir: str | Path, trial_id: str, data: bytes) -> Path:
    return atomic.write_bytes(path(results_dir, trial_id), data)


def load(file: str | Path) -> DeterministicPolicy | DeterministicActor:
    """The policy saved in `file`, ready to act: numpy observations in, actions out."""
    state = torch.load(file, weights_only=True)
    return KINDS[state["kind"]].from_state(state)
