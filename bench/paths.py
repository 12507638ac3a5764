"""Where things live on disk, in one place."""

from __future__ import annotations

import os
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[1]
# An empty variable is unset, not the working folder.
EXPERTS_DIR = Path(os.environ.get("IFO_BENCH_EXPERTS") or REPO_ROOT / "results" / "experts")
"""Shipped experts: <EXPERTS_DIR>/<env_id>/policy.pt and meta.json."""
RESULTS_DIR = REPO_ROOT / "results"
"""The checkout's committed results: every run looks here for trials already finished, wherever
its own records go."""
CACHE_DIR = Path(os.environ.get("IFO_BENCH_CACHE") or REPO_ROOT / ".cache")
"""Regenerable files (demonstration pools); safe to delete."""


def expert_dir(env_id: str) -> Path:
    return EXPERTS_DIR / env_id


def has_expert(env_id: str) -> bool:
    return (expert_dir(env_id) / "policy.pt").is_file() and (
        expert_dir(env_id) / "meta.json"
    ).is_file()


def shipped_folder(folder: str | Path) -> Path | None:
    """The shipped folder (the experts') that `folder` is, lies in or holds, or None: results
    are never written there, whatever a suite is named or `--results` says. Known by where this
    installation keeps its experts, and by what a folder holds (experts: subfolders with a
    policy.pt and a meta.json), so a second checkout's experts are as safe as this one's."""
    target = Path(folder).resolve()
    if target in EXPERTS_DIR.resolve().parents:  # a results folder there would hold it
        return EXPERTS_DIR.resolve()
    return inside_shipped(target)


def inside_shipped(folder: str | Path) -> Path | None:
    """The shipped experts' folder that `folder` is or lies in (this installation's, or any
    folder that holds experts), or None: no output file or folder goes there."""
    target = Path(folder).resolve()
    experts = EXPERTS_DIR.resolve()
    if target == experts or experts in target.parents:
        return experts
    for candidate in (target, *target.parents):
        if _holds_experts(candidate):
            return candidate
    return None


def _holds_experts(folder: Path) -> bool:
    """Whether `folder` is a folder of experts: one of its subfolders has a policy.pt and a
    meta.json."""
    try:
        return any(
            (sub / "policy.pt").is_file() and (sub / "meta.json").is_file()
            for sub in folder.iterdir()
            if sub.is_dir()
        )
    except OSError:  # not a folder, or not one we may list
        return False
