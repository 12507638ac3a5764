"""Env steps per second on one core: raw random stepping vs TRPO and GAIfO training.

    python benchmarks/throughput.py [--steps 60000] [--envs InvertedPendulumBulletEnv-v0 HopperBulletEnv-v0]
    python benchmarks/throughput.py --steps 60000 --envs HopperBulletEnv-v0 Hopper-v5 Walker2DBulletEnv-v0 \
        Walker2d-v5 HalfCheetahBulletEnv-v0 HalfCheetah-v5 AntBulletEnv-v0 Ant-v5   # both simulators
    python benchmarks/throughput.py --pixels --steps 10000   # from 64x64 frames (`observation: pixels`)
    python benchmarks/throughput.py --envs HopperBulletEnv-v0 --steps 5000 --sac 128 256   # SAC beside
    python benchmarks/throughput.py --envs HopperBulletEnv-v0 --steps 5000 --sac 256 --sac-device cpu cuda
    python benchmarks/throughput.py --library   # everything with the simulators' own stepping: the before

Prints one row per env. `raw (library)` steps the env as pybullet_envs_gymnasium or gymnasium
ships it, `raw` with `bench.envs.bullet_speed` or `bench.envs.mujoco_speed` (what every
trial runs; same trajectories). `envpool` steps the MuJoCo task in EnvPool's C++ batch (8
envs, one thread), where EnvPool is installed (`pip install envpool`); trials do not use it.
`TRPO` and `GAIfO` are training throughput (updates included; GAIfO's discriminator and
rewards too). `GAIfO 1-by-1` (MuJoCo) steps the collector's envs one at a time, as before
`bench.envs.mujoco_batch`. `physics` is the simulator's own rate on GAIfO's trajectories
(the time inside its C calls during that run, `physics_clock`), so `gaifo/physics` is the
share of training time the simulator takes: 1 would be training at the simulator's pace.
GAIfO needs the env's expert (for one demonstration).
With --pixels, raw stepping renders every frame and the networks are convolutional.
"""

from __future__ import annotations

import argparse
import contextlib
import time
from collections.abc import Iterator

import numpy as np
import torch

from bench import envs
from bench.envs import mujoco_batch, mujoco_speed
from bench.envs.pixels import PixelConfig
from bench.rl.shared_trunk import make_trpo
from bench.rl.trpo import TRPOConfig, train


def raw_steps_per_s(env_id: str, steps: int, pixels: PixelConfig | None = None) -> float:
    env = envs.make(env_id, 0, pixels)
    rng = np.random.default_rng(0)
    low, high = env.action_space.low, env.action_space.high
    actions = rng.uniform(low, high, size=(steps, len(low))).astype(np.float32)
    start = time.perf_counter()
    for a in actions:
        _, _, term, trunc, _ = env.step(a)
        if term or trunc:
            env.reset()
    elapsed = time.perf_counter() - start
    env.close()
    return steps / elapsed


@contextlib.contextmanager
def physics_clock() -> Iterator[list[float]]:
    """Seconds spent in the simulator while inside, accumulated in the list's one element.
    MuJoCo: what `MujocoEnv.do_simulation` runs (ctrl, `mj_step` x frame_skip,
    `mj_rnePostConstraint`), whether a task steps alone or E at a time. PyBullet: the scene's
    `stepSimulation` calls and the robot's state reads (`calc_state`, as
    `bench.envs.bullet_speed` makes it)."""
    import mujoco
    from pybullet_envs_gymnasium.robot_locomotors import WalkerBase
    from pybullet_envs_gymnasium.scene_abstract import Scene

    spent = [0.0]

    def timed(fn):
        def run(*args, **kwargs):
            start = time.perf_counter()
            out = fn(*args, **kwargs)
            spent[0] += time.perf_counter() - start
            return out

        return run

    def simulate(task, action):  # mujoco_speed._simulate, its shape check left out
        start = time.perf_counter()
        task.data.ctrl[:] = action
        mujoco.mj_step(task.model, task.data, nstep=task.frame_skip)
        mujoco.mj_rnePostConstraint(task.model, task.data)
        spent[0] += time.perf_counter() - start

    def simulate_all(tasks, actions):
        for task, action in zip(tasks, actions, strict=True):
            simulate(task, action)

    patched = [
        (mujoco_speed, "_simulate", simulate),
        (mujoco_batch, "_simulate", simulate_all),
        (Scene, "global_step", timed(Scene.global_step)),
        (WalkerBase, "calc_state", timed(WalkerBase.calc_state)),
    ]
    originals = [(owner, name, getattr(owner, name)) for owner, name, _ in patched]
    try:
        for owner, name, replacement in patched:
            setattr(owner, name, replacement)
        yield spent
    finally:
        for owner, name, original in originals:
            setattr(owner, name, original)


def batched_steps_per_s(env_id: str, steps: int, n_envs: int = 8) -> float:
    """Random stepping of `n_envs` copies of `env_id` in EnvPool's batch, on one thread (NaN
    where EnvPool is missing or has no such task)."""
    try:
        import envpool
    except ImportError:
        return float("nan")
    if env_id not in envpool.list_all_envs():
        return float("nan")
    env = envpool.make_gymnasium(env_id, num_envs=n_envs, seed=0, num_threads=1)
    env.reset()
    low, high = env.action_space.low, env.action_space.high
    rounds = steps // n_envs
    actions = np.random.default_rng(0).uniform(low, high, (rounds, n_envs, len(low)))
    start = time.perf_counter()
    for a in actions.astype(np.float32):
        env.step(a)  # EnvPool resets a finished env on the next step by itself
    elapsed = time.perf_counter() - start
    env.close()
    return rounds * n_envs / elapsed


def trpo_steps_per_s(env_id: str, steps: int, pixels: PixelConfig | None = None) -> float:
    cfg = TRPOConfig()
    obs_dim, act_dim, _, _ = envs.spaces(env_id, pixels)
    timings: list[tuple[int, float]] = []
    start = time.perf_counter()
    train(
        lambda s: envs.make(env_id, s, pixels),
        steps,
        seed=0,
        callback=lambda n, *_: timings.append((n, time.perf_counter() - start)),
        learner=make_trpo(obs_dim if pixels is None else pixels.shape, act_dim, cfg, 0),
    )
    # Skip the first update: env construction and first-call costs are not throughput.
    (n0, t0), (n1, t1) = timings[0], timings[-1]
    return (n1 - n0) / (t1 - t0)


def gaifo_steps_per_s(
    env_id: str, steps: int, pixels: PixelConfig | None = None
) -> tuple[float, float]:
    """GAIfO from one demonstration, timed like `trpo_steps_per_s` (same TRPO settings): its
    steps per second, and the share of its time spent in the simulator (`physics_clock`), which
    is its rate over the simulator's own on the same trajectories."""
    from algorithms import gaifo
    from algorithms.adversarial import AdversarialConfig
    from bench import paths
    from bench.demos import pools
    from bench.harness.registry import Task

    if not paths.has_expert(env_id):
        return float("nan"), float("nan")
    obs_dim, act_dim, low, high = envs.spaces(env_id, pixels)
    demo = pools.load_demos(pools.ensure_pool(env_id, pixels), env_id, 1, 0, pixels)
    timings: list[tuple[int, float]] = []
    start = time.perf_counter()

    task = Task(
        env_id, obs_dim, act_dim, low, high, lambda s: envs.make(env_id, s, pixels), pixels=pixels
    )
    with physics_clock() as physics:

        class Clock:
            def checkpoint(self, env_steps, policy):
                timings.append((env_steps, time.perf_counter() - start, physics[0]))

            def log(self, env_steps, **scalars):
                pass

        gaifo.train(task, demo, steps, 0, Clock(), AdversarialConfig())
    (n0, t0, p0), (n1, t1, p1) = timings[0], timings[-1]
    return (n1 - n0) / (t1 - t0), (p1 - p0) / (t1 - t0)


def sac_steps_per_s(env_id: str, steps: int, hidden: tuple[int, ...], device: str = "cpu") -> float:
    """SAC on the env's reward, one update per env step (its default), timed after the random
    warm-up: what the off-policy learners cost per env step once they learn. `device`: where
    its networks and updates run (the envs and the replay buffer stay on the CPU)."""
    from bench.rl import sac

    cfg = sac.SACConfig(hidden=hidden, learning_starts=1000, device=device)
    timings: list[tuple[int, float]] = []
    start = time.perf_counter()
    sac.train(
        lambda s: envs.make(env_id, s),
        cfg.learning_starts + steps,
        0,
        cfg,
        callback=lambda n, *_: timings.append((n, time.perf_counter() - start)),
        report_every=500,
    )
    learning = [(n, t) for n, t in timings if n > cfg.learning_starts]
    (n0, t0), (n1, t1) = learning[0], learning[-1]
    return (n1 - n0) / (t1 - t0)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--steps", type=int, default=60_000)
    parser.add_argument(
        "--envs", nargs="+", default=["InvertedPendulumBulletEnv-v0", "HopperBulletEnv-v0"]
    )
    parser.add_argument("--pixels", action="store_true", help="observe stacked grayscale frames")
    parser.add_argument(
        "--frame-size", type=int, default=PixelConfig.size, help="frame side with --pixels"
    )
    parser.add_argument(
        "--sac",
        type=int,
        nargs="+",
        metavar="WIDTH",
        help="also SAC (one update per env step) with WIDTH x WIDTH networks, e.g. --sac 128 256;"
        " --steps then counts its learning steps",
    )
    parser.add_argument(
        "--sac-device",
        nargs="+",
        default=["cpu"],
        metavar="DEVICE",
        help="where SAC's updates run, each in turn, e.g. --sac-device cpu cuda",
    )
    parser.add_argument(
        "--library",
        action="store_true",
        help="run everything with the simulators' own stepping (bench.envs.bullet_speed and"
        " bench.envs.mujoco_speed off)",
    )
    args = parser.parse_args()
    pixels = PixelConfig(size=args.frame_size) if args.pixels else None
    torch.set_num_threads(1)
    pybullet = [e for e in args.envs if envs.is_pybullet(e)]
    if pybullet:
        from bench.envs import bullet_speed

        envs.make(pybullet[0], 0).close()  # registers the envs, and with them the patches
    header = (
        "env", "raw (library)", "raw", "envpool", "TRPO", "GAIfO 1-by-1", "GAIfO", "physics",
        "gaifo/phys 1-by-1", "gaifo/physics",
    )  # fmt: skip
    print("steps per second, one core" + (" (--library: no speed patches)" if args.library else ""))
    print(f"{header[0]:24s}" + "".join(f"{h:>14s}" for h in header[1:-2]), *header[-2:])
    for env_id in args.envs:
        batched, one_by_one, one_by_one_share = float("nan"), float("nan"), float("nan")
        if envs.is_pybullet(env_id):
            bullet_speed.restore()
            library = raw_steps_per_s(env_id, args.steps, pixels)
            if not args.library:
                bullet_speed.apply_again()
            raw = raw_steps_per_s(env_id, args.steps, pixels)
        else:
            mujoco_speed.set_enabled(False)
            library = raw_steps_per_s(env_id, args.steps, pixels)
            mujoco_speed.set_enabled(not args.library)
            raw = raw_steps_per_s(env_id, args.steps, pixels)
            batched = batched_steps_per_s(env_id, args.steps) if pixels is None else float("nan")
            if not args.library:
                mujoco_batch.set_enabled(False)  # the collectors step their envs one at a time
                one_by_one, one_by_one_share = gaifo_steps_per_s(env_id, args.steps, pixels)
                mujoco_batch.set_enabled(True)
        trpo = trpo_steps_per_s(env_id, args.steps, pixels)
        gaifo, share = gaifo_steps_per_s(env_id, args.steps, pixels)
        print(
            f"{env_id:24s}{library:14,.0f}{raw:14,.0f}{batched:14,.0f}{trpo:14,.0f}"
            f"{one_by_one:14,.0f}{gaifo:14,.0f}{gaifo / share:14,.0f}"
            f"{one_by_one_share:18.2f}{share:14.2f}",
            flush=True,
        )
        for width in args.sac or []:
            for device in args.sac_device:
                off = sac_steps_per_s(env_id, args.steps, (width, width), device)
                print(
                    f"  SAC {width} x {width} on {device}: {off:,.0f} steps/s"
                    f" ({trpo / off:.1f}x TRPO's cost per step)"
                )


if __name__ == "__main__":
    main()
