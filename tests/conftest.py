import os
import subprocess
import sys

import pytest
import torch

torch.set_num_threads(1)
os.environ.setdefault("OMP_NUM_THREADS", "1")

PENDULUM = "InvertedPendulumBulletEnv-v0"


@pytest.fixture()
def pendulum() -> str:
    return PENDULUM


@pytest.fixture(scope="module")
def module_cache(tmp_path_factory):
    """A private bench cache (demo pools) shared by one test module, so pools are recorded once."""
    mp = pytest.MonkeyPatch()
    root = tmp_path_factory.mktemp("cache")
    mp.setattr("bench.paths.CACHE_DIR", root)
    yield root
    mp.undo()


def _bench_cli(*args: str, **kw) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-m", "bench.cli", *args], capture_output=True, text=True, **kw
    )


@pytest.fixture(scope="session")
def cli():
    """`cli("run", suite, ...)` runs the bench command in a subprocess, as a user would."""
    return _bench_cli


@pytest.fixture()
def demo_cache(tmp_path, monkeypatch):
    """A private demo cache per test, for this process and any bench subprocess it starts."""
    monkeypatch.setenv("IFO_BENCH_CACHE", str(tmp_path / "cache"))
    monkeypatch.setattr("bench.paths.CACHE_DIR", tmp_path / "cache")
