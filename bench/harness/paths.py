"""Where things live on disk, in one place."""

from __future__ import annotations

import os
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
EXPERTS_DIR = Path(os.environ.get("IFO_BENCH_EXPERTS", REPO_ROOT / "results" / "experts"))
"""Shipped experts: <EXPERTS_DIR>/<env_id>/policy.pt and meta.json."""
RESULTS_DIR = REPO_ROOT / "results"
"""The checkout's committed results: every run looks here for trials already finished, wherever
its own records go."""
CACHE_DIR = Path(os.environ.get("IFO_BENCH_CACHE", REPO_ROOT / ".cache"))
"""Regenerable files (demonstration pools); safe to delete."""


def expert_dir(env_id: str) -> Path:
    return EXPERTS_DIR / env_id


def has_expert(env_id: str) -> bool:
    return (expert_dir(env_id) / "policy.pt").is_file() and (
        expert_dir(env_id) / "meta.json"
    ).is_file()


def shipped_folder(folder: str | Path) -> Path | None:
    """The shipped folder (the experts') that `folder` is, lies in or holds, or None: results
    are never written there, whatever a suite is named or `--results` says."""
    target = Path(folder).resolve()
    experts = EXPERTS_DIR.resolve()
    if target == experts or experts in target.parents or target in experts.parents:
        return experts
    return None
