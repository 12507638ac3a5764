"""Names, labels and order: how envs, algorithms and demonstration counts are called and
listed, the same in figures, reports and the command line. What an algorithm is called and
what it is (its role, its optimizer family, whether it saw expert actions) come from its
records (`Names.of`), never from its name."""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass

import pandas as pd

from bench.envs import PAPER_ENVS
from bench.harness.registry import CONTROL_ROLES, REFERENCE_ROLES

PAPER_ALGORITHMS = ("gaifo", "gail", "bco", "tcn", "survival")
"""The paper's order and colors, kept whatever else is drawn beside them; other algorithms
follow alphabetically. Presentation only: nothing is decided by these names."""
ACTIONS_FOOTNOTE = "* has access to expert actions"


@dataclass(frozen=True)
class Shown:
    """One algorithm as figures and reports show it (a labelled variant is one of its own)."""

    label: str
    """Its display name ("GAIfO"; a variant's own label)."""
    role: str
    """`bench.harness.registry.Role`: learner, floor, ceiling, random or expert."""
    family: str | None
    """The optimizer family whose controls it is read against (None: none)."""
    method: str
    """The registered algorithm it runs."""
    uses_actions: bool = False
    """It was given the expert's actions (a * in figures and tables)."""


class Names(Mapping[str, Shown]):
    """Shown name (the frame's `algorithm`) -> `Shown`, as the records say. A name the
    records do not describe is shown as itself, a learner of no family."""

    def __init__(self, shown: Mapping[str, Shown] | None = None) -> None:
        self._shown = dict(shown or {})

    @classmethod
    def of(cls, *frames: pd.DataFrame) -> Names:
        """From frames of records (`frames.load`, `load_curves`): columns algorithm, method,
        role, family, label and inputs; the first frame's word on a name wins."""
        shown: dict[str, Shown] = {}
        for df in frames:
            inputs = df["inputs"] if "inputs" in df else pd.Series(None, index=df.index)
            for row in df.assign(inputs=inputs).drop_duplicates("algorithm").itertuples():
                family = None if pd.isna(row.family) else row.family
                shown.setdefault(
                    row.algorithm,
                    Shown(row.label, row.role, family, row.method, row.inputs == "actions"),
                )
        return cls(shown)

    def __getitem__(self, name: str) -> Shown:
        return self._shown.get(name) or Shown(name, "learner", None, name)

    def __iter__(self) -> Iterator[str]:
        return iter(self._shown)

    def __len__(self) -> int:
        return len(self._shown)

    def label(self, name: str) -> str:
        """Display name; a * marks an algorithm that was given expert actions."""
        shown = self[name]
        return shown.label + ("*" if shown.uses_actions else "")

    def starred(self, names: Iterable[str]) -> list[str]:
        """Those of `names` that were given expert actions."""
        return [a for a in names if self[a].uses_actions]

    def with_role(self, names: Iterable[str], *roles: str) -> list[str]:
        """Those of `names` whose role is one of `roles`."""
        return [a for a in names if self[a].role in roles]

    def order(self, names: Iterable[str]) -> list[str]:
        """The learners, then the controls (floors, then ceilings: `CONTROL_ROLES`), each in the
        paper's order (`algorithm_order`); the references left out. A table reads the methods
        first and the controls that bracket them after, however many methods a folder holds."""
        names = set(names)
        return [
            a
            for role in ("learner", *CONTROL_ROLES)
            for a in algorithm_order(n for n in names if self[n].role == role)
        ]

    def in_order(self, names: Iterable[str]) -> list[str]:
        """`names` without repeats: `order`, then any references as given."""
        names = list(dict.fromkeys(names))
        ordered = self.order(names)
        return ordered + [a for a in names if a not in ordered]


def env_order(env_ids: Iterable[str]) -> list[str]:
    """The paper's env order for the envs it has, then the others alphabetically."""
    env_ids = set(env_ids)
    return [e for e in PAPER_ENVS if e in env_ids] + sorted(env_ids - set(PAPER_ENVS))


def env_label(env_id: str) -> str:
    """'HopperBulletEnv-v0' -> 'Hopper'; other ids lose only their version."""
    name = env_id.rsplit("-v", 1)[0]
    return name.removesuffix("BulletEnv") or env_id


def is_reference(df: pd.DataFrame) -> pd.Series:
    """Per row of a frame of records: is its algorithm a reference (random or expert)?"""
    return df["role"].isin(REFERENCE_ROLES)


def algorithm_order(names: Iterable[str]) -> list[str]:
    """`names` in the paper's order (`PAPER_ALGORITHMS`), then the others alphabetically."""
    names = set(names)
    return [a for a in PAPER_ALGORITHMS if a in names] + sorted(names - set(PAPER_ALGORITHMS))


def demos_label(n: int, word: str = "demo") -> str:
    """'no demos', '1 demo', '5 demos'; word="demonstration" for the long form."""
    return f"no {word}s" if n == 0 else f"{n} {word}" + ("s" if n != 1 else "")
