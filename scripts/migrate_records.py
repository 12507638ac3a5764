"""Bring every trial record under a results folder to today's layout; idempotent.

- **Ids of what decides the trial**: a record's id hashes its spec without its suite's name
  or label, with its algorithm's full config (defaults added since it ran included, at the
  values it ran with) and its learning-curve count spelled out. The record and its policy are
  renamed to that id.
- **What its algorithm is**: role, optimizer family and label, as the registry says, where a
  record from before records said them lacks them.
- **One record per trial**: a copy of another suite's record (`copied_from`, from the old
  `bench run --reuse`), and a repeat of a trial another folder also ran with the very same
  results, becomes a link to the one record (`bench.harness.store.link`).

    python scripts/migrate_records.py results            # prints what it changed
    python scripts/migrate_records.py results --dry-run  # prints what it would change

Safe to run again, and on records that a run started on the old code lands later.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import sys
from collections import defaultdict
from pathlib import Path

from bench import atomic
from bench.harness import policies, registry, store
from bench.harness.types import CURVE_POINTS, TrialSpec

OPTIONAL = ("label", "dataset", "observation", "frame_size")


def migrated(raw: dict) -> dict:
    """A record's dict as today's code writes it (its id may change with it)."""
    spec = dict(raw["spec"])
    algo = registry.get(spec["algorithm"])
    config = algo.make_config(spec["hyperparams"])
    spec["hyperparams"] = json.loads(json.dumps(dataclasses.asdict(config)))
    spec["curve_points"] = spec.get("curve_points") or CURVE_POINTS
    for key in OPTIONAL:
        spec.setdefault(key, None)
    out = {**raw, "spec": spec}
    out.pop("copied_from", None)
    if out.get("role") is None:
        out |= {"role": algo.role, "family": algo.family, "label": spec["label"] or algo.label}
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("root", type=Path, help="a results folder, or a folder of them")
    parser.add_argument("--dry-run", action="store_true", help="change nothing")
    args = parser.parse_args(argv)
    renamed = filled = 0
    moved: dict[Path, Path] = {}  # record -> its new name
    copies: list[tuple[Path, Path, str]] = []  # (folder, record, copied from)
    where: dict[str, list[Path]] = defaultdict(list)  # new id -> records of it
    for folder in store.find_result_dirs(args.root):
        for path in sorted(store.trials_dir(folder).glob("*.json")):
            raw = json.loads(path.read_text())
            if store.LINK in raw:
                continue
            new = migrated(raw)
            trial_id = TrialSpec(**new["spec"]).trial_id
            target = store.record_path(folder, trial_id)
            filled += raw.get("role") is None
            if raw.get("copied_from"):
                copies.append((folder, target, raw["copied_from"]))
            where[trial_id].append(target)
            if new == raw and target == path:
                continue
            renamed += target != path
            if target != path:
                moved[Path(os.path.normpath(path))] = target
            if args.dry_run:
                continue
            if target != path and target.exists():
                sys.exit(f"{path}: its new id {trial_id} is taken by {target}; nothing more done")
            old_policy, new_policy = (
                policies.path(folder, path.stem),
                policies.path(folder, trial_id),
            )
            if old_policy.exists() and old_policy != new_policy:
                old_policy.rename(new_policy)
            atomic.write_text(target, json.dumps(new, indent=1))
            if target != path:
                path.unlink()
    if not args.dry_run:
        _follow(args.root, moved)
    linked = 0
    for folder, record, source in copies:
        # the record it was copied from, renamed to the same new id in its own folder
        original = store.record_path(Path(source).parent.parent, record.stem)
        if args.dry_run or not original.is_file() or original == record:
            linked += not args.dry_run and original.is_file()
            continue
        linked += _link(folder, record, original)
    for paths in where.values():
        for copy in paths[1:]:
            if args.dry_run or not copy.is_file() or store.LINK in json.loads(copy.read_text()):
                continue
            if _same_results(copy, paths[0]):
                linked += _link(copy.parent.parent, copy, paths[0])
    repeats = sum(len(p) > 1 for p in where.values())
    verb = "would be" if args.dry_run else "were"
    print(
        f"{renamed} records {verb} renamed to the ids of what decides them, {filled} told their"
        f" role; {len(copies)} copies and repeats among {repeats} trials recorded twice;"
        f" {linked} linked to the one record"
    )
    return 0


def _follow(root: Path, moved: dict[Path, Path]) -> None:
    """Point every link whose record was renamed at its new name, itself renamed to match."""
    for folder in store.find_result_dirs(root):
        for path in sorted(store.trials_dir(folder).glob("*.json")):
            raw = json.loads(path.read_text())
            target = Path(os.path.normpath(path.parent / raw.get(store.LINK, path.name)))
            if store.LINK not in raw or target not in moved:
                continue
            new = moved[target]
            raw[store.LINK] = os.path.relpath(new, path.parent)
            atomic.write_text(path.with_name(new.name), json.dumps(raw, indent=1))
            if path.name != new.name:
                path.unlink()


def _same_results(a: Path, b: Path) -> bool:
    """Whether two records of one trial hold the same results (not only the same settings)."""
    keys = ("status", "returns", "curve", "env_steps", "logs")
    ra, rb = json.loads(a.read_text()), json.loads(b.read_text())
    return all(ra.get(k) == rb.get(k) for k in keys)


def _link(folder: Path, record: Path, original: Path) -> int:
    """Replace `record` (of `folder`) by a link to `original`; drop its policy (the original's
    is the one). 1 where it did, 0 where the two are not one trial."""
    mine, theirs = store.read(record), store.read(original)
    if mine.trial_id != theirs.trial_id or theirs.status != "ok":
        return 0
    store.link(folder, mine.spec, mine.label or mine.spec.shown, original)
    policies.path(folder, mine.trial_id).unlink(missing_ok=True)
    return 1


if __name__ == "__main__":
    sys.exit(main())
