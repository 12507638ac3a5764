"""Names, labels and order: how envs, algorithms and demonstration counts are called and
listed, the same in figures, reports and the command line."""

from __future__ import annotations

from collections.abc import Collection, Iterable

import pandas as pd

from bench.envs import PAPER_ENVS
from bench.normalize import REFERENCES

PAPER_ALGORITHMS = ("gaifo", "gail", "bco", "tcn", "survival")
"""Fixed order and colors; other algorithms follow alphabetically."""
LABELS = {
    "gaifo": "GAIfO",
    "gail": "GAIL",
    "bco": "BCO",
    "tcn": "TCN",
    "survival": "Survival",
    "oracle": "Oracle",
    "gaifo-sac": "GAIfO (SAC)",
    "gail-sac": "GAIL (SAC)",
    "survival-sac": "Survival (SAC)",
    "oracle-sac": "Oracle (SAC)",
    "random": "Random",
    "expert": "Expert",
}
ACTIONS_FOOTNOTE = "* has access to expert actions"


def env_order(env_ids: Iterable[str]) -> list[str]:
    """The paper's env order for the envs it has, then the others alphabetically."""
    env_ids = set(env_ids)
    return [e for e in PAPER_ENVS if e in env_ids] + sorted(env_ids - set(PAPER_ENVS))


def env_label(env_id: str) -> str:
    """'HopperBulletEnv-v0' -> 'Hopper'; other ids lose only their version."""
    name = env_id.rsplit("-v", 1)[0]
    return name.removesuffix("BulletEnv") or env_id


def algorithm_order(names: Iterable[str]) -> list[str]:
    """Learners in the paper's order, then others alphabetically; references left out."""
    names = set(names) - set(REFERENCES)
    return [a for a in PAPER_ALGORITHMS if a in names] + sorted(names - set(PAPER_ALGORITHMS))


def action_users(df: pd.DataFrame) -> frozenset[str]:
    """Algorithms whose records say they were given expert actions (column `inputs`)."""
    if "inputs" not in df:
        return frozenset()
    return frozenset(df.loc[df["inputs"] == "actions", "algorithm"])


def algorithm_label(name: str, action_users: Collection[str] = ()) -> str:
    """Display name; a * marks an algorithm that was given expert actions."""
    return LABELS.get(name, name) + ("*" if name in action_users else "")


def demos_label(n: int, word: str = "demo") -> str:
    """'no demos', '1 demo', '5 demos'; word="demonstration" for the long form."""
    return f"no {word}s" if n == 0 else f"{n} {word}" + ("s" if n != 1 else "")


def in_order(names: Iterable[str]) -> list[str]:
    """`names` without repeats, in `algorithm_order`, and any references after them as given."""
    names = list(dict.fromkeys(names))
    ordered = algorithm_order(names)
    return ordered + [a for a in names if a not in ordered]
