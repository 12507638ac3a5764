"""PWIL's greedy coupling (Dadashi et al. 2021, Algorithm 1): an upper bound on the
Wasserstein distance between an agent's episode and the expert's states, paid step by step.

The expert's states are atoms of mass 1/N each. Each step of an agent's episode brings a mass of
1/T (T the horizon) and moves it onto the expert atoms nearest to its own state that have mass
left, nearest first, until its mass is spent; the step's cost is the mass it moved times the
distances it moved it. What an atom gives up is gone for the rest of the episode, so an agent
that stays near one expert state exhausts it and is paid less and less for staying: the
coupling matches the whole of the expert's visits, not the nearest of them.
"""

from __future__ import annotations

import numpy as np

SPARE = 1e-6
"""Taken off each step's mass (PWIL's own code does the same): T steps then never ask for more
mass than the N atoms hold, whatever the rounding of 1/N."""


def standardizer(atoms: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and scale of each feature of the (N, d) expert atoms, to measure distances in units
    of the expert's spread (PWIL's standardized Euclidean distance); a feature that never varies
    keeps its units (scale 1)."""
    mean, std = atoms.mean(axis=0), atoms.std(axis=0)
    return mean, np.where(std > 0, std, 1.0)


def couple(left: np.ndarray, distances: np.ndarray, mass: float) -> np.ndarray:
    """One step of each of E episodes: the (E,) costs of moving `mass` from each agent state
    onto the expert atoms, nearest first, given the (E, N) `distances` from each state to each
    atom, out of `left` (E, N), the mass each episode's atoms still hold, which it spends in
    place."""
    costs = np.zeros(len(distances))
    for e in range(len(distances)):
        held, reach = left[e], np.where(left[e] > 0, distances[e], np.inf)
        to_move = mass - SPARE
        while to_move > 0:
            j = int(reach.argmin())
            if not np.isfinite(reach[j]):
                break  # every atom spent: an episode longer than the horizon
            moved = min(to_move, held[j])
            costs[e] += moved * reach[j]
            held[j] -= moved
            to_move -= moved
            if held[j] <= 0:
                reach[j] = np.inf
    return costs
