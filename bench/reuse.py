"""Records of one suite's trials taken from another suite's folder (`bench run --reuse DIR`).

Suites overlap: Hopper at 1M steps with 5 demonstrations is a trial of
`hopper-adversarial`, of `pybullet-slice` and of `locomotion`. A trial's id hashes
its suite's name, so each suite would run it again. Everything else that decides
the outcome (env, algorithm, resolved config, demos, seed, budget, evaluation)
is in the spec, so a finished record whose spec differs only in the suite's name
(or the label it is shown under, a name too: `gaifo-b4096` in a screen is `gaifo` in a suite
that sets the same batch for the env) is that trial: it is copied, marked with where it came
from (`copied_from`), instead of spending core-hours to redraw it. (On one machine the rerun would be
bit-identical; on another it would be a fresh draw of the same distribution.)
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Iterable
from pathlib import Path

from bench import policies, store
from bench.types import TrialResult, TrialSpec


def _key(spec: TrialSpec) -> str:
    """The spec without its suite's name and label: what the trial is, wherever it ran and
    whatever it was called."""
    return json.dumps(
        {**json.loads(spec.canonical()), "suite": None, "label": None}, sort_keys=True
    )


def reuse(
    specs: Iterable[TrialSpec], results_dir: str | Path, sources: Iterable[str | Path]
) -> int:
    """Copy into `results_dir` a finished record from `sources` for every spec that has no
    finished record there yet; return how many were copied. Failed records are never copied."""
    finished = {r.trial_id for r in store.scan(results_dir) if r.status == "ok"}
    available: dict[str, tuple[Path, TrialResult]] = {}
    for source in sources:
        if not store.trials_dir(source).is_dir():
            raise FileNotFoundError(
                f"{source}: no trial records to reuse (no {store.TRIALS}/ there)"
            )
        if Path(source).resolve() == Path(results_dir).resolve():
            continue  # its own records are resumed anyway
        for record in store.scan(source):
            if record.status == "ok":
                path = store.record_path(source, record.trial_id)
                available.setdefault(_key(record.spec), (path, record))
    copied = 0
    for spec in specs:
        match = available.get(_key(spec))
        if spec.trial_id in finished or match is None:
            continue
        path, record = match
        origin = record.copied_from or str(path)  # a copy of a copy names the run itself
        saved = policies.path(path.parent.parent, record.trial_id)
        if saved.is_file():  # the policy first: a record implies its policy
            policies.write(results_dir, spec.trial_id, saved.read_bytes())
        store.write(results_dir, dataclasses.replace(record, spec=spec, copied_from=origin))
        finished.add(spec.trial_id)
        copied += 1
    return copied
