"""Batched on-policy collection over several envs in one process.

Envs are stepped one after another; the policy runs once per step on all of
their observations together, so inference costs ~1/E of a per-env forward.
Episodes carry over between batches: an env is reset only when its episode ends.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

import gymnasium as gym
import numpy as np
import torch

from bench.rl.episodes import Episode
from bench.rl.networks import GaussianPolicy, observation


@dataclass(frozen=True)
class Batch:
    """T steps from each of E envs. Arrays are (T, E, ...); `next_obs` is the true s'.

    At an episode's last step `next_obs` is its final observation (terminated
    or truncated), never the following episode's reset observation.
    """

    obs: np.ndarray
    """(T, E, O) float32 (uint8 for flat frames)."""
    actions: np.ndarray
    """(T, E, A) float32, as the policy gave them (before clipping to the action bounds)."""
    next_obs: np.ndarray
    """(T, E, O), like obs."""
    rewards: np.ndarray
    """(T, E) float32 env rewards."""
    terminated: np.ndarray
    """(T, E) bool: the episode ended in a terminal state (no bootstrap)."""
    truncated: np.ndarray
    """(T, E) bool: the episode was cut by its time limit (bootstrap from next_obs)."""
    timesteps: np.ndarray
    """(T, E) int64: index of the step within its episode (0 at reset)."""
    episode_returns: list[float]
    """Env returns of the episodes that finished during this batch."""
    frames: np.ndarray | None = None
    """(T, E, F) uint8 flat frames of obs, where the envs film themselves beside their state
    observations (`bench.envs.pixels.VideoBeside`: a reward judged on video); else None."""
    next_frames: np.ndarray | None = None
    """(T, E, F) frames of next_obs, like frames."""

    @property
    def n_steps(self) -> int:
        return self.rewards.size

    def flat(self, name: str) -> np.ndarray:
        """Field `name` with the (T, E) axes merged into one."""
        x = getattr(self, name)
        return x.reshape(-1, *x.shape[2:])

    def judged(self, name: str) -> np.ndarray:
        """What a reward judges of "obs" or "next_obs", flat: the observations, or where the envs
        film themselves beside states, the frames of them (shaped `Task.judged_shape`)."""
        frames = {"obs": "frames", "next_obs": "next_frames"}
        if name not in frames:
            raise ValueError(f'a reward judges "obs" or "next_obs", not {name!r}')
        return self.flat(name if self.frames is None else frames[name])


@dataclass(frozen=True)
class Rewards:
    """What a reward function returns beyond plain (T, E) rewards: a value for what follows a
    termination, and what it wants logged.

    See `bench.rl.absorbing`: a terminated step bootstraps from `after_termination`
    (the tail's discounted value) instead of from 0.
    """

    per_step: np.ndarray
    """(T, E) rewards of the batch's transitions."""
    after_termination: np.ndarray | None = None
    """(T, E): at a terminated step, the discounted value of what follows it; ignored elsewhere.
    None: what follows a termination is worth 0."""
    logged: dict[str, float] = field(default_factory=dict)
    """Diagnostics of this batch's rewards (D's accuracy, say): the loop logs them with the
    update's own."""


RewardFn = Callable[[Batch], "np.ndarray | Rewards"]
"""Replaces the env reward: Batch -> (T, E) rewards, a function of (obs, action, next_obs) (and
timestep); or `Rewards`, to value terminations or to log diagnostics."""


StepTogether = Callable[
    [list[gym.Env], np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
]
"""Steps E envs of one task at once, as each one's own `step` would: (E, A) actions -> (E, O)
observations, (E,) rewards, (E,) terminated, (E,) truncated. An env offers it as its
`step_together` attribute (`bench.envs.mujoco_batch` gives it to the MuJoCo locomotion
tasks); collectors use it where every env they step offers the same one."""


def step_together(envs: list[gym.Env]) -> StepTogether | None:
    """The batched step all of `envs` share, or None (step them one at a time)."""
    steps = {getattr(env, "step_together", None) for env in envs}
    return steps.pop() if len(steps) == 1 else None


class VecCollector:
    """Holds E live envs and collects `Batch`es from them, one batched policy call per step."""

    def __init__(self, envs: list[gym.Env], seed: int) -> None:
        self.envs = envs
        first = [Episode.begin(env, seed + i) for i, env in enumerate(envs)]
        self.obs = observation(np.stack([o for o, _, _ in first]))
        filmed = "frames" in first[0][1]
        self.frames = np.stack([info["frames"] for _, info, _ in first]) if filmed else None
        self.episodes = [episode for _, _, episode in first]
        self.t = np.zeros(len(envs), dtype=np.int64)
        self.ret = np.zeros(len(envs), dtype=np.float64)
        self.low = envs[0].action_space.low.astype(np.float32)
        self.high = envs[0].action_space.high.astype(np.float32)
        self.gen = torch.Generator().manual_seed(seed)
        self.together = None if filmed else step_together(envs)

    def collect(self, policy: GaussianPolicy, steps_per_env: int) -> Batch:
        """A batch from the Gaussian policy: a ~ N(policy(s), exp(log_std)), one forward per step."""
        std = policy.log_std.detach().exp()
        mean_action = policy.frozen_mean()  # the policy stays as it is until the batch is in

        @torch.no_grad()
        def sample(obs: np.ndarray) -> np.ndarray:
            mean = mean_action(torch.from_numpy(obs))
            return (mean + std * torch.randn(mean.shape, generator=self.gen)).numpy()

        return self.run(sample, steps_per_env)

    def run(self, act: Callable[[np.ndarray], np.ndarray], steps_per_env: int) -> Batch:
        """A batch from any batched policy `act`: (E, O) observations -> (E, A) actions."""
        T, E = steps_per_env, len(self.envs)
        obs_dim, act_dim = self.obs.shape[1], self.low.shape[0]
        obs = np.empty((T, E, obs_dim), self.obs.dtype)
        next_obs = np.empty_like(obs)
        actions = np.empty((T, E, act_dim), np.float32)
        rewards = np.empty((T, E), np.float32)
        terminated = np.zeros((T, E), bool)
        truncated = np.zeros((T, E), bool)
        timesteps = np.empty((T, E), np.int64)
        ep_returns: list[float] = []
        filmed = self.frames is not None
        if filmed:
            frames = np.empty((T, *self.frames.shape), np.uint8)
            next_frames = np.empty_like(frames)
        for t in range(T):
            obs[t] = self.obs
            timesteps[t] = self.t
            if filmed:
                frames[t] = self.frames
            act_t = act(self.obs)
            actions[t] = act_t
            clipped = np.clip(act_t, self.low, self.high)
            if self.together is not None:
                self._step_together(
                    clipped, t, next_obs, rewards, terminated, truncated, ep_returns
                )
                continue
            for i, env in enumerate(self.envs):
                o, r, term, trunc, info = env.step(clipped[i])
                self.episodes[i].actions.append(clipped[i])
                next_obs[t, i] = o
                if filmed:
                    next_frames[t, i] = info["frames"]
                rewards[t, i] = r
                self.ret[i] += r
                self.t[i] += 1
                if term or trunc:
                    terminated[t, i], truncated[t, i] = term, trunc and not term
                    ep_returns.append(float(self.ret[i]))
                    o, info, self.episodes[i] = Episode.begin(env)
                    self.ret[i], self.t[i] = 0.0, 0
                self.obs[i] = o
                if filmed:
                    self.frames[i] = info["frames"]
        return Batch(
            obs,
            actions,
            next_obs,
            rewards,
            terminated,
            truncated,
            timesteps,
            ep_returns,
            frames if filmed else None,
            next_frames if filmed else None,
        )

    def _step_together(
        self,
        clipped: np.ndarray,
        t: int,
        next_obs: np.ndarray,
        rewards: np.ndarray,
        terminated: np.ndarray,
        truncated: np.ndarray,
        ep_returns: list[float],
    ) -> None:
        """`run`'s step t through the envs' batched step: the same values as stepping them one
        by one, written into the batch's arrays."""
        o, r, term, trunc = self.together(self.envs, clipped)
        for episode, action in zip(self.episodes, clipped, strict=True):
            episode.actions.append(action)
        next_obs[t] = o
        rewards[t] = r
        self.ret += r
        self.t += 1
        self.obs[:] = o
        terminated[t], truncated[t] = term, trunc & ~term
        for i in np.flatnonzero(term | trunc):
            ep_returns.append(float(self.ret[i]))
            self.obs[i], _, self.episodes[i] = Episode.begin(self.envs[i])
            self.ret[i], self.t[i] = 0.0, 0

    def state_dict(self) -> dict:
        """Where each env's episode stands (`Episode`), its step and return so far, and the
        action noise's generator (tensors and plain numbers: weights_only-safe)."""
        return {
            "episodes": [episode.state() for episode in self.episodes],
            "t": torch.from_numpy(self.t.copy()),
            "ret": torch.from_numpy(self.ret.copy()),
            "gen": self.gen.get_state(),
        }

    def load_state_dict(self, state: dict) -> None:
        """Bring fresh envs (of the same seeds) to where the saved ones were, by replaying each
        episode so far: their steps count again unless the caller stops the count."""
        self.episodes = [Episode.of_state(e) for e in state["episodes"]]
        for i, (env, episode) in enumerate(zip(self.envs, self.episodes, strict=True)):
            o, info = episode.replay(env)
            self.obs[i] = o
            if self.frames is not None:
                self.frames[i] = info["frames"]
        self.t, self.ret = state["t"].numpy().copy(), state["ret"].numpy().copy()
        self.gen.set_state(state["gen"])

    def close(self) -> None:
        for env in self.envs:
            env.close()


def checked_actions(actions: Any, n: int, shape: tuple[int, ...]) -> np.ndarray:
    """A policy's actions for n observations, as an array of n actions of the env's `shape`,
    all finite; else ValueError saying what was wrong. The harness trusts no learner's policy."""
    actions = np.asarray(actions)
    if actions.shape != (n, *shape):
        raise ValueError(
            f"the policy returned actions of shape {actions.shape} for {n} observations;"
            f" the env takes {(n, *shape)}"
        )
    if not np.all(np.isfinite(actions)):
        raise ValueError("the policy returned non-finite actions (NaN or inf)")
    return actions


def evaluate(
    policy: Callable[[np.ndarray], np.ndarray],
    envs: list[gym.Env],
    episodes: int,
    seed: int,
    visited: list[np.ndarray] | None = None,
) -> list[float]:
    """Returns of `episodes` full episodes of a deterministic numpy policy.

    Runs up to len(envs) episodes side by side so the policy sees one batch per
    step. Episode k resets with seed `seed + k`, and returns come back in
    episode order, so the result does not depend on how many envs are used.
    Given `visited`, every observation the policy acts on is appended to it, one (n, O) batch
    per step.
    """
    returns = np.full(episodes, np.nan)
    together = step_together(envs)

    def step(live: list[tuple[int, gym.Env]], acts: np.ndarray) -> Iterable[tuple]:
        """Each live env's (obs, reward, terminated, truncated) after its action."""
        stepping = [env for _, env in live]
        if together is None:
            return (env.step(a)[:4] for env, a in zip(stepping, acts, strict=True))
        return zip(*together(stepping, acts), strict=True)

    free = list(envs)
    live: list[tuple[int, gym.Env]] = []
    obs: list[np.ndarray] = []
    acc: list[float] = []
    next_episode = 0
    while next_episode < episodes or live:
        while free and next_episode < episodes:
            env = free.pop()
            o, _ = env.reset(seed=seed + next_episode)
            live.append((next_episode, env))
            obs.append(observation(o))
            acc.append(0.0)
            next_episode += 1
        batch = np.stack(obs)
        if visited is not None:
            visited.append(batch)
        acts = checked_actions(policy(batch), len(batch), live[0][1].action_space.shape)
        keep = []
        for j, ((k, env), (o, r, term, trunc)) in enumerate(
            zip(live, step(live, acts), strict=True)
        ):
            acc[j] += float(r)
            obs[j] = observation(o)
            if term or trunc:
                returns[k] = acc[j]
                free.append(env)
            else:
                keep.append(j)
        live = [live[j] for j in keep]
        obs = [obs[j] for j in keep]
        acc = [acc[j] for j in keep]
    return returns.tolist()
