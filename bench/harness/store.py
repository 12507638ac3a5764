"""Per-trial records on disk: written, linked, read, found and set aside (the tidy frames read
from them are `bench.harness.frames`').

Layout: `<results_dir>/trials/<trial_id>.json`, one `TrialResult` per file.
A record appears under its final name only once complete (temp file in the
same folder, fsync, atomic rename), so a killed run leaves at worst a stray
`*.tmp`, which readers ignore and the next write or scan removes. A trial is
finished exactly when its record exists; resuming a suite is skipping those.

A trial is identified by what decides its outcome (`TrialSpec.identity`), not by the suite
that asked for it, so one that another suite ran already is not run again: its suite's folder
gets a link instead (`link`), a small file naming where the record is, with this suite's name
and label for it. Readers see a linked record as the folder's own (`read`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import fcntl
import json
import math
import os
import time
import warnings
from collections.abc import Collection, Iterable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from bench import atomic, reading
from bench.errors import BadInput
from bench.harness import policies, registry
from bench.harness.types import OPTIONAL_FIELDS, CurvePoint, TrialResult, TrialSpec

TRIALS = "trials"
STALE_TMP_SECONDS = 600.0
"""A *.tmp older than this is a dead writer's; younger ones may belong to a live worker."""


NO_RETURN = "no finite return"
"""The status `frames.load` gives a record marked ok whose returns are missing, NaN or infinite."""
LINK = "same_as"
"""The key of a link file: the record it stands for, relative to the link's folder."""
LOCK = ".lock"
"""A results folder's lock file: held (flock) by the one `bench run` writing into it."""


class BrokenLink(ValueError):
    """A record that says it is another folder's, where that one is not (a folder copied or
    moved without the folders it links to)."""


class FolderBusy(BadInput, RuntimeError):
    """A results folder that cannot be written now; the message is one line."""


@contextlib.contextmanager
def claim(results_dir: str | Path) -> Iterator[None]:
    """Hold `results_dir` for one run: a second run into it is refused (FolderBusy) rather than
    running every trial twice. The lock is the kernel's (flock), so a killed run leaves none
    behind. Also where an unwritable folder is found, before any trial trains."""
    folder = Path(results_dir)
    for name in (TRIALS, policies.FOLDER):
        if (folder / name).exists() and not (folder / name).is_dir():
            raise FolderBusy(
                f"{folder / name} is a file where a run keeps its {name}: move it away, or use"
                " --results"
            )
    try:
        trials_dir(folder).mkdir(parents=True, exist_ok=True)
        handle = open(folder / LOCK, "a")  # noqa: SIM115 - held for the whole run
    except OSError as e:
        raise FolderBusy(f"cannot write results into {folder}: {e.strerror or e}") from None
    try:
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise FolderBusy(
                f"{folder} is being written by another bench run; wait for it, or use --results"
            ) from None
        yield
    finally:
        handle.close()


def trials_dir(results_dir: str | Path) -> Path:
    return Path(results_dir) / TRIALS


def record_path(results_dir: str | Path, trial_id: str) -> Path:
    return trials_dir(results_dir) / f"{trial_id}.json"


def write(results_dir: str | Path, result: TrialResult) -> Path:
    """Write `result` atomically to `<results_dir>/trials/<trial_id>.json`; return that path."""
    folder = trials_dir(results_dir)
    folder.mkdir(parents=True, exist_ok=True)
    _remove_stale_tmp(folder)
    record = dataclasses.asdict(dataclasses.replace(result, spec=None, policy=None))
    record["spec"] = result.spec.plain()  # keeps its place: spec is the record's first key
    del record["policy"]  # a file of its own (bench.harness.policies)
    del record["stored_in"]  # where the reader found it
    if not record["resumed_at"]:  # trials that ran in one go: records as they always were
        del record["resumed_at"]
    if record["cpu_time"] is None:  # not measured: records as they always were
        del record["cpu_time"]
    for optional in OPTIONAL_FIELDS:  # unset: records as they always were
        if record["spec"][optional] is None:
            del record["spec"][optional]
    text = json.dumps(_finite(record), allow_nan=False, indent=1)
    return atomic.write_text(record_path(results_dir, result.trial_id), text)


def link(results_dir: str | Path, spec: TrialSpec, label: str, record: str | Path) -> Path:
    """Say in `results_dir` that its suite's trial `spec` is the one recorded at `record`
    (another folder's, the same trial id): a link file that `read` follows, with `spec`'s
    suite and label and the `label` figures show it under. Written atomically."""
    record = Path(record)
    if record.parent.parent.resolve() == Path(results_dir).resolve():
        raise ValueError(f"{record} is in {results_dir} already")
    target = os.path.relpath(record, trials_dir(results_dir))
    text = json.dumps(
        {LINK: target, "suite": spec.suite, "spec_label": spec.label, "label": label}, indent=1
    )
    return atomic.write_text(record_path(results_dir, spec.trial_id), text)


SPEC_TYPES = {
    "suite": str,
    "env_id": str,
    "algorithm": str,
    "n_demos": int,
    "seed": int,
    "budget": int,
    "eval_episodes": int,
    "hyperparams": dict,
}
RECORD_TYPES = {"status": str, "returns": list, "curve": list, "env_steps": int, "wall_time": float}


def _check_types(raw: Any) -> None:
    """Raise ValueError naming the first field of a record that has the wrong type: a record
    edited by hand, or by a broken writer, is left out (`scan`) rather than trusted."""

    def check(where: str, value: Any, kind: type) -> None:
        if kind is float and value is None:
            return  # a non-finite number, written as null (`_finite`)
        number = kind in (int, float) and not isinstance(value, bool)
        wanted = (int, float) if kind is float else kind
        if not (isinstance(value, wanted) and (number or kind not in (int, float))):
            raise ValueError(f"{where} is {value!r}, not {kind.__name__}")

    if not isinstance(raw, dict) or not isinstance(raw.get("spec"), dict):
        raise ValueError("not a record: no spec")
    for key, kind in SPEC_TYPES.items():
        check(f"spec.{key}", raw["spec"].get(key), kind)
    if "config" in raw["spec"]:
        raise ValueError("spec.config is no part of a record (its hyperparams are)")
    for key, kind in RECORD_TYPES.items():
        check(key, raw.get(key), kind)
    for i, r in enumerate(raw["returns"]):
        check(f"returns[{i}]", r, float)


def real_path(path: str | Path) -> Path:
    """The record file that `path` stands for: itself, or the one a link names."""
    path = Path(path)
    raw = _json(path)
    if isinstance(raw, dict) and LINK in raw:
        return Path(os.path.normpath(path.parent / raw[LINK]))
    return path


MAX_RECORD_BYTES = 64 * 2**20
"""A record is read only up to this size (a 10M-step trial's, logs and all, is ~1 MB)."""


def _json(path: str | Path) -> Any:
    """A record file's JSON: a regular file of at most MAX_RECORD_BYTES (a FIFO or a device
    where a record or a link's target is expected is refused, never waited on)."""
    return json.loads(reading.read_bytes(path, MAX_RECORD_BYTES, "trial record"))


def read(path: str | Path) -> TrialResult:
    """Rebuild a TrialResult (with its TrialSpec and CurvePoints) from a record, or from the
    record a link names, as the linking suite's (its name and label; `stored_in` the folder
    that holds it)."""
    raw = _json(path)
    if LINK in raw:
        target = Path(os.path.normpath(Path(path).parent / raw[LINK]))
        if not target.exists():
            raise BrokenLink(f"{path} links to {target}, which is not there")
        if LINK in _json(target):
            raise ValueError(f"{path} links to {target}, itself a link")
        result = read(target)
        spec = dataclasses.replace(result.spec, suite=raw["suite"], label=raw["spec_label"])
        folder = str(target.parent.parent)
        return dataclasses.replace(result, spec=spec, label=raw["label"], stored_in=folder)
    _check_types(raw)
    spec = TrialSpec(**raw["spec"])
    role, family, label = raw.get("role"), raw.get("family"), raw.get("label")
    if role is None:  # a record from before records said it: what the registry says now
        role, family, label = registry.describe(spec.algorithm)
        label = spec.label or label
    return TrialResult(
        spec=spec,
        status=raw["status"],
        returns=[_float(r) for r in raw["returns"]],
        curve=[CurvePoint(p["env_steps"], _float(p["mean_return"])) for p in raw["curve"]],
        env_steps=raw["env_steps"],
        wall_time=_float(raw["wall_time"]),
        versions=raw["versions"],
        traceback=raw.get("traceback"),
        logs={k: [_float(v) for v in vs] for k, vs in raw.get("logs", {}).items()},
        inputs=raw.get("inputs"),
        reference=raw.get("reference"),
        state_distance=raw.get("state_distance"),
        role=role,
        family=family,
        label=label,
        resumed_at=raw.get("resumed_at", []),
        cpu_time=_cpu_time(raw.get("cpu_time")),
    )


def suite_dirs(root: str | Path) -> list[Path]:
    """`find_result_dirs(root)`, or FileNotFoundError (one line) when there is nothing to read."""
    root = Path(root)
    if not root.is_dir():
        raise FileNotFoundError(f"no results directory {root}")
    dirs = find_result_dirs(root)
    if not dirs:
        raise FileNotFoundError(f"no trial records under {root}")
    return dirs


SEARCH_DEPTH = 2
"""How far below a root results folders are looked for: `root/<suite>/` and one level more
(`results/scratch/<suite>/`). Bounded, so a run whose results' parent is `/` or a home folder
reads a few folders, not the whole disk."""


def find_result_dirs(root: str | Path) -> list[Path]:
    """Every folder under `root` (itself included, at most `SEARCH_DEPTH` levels down) that
    holds a trials/ folder; experts/ and hidden folders skipped. Linked folders are followed (a
    suite's folder linked in from scratch space is still seen), each real folder once, so a
    link loop ends."""
    if Path(root).name == "experts":
        return []
    found, seen = [], set()
    top = len(Path(root).parts)
    for folder, subdirs, _ in os.walk(root, followlinks=True):
        real = os.path.realpath(folder)
        if real in seen:
            subdirs[:] = []
            continue
        seen.add(real)
        if TRIALS in subdirs:
            found.append(Path(folder))
        if len(Path(folder).parts) - top >= SEARCH_DEPTH:
            subdirs[:] = []  # its own trials/ counted, nothing below it
            continue
        # Prune: never descend into expert folders, trials/ (records only) or hidden folders
        # (.venv, .git: a run with `--results NAME` prices by every record under `.`).
        subdirs[:] = sorted(
            d for d in subdirs if d not in ("experts", TRIALS) and not d.startswith(".")
        )
    return sorted(found)


# ---------------------------------------------------------------- helpers


def _roots(roots: str | Path | Sequence[str | Path]) -> list[Path]:
    """Search roots as a list of existing folders, each real folder once."""
    many = [roots] if isinstance(roots, str | Path) else list(roots)
    real = {os.path.realpath(r): Path(r) for r in reversed(many) if Path(r).is_dir()}
    return list(reversed(real.values()))


def scan_under(
    roots: str | Path | Sequence[str | Path], besides: str | Path | None = None
) -> Iterator[TrialResult]:
    """`scan` of every results folder under `roots` (`find_result_dirs`), each once, but
    `besides` (a folder the caller has read already)."""
    seen = set() if besides is None else {os.path.realpath(besides)}
    for root in _roots(roots):
        for results_dir in find_result_dirs(root):
            real = os.path.realpath(results_dir)
            if real not in seen:
                seen.add(real)
                yield from scan(results_dir)


SET_ASIDE = "set-aside"
"""Where a run moves the records its suite no longer asks for (`superseded`)."""


def superseded(records: Iterable[TrialResult], specs: Collection[TrialSpec]) -> set[str]:
    """The trial ids of `records` (one folder's, `scan`) in the cells `specs` ask for (env,
    algorithm as shown, demonstration count, seed) that are not those trials: made with other
    settings, or by another version of a plugin's code. They are never reused as these trials,
    and left in the folder they would be averaged in with them."""
    wanted = {_cell(s): s.trial_id for s in specs}
    return {r.trial_id for r in records if wanted.get(_cell(r.spec), r.trial_id) != r.trial_id}


def _cell(spec: TrialSpec) -> tuple:
    return (spec.env_id, spec.shown, spec.n_demos, spec.seed, spec.dataset, spec.observation)


def set_aside(results_dir: str | Path, trial_ids: Collection[str]) -> Path:
    """Move the records `trial_ids` of `results_dir` (and their policies) into its `SET_ASIDE`
    folder, file by file, where no figure or run reads them; nothing is deleted. Returns that
    folder."""
    folder = Path(results_dir) / SET_ASIDE
    folder.mkdir(exist_ok=True)
    for trial_id in trial_ids:
        policy = policies.path(results_dir, trial_id)
        if policy.is_file():
            os.replace(policy, folder / policy.name)
        record = record_path(results_dir, trial_id)
        os.replace(record, folder / record.name)
    return folder


def find(
    roots: str | Path | Sequence[str | Path],
    ids: Collection[str],
    besides: str | Path | None = None,
) -> dict[str, Path]:
    """Where under `roots` (but in `besides`) each of `ids` is recorded as finished (ok, with
    finite returns): trial id -> its record's own file (a link followed). Reads only the files
    named by those ids; the first root that has a trial is where it is found."""
    skip = None if besides is None else os.path.realpath(besides)
    found: dict[str, Path] = {}
    folders = [d for root in _roots(roots) for d in find_result_dirs(root)]
    for results_dir in dict.fromkeys(folders):
        if os.path.realpath(results_dir) == skip:
            continue
        for trial_id in sorted(set(ids) - found.keys()):
            path = record_path(results_dir, trial_id)
            if not path.is_file():
                continue
            try:
                result = read(path)
            except (OSError, ValueError, KeyError, TypeError):
                continue  # a malformed record is `scan`'s to warn about
            if status_of(result) == "ok" and result.trial_id == trial_id:
                found[trial_id] = real_path(path)
    return found


def scan(results_dir: str | Path) -> Iterator[TrialResult]:
    """Every readable record, in file-name order; unreadable ones are warned about and skipped."""
    folder = trials_dir(results_dir)
    if not folder.is_dir():
        return
    _remove_stale_tmp(folder)
    broken: list[BrokenLink] = []
    for path in sorted(folder.glob("*.json")):
        try:
            result = read(path)
        except BrokenLink as e:  # said once for all of them, below: a copy breaks them all
            broken.append(e)
            continue
        except (OSError, ValueError, KeyError, TypeError) as e:  # JSONDecodeError is a ValueError
            warnings.warn(f"skipping unreadable trial record {path}: {e!r}", stacklevel=2)
            continue
        if result.trial_id != path.stem:
            # A renamed or edited file: which trial it records cannot be trusted.
            warnings.warn(
                f"skipping {path}: its spec hashes to {result.trial_id}, not to its file name"
                " (renamed or edited? scripts/migrate_records.py renames records to their ids)",
                stacklevel=2,
            )
            continue
        yield result
    if broken:
        warnings.warn(
            f"skipping {len(broken)} records of {folder} that link to another folder's, not"
            f" there (copied or moved without it?), e.g. {broken[0]}",
            stacklevel=2,
        )


def status_of(r: TrialResult) -> str:
    """The record's status, but NO_RETURN for an "ok" one without a finite return (edited, or
    from a broken writer): no score, listed and retried with the failed ones."""
    returns = np.asarray(r.returns, dtype=float)
    finite = returns.size > 0 and bool(np.isfinite(returns).all())
    return NO_RETURN if r.status == "ok" and not finite else r.status


def _finite(value: Any) -> Any:
    """Replace NaN and inf by None, all the way down: JSON has no NaN."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_finite(v) for v in value]
    if isinstance(value, np.ndarray | np.generic):
        return _finite(value.tolist())  # runners may hand over numpy returns
    return value


def _cpu_time(value: Any) -> float | None:
    """A record's `cpu_time`, where it holds a number (a hand-edited one is not trusted)."""
    number = isinstance(value, int | float) and not isinstance(value, bool)
    return float(value) if number and math.isfinite(value) and value >= 0 else None


def _float(value: Any) -> float:
    return math.nan if value is None else float(value)


def _remove_stale_tmp(folder: Path) -> None:
    cutoff = time.time() - STALE_TMP_SECONDS
    for tmp in folder.glob("*.tmp"):
        with contextlib.suppress(OSError):  # another process may clean it first
            if tmp.stat().st_mtime < cutoff:
                tmp.unlink()
