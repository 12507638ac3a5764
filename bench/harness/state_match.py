"""How far a policy's states lie from the expert's: the imitation a return cannot see.

Where a task's reward is mostly a bonus for staying alive (InvertedDoublePendulum:
10 per step minus penalties worth 0.2% of the return), a policy that merely
survives scores like the expert, and the return cannot tell imitation from
survival. What can: an imitator should visit the states the expert visits. The
survival control holds the poles up with the cart wherever it drifted; an
imitator should hold them where the expert does.

The distance. Each state dimension's 1-Wasserstein distance between the
policy's visited states and the expert's (the area between the two quantile
functions), in units of that dimension's spread in the expert's states, then
averaged over dimensions. 0: the marginals match; 1: on average they are one
expert standard deviation apart. It compares marginals, not the joint
distribution, so it is a lower bound on how different the two are; it is
cheap, has no parameter to tune, and reads in the task's own units.
"""

from __future__ import annotations

import numpy as np

QUANTILES = 1000
"""Quantile levels the two distributions are compared at (mid-points of equal bins)."""
SCALE_FLOOR = 0.05
"""A dimension's scale is at least this fraction of the mean scale over dimensions: one the
expert holds (nearly) constant would otherwise turn tiny deviations into huge distances."""


def expert_scale(expert_states: np.ndarray) -> np.ndarray:
    """(O,) per-dimension scale of the (N, O) expert states: their std, floored at
    SCALE_FLOOR x the mean std (and at 1e-8 when the expert holds every dimension still)."""
    std = np.asarray(expert_states, dtype=np.float64).std(axis=0)
    return np.maximum(std, max(SCALE_FLOOR * std.mean(), 1e-8))


def wasserstein_per_dim(states: np.ndarray, expert_states: np.ndarray) -> np.ndarray:
    """(O,) 1-Wasserstein distance of each dimension's marginal, in expert-scale units."""
    states = np.asarray(states, dtype=np.float64)
    expert_states = np.asarray(expert_states, dtype=np.float64)
    if states.ndim != 2 or expert_states.ndim != 2 or states.shape[1] != expert_states.shape[1]:
        raise ValueError(
            f"need (N, O) states like the expert's, got {states.shape} and {expert_states.shape}"
        )
    levels = (np.arange(QUANTILES) + 0.5) / QUANTILES
    gap = np.quantile(states, levels, axis=0) - np.quantile(expert_states, levels, axis=0)
    return np.abs(gap).mean(axis=0) / expert_scale(expert_states)


def state_distance(states: np.ndarray, expert_states: np.ndarray) -> float:
    """Mean over dimensions of `wasserstein_per_dim`: 0 where the policy's states are
    distributed like the expert's; lower is closer."""
    return float(wasserstein_per_dim(states, expert_states).mean())
