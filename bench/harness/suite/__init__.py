"""Suite files: YAML -> validated `Suite` -> list[TrialSpec].

A suite names everything one experiment runs::

    name: quick            # optional, defaults to the file stem; results go to results/<name>/
    envs:                  # env id -> settings; budget = env steps per training trial
      InvertedPendulumBulletEnv-v0: {budget: 100000}
      # optional per env: dataset (a Minari dataset's demos instead of the shipped expert's),
      # observation: pixels (learners see stacked 64x64 grayscale frames, demos are video),
      # or video-reward (learners act on states, demos are video: not the paper's setting);
      # with either, frame_size: 32 (frame side in pixels, default 64; ~3.5x cheaper per step);
      # trpo: {n_envs: 16} (TRPO settings for every TRPO learner on this env, e.g. its batch,
      # so the survival control stays matched; an algorithm's own setting wins);
      # hyperparams: {disc_steps: 25} (settings for every algorithm on this env that has
      # them, e.g. the adversarial learners' discriminator pace; an algorithm's own wins);
      # seeds: {gaifo: 5, bco: 3} (seeds per algorithm or label on this env, over the
      # entry's and the suite's: a dear env runs fewer; 0: the algorithm does not run here)
    demos: [1, 5, 10, 25]  # demonstration counts: distinct ints in 1..DEMO_POOL_SIZE
    algorithms:            # a name, or {name: {hyperparameter: value}}
      - random
      - expert
      - gaifo: {disc_lr: 0.001}
    seeds: 10              # a count (seeds 0..n-1) or a list of distinct ints >= 0; default 10
    eval_episodes: 10      # episodes per evaluation; default 10
    curve_points: 10       # learning-curve evaluations per trial (5 episodes each); default 10
    runner: {jobs: 2, backend: loky}   # optional; jobs >= 1 or -1 (all cores), backend loky|dask;
                           # first: [gaifo, gail] runs those algorithms' trials before the rest

Everything is checked before any work starts: unknown keys, wrong types,
unknown algorithms, hyperparameters and env ids, and a missing expert (every
suite needs one per env, since it defines a normalized score of 1). Each
problem raises `SuiteError`, whose message is one line: file, key path, what
was expected.
"""

from bench.demos.pools import POOL_SIZE as DEMO_POOL_SIZE
from bench.harness.suite.expand import seeds_of, select
from bench.harness.suite.load import load_suite
from bench.harness.suite.types import AlgorithmEntry, EnvSettings, RunnerSettings, Suite, SuiteError

__all__ = [
    "DEMO_POOL_SIZE",
    "AlgorithmEntry",
    "EnvSettings",
    "RunnerSettings",
    "Suite",
    "SuiteError",
    "load_suite",
    "seeds_of",
    "select",
]
