"""Faster stepping of gymnasium's MuJoCo locomotion tasks, with every trajectory unchanged to the bit.

A v5 locomotion step is the simulator plus 20-40% of the envs' own Python (Hopper 0.37, Ant
0.24 of a random step on one core): `is_healthy` runs twice a step (once for the reward, once
for `terminated`), Hopper's and Ant's through a fresh `state_vector()` each time, Ant clips its
contact forces twice (observation and cost) and looks its torso up by name twice, and every
step re-checks the action's shape through `np.array` and recomputes `dt` through two
properties. Here each of those is done once, with the same numpy operations in the same
order, so observations, rewards, ends and infos are the library's to the bit
(`tests/test_envs.py` steps each task both ways, through falls and resets).

The fast step is bound to one env instance (`speed_up`), never patched into gymnasium's
classes: other code in the process, and subclasses of the tasks, step as the library does.
Only the exact v5 classes at their construction defaults are sped up (gymnasium 1.x; the
method bodies follow gymnasium 1.4's, MIT licence); anything else is left as it is.
"""

from __future__ import annotations

from collections.abc import Callable
from types import MethodType
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

from bench.envs import mujoco_batch

Step = Callable[[Any, np.ndarray], tuple]
_enabled = True


def set_enabled(enabled: bool) -> None:
    """Whether `speed_up` binds the fast step to envs made from now on (off: the library's
    step, the "before" of `benchmarks/throughput.py --library`)."""
    global _enabled
    _enabled = enabled


def speed_up(env: gym.Env) -> gym.Env:
    """Bind the fast step to `env`'s MuJoCo task where it is one of the four locomotion v5
    tasks with the options the fast step assumes; return `env` (changed in place) either way."""
    task = env.unwrapped
    fast = _fast_step(task) if _enabled else None
    if fast is not None:
        # `dt`, as the library's property computes it, once
        task._step_dt = task.model.opt.timestep * task.frame_skip
        task.step = MethodType(fast, task)
        mujoco_batch.bind(env)  # and E of them at once, where a collector steps several
    return env


def _fast_step(task: Any) -> Step | None:
    """The fast step for `task`'s class, or None where this module does not cover it."""
    from gymnasium.envs.mujoco.ant_v5 import AntEnv
    from gymnasium.envs.mujoco.half_cheetah_v5 import HalfCheetahEnv
    from gymnasium.envs.mujoco.hopper_v5 import HopperEnv
    from gymnasium.envs.mujoco.walker2d_v5 import Walker2dEnv

    if getattr(task, "render_mode", None) == "human":
        return None  # the library's step renders each frame: leave it
    covered = {HopperEnv: _hopper, Walker2dEnv: _walker2d, HalfCheetahEnv: _half_cheetah}
    if type(task) in covered:
        return covered[type(task)] if task._exclude_current_positions_from_observation else None
    if type(task) is AntEnv:
        plain_ant = (
            task._exclude_current_positions_from_observation
            and task._include_cfrc_ext_in_observation
        )
        return _ant if plain_ant else None
    return None


def _simulate(task: Any, action: np.ndarray) -> None:
    """`MujocoEnv.do_simulation(action, frame_skip)`: the same check and the same calls."""
    if np.shape(action) != (task.model.nu,):
        raise ValueError(
            f"Action dimension mismatch. Expected {(task.model.nu,)}, found {np.shape(action)}"
        )
    task.data.ctrl[:] = action
    mujoco.mj_step(task.model, task.data, nstep=task.frame_skip)
    # force quantities (cfrc_ext) are filled only by this call, as in the library's step
    mujoco.mj_rnePostConstraint(task.model, task.data)


def _sum_of_squares(x: np.ndarray) -> Any:
    """`np.sum(np.square(x))` of an array, without `np.sum`'s dispatch: the same reduction."""
    return np.add.reduce(np.square(x), axis=None)


def _control_cost(task: Any, action: np.ndarray) -> Any:
    return task._ctrl_cost_weight * _sum_of_squares(action)


def _planar_advance(task: Any, action: np.ndarray, clip_velocity: bool) -> tuple:
    """Simulate one step of a planar task (Hopper, Walker2d, HalfCheetah): its x position after,
    its x velocity and its observation (velocities clipped to +-10 where `clip_velocity`, as
    Hopper's and Walker2d's are)."""
    qpos = task.data.qpos
    x_position_before = qpos[0]
    _simulate(task, action)
    x_position_after = qpos[0]
    x_velocity = (x_position_after - x_position_before) / task._step_dt
    velocity = task.data.qvel.flatten()
    if clip_velocity:
        velocity = velocity.clip(-10, 10)  # np.clip, undispatched
    observation = np.concatenate((qpos.flatten()[1:], velocity)).ravel()
    return x_position_after, x_velocity, observation


def _planar_walker_step(task: Any, action: np.ndarray, healthy: Callable[[Any], Any]) -> tuple:
    """Hopper's and Walker2d's step (the same code but for `is_healthy`), `healthy` run once."""
    x_position_after, x_velocity, observation = _planar_advance(task, action, clip_velocity=True)
    qpos = task.data.qpos
    is_healthy = healthy(task)
    forward_reward = task._forward_reward_weight * x_velocity
    healthy_reward = is_healthy * task._healthy_reward
    ctrl_cost = _control_cost(task, action)
    reward = (forward_reward + healthy_reward) - ctrl_cost
    terminated = (not is_healthy) and task._terminate_when_unhealthy
    info = {
        "x_position": x_position_after,
        "z_distance_from_origin": qpos[1] - task.init_qpos[1],
        "x_velocity": x_velocity,
        "reward_forward": forward_reward,
        "reward_ctrl": -ctrl_cost,
        "reward_survive": healthy_reward,
    }
    return observation, reward, terminated, False, info


def _hopper_healthy(task: Any) -> bool:
    qpos = task.data.qpos
    state = np.concatenate([qpos.flat, task.data.qvel.flat])[2:]
    z, angle = qpos[1:3]
    min_state, max_state = task._healthy_state_range
    min_z, max_z = task._healthy_z_range
    min_angle, max_angle = task._healthy_angle_range
    healthy_state = np.logical_and(min_state < state, state < max_state).all()
    healthy_z = min_z < z < max_z
    healthy_angle = min_angle < angle < max_angle
    return all((healthy_state, healthy_z, healthy_angle))


def _walker2d_healthy(task: Any) -> Any:
    z, angle = task.data.qpos[1:3]
    min_z, max_z = task._healthy_z_range
    min_angle, max_angle = task._healthy_angle_range
    healthy_z = min_z < z < max_z
    healthy_angle = min_angle < angle < max_angle
    return healthy_z and healthy_angle


def _hopper(task: Any, action: np.ndarray) -> tuple:
    return _planar_walker_step(task, action, _hopper_healthy)


def _walker2d(task: Any, action: np.ndarray) -> tuple:
    return _planar_walker_step(task, action, _walker2d_healthy)


def _half_cheetah(task: Any, action: np.ndarray) -> tuple:
    x_position_after, x_velocity, observation = _planar_advance(task, action, clip_velocity=False)
    forward_reward = task._forward_reward_weight * x_velocity
    ctrl_cost = _control_cost(task, action)
    reward = forward_reward - ctrl_cost
    info = {
        "x_position": x_position_after,
        "x_velocity": x_velocity,
        "reward_forward": forward_reward,
        "reward_ctrl": -ctrl_cost,
    }
    return observation, reward, False, False, info


def _ant(task: Any, action: np.ndarray) -> tuple:
    data = task.data
    torso = data.xpos[task.model.body(task._main_body).id]  # data.body(main_body).xpos
    xy_position_before = torso[:2].copy()
    _simulate(task, action)
    xy_position_after = torso[:2].copy()
    xy_velocity = (xy_position_after - xy_position_before) / task._step_dt
    x_velocity, y_velocity = xy_velocity

    qpos, qvel = data.qpos, data.qvel
    min_force, max_force = task._contact_force_range
    contact_forces = data.cfrc_ext.clip(min_force, max_force)
    observation = np.concatenate((qpos.flatten()[2:], qvel.flatten(), contact_forces[1:].flatten()))

    state = np.concatenate([qpos.flat, qvel.flat])
    min_z, max_z = task._healthy_z_range
    is_healthy = np.isfinite(state).all() and min_z <= state[2] <= max_z
    forward_reward = x_velocity * task._forward_reward_weight
    healthy_reward = is_healthy * task._healthy_reward
    ctrl_cost = _control_cost(task, action)
    contact_cost = task._contact_cost_weight * _sum_of_squares(contact_forces)
    reward = (forward_reward + healthy_reward) - (ctrl_cost + contact_cost)
    terminated = (not is_healthy) and task._terminate_when_unhealthy
    origin = qpos[0:2]
    info = {
        "x_position": qpos[0],
        "y_position": qpos[1],
        "distance_from_origin": np.sqrt(origin.dot(origin)),  # np.linalg.norm(origin, ord=2)
        "x_velocity": x_velocity,
        "y_velocity": y_velocity,
        "reward_forward": forward_reward,
        "reward_ctrl": -ctrl_cost,
        "reward_contact": -contact_cost,
        "reward_survive": healthy_reward,
    }
    return observation, reward, terminated, False, info
