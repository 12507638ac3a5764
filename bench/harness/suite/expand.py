"""A suite -> its trials: env x demo count x algorithm x seed, each config resolved (defaults,
the env's settings, the entry's overrides) so that a trial's id hashes all of it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from bench.harness import registry
from bench.harness.suite import resolve
from bench.harness.suite.types import AlgorithmEntry, EnvSettings, Suite, SuiteError
from bench.harness.types import TrialSpec


def expand(suite: Suite, configs: dict[tuple[str, str], Any]) -> list[TrialSpec]:
    """All trials of a suite, in a fixed order, each carrying its algorithm's config on its
    env (`configs`, by env id and shown name: `checks.build_configs`).

    Per env: the algorithms that take no demonstrations (once per seed, with
    n_demos=0), then demo count x algorithm x seed for the others.
    """
    return [spec for env in suite.envs for spec in env_trials(suite, env, configs)]


def env_trials(
    suite: Suite, env: EnvSettings, configs: dict[tuple[str, str], Any]
) -> list[TrialSpec]:
    """One env's trials; the seeds and demo counts of an entry share its one config."""
    resolved = {a.shown: resolve.as_json(configs[env.env_id, a.shown]) for a in suite.algorithms}

    def spec(algo: AlgorithmEntry, n_demos: int, seed: int) -> TrialSpec:
        return TrialSpec(
            suite=suite.name,
            env_id=env.env_id,
            algorithm=algo.name,
            n_demos=n_demos,
            seed=seed,
            budget=env.budget,
            eval_episodes=suite.eval_episodes,
            hyperparams=dict(resolved[algo.shown]),
            label=algo.label,
            dataset=env.dataset,
            observation=env.observation,
            frame_size=env.frame_size,
            curve_points=suite.curve_points,
            code=registry.get(algo.name).code,
            kernels=None if suite.kernels == "native" else suite.kernels,
            config=configs[env.env_id, algo.shown],
        )

    no_demos = [a for a in suite.algorithms if not a.uses_demos]
    with_demos = [a for a in suite.algorithms if a.uses_demos]
    return [spec(a, 0, s) for a in no_demos for s in seeds_of(suite, env, a)] + [
        spec(a, n, s) for n in suite.demos for a in with_demos for s in seeds_of(suite, env, a)
    ]


def seeds_of(suite: Suite, env: EnvSettings, algo: AlgorithmEntry) -> tuple[int, ...]:
    """An entry's seeds on an env: the env's for it (by label, then by name), else the
    entry's own, else the suite's."""
    for name in (algo.shown, algo.name):
        if name in env.seeds:
            return env.seeds[name]
    return algo.seeds or suite.seeds


def select(
    specs: list[TrialSpec],
    source: str | Path,
    env: list[str] | None = None,
    algorithm: list[str] | None = None,
    demos: list[int] | None = None,
) -> list[TrialSpec]:
    """The trials of some envs, algorithms and/or demonstration counts only (None: all); ids
    are unchanged. A demo count keeps the trials that take no demonstrations (random, expert,
    the controls), which every count is normalized and compared against.

    A name or count the suite does not have raises SuiteError, so a typo never silently runs
    nothing.
    """
    names = {
        "env_id": lambda s: {s.env_id},
        "algorithm": lambda s: {s.algorithm, s.shown},  # a variant by label, or all by algorithm
        "n_demos": lambda s: {s.n_demos} if s.n_demos else set(),
    }
    wanted_by_key = (
        ("env_id", "envs", env),
        ("algorithm", "algorithms", algorithm),
        ("n_demos", "demo counts", demos),
    )
    for key, label, wanted in wanted_by_key:  # checked against the whole suite, before filtering
        have = sorted(set().union(*(names[key](s) for s in specs)))
        for name in wanted or ():
            if name not in have:
                raise SuiteError(f"{source}: {name!r} is not one of the suite's {label}: {have}")
    chosen = specs
    for key, _, wanted in wanted_by_key:
        if wanted is not None:
            # a demo count keeps the trials that take none (names[...] is empty for them)
            chosen = [s for s in chosen if names[key](s) & set(wanted) or not names[key](s)]
    if specs and not chosen:
        asked = ", ".join(f"{label} {wanted}" for _, label, wanted in wanted_by_key if wanted)
        raise SuiteError(f"{source}: no trial of the suite has all of: {asked}")
    return chosen
