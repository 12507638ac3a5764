"""Fingerprints of what trials compute, to show a refactoring changed nothing.

Runs every trial of the tiny suites in benchmarks/identity/ (every built-in algorithm and
control on InvertedPendulum and Hopper, and the pixel learners) in this process, one after
another, and writes each trial's returns, learning curve and logs, exactly (floats as their
repr), keyed by what the trial is rather than by its id (ids may change in a refactoring):

    python benchmarks/identity.py --out before.json          # on the old code
    python benchmarks/identity.py --out after.json --compare before.json

`--compare` prints the trials that differ and exits 1 if any does. Same machine only:
floats differ between CPUs. Logs of wall-clock time (`collect_s`, `update_s`) are left out.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import torch

from bench.harness.suite import load_suite
from bench.harness.trial import plan, run_trial

SUITES = sorted((Path(__file__).parent / "identity").glob("*.yaml"))


def key(spec) -> str:
    """What a trial is, readably: env (and observation), algorithm, demos, seed."""
    seen = f"{spec.env_id}:{spec.observation or 'states'}"
    return f"{seen} {spec.label or spec.algorithm} demos={spec.n_demos} seed={spec.seed}"


def timing(key: str) -> bool:
    """Logs of wall-clock seconds (`collect_s`, `update_s`): measured, never reproduced."""
    return key.endswith("_s")


def fingerprint(result) -> dict:
    return {
        "status": result.status,
        "returns": [repr(float(r)) for r in result.returns],
        "curve": [[p.env_steps, repr(float(p.mean_return))] for p in result.curve],
        "logs": {
            k: [repr(float(v)) for v in vs]
            for k, vs in sorted(result.logs.items())
            if not timing(k)
        },
        "env_steps": result.env_steps,
        "traceback": (result.traceback or "").strip().splitlines()[-1:],
    }


def untimed(prints: dict) -> dict:
    """Fingerprints without timing logs (files written before they were left out hold them)."""
    return {
        k: {**v, "logs": {f: x for f, x in v["logs"].items() if not timing(f)}}
        for k, v in prints.items()
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, required=True, help="where the fingerprints go")
    parser.add_argument("--compare", type=Path, help="fingerprints of the old code to check")
    parser.add_argument("--only", help="run only the trials whose key contains this")
    args = parser.parse_args(argv)
    torch.set_num_threads(1)
    prints = {}
    for path in SUITES:
        for spec in list(load_suite(path).trials):
            if args.only and args.only not in key(spec):
                continue
            result = run_trial(spec, plan(spec).inputs())
            prints[key(spec)] = fingerprint(result)
            print(f"{result.status:6} {result.wall_time:6.1f}s  {key(spec)}", flush=True)
    args.out.write_text(json.dumps(prints, indent=1, sort_keys=True))
    if args.compare is None:
        return 0
    before = untimed(json.loads(args.compare.read_text()))
    if args.only:  # the trials asked for only
        before = {k: v for k, v in before.items() if args.only in k}
    differ = [k for k in sorted(set(before) | set(prints)) if before.get(k) != prints.get(k)]
    for k in differ:
        print(f"differs: {k}")
    print(f"{len(prints) - len(differ)} of {len(set(before) | set(prints))} trials identical")
    return 1 if differ else 0


if __name__ == "__main__":
    sys.exit(main())
