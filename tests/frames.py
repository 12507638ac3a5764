"""Hand-built frames of records, as `bench.harness.frames.load` gives them."""

from __future__ import annotations

import pandas as pd

from bench.analysis.labels import Names
from bench.harness import registry


def described(df: pd.DataFrame) -> pd.DataFrame:
    """`df` with the columns records give about each algorithm (method, role, family, label),
    as the built-ins register them; a variant (an `algorithm` with a `method` column naming
    another) keeps its own name as its label."""
    method = df["method"].fillna(df["algorithm"]) if "method" in df else df["algorithm"]
    about = {m: registry.describe(m) for m in method.unique()}
    label = [a if a != m else about[m][2] for a, m in zip(df["algorithm"], method, strict=True)]
    return df.assign(
        method=method,
        role=method.map(lambda m: about[m][0]),
        family=method.map(lambda m: about[m][1]),
        label=label,
    )


def names(methods: dict[str, str] | list[str]) -> Names:
    """`Names` of shown algorithms (a list, or shown name -> the registered one it runs), as
    the records of the built-ins describe them."""
    methods = methods if isinstance(methods, dict) else {a: a for a in methods}
    frame = pd.DataFrame({"algorithm": list(methods), "method": list(methods.values())})
    return Names.of(described(frame))
