"""Faster stepping of the PyBullet envs, with every trajectory unchanged to the bit.

Profiled on HalfCheetah under GAIfO, the physics is under a third of a step; the rest is the
envs' Python. Two patches, applied when the envs are registered (`bench.envs`), take the
largest parts of it away:

- `BulletClient.__getattr__` wraps the pybullet function in a new `functools.partial` on every
  attribute access (~40 a step). The bound function is kept in the instance instead.
- The locomotion robots' `calc_state` asks pybullet for each body part's pose and each
  joint's state one call at a time, and builds a 7-float array per part to keep 3 of them.
  Here the same values come from one `getLinkStates` and one `getJointStates` call per body,
  and the rest of the method is the library's (pybullet_envs_gymnasium 0.6, zlib licence).
- Their `apply_action` clips each action component and sets each joint's torque in a call of
  its own; here the same torques go in one `setJointMotorControlArray` call per body.

Same calls, same values, same float operations in the same order: `tests/test_envs.py` steps
every locomotion env with and without the patches and compares the observations bit for bit.
"""

from __future__ import annotations

import numpy as np
import pybullet

ORIGINALS: dict[str, object] = {}
"""The library's own methods, by name, for the test that compares them."""


def apply() -> None:
    """Patch once per process; call after pybullet_envs_gymnasium is imported."""
    from pybullet_envs_gymnasium.robot_locomotors import WalkerBase
    from pybullet_utils.bullet_client import BulletClient

    if ORIGINALS:
        return
    ORIGINALS["BulletClient.__getattr__"] = BulletClient.__getattr__
    ORIGINALS["WalkerBase.calc_state"] = WalkerBase.calc_state
    ORIGINALS["WalkerBase.apply_action"] = WalkerBase.apply_action
    apply_again()


def apply_again() -> None:
    """Put the patches (back) in place."""
    from pybullet_envs_gymnasium.robot_locomotors import WalkerBase
    from pybullet_utils.bullet_client import BulletClient

    BulletClient.__getattr__ = _bound_once
    WalkerBase.calc_state = _calc_state
    WalkerBase.apply_action = _apply_action


def restore() -> None:
    """Undo `apply` (for the comparison test)."""
    from pybullet_envs_gymnasium.robot_locomotors import WalkerBase
    from pybullet_utils.bullet_client import BulletClient

    BulletClient.__getattr__ = ORIGINALS["BulletClient.__getattr__"]
    WalkerBase.calc_state = ORIGINALS["WalkerBase.calc_state"]
    WalkerBase.apply_action = ORIGINALS["WalkerBase.apply_action"]


def _bound_once(self, name: str):
    attribute = ORIGINALS["BulletClient.__getattr__"](self, name)
    if name != "disconnect":  # it resets the client id: it stays the library's
        self.__dict__[name] = attribute
    return attribute


class _Layout:
    """Which pybullet bodies and indices a robot's parts and joints are, grouped per body."""

    def __init__(self, robot) -> None:
        self.parts = robot.parts  # the dict it was built from: rebuilt if the robot's changes
        parts = list(robot.parts.values())
        self.n_parts = len(parts)
        self.bases = [
            (i, p.bodies[p.bodyIndex]) for i, p in enumerate(parts) if p.bodyPartIndex < 0
        ]
        self.links = _grouped(
            [
                (i, p.bodies[p.bodyIndex], p.bodyPartIndex)
                for i, p in enumerate(parts)
                if p.bodyPartIndex >= 0
            ]
        )
        joints = robot.ordered_joints
        self.n_joints = len(joints)
        self.joints = _grouped(
            [(i, j.bodies[j.bodyIndex], j.jointIndex) for i, j in enumerate(joints)]
        )
        self.lower = np.array([j.lowerLimit for j in joints], np.float64)
        self.upper = np.array([j.upperLimit for j in joints], np.float64)


def _grouped(items: list[tuple[int, int, int]]) -> list[tuple[list[int], int, list[int]]]:
    """(row, body, index) triples -> per body: (rows, body, indices), in first-seen order."""
    groups: dict[int, tuple[list[int], list[int]]] = {}
    for row, body, index in items:
        rows, indices = groups.setdefault(body, ([], []))
        rows.append(row)
        indices.append(index)
    return [(rows, body, indices) for body, (rows, indices) in groups.items()]


def _layout(robot) -> _Layout:
    layout = robot.__dict__.get("_bench_layout")
    if layout is None or layout.parts is not robot.parts or layout.n_parts != len(robot.parts):
        layout = robot.__dict__["_bench_layout"] = _Layout(robot)
    return layout


def _apply_action(self, a):
    """WalkerBase.apply_action, one pybullet call per body."""
    assert np.isfinite(a).all()
    layout = _layout(self)
    clipped = np.clip(a, -1, +1)
    torques = [
        self.power * j.power_coef * float(c)
        for j, c in zip(self.ordered_joints, clipped, strict=True)
    ]
    for rows, body, indices in layout.joints:
        forces = [torques[n] for n in rows]
        self._p.setJointMotorControlArray(body, indices, pybullet.TORQUE_CONTROL, forces=forces)


def _calc_state(self):
    """WalkerBase.calc_state with its part poses and joint states read per body."""
    p, layout = self._p, _layout(self)
    pos = np.empty(layout.n_joints, np.float64)
    vel = np.empty(layout.n_joints, np.float64)
    for rows, body, indices in layout.joints:
        states = p.getJointStates(body, indices)
        pos[rows] = [s[0] for s in states]
        vel[rows] = [s[1] for s in states]
    # Joint.current_relative_position's arithmetic, element-wise in the same order
    scaled = 2 * (pos - layout.lower) / (layout.upper - layout.lower) - 1.0
    j = np.stack([scaled, 0.1 * vel], axis=1).astype(np.float32).flatten()
    # even elements [0::2] position, scaled to -1..+1 between limits
    # odd elements  [1::2] angular speed, scaled to show -1..+1
    self.joint_speeds = j[1::2]
    self.joints_at_limit = np.count_nonzero(np.abs(j[0::2]) > 0.99)

    body_pose = self.robot_body.pose()
    xyz = np.empty((layout.n_parts, 3), np.float64)
    for row, body in layout.bases:
        xyz[row] = p.getBasePositionAndOrientation(body)[0]
    for rows, body, indices in layout.links:
        xyz[rows] = [state[0] for state in p.getLinkStates(body, indices)]
    parts_xyz = xyz.flatten()
    self.body_xyz = (
        parts_xyz[0::3].mean(),
        parts_xyz[1::3].mean(),
        body_pose.xyz()[2],
    )  # torso z is more informative than mean z
    self.body_real_xyz = body_pose.xyz()
    self.body_rpy = body_pose.rpy()
    z = self.body_xyz[2]
    if self.initial_z is None:
        self.initial_z = z
    r, pitch, yaw = self.body_rpy
    self.walk_target_theta = np.arctan2(
        self.walk_target_y - self.body_xyz[1], self.walk_target_x - self.body_xyz[0]
    )
    self.walk_target_dist = np.linalg.norm(
        [self.walk_target_y - self.body_xyz[1], self.walk_target_x - self.body_xyz[0]]
    )
    angle_to_target = self.walk_target_theta - yaw

    rot_speed = np.array(
        [[np.cos(-yaw), -np.sin(-yaw), 0], [np.sin(-yaw), np.cos(-yaw), 0], [0, 0, 1]]
    )
    vx, vy, vz = np.dot(rot_speed, self.robot_body.speed())  # rotate speed back to body frame

    more = np.array(
        [
            z - self.initial_z,
            np.sin(angle_to_target),
            np.cos(angle_to_target),
            0.3 * vx,
            0.3 * vy,
            0.3 * vz,  # 0.3 is just scaling typical speed into -1..+1, no physical sense here
            r,
            pitch,
        ],
        dtype=np.float32,
    )
    return np.clip(np.concatenate([more, j, self.feet_contact]), -5, +5)
