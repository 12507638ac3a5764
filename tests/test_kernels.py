"""Portable kernels: a suite with `kernels: portable` computes the same records whatever
kernels the CPU would choose. Another CPU is stood in for by MKL's own switch that restricts
its dispatch to AVX2 (`MKL_ENABLE_INSTRUCTIONS`), which on a CPU where MKL runs AVX-512 changes
native records from the first update (as the committed HalfCheetah-v5 records change on another
CPU)."""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from bench import kernels
from bench.harness.suite import load_suite

SUITE = """name: k
kernels: {kind}
envs:
  HalfCheetah-v5: {{budget: 4096}}
demos: [1]
algorithms: [gaifo]
seeds: 1
eval_episodes: 1
"""


def _records(tmp_path: Path, kind: str, restricted: bool) -> dict:
    """The records of the suite run in a fresh cache (its demonstration pool recorded anew)."""
    where = tmp_path / f"{kind}-{restricted}"
    suite = where / "k.yaml"
    suite.parent.mkdir()
    suite.write_text(SUITE.format(kind=kind))
    env = {**os.environ, "IFO_BENCH_CACHE": str(where / "cache")}
    if restricted:
        env["MKL_ENABLE_INSTRUCTIONS"] = "AVX2"
    run = [sys.executable, "-m", "bench.cli", "run", str(suite), "--results", str(where / "r")]
    out = subprocess.run(run, env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    records = {}
    for path in (where / "r" / "trials").glob("*.json"):
        record = json.loads(path.read_text())
        record["logs"] = {k: v for k, v in record["logs"].items() if not k.endswith("_s")}
        records[path.name] = {k: record[k] for k in ("returns", "curve", "logs", "versions")}
    return records


@pytest.mark.slow
def test_portable_kernels_compute_alike_where_native_ones_differ(tmp_path):
    portable = _records(tmp_path, "portable", restricted=False)
    assert portable == _records(tmp_path, "portable", restricted=True)
    assert all(r["versions"]["kernels"] == "portable: ATen AVX2" for r in portable.values())
    # The restriction stands in for another CPU only where MKL would choose other kernels:
    # not on an AVX2 CPU (known without running), nor on an AVX-512 one where MKL runs its
    # AVX2 branch anyway (some AMD CPUs: only running shows it). There the equality above
    # shows nothing a native run would not.
    unmoved = "MKL_ENABLE_INSTRUCTIONS=AVX2 changes nothing here: no other CPU to stand in"
    if torch.backends.cpu.get_cpu_capability() != "AVX512":
        pytest.skip(unmoved)
    native = _records(tmp_path, "native", restricted=False)
    if native == _records(tmp_path, "native", restricted=True):
        pytest.skip(unmoved)


def test_portable_trials_are_other_trials_and_native_ids_are_unchanged(tmp_path):
    path = tmp_path / "k.yaml"
    ids = {}
    for kind in kernels.KINDS:
        path.write_text(SUITE.format(kind=kind))
        (spec,) = load_suite(path).trials
        ids[kind] = spec
    assert ids["native"].kernels is None and "kernels" not in ids["native"].identity()
    assert ids["portable"].kernels == "portable"
    assert ids["portable"].trial_id != ids["native"].trial_id


def test_a_portable_trial_in_a_process_without_the_pins_fails_saying_how_to_start_it(
    monkeypatch,
):
    for name in kernels.PORTABLE:
        monkeypatch.delenv(name, raising=False)
    kernels.require("native")  # nothing to ask of a native trial
    with pytest.raises(kernels.NotPinned, match="MKL_CBWR='AVX2,STRICT'"):
        kernels.require("portable")
