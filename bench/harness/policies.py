"""Each trial's final policy, kept beside its record: `<results>/policies/<trial id>.pt`.

A policy file is a plain dict of tensors and numbers (`DeterministicPolicy.state`), so it
loads with `torch.load(..., weights_only=True)` and needs no class of a given version to be
read: the networks are rebuilt from the sizes it holds, the normalizer's statistics included.
Any policy that can say so is kept the same way, a plugin's too: one with a `state()` of
tensors, numbers and lists, and a `from_state(state)` classmethod that rebuilds it.
Workers send the bytes back with the result; the driver writes them, atomically, before the
record, so every ok record of a learner has its policy. The references have none: random
holds no weights, and the expert is `results/experts/<env>/policy.pt`.
"""

from __future__ import annotations

import importlib
import io
from pathlib import Path
from typing import Any

import torch

from bench import atomic
from bench.errors import BadInput
from bench.rl.networks import DeterministicPolicy
from bench.rl.sac import DeterministicActor

FOLDER = "policies"


def path(results_dir: str | Path, trial_id: str) -> Path:
    return Path(results_dir) / FOLDER / f"{trial_id}.pt"


KINDS = {"gaussian-mean": DeterministicPolicy, "sac-actor": DeterministicActor}
"""What a built-in file's `kind` rebuilds: the TRPO learners' mean policy, SAC's (and TD3's)
squashed-mean actor. Any other policy's file names its class (CLASS: "module:qualname")."""
CLASS = "class"


def to_bytes(policy: object) -> bytes | None:
    """The file's bytes for a policy that can be rebuilt (`state()` and `from_state`); None
    for one that cannot (random's, which holds no weights, or a plain function)."""
    cls = type(policy)
    if not (
        callable(getattr(policy, "state", None)) and callable(getattr(cls, "from_state", None))
    ):
        return None
    state = policy.state()
    if KINDS.get(state.get("kind")) is not cls:  # a plugin's: its file says what rebuilds it
        state = {**state, CLASS: f"{cls.__module__}:{cls.__qualname__}"}
    buffer = io.BytesIO()
    torch.save(state, buffer)
    return buffer.getvalue()


def write(results_dir: str | Path, trial_id: str, data: bytes) -> Path:
    return atomic.write_bytes(path(results_dir, trial_id), data)


class PolicyError(BadInput, ValueError):
    """A policy file that cannot be loaded as one, or that names code it may not."""


def from_bytes(data: bytes) -> Any:
    """The policy `to_bytes` gave these bytes for, as `load` rebuilds it from its file: a trial
    checks its policy this way before it is recorded ok (one that cannot be rebuilt would fail
    only later, in a video)."""
    return load(io.BytesIO(data), "the trained policy")


def load(file: str | Path | io.BytesIO, name: str | None = None) -> Any:
    """The policy saved in `file`, ready to act: numpy observations in, actions out.

    A file is data: what it may name to rebuild it is a closed set, the built-in kinds and the
    classes of registered algorithms' own packages; anything else is refused in one line
    before it is imported. `name`: what messages call it (default: the file's path)."""
    name = name or str(file)
    try:
        state = torch.load(file, weights_only=True)
    except Exception as e:  # a malicious pickle (refused by weights_only), a torn file
        raise PolicyError(f"{name}: not a policy file ({type(e).__name__})") from None
    if not isinstance(state, dict):
        raise PolicyError(f"{name}: not a policy file (no state dict)")
    if CLASS not in state:
        if state.get("kind") not in KINDS:
            raise PolicyError(f"{name}: unknown policy kind {str(state.get('kind'))[:40]!r}")
        return KINDS[state["kind"]].from_state(state)
    module, _, qualname = str(state[CLASS]).partition(":")
    if module.split(".")[0] not in _registered_packages():
        raise PolicyError(
            f"{name}: names {module[:60]!r}, which is no registered algorithm's package"
        )
    cls: Any = importlib.import_module(module)
    for part in qualname.split("."):
        cls = getattr(cls, part, None)
    if not isinstance(cls, type) or not callable(getattr(cls, "from_state", None)):
        raise PolicyError(f"{name}: names {state[CLASS][:60]!r}, which is no policy class")
    return cls.from_state(state)


def _registered_packages() -> set[str]:
    """The top-level packages that registered algorithms (their train functions) live in."""
    from bench.harness import registry

    return {a.train.__module__.split(".")[0] for a in registry.all_algorithms().values()}
