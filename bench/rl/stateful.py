"""A learner's state as one dict of its parts, for snapshots (`bench.snapshots`): what a
module, an optimizer or a replay buffer says of itself (`state_dict`), a random generator's
state, a tensor's values. Loading puts each back in place, so lists of parameters and
optimizers that point at them stay valid."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import torch


def state_of(parts: Mapping[str, Any]) -> dict[str, Any]:
    """The state of each part: a `torch.Generator`'s, a tensor's values, else its `state_dict()`."""
    out: dict[str, Any] = {}
    for name, part in parts.items():
        if isinstance(part, torch.Generator):
            out[name] = part.get_state()
        elif isinstance(part, torch.Tensor):
            out[name] = part.detach().cpu().clone()
        else:
            out[name] = part.state_dict()
    return out


def load_into(parts: Mapping[str, Any], state: Mapping[str, Any]) -> None:
    """Put each part's state (from `state_of`) back into the part itself."""
    for name, part in parts.items():
        if isinstance(part, torch.Generator):
            part.set_state(state[name])
        elif isinstance(part, torch.Tensor):
            with torch.no_grad():
                part.copy_(state[name])
        else:
            part.load_state_dict(state[name])


class Stateful:
    """`state_dict` and `load_state_dict` of an object from its `parts()`, as named above."""

    def parts(self) -> dict[str, Any]:
        raise NotImplementedError

    def state_dict(self) -> dict[str, Any]:
        return state_of(self.parts())

    def load_state_dict(self, state: dict[str, Any]) -> None:
        load_into(self.parts(), state)
