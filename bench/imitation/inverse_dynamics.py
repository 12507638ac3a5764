"""An inverse dynamics model, a = M(s, s'): what BCO labels the demonstrations' transitions with,
fitted on the agent's own (s, a, s')."""

from __future__ import annotations

import numpy as np
import torch
from torch import nn

from bench.rl.networks import RunningNorm, mlp


class TransitionRows:
    """The agent's own (s, a, s'), appended chunk by chunk and read as one set of arrays.

    BCO refits M on every transition so far after each chunk. Concatenating the chunks anew
    each time copied the whole set per iteration (1.6 GB, 400 times, in a 2M-step Ant-v5
    trial); here each row is written once into arrays that grow by doubling, and `tensors` is
    a view of the rows so far. Each column takes the dtype `np.concatenate` would give its
    chunks, so what M is fitted on is the same to the bit.
    """

    def __init__(self) -> None:
        self._columns: list[np.ndarray] = []
        self._n = 0

    def __len__(self) -> int:
        return self._n

    def append(self, *chunk: np.ndarray) -> None:
        if not self._columns:
            self._columns = [np.empty((0, *x.shape[1:]), x.dtype) for x in chunk]
        start, end = self._n, self._n + len(chunk[0])
        room = len(self._columns[0])
        room = max(end, 2 * room) if end > room else room
        for i, x in enumerate(chunk):
            column = self._columns[i]
            dtype = np.result_type(column, x)
            if room > len(column) or dtype != column.dtype:
                self._columns[i] = np.empty((room, *column.shape[1:]), dtype)
                self._columns[i][:start] = column[:start]
            self._columns[i][start:end] = x
        self._n = end

    def tensors(self) -> tuple[torch.Tensor, ...]:
        """(s, a, s') of every row so far, as views (later appends never change them)."""
        return tuple(torch.from_numpy(c[: self._n]) for c in self._columns)


class InverseModel(nn.Module):
    """Predicts the action taken between raw s and s': (B, O), (B, O) -> (B, A).

    Inputs are s and the change s' - s, each with its own running normalizer: the change is
    what the action explains, and it is orders of magnitude smaller than s.
    """

    def __init__(self, obs_dim: int, act_dim: int, hidden: tuple[int, ...]) -> None:
        super().__init__()
        self.s_norm, self.d_norm = RunningNorm(obs_dim), RunningNorm(obs_dim)
        self.net = mlp([2 * obs_dim, *hidden, act_dim], nn.ReLU)

    def update_norms(self, s: np.ndarray, s_next: np.ndarray) -> None:
        self.s_norm.update(s)
        self.d_norm.update(s_next - s)

    def forward(self, s: torch.Tensor, s_next: torch.Tensor) -> torch.Tensor:
        return self.net(torch.cat([self.s_norm(s), self.d_norm(s_next - s)], dim=1))


def fit_inverse(
    model: InverseModel,
    opt: torch.optim.Optimizer,
    data: tuple[torch.Tensor, torch.Tensor, torch.Tensor],
    steps: int,
    minibatch: int,
    gen: torch.Generator,
) -> float:
    """`steps` Adam steps of MSE on minibatches of (s, a, s'); returns the last loss."""
    s, a, s_next = data
    loss = torch.zeros(())
    for _ in range(steps):
        idx = torch.randint(len(s), (minibatch,), generator=gen)
        loss = (model(s[idx], s_next[idx]) - a[idx]).square().mean()
        opt.zero_grad()
        loss.backward()
        opt.step()
    return loss.item()


@torch.no_grad()
def inverse_error(
    model: InverseModel, data: tuple[torch.Tensor, torch.Tensor, torch.Tensor]
) -> dict[str, float]:
    """Held-out MSE, and R^2 = 1 - MSE / Var(a) over all action dimensions."""
    s, a, s_next = data
    mse = (model(s, s_next) - a).square().mean(0)
    return {
        "inverse_val_mse": mse.mean().item(),
        "inverse_val_r2": 1.0
        - (mse.sum() / a.var(0, unbiased=False).sum().clamp_min(1e-12)).item(),
    }
