"""The MuJoCo v5 locomotion tasks stepped E at a time, every value the library's to the bit.

A trial's collector steps its E envs one after another (`bench.rl.rollout`). Per env and step,
the simulator is one C call; around it, the task's Python (observation, reward, health, the
time limit's wrappers) costs as much again on Hopper and more on HalfCheetah, whose physics is
cheapest. Here the physics still runs env by env (`mj_step` as `MujocoEnv.do_simulation` calls
it), but what the task computes from the new states is computed for all E at once, as (E, ...)
arrays with the same numpy operations in the same order: the same observations, rewards,
terminations and truncations (`tests/test_mujoco_batch.py` steps each task both ways through
falls, time limits and resets). Infos are not built: the collectors read none.

`bench.envs.mujoco_speed.speed_up` calls `bind` on an env whose task it sped up (one of
the four, at the options it covers): where the env is exactly `TimeLimit(OrderEnforcing(task))`,
it gets a `step_together` attribute (the protocol `bench.rl.rollout.StepTogether`); any other
env keeps stepping one at a time.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np
from gymnasium.wrappers import OrderEnforcing, TimeLimit

Stepped = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
"""(E, O) float64 observations, (E,) float64 rewards, (E,) bool terminated, (E,) bool truncated."""


_enabled = True


def set_enabled(enabled: bool) -> None:
    """Whether `bind` gives envs made from now on their batched step (off: one by one, the
    "before" of `benchmarks/throughput.py`)."""
    global _enabled
    _enabled = enabled


def bind(env: gym.Env) -> gym.Env:
    """Give `env` its task's batched step, where there is one for it; return `env`."""
    fast = _batched_step(env) if _enabled else None
    if fast is not None:
        env.step_together = fast  # type: ignore[attr-defined]
    return env


def _batched_step(env: gym.Env) -> Callable[[Sequence[gym.Env], np.ndarray], Stepped] | None:
    if type(env) is not TimeLimit or type(env.env) is not OrderEnforcing:
        return None
    task = env.env.env
    from gymnasium.envs.mujoco.ant_v5 import AntEnv
    from gymnasium.envs.mujoco.half_cheetah_v5 import HalfCheetahEnv
    from gymnasium.envs.mujoco.hopper_v5 import HopperEnv
    from gymnasium.envs.mujoco.walker2d_v5 import Walker2dEnv

    covered = {HopperEnv: _hopper, Walker2dEnv: _walker2d, HalfCheetahEnv: _half_cheetah}
    covered[AntEnv] = _ant
    return covered.get(type(task))


def _tasks(envs: Sequence[gym.Env], actions: np.ndarray) -> list[Any]:
    """The tasks under the wrappers, after the check `MujocoEnv.do_simulation` makes of each
    action and the order check `OrderEnforcing.step` makes."""
    tasks = [env.env.env for env in envs]
    nu = tasks[0].model.nu
    if actions.shape != (len(tasks), nu):
        raise ValueError(
            f"Action dimension mismatch. Expected {(len(tasks), nu)}, found {actions.shape}"
        )
    for env in envs:
        if not env.env._has_reset:
            raise gym.error.ResetNeeded("Cannot call env.step() before calling env.reset()")
    return tasks


def _simulate(tasks: list[Any], actions: np.ndarray) -> None:
    """`do_simulation(action, frame_skip)` of each task: the same calls in the same order."""
    for task, action in zip(tasks, actions, strict=True):
        task.data.ctrl[:] = action
        mujoco.mj_step(task.model, task.data, nstep=task.frame_skip)
        mujoco.mj_rnePostConstraint(task.model, task.data)


def _time_limits(envs: Sequence[gym.Env]) -> np.ndarray:
    """`TimeLimit.step`'s count and verdict for each env (its truncation)."""
    truncated = np.zeros(len(envs), bool)
    for i, env in enumerate(envs):
        env._elapsed_steps += 1
        truncated[i] = env._elapsed_steps >= env._max_episode_steps
    return truncated


def _control_costs(task: Any, actions: np.ndarray) -> np.ndarray:
    """Each row's `ctrl_cost_weight * np.sum(np.square(action))` (a reduction along each
    contiguous row sums as the 1-D one does)."""
    return task._ctrl_cost_weight * np.add.reduce(np.square(actions), axis=1)


def _planar(envs: Sequence[gym.Env], actions: np.ndarray, clip_velocity: bool) -> tuple:
    """Simulate a planar task's E envs (Hopper, Walker2d, HalfCheetah): their tasks, positions
    (E, nq), x velocities and observations."""
    tasks = _tasks(envs, actions)
    x_before = np.array([task.data.qpos[0] for task in tasks])
    _simulate(tasks, actions)
    qpos = np.stack([task.data.qpos for task in tasks])
    qvel = np.stack([task.data.qvel for task in tasks])
    x_velocity = (qpos[:, 0] - x_before) / tasks[0]._step_dt
    velocity = qvel.clip(-10, 10) if clip_velocity else qvel
    observation = np.concatenate((qpos[:, 1:], velocity), axis=1)
    return tasks, qpos, qvel, x_velocity, observation


def _planar_walker(envs: Sequence[gym.Env], actions: np.ndarray, hopper: bool) -> Stepped:
    tasks, qpos, qvel, x_velocity, observation = _planar(envs, actions, clip_velocity=True)
    task = tasks[0]
    z, angle = qpos[:, 1], qpos[:, 2]
    min_z, max_z = task._healthy_z_range
    min_angle, max_angle = task._healthy_angle_range
    healthy = (min_z < z) & (z < max_z) & (min_angle < angle) & (angle < max_angle)
    if hopper:
        state = np.concatenate((qpos, qvel), axis=1)[:, 2:]
        min_state, max_state = task._healthy_state_range
        healthy &= np.logical_and(min_state < state, state < max_state).all(axis=1)
    forward_reward = task._forward_reward_weight * x_velocity
    healthy_reward = healthy * task._healthy_reward
    reward = (forward_reward + healthy_reward) - _control_costs(task, actions)
    terminated = ~healthy & task._terminate_when_unhealthy
    return observation, reward, terminated, _time_limits(envs)


def _hopper(envs: Sequence[gym.Env], actions: np.ndarray) -> Stepped:
    return _planar_walker(envs, actions, hopper=True)


def _walker2d(envs: Sequence[gym.Env], actions: np.ndarray) -> Stepped:
    return _planar_walker(envs, actions, hopper=False)


def _half_cheetah(envs: Sequence[gym.Env], actions: np.ndarray) -> Stepped:
    tasks, _, _, x_velocity, observation = _planar(envs, actions, clip_velocity=False)
    task = tasks[0]
    reward = task._forward_reward_weight * x_velocity - _control_costs(task, actions)
    return observation, reward, np.zeros(len(tasks), bool), _time_limits(envs)


def _ant(envs: Sequence[gym.Env], actions: np.ndarray) -> Stepped:
    tasks = _tasks(envs, actions)
    task = tasks[0]
    torso = task.model.body(task._main_body).id
    xy_before = np.array([t.data.xpos[torso, :2] for t in tasks])
    _simulate(tasks, actions)
    xy_after = np.stack([t.data.xpos[torso, :2] for t in tasks])
    x_velocity = ((xy_after - xy_before) / task._step_dt)[:, 0]
    qpos = np.stack([t.data.qpos for t in tasks])
    qvel = np.stack([t.data.qvel for t in tasks])
    min_force, max_force = task._contact_force_range
    forces = np.stack([t.data.cfrc_ext for t in tasks]).clip(min_force, max_force)
    n = len(tasks)
    observation = np.concatenate((qpos[:, 2:], qvel, forces[:, 1:].reshape(n, -1)), axis=1)
    state = np.concatenate((qpos, qvel), axis=1)
    min_z, max_z = task._healthy_z_range
    healthy = np.isfinite(state).all(axis=1) & (min_z <= state[:, 2]) & (state[:, 2] <= max_z)
    forward_reward = x_velocity * task._forward_reward_weight
    healthy_reward = healthy * task._healthy_reward
    contact_cost = task._contact_cost_weight * np.add.reduce(
        np.square(forces.reshape(n, -1)), axis=1
    )
    costs = _control_costs(task, actions) + contact_cost
    reward = (forward_reward + healthy_reward) - costs
    terminated = ~healthy & task._terminate_when_unhealthy
    return observation, reward, terminated, _time_limits(envs)
